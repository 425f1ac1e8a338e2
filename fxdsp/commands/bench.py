"""`fxdsp bench [--config F] [--json F]`: throughput of the bit-exact models, measured in one run
against the same biquad written with fxpmath and with apytypes.

* fxdsp biquad: the config's first iir block (``[iir]``, one biquad, by default), int64 in/out, on
  ``--samples`` samples (>= 200k), best of ``--repeat`` runs after a warm-up (numba compiled).
* fxdsp chains: every chain of the config, whole, on its nominal stimulus of as many samples.
* fxpmath and apytypes: the *same* DF-I algorithm (exact products and sums, one rounding and one
  fit per section output, error feedback) written with each library's scalar types, one sample
  at a time (a recursive filter cannot be vectorised), timed on a prefix and extrapolated; the
  outputs are compared with fxdsp's on that prefix and the agreement is reported.
"""

from __future__ import annotations

import platform
import time

import numpy as np

from fxdsp.commands.options import count
from fxdsp.chains import build
from fxdsp.errors import InputError
from fxdsp.fixed import Format
from fxdsp.outputs import IN, OUT_FILE, json_text, staged


APY_QUANT = {"floor": "TO_NEG", "half_up": "TIES_POS", "half_even": "TIES_EVEN", "toward_zero": "TO_ZERO"}


PATHS = {"--config": IN, "--json": OUT_FILE}


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--json", help="also write the results as JSON to this file")
    parser.add_argument("--samples", type=count(200_000), default=1_000_000, help="samples for fxdsp (default 1e6, >= 200k)")
    parser.add_argument("--repeat", type=count(), default=5, help="timed runs, best kept (default 5)")
    parser.add_argument("--prefix-apytypes", type=count(), default=20_000, help="samples run through apytypes")
    parser.add_argument("--prefix-fxpmath", type=count(), default=2_000, help="samples run through fxpmath")


