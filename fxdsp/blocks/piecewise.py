"""Piecewise-polynomial coefficient engine: segment select by comparing the temperature code with
breakpoints, then a polynomial of order 1..3 evaluated by Horner's rule in fixed point.

It serves every paper: four linear segments of SF(T) and bias(T) (paper 002), one quadratic bias in
T (paper 001), one cubic K0(t), K1(t) in t = T - 25 C (paper 000).

Segment rule: with breakpoints b_1 < ... < b_{S-1} (quantised to the temperature format, still
strictly increasing), segment i is taken when b_i <= T < b_{i+1}: a temperature exactly on a
breakpoint belongs to the segment *above* it (hardware: ``seg = number of breakpoints <= T``).

Datapath (all stored integers):

* t = T - t0, exact (t0 quantised to the temperature format; t has one more bit);
* acc = c_N in ``acc_format``; then for k = N-1 .. 0:
  acc = fit(round(acc * t)) + c_k, the product rounded by ``rounding`` into ``acc_format`` and
  every fit (product and sum) by ``overflow``, each counted;
* y = fit(round(acc)) into ``out_format``.

Coefficients are given per segment in ascending powers of (T - t0) (c0 + c1 t + ...), real values
quantised (half_up; an out-of-range coefficient is a config error) to ``coef_format``: one format
for all powers, or a list with one format per power (a cubic's c3 is orders of magnitude smaller
than its c0 and wants its own scaling, as each coefficient ROM in hardware has).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from fxdsp.config import Section
from fxdsp.fixed import Format, OverflowLog, Rules, product_format, quantize, sum_format
from fxdsp.fixed.kernels import convert
from fxdsp.blocks.base import Block
from fxdsp.blocks.datapath import Datapath, limbs, OvfField, Rom, RtlPorts, const, frozen_array, info, packed, signed_width
from fxdsp.errors import InputError


@njit(cache=True)
def _piecewise_kernel(temp, breakpoints, coef, t0, top_shift, prod_shift, acc_align, coef_align,
                      out_shift, rounding, overflow, acc_lo, acc_hi, out_lo, out_hi, counts):
    """Segment select + Horner on stored integers. counts += (acc fits, product fits, output fits)."""
    n = temp.shape[0]
    order = coef.shape[1] - 1
    n_bp = breakpoints.shape[0]
    y = np.empty(n, dtype=np.int64)
    n_acc = 0
    n_prod = 0
    n_out = 0
    for i in range(n):
        t_in = temp[i]
        seg = 0
        for b in range(n_bp):  # comparators: count breakpoints <= T
            seg += breakpoints[b] <= t_in
        t = t_in - t0
        acc, o = convert(coef[seg, order], top_shift, rounding, acc_lo, acc_hi, overflow)
        n_acc += o
        for k in range(order - 1, -1, -1):
            p, o = convert(acc * t, prod_shift, rounding, acc_lo, acc_hi, overflow)
            n_prod += o
            # the sum is exact at the finer fraction length, then back to acc_format: shifted by acc_align
            acc, o = convert((p << acc_align[k]) + (coef[seg, k] << coef_align[k]), acc_align[k], rounding,
                             acc_lo, acc_hi, overflow)
            n_acc += o
        out, o = convert(acc, out_shift, rounding, out_lo, out_hi, overflow)
        n_out += o
        y[i] = out
    counts[0] += n_acc
    counts[1] += n_prod
    counts[2] += n_out
    return y

@dataclass(frozen=True, eq=False)
class PiecewiseDatapath(Datapath):
    """Fields in the order of the ``piecewise`` RTL module's parameters."""

    MODULE = "piecewise"
    RTL = RtlPorts(ready=True, serial=True, mac_bundle=True, second_set=True, signed=("temp",))

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """hdl/rtl/piecewise.v: ORDER (N + 11) + 7, N the limb products of acc (ACC_W bits) x t
        (T_W + 1 bits)."""
        return p["ORDER"] * (limbs(*PiecewiseDatapath.mac_operands(p)) + 11) + 7

    @staticmethod
    def mac_operands(p: dict) -> tuple[int, int]:
        return p["ACC_W"], p["T_W"] + 1

    t_w: int
    order: int
    segments: int
    coef_w: int              # ROM word: the widest coefficient format
    acc_w: int
    out_w: int
    out_signed: int
    t0: int = const()        # t0 on the temperature code
    top_shift: int           # top coefficient into acc_format (right shift, rounding; <= 0 exact)
    prod_shift: int          # acc * t back to acc_format
    acc_align: np.ndarray = packed()   # per power k: acc left-aligned to the sum's fraction length ...
    coef_align: np.ndarray = packed()  # ... and c_k left-aligned to it; the sum goes back by acc_align
    out_shift: int           # acc_format -> out_format
    rules: Rules
    coef: Rom                # segments x (order + 1) coefficients, ascending powers
    bp: Rom                  # breakpoint codes (one 0 word when there is one segment)
    acoef_w: int             # the serial engine's ROM word (ARCH = 1): the widest of the words below
    acoef: Rom               # per segment c_k << coef_align[k] (k < order), then c_order as it is: the
    #                          Horner sum adds the coefficient word as read (exact: the same integers)
    temp_format: Format = info()
    acc_format: Format = info()
    out_format: Format = info()
    ovf: tuple = info()


