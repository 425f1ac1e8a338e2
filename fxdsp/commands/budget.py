"""`fxdsp budget [--config F] [--json F] [--report DIR] [--target T [--optimise --config-out F]]`:
float vs fixed error budget of every block and chain in LSBs and physical units, attribution of
each chain's error to its quantisation sources, theory check of every rounding point, and
word-length exploration; floor and margin of each chain output against its ADCs, and for every
chain with a demodulator the Allan deviation of its error and a drive-frequency sweep. Every chain
of the config is covered the same way: nothing here names one."""

from __future__ import annotations

import math
import time
from functools import partial
from pathlib import Path

from tqdm import tqdm as _tqdm

from fxdsp.chains import build
from fxdsp.float_vs_fixed import port_unit
from fxdsp.config import dumps, load_config
from fxdsp.hdl.hwreport import hw_report_path, synthesised_cost
from fxdsp.outputs import IN, OUT_DIR, OUT_FILE, json_text, plain, staged
from fxdsp.budget import optimise as opt
from fxdsp.budget.attribution import ADDITIVITY_DB, THEORY_DB, Attribution, attribute
from fxdsp.budget.floor import (DOMINANT_FACTOR, FLICKER_FACTOR, WITHIN_DB, Allan, DriveSweep, Floor, allan_chain,
                    carrier_chains, demod_f_hz, drive_frequencies, drive_sweep, floor_of)
from fxdsp.budget.drive_loop import TEMPS_C, at_temperature, format_allan as format_reference_allan, format_budget, ramp, \
    reference_allan
from fxdsp.budget.static import static_errors
from fxdsp.budget.table import budget_rows, format_rows
from fxdsp.budget.units import parse_target
from fxdsp.errors import InputError

# progress bars on a terminal only: redirected, stderr keeps to the one line an error needs
tqdm = partial(_tqdm, disable=None)



def attributed(design) -> list[tuple[str, str]]:
    """Every (chain, output) of the design, in config order."""
    return [(c, p) for c, chain in design.chains.items() for p in chain.outputs]


def downstream_outputs(design, chain_name: str, kind: str) -> list[str]:
    """The outputs of the chain that a member of ``kind`` reaches (through the netlist)."""
    chain = design.chains[chain_name]
    net = chain.netlist
    reached = {p for p in net.order if chain.kinds[p] == kind}
    for inst in net.order:
        if any(u in reached for u in net.upstream(inst)):
            reached.add(inst)
    return [p for p, e in net.outputs.items() if e.instance in reached]


def drive_loop_budgets(design, with_ramp: bool) -> list:
    """Every drive loop of the design at TEMPS_C, and over the chamber ramp with ``with_ramp``."""
    from fxdsp.blocks.drive import Drive

    out = []
    fs_dps = design.rate_full_scale_dps
    for block in design.blocks.values():
        if isinstance(block, Drive):
            out += [at_temperature(block, t, rate_full_scale_dps=fs_dps) for t in TEMPS_C]
            if with_ramp:
                out.append(ramp(block, rate_full_scale_dps=fs_dps, progress=True))
    return out


def drive_reference_allans(design) -> list:
    """Every drive loop's NCO as a demodulator reference over an hour of lock (reference_allan)."""
    from fxdsp.blocks.drive import Drive

    return [reference_allan(b, rate_full_scale_dps=design.rate_full_scale_dps, progress=True)
            for b in design.blocks.values() if isinstance(b, Drive)]


def _scaled(st: dict, scale: float) -> dict:
    return {k: (v * scale if k in ("rms", "max_abs", "mean") else v) for k, v in st.items()}