def _best(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def _apy(value: int, fmt: Format):
    import apytypes as apy

    return apy.APyFixed.from_float(value * 2.0**-fmt.fl, int_bits=fmt.wl - fmt.fl, frac_bits=fmt.fl) \
        if fmt.wl <= 52 else apy.APyFixed(value & ((1 << fmt.wl) - 1), int_bits=fmt.wl - fmt.fl, frac_bits=fmt.fl)


def biquad_apytypes(iir, x: np.ndarray) -> np.ndarray:
    """The [iir] biquad cascade, one sample at a time with apytypes scalars (exact arithmetic)."""
    import apytypes as apy

    d, nf, df = iir.data_format, iir.num_format, iir.den_format
    q = getattr(apy.QuantizationMode, APY_QUANT[iir.rules.rounding])
    sat = iir.rules.overflow == "saturate"
    ib, fb = d.wl - d.fl, d.fl
    lo = apy.APyFixed(1 << (d.wl - 1), int_bits=ib, frac_bits=fb)  # bit pattern of the minimum
    hi = apy.APyFixed((1 << (d.wl - 1)) - 1, int_bits=ib, frac_bits=fb)
    v = [_apy(int(s), d) for s in x]
    for s in range(iir.b.shape[0]):
        b = [_apy(int(c), nf) for c in iir.b[s]]
        a = [_apy(int(c), df) for c in iir.a[s]]
        # error-feedback weights as 4-bit integers (an APyFixed times a Python int would double its width)
        c1, c2 = (apy.APyFixed.from_float(float(c), int_bits=4, frac_bits=0) for c in iir.c[s])
        use_ef = bool(iir.c[s].any())
        zero = _apy(0, d)
        x1 = x2 = y1 = y2 = zero
        e1 = e2 = None
        out = []
        for xn in v:
            acc = b[0] * xn + b[1] * x1 + b[2] * x2 - a[0] * y1 - a[1] * y2
            if e1 is not None and use_ef:
                acc = acc + e1 * c1 + e2 * c2
            r = acc.cast(int_bits=acc.int_bits + 1, frac_bits=fb, quantization=q)  # rounded, range kept
            if r > hi or r < lo:
                y = (hi if r > hi else lo) if sat else r.cast(int_bits=ib, frac_bits=fb,
                                                              overflow=apy.OverflowMode.WRAP)
                e = acc - acc  # a saturated sample feeds back no error
            else:
                y = r.cast(int_bits=ib, frac_bits=fb)
                e = acc - r
            y = y.cast(int_bits=ib, frac_bits=fb)
            # |e| < 1 output LSB: a fixed, exact format keeps the fed-back error from growing the accumulator
            e = e.cast(int_bits=2, frac_bits=e.frac_bits)
            e1, e2 = e, (e1 if e1 is not None else e - e)
            x2, x1, y2, y1 = x1, xn, y1, y
            out.append(y)
        v = out
    bits = np.array([int(y.to_bits()) for y in v], dtype=np.int64)
    return np.where(bits >= 1 << (d.wl - 1), bits - (1 << d.wl), bits)  # to_bits() is the unsigned pattern


def biquad_fxpmath(iir, x: np.ndarray) -> np.ndarray:
    """The same algorithm with fxpmath Fxp scalars (its own rounding and saturation on the cast)."""
    from fxpmath import Fxp

    d, nf, df = iir.data_format, iir.num_format, iir.den_format
    rounding = {"floor": "floor", "half_up": "around", "half_even": "around", "toward_zero": "fix"}[iir.rules.rounding]

    def fx(value, fmt):
        return Fxp(value, signed=fmt.signed, n_word=fmt.wl, n_frac=fmt.fl, raw=True)

    v = [fx(int(s), d) for s in x]
    for s in range(iir.b.shape[0]):
        b = [fx(int(c), nf) for c in iir.b[s]]
        a = [fx(int(c), df) for c in iir.a[s]]
        c1, c2 = (int(c) for c in iir.c[s])
        x1 = x2 = y1 = y2 = fx(0, d)
        e1 = e2 = 0.0
        out = []
        for xn in v:
            acc = b[0] * xn + b[1] * x1 + b[2] * x2 - a[0] * y1 - a[1] * y2
            acc_val = acc.get_val() + c1 * e1 + c2 * e2
            y = Fxp(acc_val, signed=True, n_word=d.wl, n_frac=d.fl, rounding=rounding, overflow=iir.rules.overflow)
            e1, e2 = acc_val - y.get_val(), e1
            x2, x1, y2, y1 = x1, xn, y1, y
            out.append(y)
        v = out
    return np.array([int(y.val) for y in v], dtype=np.int64)


def _drive_loops(design, samples: int, repeat: int) -> dict:
    """Every drive loop of the config closed on its mode (:func:`fxdsp.sim.resonator.resonator_for`):
    samples per second of the bit-exact and the float loop, and of the resonator with its ADC alone."""
    from fxdsp.blocks.drive import Drive
    from fxdsp.sim.driveloop import closed_loop
    from fxdsp.sim.resonator import _open_drive, resonator_for

    out = {}
    for name, drive in design.blocks.items():
        if not isinstance(drive, Drive):
            continue
        res = resonator_for(drive)   # the mode `fxdsp simulate --drive-loop` closes it on
        seconds = samples / drive.fs_hz
        row = {"fs_hz": drive.fs_hz, "samples": samples}
        for kind, fixed in (("fixed", True), ("float", False)):
            closed_loop(drive, res, 25.0, 0.01, fixed=fixed)   # compile
            row[f"{kind}_samples_per_s"] = samples / _best(
                lambda: closed_loop(drive, res, 25.0, seconds, fixed=fixed, record_every=960), max(1, repeat // 2))
        coef = res.coefficients([25.0], drive.fs_hz)
        dac, noise = np.zeros(samples, dtype=np.int64), np.zeros(samples)
        fi = drive.in_format
        go = lambda n: _open_drive(dac[:n], 1.0, coef, samples, np.zeros(3), noise[:n], 2.0**fi.fl,  # noqa: E731
                                   fi.min_int, fi.max_int)
        go(10)
        row["resonator_samples_per_s"] = samples / _best(lambda: go(samples), repeat)
        out[name] = row
    return out


def run(args) -> int:
    for option, value in (("--prefix-apytypes", args.prefix_apytypes), ("--prefix-fxpmath", args.prefix_fxpmath)):
        if not 1 <= value <= args.samples:
            raise InputError(f"{option}: must be within 1..--samples ({args.samples}), got {value}")
    design = build(args.config)
    iirs = [b for n, b in design.blocks.items() if design.instances[n].module == "iir"]
    if not iirs:
        raise InputError(f"--config {args.config}: fxdsp bench times an iir block against apytypes and fxpmath; "
                         f"the config has none")
    iir = iirs[0]
    rng = np.random.default_rng(design.seed)
    fmt = iir.data_format
    x = (0.25 * fmt.max_int * np.sin(2 * np.pi * np.arange(args.samples) / 997)
         + rng.normal(0, 0.1 * fmt.max_int, args.samples)).astype(np.int64)

    iir.filter(x[:1000])  # compile
    t_biquad = _best(lambda: iir.filter(x), args.repeat)
    y_ref = iir.filter(x)

    chains = {}
    for name, chain in design.chains.items():   # every chain of the config, on its nominal stimulus
        stim = chain.nominal_stimulus(rng, args.samples)
        chain.run(**{k: v[:1000] for k, v in stim.items()})   # compile
        n = len(next(iter(stim.values())))
        chains[name] = {"samples": n, "samples_per_s": n / _best(lambda: chain.run(**stim), max(2, args.repeat // 2))}

    results = {"machine": platform.machine(), "python": platform.python_version(), "samples": args.samples,
               "biquad": {"block": iir.name, "sections": int(iir.b.shape[0]), "rules": str(iir.rules),
                          "samples_per_s": args.samples / t_biquad},
               "chains": chains, "drive": _drive_loops(design, args.samples, args.repeat)}

    for name, fn, n in (("apytypes", biquad_apytypes, args.prefix_apytypes),
                        ("fxpmath", biquad_fxpmath, args.prefix_fxpmath)):
        n = min(n, args.samples)
        t = time.perf_counter()
        y = fn(iir, x[:n])
        dt = time.perf_counter() - t
        same = int(np.count_nonzero(y == y_ref[:n])) if y is not None else 0
        rate = n / dt
        results[name] = {"prefix_samples": n, "samples_per_s": rate, "extrapolated_s_for_all": args.samples / rate,
                         "bit_identical_samples": same, "ratio_fxdsp_over_lib": results["biquad"]["samples_per_s"] / rate}

    b = results["biquad"]["samples_per_s"]
    print(f"fxdsp bench  ({args.samples} samples, int64 in/out, best of {args.repeat}; {platform.machine()})")
    print(f"  biquad [{iir.name}] ({results['biquad']['sections']} section, {iir.rules}):  {b / 1e6:8.1f} MS/s   "
          f"target >= 150")
    for name, c in chains.items():
        print(f"  {name + ':':47s}{c['samples_per_s'] / 1e6:8.1f} MS/s   target >= 20")
    for name, c in results["drive"].items():
        label = f"{name} closed on its resonator (fixed / float):"
        print(f"  {label:47s}{c['fixed_samples_per_s'] / 1e6:8.1f} / {c['float_samples_per_s'] / 1e6:.1f} MS/s   "
              f"(one hour at {c['fs_hz'] / 1e3:g} kS/s: {3600 * c['fs_hz'] / c['fixed_samples_per_s']:.0f} s)")
        print(f"  {'  its resonator and pick-off ADC alone:':47s}{c['resonator_samples_per_s'] / 1e6:8.1f} MS/s   "
              f"target >= 10")
    for name in ("apytypes", "fxpmath"):
        r = results[name]
        print(f"  same biquad in {name:8s}: {r['samples_per_s'] / 1e3:8.2f} kS/s on a {r['prefix_samples']}-sample "
              f"prefix (extrapolated: {r['extrapolated_s_for_all']:.0f} s for all);  fxdsp is "
              f"{r['ratio_fxdsp_over_lib']:,.0f}x faster;  bit-identical on {r['bit_identical_samples']}/"
              f"{r['prefix_samples']}")
    if args.json:
        with staged() as stage:
            stage.write_text(args.json, json_text(results, "--json", indent=1))
    return 0