class Piecewise(Block):
    """Piecewise-polynomial coefficient engine: temperature ``temp`` -> ``y`` by segment select and
    a Horner polynomial of order 1..3 (SF(T), bias(T), K0/K1; module docstring)."""

    def __init__(self, breakpoints_c, coefficients, temp_format: Format, coef_format: Format | list[Format],
                 acc_format: Format, out_format: Format, rules: Rules, t0_c: float = 0.0, name: str = "piecewise"):
        self.name = name
        coefficients = [list(map(float, c)) for c in coefficients]
        breakpoints_c = [float(b) for b in breakpoints_c]
        if len(coefficients) != len(breakpoints_c) + 1:
            raise InputError(f"{name}.coefficients: {len(breakpoints_c)} breakpoints need "
                             f"{len(breakpoints_c) + 1} segments, got {len(coefficients)}")
        orders = {len(c) for c in coefficients}
        if len(orders) != 1:
            raise InputError(f"{name}.coefficients: every segment needs the same number of coefficients")
        n_coef = orders.pop()
        if not 2 <= n_coef <= 4:
            raise InputError(f"{name}.coefficients: polynomial order must be 1..3 (2..4 coefficients), "
                             f"got {n_coef} coefficients")
        if any(b2 <= b1 for b1, b2 in zip(breakpoints_c, breakpoints_c[1:])):
            raise InputError(f"{name}.breakpoints_c: must be strictly increasing without duplicates, "
                             f"got {breakpoints_c}")
        self.order = n_coef - 1
        coef_formats = list(coef_format) if isinstance(coef_format, (list, tuple)) else [coef_format] * n_coef
        if len(coef_formats) != n_coef:
            raise InputError(f"{name}.coef_format: {len(coef_formats)} formats for {n_coef} coefficients per segment")
        self.temp_format, self.coef_formats = temp_format, coef_formats
        self.acc_format, self.out_format = acc_format, out_format
        self.rules = rules
        exact = Rules("half_up", "saturate")
        qlog = OverflowLog()
        self.breakpoints_c = breakpoints_c
        self.breakpoints = quantize(breakpoints_c, temp_format, exact, qlog, "breakpoints") if breakpoints_c \
            else np.zeros(0, np.int64)
        if qlog.total:
            raise InputError(f"{name}.breakpoints_c: outside the temperature format {temp_format}")
        if np.any(np.diff(self.breakpoints) <= 0):
            raise InputError(f"{name}.breakpoints_c: two breakpoints fall on the same code of {temp_format}")
        self.t0_c = t0_c
        self.t0 = quantize([t0_c], temp_format, exact, qlog, "t0")
        if qlog.total:
            raise InputError(f"{name}.t0_c: {t0_c} is outside the temperature format {temp_format}")
        self.coefficients_real = np.array(coefficients)
        self.coef = np.empty(self.coefficients_real.shape, dtype=np.int64)
        for k, fmt in enumerate(coef_formats):
            self.coef[:, k] = quantize(self.coefficients_real[:, k], fmt, exact, qlog, "coef")
            if qlog.total:
                raise InputError(f"{name}.coefficients: c{k} up to {np.abs(self.coefficients_real[:, k]).max():.6g} "
                                 f"does not fit coef_format {fmt}")
        self.breakpoints.setflags(write=False)
        t_format = sum_format(temp_format, temp_format)  # T - t0, one bit wider than the temperature
        p_fmt = product_format(acc_format, t_format)  # raises if acc * t would not fit 63 bits
        sums = [sum_format(acc_format, fmt) for fmt in coef_formats]
        # shifts of the datapath (right shift = rounding, negative = exact left shift)
        coef_w = max(f.wl for f in coef_formats)
        coef_align = [sf.fl - cf.fl for sf, cf in zip(sums, coef_formats)]
        awords = self.coef.copy()
        for k in range(self.order):
            awords[:, k] = self.coef[:, k] << coef_align[k]
        acoef = Rom(awords, signed_width(awords, 2))
        self.datapath = PiecewiseDatapath(
            t_w=temp_format.wl, order=self.order, segments=int(self.coef.shape[0]), coef_w=coef_w,
            acc_w=acc_format.wl, out_w=out_format.wl, out_signed=int(out_format.signed), t0=int(self.t0[0]),
            top_shift=coef_formats[-1].fl - acc_format.fl, prod_shift=p_fmt.fl - acc_format.fl,
            acc_align=frozen_array([sf.fl - acc_format.fl for sf in sums]),
            coef_align=frozen_array(coef_align),
            out_shift=acc_format.fl - out_format.fl, rules=rules, coef=Rom(self.coef, coef_w),
            bp=Rom(self.breakpoints if self.breakpoints.size else [0], temp_format.wl),
            acoef_w=acoef.width, acoef=acoef, temp_format=temp_format, acc_format=acc_format, out_format=out_format,
            ovf=(OvfField("acc", self.order + 1), OvfField("product", self.order), OvfField("out", 1)))
        self.coef = self.datapath.coef.words
        self.inputs = {"temp": temp_format}
        self.outputs = {"y": out_format}

    @classmethod
    def from_config(cls, sec: Section, temp_format: Format) -> "Piecewise":
        """Named after its config table (``piecewise.sf``), so every error names the field."""
        breakpoints = sec.numbers("breakpoints_c")
        coefficients = sec.matrix("coefficients")
        return cls(breakpoints, coefficients, temp_format, sec.formats("coef_format"), sec.format("acc_format"),
                   sec.format("out_format"), sec.rules(), t0_c=sec.number("t0_c"), name=sec.path)

    def segment(self, temp: np.ndarray) -> np.ndarray:
        """Segment index per sample: the number of breakpoints <= T (what the comparators count)."""
        return np.searchsorted(self.breakpoints, temp, side="right").astype(np.int64)

    def stream(self, log: OverflowLog, temp: np.ndarray) -> dict[str, np.ndarray]:
        dp = self.datapath
        counts = np.zeros(len(dp.ovf), dtype=np.int64)
        a, o = dp.acc_format, dp.out_format
        y = _piecewise_kernel(temp, self.breakpoints, dp.coef.words, dp.t0, dp.top_shift, dp.prod_shift,
                              dp.acc_align, dp.coef_align, dp.out_shift,
                              dp.rules.rounding_code, dp.rules.overflow_code, a.min_int, a.max_int,
                              o.min_int, o.max_int, counts)
        for f, c in zip(dp.ovf, counts):
            log.add(f"{self.name}.{f.counter}", int(c))
        return {"y": y}

    def reference(self, temp: np.ndarray) -> dict[str, np.ndarray]:
        """Float: same segment rule on the real breakpoints, unquantised coefficients, exact t0."""
        seg = np.searchsorted(np.asarray(self.breakpoints_c), temp, side="right")
        c = self.coefficients_real[seg]
        t = np.asarray(temp, dtype=float) - self.t0_c
        y = c[:, self.order].copy()
        for k in range(self.order - 1, -1, -1):
            y = y * t + c[:, k]
        return {"y": y}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Every breakpoint and its two neighbours, full scale, and random temperatures."""
        bp = self.breakpoints
        around = np.concatenate([bp - 1, bp, bp + 1]) if bp.size else np.zeros(0, np.int64)
        fmt = self.temp_format
        span = quantize([-40.0, 85.0], fmt, Rules("half_up", "saturate"))
        sweep = np.linspace(span[0], span[1], 256).astype(np.int64)
        temps = np.concatenate([np.sort(around), [fmt.min_int, fmt.min_int + 1, -1, 0, 1, fmt.max_int - 1,
                                                  fmt.max_int], sweep, rng.integers(span[0], span[1], n)])
        temps = temps[(temps >= fmt.min_int) & (temps <= fmt.max_int)]
        return {"temp": temps.astype(np.int64)}

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        span = quantize([-40.0, 85.0], self.temp_format, Rules("half_up", "saturate"))
        return {"temp": rng.integers(span[0], span[1], n)}

    def parameters(self) -> dict:
        return {"order": self.order, "segments": int(self.coef.shape[0]), "temp_format": str(self.temp_format),
                "coef_format": [str(f) for f in self.coef_formats], "acc_format": str(self.acc_format),
                "out_format": str(self.out_format), "rounding": self.rules.rounding,
                "overflow": self.rules.overflow, "t0": int(self.t0[0]), "breakpoints": self.breakpoints.tolist(),
                "coefficients": self.coef.tolist(), "breakpoints_c": self.breakpoints_c,
                "coefficients_real": self.coefficients_real.tolist()}

