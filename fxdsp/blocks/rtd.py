"""RTD bridge readout: platinum element in a resistor bridge, instrumentation amplifier, ADC, and the
fixed-point conversion ADC code -> temperature code.

Topology (paper 002's equation (13) is lost; this is the reading documented in DOMAIN.md):
the RTD (R0 = 500 Ohm at 0 C) sits under R1 in one arm, the reference R3 + R4 = 525 Ohm under R2 in
the other, both arms fed by ``v_exc``. The instrumentation amplifier (gain A = 16) takes the
difference of the two mid-points::

    v_adc = A * v_exc * (RT / (R1 + RT) - (R3 + R4) / (R2 + R3 + R4))

which balances where RT = 525 Ohm: 22.9 C with the paper's linear law, so the ADC sees a signed
voltage over -20..60 C. The paper quotes RG = 9.1 kOhm for the gain resistor; common in-amp gain
formulas do not give 16 from it, so the gain is taken as the stated A = 16.

Element laws: ``linear`` (the paper's calibrated RT = R0 (1 + beta T), beta = 2.183e-3 /C, a
thin-film element) or ``cvd`` (IEC 60751 Callendar-Van Dusen, C term below 0 C only).

Fixed-point conversion (bit-exact): the ADC code, read as offset binary, is split into a segment
index (top ``lut_index_bits`` bits) and a fraction (the rest). The LUT holds the exact inverse
temperature at the 2**k + 1 segment ends, quantised to ``lut_format``; the output is
``L[i] + (L[i+1] - L[i]) * frac / 2**s`` computed exactly, then one rounding (``rounding``) and one
range fit (``overflow``) into ``temp_format``. The float reference is the exact inverse of the
bridge and element law on the same code, so the difference is LUT interpolation error plus that
one rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from fxdsp.config import Section
from fxdsp.fixed import Format, OverflowLog, Rules, quantize
from fxdsp.fixed.kernels import convert
from fxdsp.blocks.base import Block, corner_codes, random_codes
from fxdsp.blocks.datapath import Datapath, limbs, OvfField, Rom, RtlPorts, info
from fxdsp.errors import InputError


@njit(cache=True)
def _lut_interp_kernel(code, lut, code_min, s, out_shift, rounding, lo, hi, overflow):
    """Offset-binary code -> (segment, fraction) -> L[i] + (L[i+1] - L[i]) * frac, exact, then one
    rounding and fit. Returns (temperatures, overflows)."""
    n = code.shape[0]
    y = np.empty(n, dtype=np.int64)
    mask = (np.int64(1) << s) - 1
    count = 0
    for i in range(n):
        u = code[i] - code_min
        idx = u >> s
        base = lut[idx]
        exact = (base << s) + (lut[idx + 1] - base) * (u & mask)
        out, o = convert(exact, out_shift, rounding, lo, hi, overflow)
        count += o
        y[i] = out
    return y, count

LAWS = ("linear", "cvd")


class RtdPhysics:
    """The analogue front end in float: element law, bridge, amplifier, ADC scaling."""

    def __init__(self, law="linear", r0_ohm=500.0, beta_per_c=2.183e-3, cvd_a=3.9083e-3,
                 cvd_b=-5.775e-7, cvd_c=-4.183e-12, r1_ohm=5000.0, r2_ohm=5000.0, r3_ohm=500.0,
                 r4_ohm=25.0, v_exc=3.3, gain=16.0, adc_vref=1.25):
        self.law = law
        self.r0, self.beta = r0_ohm, beta_per_c
        self.a, self.b, self.c = cvd_a, cvd_b, cvd_c
        self.r1, self.r2, self.rref = r1_ohm, r2_ohm, r3_ohm + r4_ohm
        self.v_exc, self.gain, self.adc_vref = v_exc, gain, adc_vref
        self.p_ref = self.rref / (self.r2 + self.rref)

    # element law
    def resistance(self, t_c):
        t = np.asarray(t_c, dtype=float)
        if self.law == "linear":
            return self.r0 * (1.0 + self.beta * t)
        cold = np.where(t < 0.0, self.c * (t - 100.0) * t**3, 0.0)
        return self.r0 * (1.0 + self.a * t + self.b * t**2 + cold)

    def temperature(self, r_ohm):
        r = np.asarray(r_ohm, dtype=float)
        if self.law == "linear":
            return (r / self.r0 - 1.0) / self.beta
        # quadratic (exact above 0 C), then Newton on the full CVD curve (converges in a few steps)
        t = (-self.a + np.sqrt(self.a**2 - 4.0 * self.b * (1.0 - r / self.r0))) / (2.0 * self.b)
        for _ in range(6):
            cold = t < 0.0
            f = self.resistance(t) - r
            df = self.r0 * (self.a + 2 * self.b * t + np.where(cold, self.c * (4 * t**3 - 300 * t**2), 0.0))
            t = t - f / df
        return t

    # bridge + amplifier
    def adc_fraction(self, r_ohm):
        """ADC input as a fraction of full scale (before quantisation)."""
        r = np.asarray(r_ohm, dtype=float)
        v = self.gain * self.v_exc * (r / (self.r1 + r) - self.p_ref)
        return v / self.adc_vref

    def resistance_from_fraction(self, frac):
        p = np.asarray(frac, dtype=float) * self.adc_vref / (self.gain * self.v_exc) + self.p_ref
        if np.any((p <= 0.0) | (p >= 1.0)):
            raise InputError("rtd: ADC range reaches voltages the bridge cannot produce; "
                             "lower rtd.adc_vref or rtd.gain")
        return self.r1 * p / (1.0 - p)

    def temperature_from_fraction(self, frac):
        return self.temperature(self.resistance_from_fraction(frac))


@dataclass(frozen=True, eq=False)
class RtdDatapath(Datapath):
    """Fields in the order of the ``rtd`` RTL module's parameters."""

    MODULE = "rtd"
    RTL = RtlPorts(ready=True, serial=True, mac_bundle=True, signed=("temp",))

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """hdl/rtl/rtd.v: N + 10 cycles, N the 16 x 16 limb products of the diff (LUT_W + 1 bits) x
        frac (S + 1 bits) product."""
        return limbs(*RtdDatapath.mac_operands(p)) + 10

    @staticmethod
    def mac_operands(p: dict) -> tuple[int, int]:
        return p["LUT_W"] + 1, p["ADC_W"] - p["LUT_INDEX_BITS"] + 1

    adc_w: int
    lut_index_bits: int      # k: segment index = top k bits of the offset-binary code
    lut_w: int
    temp_w: int
    shift: int               # exact interpolation (lut.fl + s fraction bits) -> temp_format
    rules: Rules
    lut: Rom                 # temperature at the 2**k + 1 segment ends
    frac_bits: int = info()  # s = adc_w - k: fraction bits within a segment
    adc_format: Format = info()
    temp_format: Format = info()
    ovf: tuple = info(default=(OvfField("temp", 1),))