PATHS = {"--config": IN, "--json": OUT_FILE, "--report": OUT_DIR, "--config-out": OUT_FILE}


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--json", help="write every number to this JSON file")
    parser.add_argument("--report", help="directory for the Markdown report and PNG plots")
    parser.add_argument("--target", help="error target on a chain output, <value><unit>: deg/h, deg/s, FS, C, mC, "
                                         "xnoise or %%noise (a fraction of the sensor noise at the output)")
    parser.add_argument("--chain", help="chain of --target (default: the config's first chain)")
    parser.add_argument("--metric", default="rms", choices=("rms", "max"), help="error measure of --target")
    parser.add_argument("--optimise", action="store_true", help="search small word lengths meeting --target")
    parser.add_argument("--config-out", help="with --optimise: write the optimised TOML config here")
    parser.add_argument("--cost", default="total_bits", choices=("total_bits", "register_bits"),
                        help="cost the search minimises: every bit (registers, coefficients, LUT memory; default) "
                             "or register/coefficient bits only")
    parser.add_argument("--margin", type=float, default=0.02, help="optimise to (1 - margin) x target (default 0.02)")
    parser.add_argument("--max-mean", help="with --optimise: also keep |mean| (a bias) of the --target output within "
                                           "this, <value><unit> as --target")
    parser.add_argument("--drive-ramp", action="store_true",
                        help="also run every drive loop over the chamber ramp -40 -> 85 C at 1 C/min (about 4 min of "
                             "simulation per loop; without it the drive loops are budgeted at -40, 25 and 85 C)")
    parser.add_argument("--drive-allan", action="store_true",
                        help="also run every drive loop locked for an hour and give the Allan deviation of its NCO's "
                             "error as a demodulator reference, fixed minus float, against the open-loop NCO's drift "
                             "(about 2 min of simulation per loop)")
    parser.add_argument("--drive-band", action="store_true",
                        help="with --optimise on a chain with a demodulator: meet the target at every frequency of "
                             "the drive sweep too (the band a -40..85 C silicon resonator covers), not only at the "
                             "demodulator's f_hz")


def _attr_dict(a: Attribution) -> dict:
    return {"chain": a.chain, "port": a.port, "unit": a.unit, "samples": a.samples, "total_rms": a.total_rms,
            "total_mean": a.total_mean, "total_std": a.total_std, "sensor_noise_rms": a.sensor_noise_rms,
            "hybrid_vs_bitexact_max_lsb": a.hybrid_max_diff, "power_sum_db": a.power_sum_db,
            "power_sum_with_cross_terms_db": a.with_cross_db, "mean_sum": a.mean_sum, "variance_sum_db": a.var_sum_db,
            "superposition_rms": a.superposition_rms, "tolerance_db": a.tolerance_db, "power_ok": a.power_ok,
            "explanation": a.explanation(), "by_category": a.by_category(),
            "sources": [{"name": s.source.name, "category": s.source.category, "stage": s.source.stage,
                         "rms": s.rms, "mean": s.mean, "std": s.std, "power_share": s.power_share,
                         "white_model_rms": s.model_rms} for s in a.sources],
            "cross_terms": [{"a": x, "b": y, "share": c} for x, y, c in a.cross_terms],
            "theory": [{k: v for k, v in t.__dict__.items()} for t in a.theory]}


def format_attribution(a: Attribution) -> str:
    lines = [f"{a.chain}.{a.port}: total {a.total_rms:.4g} {a.unit} rms (mean {a.total_mean:+.4g}, std {a.total_std:.4g}) "
             f"vs float on the analog inputs, {a.samples} samples; sensor noise at this output {a.sensor_noise_rms:.4g} "
             f"{a.unit} rms; all-on hybrid vs bit-exact: {a.hybrid_max_diff:g} LSB",
             f"  {'source':26s} {'category':25s} {'rms':>10s} {'mean':>11s} {'power %':>8s} {'white model':>11s}"]
    for s in sorted(a.sources, key=lambda s: -s.rms):
        model = f"{s.model_rms:.3g}" if s.model_rms is not None else "-"
        lines.append(f"  {s.source.name:26s} {s.source.category:25s} {s.rms:10.3g} {s.mean:+11.3g} "
                     f"{s.power_share * 100:8.2f} {model:>11s}")
    cats = a.by_category()
    lines.append("  by category (rms): " + ", ".join(f"{c} {math.sqrt(v):.3g}" for c, v in cats.items() if v))
    lines.append(f"  additivity: sum of powers {a.power_sum_db:+.2f} dB vs total (tolerance +-{a.tolerance_db} dB) "
                 f"-> {'OK' if a.power_ok else 'NOT within tolerance'}; with cross terms {a.with_cross_db:+.3f} dB")
    lines.append("  " + a.explanation())
    return "\n".join(lines)


