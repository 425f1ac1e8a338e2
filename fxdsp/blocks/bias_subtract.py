"""Bias compensation: y = fit(round(x - bias)).

The difference is exact (aligned to the finer fraction length, one carry bit); then one rounding
(``rounding``, only when out_format has fewer fraction bits) and one fit into ``out_format`` by
``overflow`` (default ``saturate``), counted as ``bias_subtract.out``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from fxdsp.config import Section
from fxdsp.fixed import Format, OverflowLog, Rules, sum_format
from fxdsp.fixed.kernels import convert
from fxdsp.blocks.base import Block, corner_codes, random_codes
from fxdsp.blocks.datapath import Datapath, OvfField, RtlPorts, info


@njit(cache=True)
def _subtract_kernel(x, bias, x_align, b_align, shift, rounding, lo, hi, overflow):
    n = x.shape[0]
    y = np.empty(n, dtype=np.int64)
    count = 0
    for i in range(n):
        out, o = convert((x[i] << x_align) - (bias[i] << b_align), shift, rounding, lo, hi, overflow)
        count += o
        y[i] = out
    return y, count


@dataclass(frozen=True, eq=False)
class BiasSubtractDatapath(Datapath):
    """Fields in the order of the ``bias_subtract`` RTL module's parameters."""

    MODULE = "bias_subtract"
    RTL = RtlPorts(signed=("x", "bias", "y"))
    LATENCY = 2

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """Two registered stages (difference, then round and fit), whatever the parameters."""
        return 2

    in_w: int
    bias_w: int
    out_w: int
    x_align: int         # x and bias left-aligned to the exact difference's fraction length
    b_align: int
    shift: int           # difference -> out_format
    rules: Rules
    out_format: Format = info()
    ovf: tuple = info(default=(OvfField("out", 1),))


class BiasSubtract(Block):
    """Bias compensation ``y = fit(round(x - bias))`` (module docstring)."""

    name = "bias_subtract"

    def __init__(self, in_format: Format, bias_format: Format, out_format: Format, rules: Rules,
                 name: str = "bias_subtract"):
        self.name = name
        self.in_format, self.bias_format, self.out_format = in_format, bias_format, out_format
        self.rules = rules
        d = sum_format(in_format, bias_format)  # exact difference, checked against 63 bits
        self.datapath = BiasSubtractDatapath(
            in_w=in_format.wl, bias_w=bias_format.wl, out_w=out_format.wl, x_align=d.fl - in_format.fl,
            b_align=d.fl - bias_format.fl, shift=d.fl - out_format.fl, rules=rules,
            out_format=out_format)
        self.inputs = {"x": in_format, "bias": bias_format}
        self.outputs = {"y": out_format}

    @classmethod
    def from_config(cls, sec: Section, in_format: Format, bias_format: Format) -> "BiasSubtract":
        return cls(in_format, bias_format, sec.format("out_format"), sec.rules(), name=sec.path)

    def stream(self, log: OverflowLog, x: np.ndarray, bias: np.ndarray) -> dict[str, np.ndarray]:
        dp = self.datapath
        y, n = _subtract_kernel(x, bias, dp.x_align, dp.b_align, dp.shift, dp.rules.rounding_code,
                                dp.out_format.min_int, dp.out_format.max_int, dp.rules.overflow_code)
        log.add(f"{self.name}.{dp.ovf[0].counter}", n)
        return {"y": y}

    def reference(self, x: np.ndarray, bias: np.ndarray) -> dict[str, np.ndarray]:
        return {"y": np.asarray(x) - np.asarray(bias)}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Every corner of x against every corner of the bias (saturation both ways), then nominal."""
        cx, cb = corner_codes(self.in_format), corner_codes(self.bias_format)
        nom = self.nominal_stimulus(rng, n)
        return {"x": np.concatenate([np.repeat(cx, cb.size), nom["x"]]),
                "bias": np.concatenate([np.tile(cb, cx.size), nom["bias"]])}

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        return {"x": random_codes(rng, self.in_format, n) // 4, "bias": random_codes(rng, self.bias_format, n) // 4}

    def parameters(self) -> dict:
        return {"in_format": str(self.in_format), "bias_format": str(self.bias_format),
                "out_format": str(self.out_format), "rounding": self.rules.rounding, "overflow": self.rules.overflow}
