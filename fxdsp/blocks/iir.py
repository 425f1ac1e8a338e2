"""IIR filter: a cascade of biquads (second-order sections) designed with scipy.signal.

Structure: **direct form I** per section, chosen because its only rounding point is the section
output and its accumulator never overflows internally when wide enough (no internal state of
unknown range as in transposed DF-II)::

    acc  = b0 x[n] + b1 x[n-1] + b2 x[n-2] - a1 y[n-1] - a2 y[n-2]      exact, wide
    y[n] = fit(round(acc))                                               into data_format

* Numerator coefficients are quantised to ``num_format``, denominator (a1, a2) to ``den_format``
  (a low-pass with a low cut-off has tiny b and a1 close to -2: they want different formats).
  Each section of a low-pass is scaled to unity DC gain, so the overall gain is not carried by
  one section's tiny numerator.
* DC-exact numerator (low-pass, ``dc_exact``): with a cut-off far below fs, 1 + a1 + a2 is tiny
  (1e-5 at 50 Hz / 96 kHz) and quantising a1, a2 alone would move the DC gain by about 1 %. The
  middle tap b1 absorbs the rounding instead, so that sum(b) = 1 + a1 + a2 holds *exactly* on the
  quantised coefficients: each section passes DC with gain exactly 1 (needs num.fl >= den.fl).
* Error feedback (``error_feedback``): the output rounding sits inside the loop, where a
  narrow low-pass amplifies it by 1/(1 + a1 + a2) (94 000 at 50 Hz / 96 kHz: half an LSB becomes
  0.01 FS). The rounding error e = acc - (round(acc) << shift) of the last two samples is added
  back with integer weights c1 = -nearest(a1), c2 = -nearest(a2) (2 and -1 for a narrow low-pass),
  which shapes the rounding noise by 1 + nearest(a1) z^-1 + nearest(a2) z^-2 = (1 - z^-1)^2: zero at
  DC. After an overflow the error is taken as 0 (a saturated sample carries no useful residue).
* Products are aligned to the finer of the two product fraction lengths and summed exactly in
  int64; the accumulator width is checked against 63 bits when the filter is built.
* Section outputs: rounded by ``rounding``, fitted into ``data_format`` by ``overflow``, and
  each section's overflows counted (``iir.section<i>``).
* The float reference runs scipy.signal.sosfilt with the unquantised design, so the difference
  includes coefficient quantisation as well as data-path rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal as sps
from numba import njit

from fxdsp.config import Section
from fxdsp.fixed import Format, OverflowLog, Rules, quantize
from fxdsp.fixed.kernels import fit, shift_right_round
from fxdsp.blocks.base import Block, corner_codes, random_codes
from fxdsp.blocks.datapath import Datapath, limbs, OvfField, Rom, RtlPorts, info, signed_width
from fxdsp.errors import InputError

DESIGNS = ("butter", "cheby1", "bessel")
BTYPES = ("lowpass", "highpass")


@njit(cache=True)
def df1_step(v, x1, x2, y1, y2, e1, e2, b0, b1, b2, a1, a2, c1, c2, shift_b, shift_a, out_shift, rounding, lo, hi,
             overflow):
    """One sample of one DF-I section: (output, overflowed, rounding error e fed back next sample;
    0 after an overflow). The section loops below and the drive loop's per-sample low-pass call it."""
    acc = ((b0 * v + b1 * x1 + b2 * x2) << shift_b) - ((a1 * y1 + a2 * y2) << shift_a) + c1 * e1 + c2 * e2
    r = shift_right_round(acc, out_shift, rounding)
    out, o = fit(r, lo, hi, overflow)
    e = 0 if o else acc - (r << out_shift)
    return out, o, e