def format_theory(a: Attribution) -> str:
    lines = [f"{a.chain}.{a.port}: rounding points vs theory (q^2/12, zero mean; output vs white-noise model)",
             f"  {'source':24s} {'mode':8s} {'q':>9s} {'mean/q':>7s} {'var dB':>7s} {'MSE dB':>7s} "
             f"{'out':>9s} {'model':>9s} {'out dB':>7s} flag"]
    for t in a.theory:
        lines.append(f"  {t.source:24s} {t.rounding:8s} {t.q:9.3g} {t.local_mean_q:+7.3f} {t.local_var_db:+7.2f} "
                     f"{t.local_mse_db:+7.2f} {t.output_rms:9.3g} {t.model_output_rms:9.3g} {t.output_db:+7.2f} "
                     f"{'FLAG' if t.flagged else 'ok'}")
        for r in t.reasons:
            lines.append(f"      - {r}")
    return "\n".join(lines)


def format_floor(f: Floor) -> str:
    head = f"floor: {f.chain}.{f.port} "
    dom = ", ".join(f"{n} {r:.3g}" + (f" ({20 * math.log10(r / f.total):+.1f} dB)" if f.total > 0 else "")
                    for n, r in f.dominant) or "none"
    tail = f"; dominant (within {20 * math.log10(1 / DOMINANT_FACTOR):.0f} dB of the total): {dom}"
    if f.floor <= 0:
        return head + f"floor 0 (no ADC reaches this output), total {f.total:.3g} {f.unit}: no margin" + tail
    if f.total <= 0:
        return head + f"floor {f.floor:.3g} {f.unit} (ADC), total 0: no margin" + tail
    verdict = f"within {WITHIN_DB:g} dB" if f.within else f"NOT within {WITHIN_DB:g} dB"
    if f.margin_db < 0:  # possible: correlated sources can partly cancel the ADCs' error
        verdict += " (total below the floor: the sources partly cancel)"
    return head + (f"floor {f.floor:.3g} {f.unit} (ADC), total {f.total:.3g}, margin {f.margin_db:+.1f} dB "
                   f"-> {verdict}") + tail


def format_allan(a: Allan) -> str:
    edge = " (at the longest tau: the curve is still falling, an upper bound)" if a.bi_at_longest_tau else ""
    how = ("measured" if a.measured_1s else
           f"extrapolated along tau^-1/2 from tau {a.fit_taus[0]:.3g}..{a.fit_taus[-1]:.3g} s")
    return "\n".join([
        f"{a.chain}.{a.port} bit-exact minus float at {a.temp_c:g} C and a constant input {a.level:g}, {a.samples} "
        f"samples at "
        f"{a.fs:g} Hz after {a.settle} settling samples (allantools.oadev, octave-spaced taus "
        f"{a.taus[0]:.3g}..{a.taus[-1]:.3g} s):",
        f"  bias instability: min adev {a.bi_adev:.3g} {a.unit} at tau {a.bi_tau:.3g} s{edge}; flicker floor "
        f"B = min / {FLICKER_FACTOR} = {a.flicker_floor:.3g} {a.unit} (IEEE 952: sigma = {FLICKER_FACTOR} B on "
        f"the flat part)",
        f"  random walk of the fixed-point design: adev(1 s) {a.adev_1s:.3g} {a.unit} ({how}) -> "
        f"adev(1 s) / 60 = {a.arw:.3g} {a.unit} sqrt(h)" + (" (the angle random walk, deg/sqrt(h))"
                                                           if a.unit == "deg/h" else "")])


