"""Scale-factor compensation: signal / SF(T) with an exactly defined integer divider.

Divider (what the RTL's sequential restoring divider computes, bit for bit)::

    N = x << (sf_format.fl + guard_bits)           exact numerator, fraction in_format.fl + guard_bits
    q = sign(N) sign(d) * (|N| div |d|)            integer quotient, truncated toward zero
    y = fit(round(q))  into out_format             the paper's rescale: drop the guard bits

``rounding`` names how the guard bits are dropped (the paper drops low bits: ``floor``), ``overflow``
how the result is fitted. Division by zero gives full scale with the sign of x (0 for x = 0) and
is counted as ``sf_divide.zero``; a near-zero SF overflows the output and is counted by the fit.
The numerator width in_format.wl + sf_format.fl + guard_bits is checked against 63 bits.

The float reference divides the real values: x / SF.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from fxdsp.config import Section
from fxdsp.fixed import Format, OverflowLog, Rules, quantize
from fxdsp.fixed.kernels import convert
from fxdsp.blocks.base import Block, corner_codes, random_codes, tie_codes
from fxdsp.blocks.datapath import Datapath, OvfField, RtlPorts, info
from fxdsp.errors import InputError


@njit(cache=True)
def _divide_kernel(x, sf, num_shift, out_shift, rounding, lo, hi, overflow, counts):
    """counts += (output fits, divisions by zero)."""
    n = x.shape[0]
    y = np.empty(n, dtype=np.int64)
    for i in range(n):
        d = sf[i]
        if d == 0:
            if x[i] != 0:
                counts[1] += 1
            y[i] = hi if x[i] > 0 else (lo if x[i] < 0 else 0)
            continue
        num = x[i] << num_shift
        q = abs(num) // abs(d)  # restoring divider on magnitudes: truncation toward zero
        if (num < 0) != (d < 0):
            q = -q
        out, o = convert(q, out_shift, rounding, lo, hi, overflow)
        counts[0] += o
        y[i] = out
    return y


@dataclass(frozen=True, eq=False)
class SfDivideDatapath(Datapath):
    """Fields in the order of the ``sf_divide`` RTL module's parameters."""

    MODULE = "sf_divide"
    RTL = RtlPorts(ready=True, serial=True, signed=("y",))

    @staticmethod
    def steps(p: dict, unroll: int = 1) -> int:
        """The restoring divider's steps (hdl/rtl/sf_divide.v): ceil((IN_W + NUM_SHIFT) / UNROLL)."""
        return -(-(p["IN_W"] + p["NUM_SHIFT"]) // unroll)

    @classmethod
    def latency(cls, p: dict, unroll: int = 1) -> int:
        return cls.steps(p, unroll) + 1

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """The pipelined divider (ARCH = 1), from its accepting edge to its successor's: its
        latency, its steps + 6."""
        return SfDivideDatapath.steps(p, unroll) + 6

    in_w: int
    sf_w: int
    sf_signed: int
    out_w: int
    num_shift: int       # numerator x << (sf.fl + guard_bits): the quotient keeps guard_bits extra bits
    out_shift: int       # quotient -> out_format (the paper's rescale)
    rules: Rules
    q_format: Format = info()
    out_format: Format = info()
    ovf: tuple = info(default=(OvfField("out", 1), OvfField("zero", 1)))


class SfDivide(Block):
    """Scale-factor compensation ``y = x / sf`` by an exact integer divider and the paper's rescale
    (module docstring)."""

    name = "sf_divide"

    def __init__(self, in_format: Format, sf_format: Format, out_format: Format, guard_bits: int, rules: Rules):
        if guard_bits < 0:
            raise InputError(f"sf_divide.guard_bits: must be >= 0, got {guard_bits}")
        self.num_bits = in_format.wl + sf_format.fl + guard_bits
        if self.num_bits > 63:
            raise InputError(f"sf_divide: numerator of {in_format} << ({sf_format.fl} + {guard_bits}) needs "
                             f"{self.num_bits} bits, more than 63")
        self.in_format, self.sf_format, self.out_format = in_format, sf_format, out_format
        self.guard_bits = guard_bits
        self.rules = rules
        self.q_format = Format(True, min(63, self.num_bits + 1), in_format.fl + guard_bits)
        if sf_format.fl + guard_bits < 0:
            raise InputError(f"sf_divide.guard_bits: numerator shift sf.fl + guard_bits = {sf_format.fl + guard_bits} "
                             f"must be >= 0")
        self.datapath = SfDivideDatapath(
            in_w=in_format.wl, sf_w=sf_format.wl, sf_signed=int(sf_format.signed), out_w=out_format.wl,
            num_shift=sf_format.fl + guard_bits, out_shift=self.q_format.fl - out_format.fl, rules=rules,
            q_format=self.q_format, out_format=out_format)
        self.inputs = {"x": in_format, "sf": sf_format}
        self.outputs = {"y": out_format}

    @classmethod
    def from_config(cls, sec: Section, in_format: Format, sf_format: Format) -> "SfDivide":
        return cls(in_format, sf_format, sec.format("out_format"), sec.integer("guard_bits", low=0, high=32),
                   sec.rules(default=Rules("floor", "saturate")))

    def stream(self, log: OverflowLog, x: np.ndarray, sf: np.ndarray) -> dict[str, np.ndarray]:
        dp = self.datapath
        counts = np.zeros(2, dtype=np.int64)
        y = _divide_kernel(x, sf, dp.num_shift, dp.out_shift, dp.rules.rounding_code, dp.out_format.min_int,
                           dp.out_format.max_int, dp.rules.overflow_code, counts)
        for f, c in zip(dp.ovf, counts):
            log.add(f"{self.name}.{f.counter}", int(c))
        return {"y": y}

    def reference(self, x: np.ndarray, sf: np.ndarray) -> dict[str, np.ndarray]:
        with np.errstate(divide="ignore", invalid="ignore"):
            y = np.where(sf == 0, np.sign(x) * np.inf, x / np.where(sf == 0, 1.0, sf))
        return {"y": y}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Corners of x against SF = 1, SF at and near zero (both signs), quotients that land exactly
        on rounding ties of the rescale, and nominal random samples."""
        fi, fs = self.in_format, self.sf_format
        one = quantize([1.0], fs, Rules("half_up", "saturate"))[0]
        cx = corner_codes(fi)
        near_zero = np.array([0, 1, 2, 3, -1, -2, -3], dtype=np.int64)
        near_zero = near_zero[(near_zero >= fs.min_int) & (near_zero <= fs.max_int)]
        xs = [cx, np.repeat(cx, near_zero.size), np.zeros(0, np.int64)]
        sfs = [np.full(cx.size, one), np.tile(near_zero, cx.size), np.zeros(0, np.int64)]
        # with SF = 1 the quotient is x << guard_bits: ties come from dividing by 2**k instead
        ties = tie_codes(fi, 1)
        if ties.size and (one >> 1) > 0:
            xs.append(ties)
            sfs.append(np.full(ties.size, one << 1 if (one << 1) <= fs.max_int else one))
        nom = self.nominal_stimulus(rng, n)
        xs.append(nom["x"])
        sfs.append(nom["sf"])
        return {"x": np.concatenate(xs), "sf": np.concatenate(sfs)}

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """x over half its range, SF within 10 % of the smallest divisor (at least 1) whose quotients
        of those x fit the output: a scale factor near 1, or a K1 of 52 Hz/g for a Df in Hz."""
        scale = max(1.0, self.in_format.max_value / 2 / (0.9 * self.out_format.max_value))
        sf = quantize(rng.uniform(0.9, 1.1, n) * scale, self.sf_format, Rules("half_up", "saturate"))
        x = random_codes(rng, self.in_format, n) // 2
        return {"x": x, "sf": sf}

    def parameters(self) -> dict:
        return {"in_format": str(self.in_format), "sf_format": str(self.sf_format), "out_format": str(self.out_format),
                "guard_bits": self.guard_bits, "numerator_bits": self.num_bits, "divider": "toward_zero",
                "rounding": self.rules.rounding, "overflow": self.rules.overflow}