@njit(cache=True)
def _df1_section(x, b0, b1, b2, a1, a2, c1, c2, shift_b, shift_a, out_shift, rounding, lo, hi, overflow, state):
    """One DF-I section over a whole stream, its state in registers; returns (y, overflows).

    ``state`` = (x1, x2, y1, y2, e1, e2) is read at the start and written back at the end; e1, e2
    are the last two rounding errors (acc - rounded << out_shift, 0 after an overflow) fed back
    with integer weights c1, c2 (error feedback; c1 = c2 = 0 turns it off)."""
    n = x.shape[0]
    y = np.empty(n, dtype=np.int64)
    x1, x2, y1, y2, e1, e2 = state[0], state[1], state[2], state[3], state[4], state[5]
    count = 0
    for i in range(n):
        v = x[i]
        out, o, e = df1_step(v, x1, x2, y1, y2, e1, e2, b0, b1, b2, a1, a2, c1, c2, shift_b, shift_a, out_shift,
                             rounding, lo, hi, overflow)
        count += o
        x2 = x1
        x1 = v
        y2 = y1
        y1 = out
        e2 = e1
        e1 = e
        y[i] = out
    state[0], state[1], state[2], state[3], state[4], state[5] = x1, x2, y1, y2, e1, e2
    return y, count


@njit(cache=True)
def df1_cascade_step(v, b, a, c, shift_b, shift_a, out_shift, rounding, lo, hi, overflow, state, counts):
    """One sample through the whole cascade, each section's state in its row of ``state`` (the
    same words as :func:`_df1_cascade` over a stream: a section sees its predecessor's outputs)."""
    for s in range(b.shape[0]):
        st = state[s]
        out, o, e = df1_step(v, st[0], st[1], st[2], st[3], st[4], st[5], b[s, 0], b[s, 1], b[s, 2], a[s, 0],
                             a[s, 1], c[s, 0], c[s, 1], shift_b, shift_a, out_shift, rounding, lo, hi, overflow)
        counts[s] += o
        st[1] = st[0]
        st[0] = v
        st[3] = st[2]
        st[2] = out
        st[5] = st[4]
        st[4] = e
        v = out
    return v


@njit(cache=True)
def _df1_cascade(x, b, a, c, shift_b, shift_a, out_shift, rounding, lo, hi, overflow, state, counts):
    """The cascade, section after section over the whole stream: bit-identical to sample-major
    order (a section sees only its predecessor's output sequence) and keeps each state in registers."""
    v = x
    for s in range(b.shape[0]):
        v, n_ovf = _df1_section(v, b[s, 0], b[s, 1], b[s, 2], a[s, 0], a[s, 1], c[s, 0], c[s, 1], shift_b,
                                shift_a, out_shift, rounding, lo, hi, overflow, state[s])
        counts[s] += n_ovf
    return v


def design_sos(design: str, order: int, cutoff_hz: float, fs_hz: float, btype: str = "lowpass",
               ripple_db: float = 0.5) -> np.ndarray:
    """Float SOS from scipy, each low-pass section normalised to unity DC gain."""
    if not 0 < cutoff_hz < fs_hz / 2:
        raise InputError(f"cutoff_hz: must be within (0, fs/2 = {fs_hz / 2}), got {cutoff_hz}")
    if design == "butter":
        sos = sps.butter(order, cutoff_hz, btype=btype, fs=fs_hz, output="sos")
    elif design == "cheby1":
        sos = sps.cheby1(order, ripple_db, cutoff_hz, btype=btype, fs=fs_hz, output="sos")
    else:
        sos = sps.bessel(order, cutoff_hz, btype=btype, fs=fs_hz, output="sos", norm="phase")
    sos = np.array(sos, dtype=float)
    if btype == "lowpass":
        total = np.prod(sos[:, :3].sum(axis=1) / sos[:, 3:].sum(axis=1))
        for s in range(sos.shape[0]):
            sos[s, :3] *= sos[s, 3:].sum() / sos[s, :3].sum()
        sos[-1, :3] *= total  # unity for butter/bessel, the ripple offset for cheby1
    return sos


