"""Resonator thermometer (paper 001): drive-loop frequency word -> temperature, T = (f - f0) / k.

The resonant frequency f (Hz, from the drive loop's PLL) arrives in ``freq_format``. The divide by
the constant k is a multiply by 1/k::

    d = f - f0                      exact (f0 quantised half_up to freq_format)
    T = fit(round(d * kinv))        kinv = 1/k quantised half_up to kinv_format; one rounding by
                                    ``rounding``, one fit into temp_format by ``overflow``

With the paper's k = 0.0536 Hz/C a 0.001 C temperature LSB needs 5.4e-5 Hz of frequency
resolution: freq_format needs about 15 fraction bits, and f0 must be the *unrounded* intercept
(3837.471 Hz; the printed 3837.4 Hz shifts every temperature by -1.33 C).

The quadratic bias q(T) and the subtraction are the ``piecewise`` and ``bias_subtract`` blocks; the
paper 001 chain composes the three (see :mod:`fxdsp.chains`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxdsp.config import Section
from fxdsp.fixed import Format, OverflowLog, Rules, product_format, quantize, resize, sub
from fxdsp.blocks.base import Block, corner_codes
from fxdsp.blocks.datapath import Datapath, limbs, OvfField, RtlPorts, const, info
from fxdsp.errors import InputError


@dataclass(frozen=True, eq=False)
class Freq2TempDatapath(Datapath):
    """Fields in the order of the ``freq2temp`` RTL module's parameters."""

    MODULE = "freq2temp"
    RTL = RtlPorts(ready=True, serial=True, signed=("temp",))

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """hdl/rtl/freq2temp.v: N + 7, N the limb products of d (FREQ_W + 1 bits) x KINV (KINV_W bits)."""
        return limbs(p["FREQ_W"] + 1, p["KINV_W"]) + 7

    freq_w: int
    kinv_w: int
    temp_w: int
    f0: int = const()        # f0 on freq_format
    kinv: int = const()      # 1/k on kinv_format
    shift: int               # (f - f0) * kinv -> temp_format
    rules: Rules
    p_format: Format = info()
    temp_format: Format = info()
    ovf: tuple = info(default=(OvfField("temp", 1),))


class Freq2Temp(Block):
    """Resonator thermometer (paper 001): frequency word ``f`` -> temperature ``temp``,
    T = (f - f0) / k (module docstring)."""

    name = "freq2temp"

    def __init__(self, freq_format: Format, temp_format: Format, kinv_format: Format, f0_hz: float,
                 k_hz_per_c: float, rules: Rules, t_min_c: float = -40.0, t_max_c: float = 85.0):
        if k_hz_per_c == 0:
            raise InputError("freq2temp.k_hz_per_c: must not be zero")
        self.freq_format, self.temp_format, self.kinv_format = freq_format, temp_format, kinv_format
        self.f0_hz, self.k_hz_per_c = f0_hz, k_hz_per_c
        self.rules = rules
        self.t_min_c, self.t_max_c = t_min_c, t_max_c
        exact = Rules("half_up", "saturate")
        qlog = OverflowLog()
        self.f0 = int(quantize([f0_hz], freq_format, exact, qlog, "f0")[0])
        self.kinv = int(quantize([1.0 / k_hz_per_c], kinv_format, exact, qlog, "kinv")[0])
        if qlog.get("f0"):
            raise InputError(f"freq2temp.f0_hz: {f0_hz} does not fit freq_format {freq_format}")
        if qlog.get("kinv"):
            raise InputError(f"freq2temp.kinv_format: {kinv_format} cannot hold 1/k = {1 / k_hz_per_c:.6g}")
        self.d_format = sub(np.zeros(1, np.int64), freq_format, np.zeros(1, np.int64), freq_format)[1]
        self.p_format = product_format(self.d_format, kinv_format)
        self.datapath = Freq2TempDatapath(
            freq_w=freq_format.wl, kinv_w=kinv_format.wl, temp_w=temp_format.wl, f0=self.f0, kinv=self.kinv,
            shift=self.p_format.fl - temp_format.fl, rules=rules, p_format=self.p_format, temp_format=temp_format)
        self.inputs = {"f": freq_format}
        self.outputs = {"temp": temp_format}

    @classmethod
    def from_config(cls, sec: Section, temp_format: Format, freq_format: Format | None = None) -> "Freq2Temp":
        """``freq_format``: the format a chain wires to ``f`` (a drive loop's), else the table's own."""
        return cls(freq_format or sec.format("freq_format"), temp_format, sec.format("kinv_format"),
                   sec.number("f0_hz"), sec.number("k_hz_per_c"), sec.rules(),
                   sec.number("t_min_c", -40.0), sec.number("t_max_c", 85.0))

    def stream(self, log: OverflowLog, f: np.ndarray) -> dict[str, np.ndarray]:
        dp = self.datapath
        return {"temp": resize((f - dp.f0) * dp.kinv, dp.p_format, dp.temp_format, dp.rules, log,
                               f"{self.name}.{dp.ovf[0].counter}")}

    def reference(self, f: np.ndarray) -> dict[str, np.ndarray]:
        return {"temp": (np.asarray(f) - self.f0_hz) / self.k_hz_per_c}

    def frequency(self, t_c) -> np.ndarray:
        """Resonant frequency (Hz) at temperature t_c under the linear law f = f0 + k T (analog)."""
        return self.f0_hz + self.k_hz_per_c * np.asarray(t_c, dtype=float)

    def freq_code(self, t_c) -> np.ndarray:
        """Frequency word of a resonator at temperature t_c: the nearest word (half_up), saturated."""
        return quantize(self.frequency(t_c), self.freq_format, Rules("half_up", "saturate"))

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        return {"f": self.freq_code(rng.uniform(self.t_min_c, self.t_max_c, n))}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Frequency-word corners (temperature saturates), f0 and its neighbours, a sweep over the
        temperature range, random words in range."""
        f0 = np.array([self.f0 - 1, self.f0, self.f0 + 1], np.int64)
        sweep = self.freq_code(np.linspace(self.t_min_c, self.t_max_c, 126))
        fs = np.concatenate([corner_codes(self.freq_format), f0, sweep, self.nominal_stimulus(rng, n)["f"]])
        return {"f": fs[(fs >= self.freq_format.min_int) & (fs <= self.freq_format.max_int)]}

    def parameters(self) -> dict:
        return {"freq_format": str(self.freq_format), "temp_format": str(self.temp_format),
                "kinv_format": str(self.kinv_format), "f0_hz": self.f0_hz, "k_hz_per_c": self.k_hz_per_c,
                "f0": self.f0, "kinv": self.kinv, "rounding": self.rules.rounding, "overflow": self.rules.overflow}