class Rtd(Block):
    """RTD readout (paper 002): bridge ADC word ``code`` (a fraction of full scale) -> temperature
    ``temp`` (C) by LUT and linear interpolation (module docstring)."""

    name = "rtd"

    def __init__(self, physics: RtdPhysics, adc_format: Format, lut_format: Format, temp_format: Format,
                 lut_index_bits: int, rules: Rules, t_min_c: float = -40.0, t_max_c: float = 85.0):
        if not adc_format.signed:
            raise InputError("rtd.adc_format: the bridge ADC is bipolar; use a signed format")
        if not 1 <= lut_index_bits < adc_format.wl:
            raise InputError(f"rtd.lut_index_bits: must be 1..{adc_format.wl - 1}, got {lut_index_bits}")
        self.physics = physics
        self.adc_format, self.lut_format, self.temp_format = adc_format, lut_format, temp_format
        self.k = lut_index_bits
        self.s = adc_format.wl - lut_index_bits  # fraction bits within a segment
        self.rules = rules
        self.t_min_c, self.t_max_c = t_min_c, t_max_c
        self.inputs = {"code": adc_format}
        self.outputs = {"temp": temp_format}
        # LUT at the 2**k + 1 segment ends of the offset-binary code range
        ends = np.arange(2**self.k + 1, dtype=np.int64) << self.s
        frac = (ends + adc_format.min_int).astype(float) * adc_format.lsb
        lut_log = OverflowLog()
        self.lut_real = physics.temperature_from_fraction(frac)
        self.lut = quantize(self.lut_real, lut_format, Rules("half_up", "saturate"), lut_log, "rtd.lut")
        if lut_log.total:
            raise InputError(f"rtd.lut_format: {lut_format} cannot hold the LUT range "
                             f"{self.lut_real.min():.1f}..{self.lut_real.max():.1f} C")
        # exact interpolation value lut.fl + s fraction bits, lut.wl + s + 2 bits wide
        if lut_format.wl + self.s + 2 > 63:
            raise InputError(f"rtd: interpolation of {lut_format} over {self.s} fraction bits exceeds 63 bits")
        self.datapath = RtdDatapath(adc_w=adc_format.wl, lut_index_bits=self.k, lut_w=lut_format.wl,
                                    temp_w=temp_format.wl, shift=lut_format.fl + self.s - temp_format.fl,
                                    rules=rules, lut=Rom(self.lut, lut_format.wl), frac_bits=self.s,
                                    adc_format=adc_format, temp_format=temp_format)
        self.lut = self.datapath.lut.words

    @classmethod
    def from_config(cls, sec: Section) -> "Rtd":
        physics = RtdPhysics(
            law=sec.choice("law", LAWS, "linear"),
            r0_ohm=sec.number("r0_ohm", 500.0, low=0, low_open=True),
            beta_per_c=sec.number("beta_per_c", 2.183e-3),
            cvd_a=sec.number("cvd_a", 3.9083e-3), cvd_b=sec.number("cvd_b", -5.775e-7),
            cvd_c=sec.number("cvd_c", -4.183e-12),
            r1_ohm=sec.number("r1_ohm", 5000.0, low=0, low_open=True),
            r2_ohm=sec.number("r2_ohm", 5000.0, low=0, low_open=True),
            r3_ohm=sec.number("r3_ohm", 500.0, low=0), r4_ohm=sec.number("r4_ohm", 25.0, low=0),
            v_exc=sec.number("v_exc", 3.3, low=0, low_open=True),
            gain=sec.number("gain", 16.0, low=0, low_open=True),
            adc_vref=sec.number("adc_vref", 1.25, low=0, low_open=True),
        )
        t_min = sec.number("t_min_c", -40.0)
        t_max = sec.number("t_max_c", 85.0)
        if t_max <= t_min:
            raise InputError(f"{sec.field('t_max_c')}: must exceed t_min_c")
        block = cls(physics, sec.format("adc_format", "s16.15"), sec.format("lut_format", "s26.16"),
                    sec.format("temp_format"), sec.integer("lut_index_bits", low=1, high=16),
                    sec.rules(), t_min, t_max)
        return block

    # --- bit-exact ---
    def stream(self, log: OverflowLog, code: np.ndarray) -> dict[str, np.ndarray]:
        dp = self.datapath
        out, n = _lut_interp_kernel(code, dp.lut.words, dp.adc_format.min_int, dp.frac_bits, dp.shift,
                                    dp.rules.rounding_code, dp.temp_format.min_int, dp.temp_format.max_int,
                                    dp.rules.overflow_code)
        log.add(f"{self.name}.{dp.ovf[0].counter}", n)
        return {"temp": out}

    # --- float reference ---
    def reference(self, code: np.ndarray) -> dict[str, np.ndarray]:
        return {"temp": self.physics.temperature_from_fraction(code)}

    # --- the sensor side: true temperature -> ADC code ---
    def adc_code(self, t_c, log: OverflowLog | None = None) -> np.ndarray:
        return self.adc_quantize(self.adc_fraction(t_c), log)

    def adc_fraction(self, t_c) -> np.ndarray:
        """The ADC input at temperature t_c, as a fraction of full scale (analog, before the ADC)."""
        return self.physics.adc_fraction(self.physics.resistance(t_c))

    def adc_quantize(self, frac, log: OverflowLog | None = None) -> np.ndarray:
        """The bridge ADC: nearest code (half_up), clipped at full scale (saturate)."""
        return quantize(frac, self.adc_format, Rules("half_up", "saturate"), log, "rtd.adc")

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        seg_ends = (np.arange(2**self.k, dtype=np.int64) << self.s) + self.adc_format.min_int
        around_ends = np.concatenate([seg_ends - 1, seg_ends, seg_ends + 1])
        around_ends = around_ends[(around_ends >= self.adc_format.min_int) & (around_ends <= self.adc_format.max_int)]
        temps = np.linspace(self.t_min_c, self.t_max_c, 64)
        codes = np.concatenate([corner_codes(self.adc_format), np.sort(around_ends), self.adc_code(temps),
                                random_codes(rng, self.adc_format, n)])
        return {"code": codes}

    def parameters(self) -> dict:
        p = self.physics
        return {"law": p.law, "r0_ohm": p.r0, "beta_per_c": p.beta, "gain": p.gain, "v_exc": p.v_exc,
                "adc_vref": p.adc_vref, "adc_format": str(self.adc_format), "lut_format": str(self.lut_format),
                "temp_format": str(self.temp_format), "lut_index_bits": self.k,
                "rounding": self.rules.rounding, "overflow": self.rules.overflow,
                "lut": [int(v) for v in self.lut]}