@dataclass(frozen=True, eq=False)
class IirDatapath(Datapath):
    """Fields in the order of the ``iir`` RTL module's parameters."""

    MODULE = "iir"
    RTL = RtlPorts(ready=True, serial=True, mac_bundle=True)

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """hdl/rtl/iir.v: SECTIONS * (7 N + 10) + 1 cycles, N the 16 x 16 limb products of one
        coefficient-or-error x data product."""
        return p["SECTIONS"] * (7 * limbs(*IirDatapath.mac_operands(p)) + 10) + 1

    @staticmethod
    def mac_operands(p: dict) -> tuple[int, int]:
        return max(p["ACOEF_W"], p["OUT_SHIFT"] + 2), p["DATA_W"]

    data_w: int
    sections: int
    coef_w: int          # ROM word: the wider of num_format and den_format (>= 4 for the c weights)
    shift_b: int         # b x products left-aligned to the accumulator's fraction length ...
    shift_a: int         # ... and a y products
    out_shift: int       # accumulator -> data_format (the one rounding of a section)
    acc_w: int           # the bound acc_bits plus one bit: the RTL's signed accumulator register
    rules: Rules
    coef: Rom            # per section b0 b1 b2 a1 a2 c1 c2
    acoef_w: int         # the serial engine's ROM word (ARCH = 1): the widest of the words below
    acoef: Rom           # per section b0 b1 b2 << shift_b, -(a1 a2 << shift_a), c1 c2: each product
    #                      then enters the accumulator as it is (the alignment and the subtraction of
    #                      the a products are in the words: exact integers, the same sums)
    b: np.ndarray = info()   # sections x 3, num_format
    a: np.ndarray = info()   # sections x 2 (a1, a2), den_format
    c: np.ndarray = info()   # sections x 2 error-feedback weights (0 when off)
    c_w: int = info()        # bits the c weights need (the RTL holds 4)
    data_format: Format = info()
    ovf: tuple = info()      # one flag per section output