def format_sweep(s: DriveSweep) -> str:
    lo_t, hi_t = s.temp_range_c
    lines = [f"{s.chain}.{s.port} vs drive frequency ({s.demod}.f_hz): w(T) = w0 [1 - a (T - T0) / 2], a {s.a_ppm_per_c:g} ppm/C, "
             f"T0 {s.t0_c:g} C, {lo_t:g}..{hi_t:g} C -> {s.band[0]:.2f}..{s.band[1]:.2f} Hz around f0 "
             f"{s.f0:g} Hz, {len(s.points)} points ({s.unit}; nominal = section 1's chain row, static = "
             f"quasi-static chamber points)",
             f"  {'f Hz':>10s} {'rms':>9s} {'mean':>10s} {'static rms':>10s} {'static mean':>11s} {'ovf':>4s}"]
    for p in s.points:
        lines.append(f"  {p.f_hz:10.2f} {p.rms:9.4g} {p.mean:+10.3g} {p.static_rms:10.4g} {p.static_mean:+11.3g} "
                     f"{p.overflows:4d}")
    w = {k: s.worst(k) for k in ("rms", "mean", "static_rms", "static_mean")}
    lines.append(f"  worst over the band: rms {w['rms'].rms:.4g} at {w['rms'].f_hz:.2f} Hz, |mean| "
                 f"{abs(w['mean'].mean):.4g} at {w['mean'].f_hz:.2f} Hz; quasi-static rms "
                 f"{w['static_rms'].static_rms:.4g} at {w['static_rms'].f_hz:.2f} Hz, |mean| "
                 f"{abs(w['static_mean'].static_mean):.4g} at {w['static_mean'].f_hz:.2f} Hz")
    return "\n".join(lines)


def run(args) -> int:
    with staged() as stage:  # every output moved into place only when the whole run has succeeded
        return _run(args, stage)


