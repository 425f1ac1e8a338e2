"""Synchronous demodulator: NCO (phase accumulator + cos/sin LUT), two mixers, two low-pass filters
(the ``iir`` block), and a CORDIC for amplitude and phase (drive loop; paper 003's sweep).

* NCO: ``phase[n] = (n * ftw + phase0) mod 2**phase_bits`` with ``ftw = f_hz / fs_hz * 2**phase_bits``
  quantised half_up; the LUT address is the top ``lut_bits`` bits of the phase (truncation, the
  usual phase-truncation spur); the LUT holds cos and -sin over a full turn in ``lut_format``,
  quantised half_up and saturated (cos 0 = 1 does not fit s.15 exactly: it saturates to 1 - 2**-15).
* Mixers: ``i = 2 x cos``, ``q = -2 x sin`` exact products, the factor 2 taken by reading the
  product one fraction bit coarser (so I and Q are the in-phase and quadrature *amplitudes*),
  then rounded by ``rounding`` and fitted by ``overflow`` into ``data_format``.
* Low-pass: one ``iir`` per channel with the ``[demod.lpf]`` design, data_format = demod's.
* CORDIC (vectoring, ``cordic_iterations`` steps): pre-rotation by +-90 deg into the right half
  plane, then x, y updated with arithmetic right shifts (``floor``: the shifts truncate) in
  data_format widened by 2 guard bits, the angle accumulated from an arctan table in
  ``angle_format`` (radians). Amplitude = x * (1/K) with 1/K quantised in s18.17, rounded by
  ``rounding`` into data_format; phase = the angle accumulator.

Float reference: exact cos/sin of the exact phase, float mixers, scipy sosfilt with the float
design, hypot and arctan2.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..config import Section
from ..fixed import Format, OverflowLog, Rules, product_format, quantize, resize
from ..fixed.kernels import convert
from .base import Block, corner_codes
from .iir import Iir


@njit(cache=True)
def _mix_kernel(x, phase0, ftw, phase_mask, addr_shift, cos_lut, msin_lut, shift, rounding, lo, hi, overflow,
                counts):
    """NCO + both mixers. phase = (phase0 + n ftw) mod 2**phase_bits accumulated sample by sample
    (masking after each add keeps it within 48 bits); counts += (I fits, Q fits)."""
    n = x.shape[0]
    i_out = np.empty(n, dtype=np.int64)
    q_out = np.empty(n, dtype=np.int64)
    phase = phase0
    for k in range(n):
        addr = phase >> addr_shift
        v, o = convert(x[k] * cos_lut[addr], shift, rounding, lo, hi, overflow)
        i_out[k] = v
        counts[0] += o
        v, o = convert(x[k] * msin_lut[addr], shift, rounding, lo, hi, overflow)
        q_out[k] = v
        counts[1] += o
        phase = (phase + ftw) & phase_mask
    return i_out, q_out, phase


@njit(cache=True)
def _cordic_kernel(i_in, q_in, atans, half_pi, iterations):
    """CORDIC vectoring: pre-rotate into the right half plane, then shift-and-add (arithmetic right
    shifts: floor). Returns (K * magnitude, angle) as stored integers."""
    n = i_in.shape[0]
    xs = np.empty(n, dtype=np.int64)
    zs = np.empty(n, dtype=np.int64)
    for k in range(n):
        x, y, z = i_in[k], q_in[k], np.int64(0)
        if x < 0:
            if y >= 0:
                x, y, z = y, -x, half_pi
            else:
                x, y, z = -y, x, -half_pi
        for j in range(iterations):
            dx = y >> j
            dy = x >> j
            if y >= 0:
                x, y, z = x + dx, y - dy, z + atans[j]
            else:
                x, y, z = x - dx, y + dy, z - atans[j]
        xs[k] = x
        zs[k] = z
    return xs, zs

INV_K_FORMAT = Format(True, 18, 17)


class Nco:
    """Phase accumulator and quarter-free full-turn LUT (cos, -sin)."""

    def __init__(self, fs_hz: float, f_hz: float, phase_bits: int, lut_bits: int, lut_format: Format,
                 phase_offset_turns: float = 0.0):
        if not 0 < f_hz < fs_hz / 2:
            raise ValueError(f"demod.f_hz: must be within (0, fs/2 = {fs_hz / 2}), got {f_hz}")
        if not 4 <= lut_bits <= phase_bits <= 48:
            raise ValueError(f"demod.lut_bits/phase_bits: need 4 <= lut_bits <= phase_bits <= 48, "
                             f"got {lut_bits}, {phase_bits}")
        self.fs_hz, self.f_hz = fs_hz, f_hz
        self.phase_bits, self.lut_bits, self.lut_format = phase_bits, lut_bits, lut_format
        self.phase_format = Format(False, phase_bits, phase_bits)  # turns
        self.ftw = int(quantize([f_hz / fs_hz], self.phase_format, Rules("half_up", "saturate"))[0])
        self.phase0 = int(quantize([phase_offset_turns % 1.0], self.phase_format, Rules("half_up", "wrap"))[0])
        self.phase_offset_turns = phase_offset_turns
        angle = 2 * np.pi * (np.arange(2**lut_bits) + 0.5) / 2**lut_bits  # bin centres
        sat = Rules("half_up", "saturate")
        self.cos_lut = quantize(np.cos(angle), lut_format, sat)
        self.msin_lut = quantize(-np.sin(angle), lut_format, sat)
        self.phase_mask = (1 << phase_bits) - 1
        self.addr_shift = phase_bits - lut_bits
        self.reset()

    def reset(self) -> None:
        self.phase = self.phase0  # the accumulator
        self.n = 0

    def reference_phase(self, count: int, start: int = 0) -> np.ndarray:
        n = np.arange(start, start + count, dtype=float)
        return 2 * np.pi * (self.phase_offset_turns + n * self.f_hz / self.fs_hz)


def cordic_vector(i: np.ndarray, q: np.ndarray, work: Format, angle_format: Format, iterations: int):
    """CORDIC vectoring on stored integers: returns (x_final, angle) with x_final = K * |(i, q)|."""
    exact = Rules("half_up", "saturate")
    half_pi = int(quantize([np.pi / 2], angle_format, exact)[0])
    atans = quantize(np.arctan(2.0 ** -np.arange(iterations)), angle_format, exact)
    x, z = _cordic_kernel(i, q, atans, half_pi, iterations)
    # |x| <= K * sqrt(2) * 2**(wl-1) < 2**(wl+1): the two guard bits of ``work`` always suffice
    assert x.size == 0 or np.abs(x).max() <= work.max_int, "CORDIC guard bits exhausted"
    return x, z


def cordic_gain(iterations: int) -> float:
    return float(np.prod(np.sqrt(1.0 + 2.0 ** (-2.0 * np.arange(iterations)))))


class Demod(Block):
    name = "demod"

    def __init__(self, nco: Nco, in_format: Format, data_format: Format, lpf_i: Iir, lpf_q: Iir,
                 angle_format: Format, cordic_iterations: int, rules: Rules):
        if lpf_i.data_format != data_format:
            raise ValueError(f"demod.lpf.data_format: must equal demod.data_format {data_format}")
        if not 4 <= cordic_iterations <= 40:
            raise ValueError(f"demod.cordic_iterations: must be 4..40, got {cordic_iterations}")
        if angle_format.int_bits < 2:
            raise ValueError(f"demod.angle_format: {angle_format} cannot hold +-pi radians")
        self.nco = nco
        self.in_format, self.data_format, self.angle_format = in_format, data_format, angle_format
        self.lpf_i, self.lpf_q = lpf_i, lpf_q
        self.rules = rules
        self.iterations = cordic_iterations
        self.mix_format = product_format(in_format, nco.lut_format)
        self.mix_format = self.mix_format.with_fl(self.mix_format.fl - 1)  # read as 2 * x * lut
        self.work_format = Format(True, data_format.wl + 2, data_format.fl)
        self.inv_k = int(quantize([1.0 / cordic_gain(cordic_iterations)], INV_K_FORMAT, Rules("half_up", "saturate"))[0])
        self.inputs = {"x": in_format}
        self.outputs = {"i": data_format, "q": data_format, "amp": data_format, "phase": angle_format}

    @classmethod
    def from_config(cls, sec: Section, fs_hz: float, in_format: Format) -> "Demod":
        nco = Nco(fs_hz, sec.number("f_hz", low=0, low_open=True), sec.integer("phase_bits", 32, low=4, high=48),
                  sec.integer("lut_bits", 10, low=4, high=20), sec.format("lut_format", "s16.15"),
                  sec.number("phase_offset_turns", 0.0))
        data_format = sec.format("data_format")
        lpf_sec = sec.sub("lpf")
        lpf_i = Iir.from_config(lpf_sec, fs_hz, name="demod.lpf_i")
        lpf_q = Iir(lpf_i.sos, lpf_i.data_format, lpf_i.num_format, lpf_i.den_format, lpf_i.rules,
                    name="demod.lpf_q", dc_exact=lpf_i.dc_exact, error_feedback=lpf_i.error_feedback)
        return cls(nco, in_format, data_format, lpf_i, lpf_q, sec.format("angle_format", "s20.17"),
                   sec.integer("cordic_iterations", 16, low=4, high=40), sec.rules())

    def reset(self) -> None:
        self.nco.reset()
        self.lpf_i.reset()
        self.lpf_q.reset()

    def mix(self, log: OverflowLog, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nco, counts = self.nco, np.zeros(2, dtype=np.int64)
        i, q, nco.phase = _mix_kernel(x, nco.phase, nco.ftw, nco.phase_mask, nco.addr_shift, nco.cos_lut,
                                      nco.msin_lut, self.mix_format.fl - self.data_format.fl,
                                      self.rules.rounding_code, self.data_format.min_int, self.data_format.max_int,
                                      self.rules.overflow_code, counts)
        nco.n += x.size
        log.add("demod.mix_i", int(counts[0]))
        log.add("demod.mix_q", int(counts[1]))
        return i, q

    def iq(self, log: OverflowLog, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mixers and low-pass filters: the rate (I) and quadrature (Q) channels."""
        i, q = self.mix(log, x)
        return self.lpf_i._run(log, x=i)["y"], self.lpf_q._run(log, x=q)["y"]

    def _run(self, log: OverflowLog, x: np.ndarray) -> dict[str, np.ndarray]:
        i, q = self.iq(log, x)
        amp, phase = self.polar(log, i, q)
        return {"i": i, "q": q, "amp": amp, "phase": phase}

    def polar(self, log: OverflowLog, i: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xk, z = cordic_vector(i, q, self.work_format, self.angle_format, self.iterations)
        prod_fmt = product_format(self.work_format, INV_K_FORMAT)
        amp = resize(xk * self.inv_k, prod_fmt, self.data_format, self.rules, log, "demod.amp")
        return amp, z

    def reference(self, x: np.ndarray) -> dict[str, np.ndarray]:
        import scipy.signal as sps

        ph = self.nco.reference_phase(len(x), self.nco.n)
        self.nco.n += len(x)
        i = sps.sosfilt(self.lpf_i.sos, 2 * x * np.cos(ph))
        q = sps.sosfilt(self.lpf_q.sos, -2 * x * np.sin(ph))
        return {"i": i, "q": q, "amp": np.hypot(i, q), "phase": np.arctan2(q, i)}

    def carrier(self, amplitude, phase_rad, count: int, start: int = 0) -> np.ndarray:
        """A sense-pick-off-like input: amplitude * cos(drive phase + phase_rad), real valued."""
        return np.asarray(amplitude) * np.cos(self.nco.reference_phase(count, start) + np.asarray(phase_rad))

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """A carrier at 0.5 FS whose phase steps through the four quadrants, plus noise."""
        n = max(n, 4096)
        phase = np.repeat(np.array([0.3, 2.0, -2.5, -0.8]), -(-n // 4))[:n]
        amp = 0.5 * self.in_format.max_value
        x = self.carrier(amp, phase, n) + rng.normal(0, 0.01 * amp, n)
        return {"x": quantize(x, self.in_format, Rules("half_up", "saturate"))}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        fi = self.in_format
        full = self.carrier(1.0, 0.0, 512) * fi.max_value * 1.05  # clipped: saturating carrier
        parts = [np.tile(corner_codes(fi), 16), quantize(full, fi, Rules("half_up", "saturate")),
                 np.full(512, fi.min_int, np.int64), self.nominal_stimulus(rng, n)["x"]]
        return {"x": np.concatenate(parts)}

    def parameters(self) -> dict:
        return {"fs_hz": self.nco.fs_hz, "f_hz": self.nco.f_hz, "ftw": self.nco.ftw, "phase0": self.nco.phase0,
                "phase_bits": self.nco.phase_bits, "lut_bits": self.nco.lut_bits, "lut_format": str(self.nco.lut_format),
                "in_format": str(self.in_format), "data_format": str(self.data_format),
                "angle_format": str(self.angle_format), "cordic_iterations": self.iterations, "inv_k": self.inv_k,
                "rounding": self.rules.rounding, "overflow": self.rules.overflow,
                "lpf": self.lpf_i.parameters()}