class Iir(Block):
    """Biquad cascade in direct form I with error feedback: ``x`` -> ``y`` in ``data_format``; the
    float reference is scipy's ``sosfilt`` of the unquantised design (module docstring)."""

    name = "iir"

    def __init__(self, sos: np.ndarray, data_format: Format, num_format: Format, den_format: Format,
                 rules: Rules, name: str = "iir", dc_exact: bool = False, error_feedback: bool = False):
        sos = np.asarray(sos, dtype=float)
        if sos.ndim != 2 or sos.shape[1] != 6 or sos.shape[0] < 1:
            raise InputError(f"{name}.sos: expected shape (sections, 6), got {sos.shape}")
        if not np.allclose(sos[:, 3], 1.0):
            raise InputError(f"{name}.sos: a0 of every section must be 1")
        self.name = name
        self.sos = sos
        self.data_format, self.num_format, self.den_format = data_format, num_format, den_format
        self.rules = rules
        self.inputs = {"x": data_format}
        self.outputs = {"y": data_format}
        qlog = OverflowLog()
        self.b = quantize(sos[:, :3], num_format, Rules("half_up", "saturate"), qlog, "num").reshape(-1, 3)
        self.a = quantize(sos[:, 4:], den_format, Rules("half_up", "saturate"), qlog, "den").reshape(-1, 2)
        self.dc_exact = dc_exact
        if dc_exact:
            self._make_dc_exact(name)
        if qlog.get("num"):
            raise InputError(f"{name}.num_format: {num_format} cannot hold numerator coefficients up to "
                             f"{np.abs(sos[:, :3]).max():.6g}")
        if qlog.get("den"):
            raise InputError(f"{name}.den_format: {den_format} cannot hold denominator coefficients up to "
                             f"{np.abs(sos[:, 4:]).max():.6g}")
        fl_b = num_format.fl + data_format.fl
        fl_a = den_format.fl + data_format.fl
        acc_fl = max(fl_b, fl_a)
        shift_b, shift_a = acc_fl - fl_b, acc_fl - fl_a
        # accumulator bound: |acc| <= 2**(data.wl-1) * (sum|b| 2**shift_b + sum|a| 2**shift_a) in stored units
        worst = float(2 ** (data_format.wl - 1)) * (
            np.abs(self.b).sum(axis=1) * 2.0**shift_b + np.abs(self.a).sum(axis=1) * 2.0**shift_a).max() \
            + 4.0 * 2.0 ** (acc_fl - data_format.fl)  # error feedback: |c1 e1 + c2 e2| < 4 * 2**out_shift
        self.acc_bits = int(np.ceil(np.log2(worst + 1))) + 1
        if self.acc_bits > 63:
            raise InputError(f"{name}: accumulator needs {self.acc_bits} bits for data {data_format}, "
                             f"num {num_format}, den {den_format}; more than 63")
        out_shift = acc_fl - data_format.fl
        if out_shift < 0:
            raise InputError(f"{name}: coefficient formats with negative fraction length are not supported")
        self.error_feedback = error_feedback
        # c = -nearest integer of (a1, a2), ties away from zero; the weights are tiny integers, not a datapath
        self.c = (-np.sign(sos[:, 4:]) * np.floor(np.abs(sos[:, 4:]) + 0.5)).astype(np.int64) if error_feedback \
            else np.zeros((sos.shape[0], 2), dtype=np.int64)
        for arr in (self.b, self.a, self.c):
            arr.setflags(write=False)
        coef_w = max(num_format.wl, den_format.wl, 4)
        words = np.concatenate([self.b, self.a, self.c], axis=1)
        c_max = int(np.abs(self.c).max()) if self.c.size else 0
        # the serial engine's words, in as many bits as the widest of them needs as a signed integer (at
        # most num.wl + shift_b, den.wl + shift_a + 1: the negated den minimum); >= 4 for the c weights
        awords = np.concatenate([self.b << shift_b, -(self.a << shift_a), self.c], axis=1)
        acoef_w = signed_width(awords, 4)
        self.datapath = IirDatapath(
            data_w=data_format.wl, sections=int(self.b.shape[0]), coef_w=coef_w, shift_b=shift_b, shift_a=shift_a,
            out_shift=out_shift, acc_w=self.acc_bits + 1, rules=rules, coef=Rom(words, coef_w), acoef_w=acoef_w,
            acoef=Rom(awords, acoef_w), b=self.b, a=self.a,
            c=self.c, c_w=max(2, c_max.bit_length() + 1), data_format=data_format,
            ovf=tuple(OvfField(f"section{s}", 1) for s in range(self.b.shape[0])))
        self.reset()

    def _make_dc_exact(self, name: str) -> None:
        shift = self.num_format.fl - self.den_format.fl
        if shift < 0:
            raise InputError(f"{name}.num_format: a DC-exact low-pass needs num fl >= den fl "
                             f"({self.num_format} vs {self.den_format})")
        for s in range(self.b.shape[0]):
            gain = self.sos[s, :3].sum() / self.sos[s, 3:].sum()  # 1, but for a cheby1 ripple offset
            den_sum = ((1 << self.den_format.fl) + int(self.a[s, 0]) + int(self.a[s, 1])) << shift
            target = int(quantize([gain * den_sum * 2.0 ** -self.num_format.fl], self.num_format)[0]) \
                if gain != 1.0 else den_sum
            self.b[s, 1] = target - self.b[s, 0] - self.b[s, 2]
            if not self.num_format.min_int <= self.b[s, 1] <= self.num_format.max_int:
                raise InputError(f"{name}.num_format: {self.num_format} cannot hold the DC-exact middle tap")

    @classmethod
    def from_config(cls, sec: Section, fs_hz: float, data_format: Format, name: str = "iir",
                    default_order: int = 2) -> "Iir":
        """``data_format`` is the format of the wire the filter sits on (the caller derives it);
        ``default_order`` the order when the table states none (the owner's choice)."""
        design = sec.choice("design", DESIGNS, "butter")
        order = sec.integer("order", default_order, low=1, high=12)
        btype = sec.choice("btype", BTYPES, "lowpass")
        cutoff = sec.number("cutoff_hz", low=0, low_open=True)
        ripple = sec.number("ripple_db", 0.5, low=0, low_open=True)
        try:
            sos = design_sos(design, order, cutoff, fs_hz, btype, ripple)
        except ValueError as exc:
            raise InputError(f"{sec.field('cutoff_hz')}: {exc}") from None
        return cls(sos, data_format, sec.format("num_format"), sec.format("den_format"),
                   sec.rules(), name=name, dc_exact=(btype == "lowpass"),
                   error_feedback=sec.choice("error_feedback", ("on", "off"), "on") == "on")

    def reset(self) -> None:
        self.state = np.zeros((self.b.shape[0], 6), dtype=np.int64)

    def get_state(self) -> np.ndarray:
        """Per section (x1, x2, y1, y2, e1, e2): the DF-I delay line and the error-feedback memory."""
        return self.state.copy()

    def set_state(self, state) -> None:
        st = np.asarray(state)
        if st.shape != self.state.shape or st.dtype.kind not in "iu":
            raise InputError(f"{self.name}: state: expected integers of shape {self.state.shape}, got "
                             f"{st.dtype} {st.shape}")
        self.state = st.astype(np.int64).copy()

    def stream(self, log: OverflowLog, x: np.ndarray) -> dict[str, np.ndarray]:
        """Runs from the current state (call ``reset()`` for a fresh start; ``run`` chunks stream)."""
        dp = self.datapath
        counts = np.zeros(dp.sections, dtype=np.int64)
        y = _df1_cascade(x, dp.b, dp.a, dp.c, dp.shift_b, dp.shift_a, dp.out_shift, dp.rules.rounding_code,
                         dp.data_format.min_int, dp.data_format.max_int, dp.rules.overflow_code, self.state, counts)
        for f, c in zip(dp.ovf, counts):
            log.add(f"{self.name}.{f.counter}", int(c))
        return {"y": y}

    def filter(self, x: np.ndarray, log: OverflowLog | None = None) -> np.ndarray:
        """Fresh-state bit-exact filtering of stored integers (convenience for chains)."""
        return self.run(log=log, x=x).outputs["y"]

    def reference(self, x: np.ndarray) -> dict[str, np.ndarray]:
        return {"y": sps.sosfilt(self.sos, x)}

    def settle_samples(self) -> int:
        """About five time constants of the slowest pole: how long a step takes to play out."""
        radius = max(np.abs(np.roots([1.0, a1, a2])).max() for a1, a2 in self.sos[:, 4:])
        return int(min(20_000, max(64, 5.0 / max(1e-9, 1.0 - radius))))

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Impulses at full scale (both signs), corner codes, then full-scale steps up and down, each
        long enough for the step response to overshoot (the overshoot saturates the output), a slow
        sine at 0.9 FS, and random noise."""
        fmt = self.data_format
        hi, lo = fmt.max_int, fmt.min_int
        seg = 256
        step = self.settle_samples()
        parts = [np.zeros(seg, np.int64), np.r_[hi, np.zeros(seg - 1, np.int64)], np.r_[lo, np.zeros(seg - 1, np.int64)],
                 np.tile(corner_codes(fmt), 8), np.full(step, hi, np.int64), np.full(step, lo, np.int64),
                 np.full(step, hi, np.int64), np.zeros(step, np.int64)]
        t = np.arange(seg * 2)
        parts.append((0.9 * hi * np.sin(2 * np.pi * t / (seg * 2))).astype(np.int64))
        parts.append(random_codes(rng, fmt, n) // 4)
        return {"x": np.concatenate(parts)}

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Half-scale noise plus a slow sine: in range, no saturation."""
        fmt = self.data_format
        t = np.arange(n)
        x = 0.25 * fmt.max_int * np.sin(2 * np.pi * t / 997) + rng.normal(0, 0.1 * fmt.max_int, n)
        return {"x": np.clip(x, fmt.min_int, fmt.max_int).astype(np.int64)}

    def parameters(self) -> dict:
        return {"structure": "direct form I", "sections": int(self.b.shape[0]), "data_format": str(self.data_format),
                "num_format": str(self.num_format), "den_format": str(self.den_format),
                "rounding": self.rules.rounding, "overflow": self.rules.overflow,
                "acc_bits": self.acc_bits, "dc_exact": self.dc_exact,
                "error_feedback": self.error_feedback, "c": self.c.tolist(), "b": self.b.tolist(), "a": self.a.tolist(),
                "sos_float": self.sos.tolist()}