def _run(args, stage) -> int:
    t0 = time.time()
    cfg = load_config(args.config)
    design = build(cfg)
    if args.chain is None:
        args.chain = next(iter(design.chains), None)
    if args.config_out and not args.optimise:
        raise InputError("--config-out: only with --optimise")
    if args.optimise and not args.target:
        raise InputError("--optimise: needs --target <value><unit>")
    opt.check_search(args.chain, args.margin, chains=design.chains, search=args.optimise, cost_model=args.cost,
                     drive_band=args.optimise and args.drive_band)
    for opt_only in ("max_mean", "drive_band"):
        if getattr(args, opt_only) and not args.optimise:
            raise InputError(f"--{opt_only.replace('_', '-')}: only with --optimise")
    # the target's chain first: a target that names no output of it is refused before the rest is run
    own = {(c, p): attribute(design, c, p) for c, p in attributed(design) if c == args.chain}
    noise = {p: a.sensor_noise_rms for (c, p), a in own.items()}
    target = parse_target(args.target, design, args.chain, noise) if args.target else None
    max_mean = parse_target(args.max_mean, design, args.chain, noise, "--max-mean") if args.max_mean else None
    if args.optimise:
        opt.check_search(args.chain, target=target, max_mean=max_mean)
    attrs = {key: own[key] if key in own else attribute(design, *key) for key in attributed(design)}

    print(f"fxdsp budget: config {cfg.source}, seed {design.seed}")
    print("\n1. bit-exact vs float reference (float fed with the same stored inputs), nominal stimulus:")
    rows = budget_rows(design)
    print(format_rows(rows))
    statics = {}
    for c, chain in design.chains.items():
        if chain.sensor is None:
            continue
        for p, st in static_errors(design, c).items():
            unit, scale = port_unit(design, c, p)
            statics[(c, p)] = st = _scaled(st, scale)
            print(f"{c}.{p} at {st['samples'] // 1024} quasi-static chamber temperatures (settled): rms "
                  f"{st['rms']:.4g} {unit}, max {st['max_abs']:.4g}, mean {st['mean']:+.4g}, overflows "
                  f"{st['overflows']}")
    print("\n2. attribution (one source quantised at a time, the rest in float; vs float on the analog inputs):")
    for a in attrs.values():
        print(format_attribution(a))
    floors = [floor_of(a) for a in attrs.values()]
    print("\nfloor and margin (floor = the input ADCs' quantisation carried to the output; margin = 20 log10"
          "(total / floor); dominant: a non-ADC source with rms >= total / 2):")
    for f in floors:
        print(format_floor(f))
    print(f"\n3. theory check (flag: more than {THEORY_DB} dB worse than theory):")
    for a in attrs.values():
        if a.theory:
            print(format_theory(a))
    carriers = {c: downstream_outputs(design, c, "demod") for c in carrier_chains(design)}
    print("\n4. Allan deviation of the fixed-point error (every output of a chain with a demodulator):")
    allans = [a for c, ports in carriers.items() for a in allan_chain(design, c, ports)]
    for al in allans:
        print(format_allan(al))
    if not allans:
        print("  none: no chain of this config has a demodulator and a sensor")
    print("\n5. drive-frequency sweep (the demodulator reference tracks the drive loop, which moves with "
          "temperature):")
    t_sweep = time.time()
    sweeps = [s for c, ports in carriers.items()   # a bar only if it ever takes > 2 s
              for s in drive_sweep(cfg, c, ports, progress=partial(tqdm, delay=2.0))]
    t_sweep = time.time() - t_sweep
    for sw in sweeps:
        print(format_sweep(sw))
    print(f"  ({sum(len(sw.points) for sw in sweeps)} points in {t_sweep:.1f} s)")
    loops = drive_loop_budgets(design, args.drive_ramp)
    print("\n6. drive loops (bit-exact and float closed on the simulated mode from power-on; floor = the float loop "
          "on the same drive ADC codes; margin = 20 log10(fixed / floor) of the frequency noise):")
    for lb in loops:
        print(format_budget(lb))
    if not loops:
        print("  none: this config has no drive loop")
    references = drive_reference_allans(design) if args.drive_allan else []
    for ra in references:
        print(format_reference_allan(ra))

    out = {"config": cfg.name, "seed": design.seed,
           "table": [r.as_dict() for r in rows],
           "static": [{"chain": c, "port": p, "unit": port_unit(design, c, p)[0], **st}
                      for (c, p), st in statics.items()],
           "attribution": [_attr_dict(a) for a in attrs.values()], "additivity_tolerance_db": ADDITIVITY_DB,
           "theory_limit_db": THEORY_DB, "floor": [f.as_dict() for f in floors],
           "allan": [al.as_dict() for al in allans], "drive_sweep": [sw.as_dict() for sw in sweeps],
           "drive_loop": [lb.as_dict() for lb in loops],
           "drive_reference_allan": [ra.as_dict() for ra in references],
           "null_means": "an infinite or undefined value (an exact port's SNR, a margin without a floor)"}
    status = 0
    result = None
    if target:
        row = next(r for r in rows if r.stats.block == target.chain and r.stats.port == target.port)
        measured = (row.stats.rms if args.metric == "rms" else row.stats.max_abs) * row.stats.scale
        st = statics.get((target.chain, target.port))
        if st is not None:
            measured = max(measured, st["rms"] if args.metric == "rms" else st["max_abs"])
        meets = measured <= target.value
        kind = "nominal and quasi-static" if st is not None else "nominal"
        print(f"\ntarget {args.target} on {target.chain}.{target.port} ({args.metric}, {kind}): "
              f"{target.value:.4g} {target.unit}; this config: {measured:.4g} {target.unit} -> "
              f"{'MET' if meets else 'NOT MET'}")
        out["target"] = {"text": args.target, "value": target.value, "unit": target.unit, "chain": target.chain,
                         "port": target.port, "metric": args.metric, "measured": measured, "met": meets}
        if args.optimise:
            freqs = tuple(drive_frequencies(demod_f_hz(cfg, design, target.chain))) if args.drive_band else ()
            result = opt.optimise(cfg, target, args.metric, args.margin, progress=tqdm, cost_model=args.cost,
                                  max_mean=max_mean, frequencies=freqs)
            print(f"\n7. word-length search ({result.evaluations} evaluations, greedy min+b):")
            print(opt.format_result(result))
            dc, nc = result.default_cost, result.cost
            synth = opt.synth_estimate(synthesised_cost(), design.instances[target.chain].members,
                                       dc["register_bits"], nc["register_bits"])
            if synth:
                print(f"  synthesised ({hw_report_path()}, default widths): LUT {synth['lut_default']:.0f}, MAC16 "
                      f"{synth['mac16_default']:.0f}; estimate at the new widths: LUT {synth['lut_estimate']:.0f}")
            else:
                print(f"  synthesised cost: {hw_report_path()} not found (bits only)")
            if args.config_out:
                header = opt.config_header(result, "fxdsp budget --optimise", cfg.source)
                written = stage.path(args.config_out)
                written.write_text(dumps(result.data, header), encoding="utf-8")
                build(str(written))  # must load
                print(f"  wrote {args.config_out}")
            out["optimise"] = result.as_dict(synth=synth)
        elif not meets:
            status = 1

    if args.report:
        _report(stage.dir(args.report), design, cfg, rows, attrs, statics, target, result, args, floors, allans,
                sweeps, loops, references)
        print(f"\nreport written to {args.report}/budget.md")
    if args.json:  # no wall-clock time in it: the same config and seed give the same bytes
        stage.write_text(args.json, json_text(plain(out), "--json", indent=1))
    print(f"\n({time.time() - t0:.1f} s)")
    return status


def _figures(md: list, out: Path, items, stem: str, plot, text) -> None:
    """Per chain output (``items`` with ``chain`` and ``port``): its text block and its plot."""
    for item in items:
        name = f"{stem}_{item.chain}.{item.port}.png"
        plot(item, out / name)
        md.append("```\n" + text(item) + "\n```\n")
        md.append(f"![{stem.replace('_', ' ')}]({name})\n")


def _report(out: Path, design, cfg, rows, attrs, statics, target, result, args, floors, allans, sweeps,
            loops, references) -> None:
    from fxdsp.budget import report as rp

    out.mkdir(parents=True, exist_ok=True)
    figs = {}
    for (c, p), a in attrs.items():
        tag = f"{c}.{p}"
        rp.plot_spectra(a, design.chains[c].fs_hz if c in carrier_chains(design) else 1.0, out / f"spectrum_{tag}.png")
        rp.plot_attribution(a, out / f"attribution_{tag}.png")
        figs[(c, p)] = tag
    md = [f"# fxdsp error budget\n\nConfig `{cfg.source}`, seed {design.seed}.\n",
          "## 1. Bit-exact vs float reference\n\nFloat fed with the same stored inputs (ADC excluded), nominal "
          "stimulus of each block; physical units per port.\n",
          "```\n" + format_rows(rows) + "\n```\n"]
    if statics:
        md.append("Quasi-static chamber points (settled), per chain output:\n\n```\n" + "\n".join(
            f"{c}.{p}: rms {st['rms']:.4g}, max {st['max_abs']:.4g}, mean {st['mean']:+.4g} "
            f"{port_unit(design, c, p)[0]}, overflows {st['overflows']}"
            for (c, p), st in statics.items()) + "\n```\n\nA nominal stimulus sweeps its temperature range in a "
            "few thousand samples, so the temperature word's rounding becomes a fast sawtooth that an output "
            "low-pass hides; the quasi-static test does not hide it.\n")
    md.append("## 2. Attribution\n\nOne source quantised at a time (the rest in float), against the float chain fed "
              "with the analog (pre-ADC) signals. The all-on hybrid reproduces the bit-exact model (difference "
              "shown).\n")
    for key, a in attrs.items():
        md.append("```\n" + format_attribution(a) + "\n```\n")
        md.append(f"![attribution](attribution_{figs[key]}.png)\n")
    md.append("### Floor and margin\n\nThe floor of an output is the quantisation of the input ADCs carried to it "
              "(power sum of the ADC sources above); margin = 20 log10(total / floor). A non-ADC source whose rms is "
              "at least half the total (power within 6 dB of it) dominates the design error.\n")
    md.append("```\n" + "\n".join(format_floor(f) for f in floors) + "\n```\n")
    md.append("## 3. Theory check\n\nEach rounding point's residue against q^2/12 and zero mean; each source's "
              "output contribution against the white uniform noise model pushed through the same chain (the gain "
              "after the stage).\n")
    for key, a in attrs.items():
        if a.theory:
            md.append("```\n" + format_theory(a) + "\n```\n")
            md.append(f"![spectrum](spectrum_{figs[key]}.png)\n")
    md.append("## 4. Allan deviation\n\nOverlapping Allan deviation of the bit-exact minus float error (both fed "
              "the same ADC codes) at constant temperature and input, for every output of a chain with a "
              "demodulator.\n")
    _figures(md, out, allans, "allan", rp.plot_allan, format_allan)
    md.append("## 5. Drive-frequency sweep\n\nThe design rebuilt with the demodulator's f_hz at each drive "
              "frequency the temperature range produces; both the carrier and the NCO move.\n")
    _figures(md, out, sweeps, "drive_sweep", rp.plot_drive_sweep, format_sweep)
    md.append("## 6. Drive loops\n\nThe bit-exact loop and its float reference closed on the simulated mode from "
              "power-on with the same pick-off noise; the float loop reads the same drive ADC codes, so its errors "
              "are the floor the ADC allows. Frequency word against the mode's true resonance over 10 ms records "
              "after lock; rate error = the reference phase error on the nominal quadrature.\n")
    md.append("```\n" + ("\n".join(format_budget(lb) for lb in loops) or "no drive loop") + "\n```\n")
    for ra in references:
        name = f"reference_allan_{ra.table}.png"
        rp.plot_reference_allan(ra, out / name)
        md.append("```\n" + format_reference_allan(ra) + "\n```\n")
        md.append(f"![reference Allan deviation]({name})\n")
    chain = target.chain if target else args.chain
    port = target.port if target else (list(design.chains[chain].outputs)[-1] if chain else None)
    if chain and opt.knobs_of(cfg.data, chain):
        sweeps_wl = opt.sweep(cfg, chain, port, progress=tqdm)
        unit = port_unit(design, chain, port)[0]
        name = f"wordlength_{chain}.{port}.png"
        rp.plot_sweeps(sweeps_wl, unit, target.value if target else None, out / name,
                       f"{chain}.{port}: error vs word length, one knob at a time (others at default)")
        md.append(f"## 7. Word length\n\n![sweep]({name})\n")
    else:
        md.append(f"## 7. Word length\n\n{chain}: no word-length knobs (fxdsp.budget.optimise.KIND_KNOBS).\n")
    if result:
        md.append(f"Target {args.target} ({result.target.value:.4g} {result.target.unit}, {result.metric}): error "
                  f"{result.default_error:.4g} -> {result.error:.4g}; total bits {result.default_cost['total_bits']} -> "
                  f"{result.cost['total_bits']}.\n\n```\n" + "\n".join(
                      f"{k:30s} {result.default_values[k]:3d} -> {v:3d}" for k, v in result.values.items()) + "\n```\n")
    (out / "budget.md").write_text("\n".join(md), encoding="utf-8")
