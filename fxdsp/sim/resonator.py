"""The drive mode at the sample rate: a second-order resonator driven by a DAC word, read by an ADC.

Per unit mass, the displacement x in pick-off full-scale units (1.0 = the drive ADC's full scale)::

    x'' + (w/Q) x' + w^2 x = u(t),      u = g_drive * dac      (dac in DAC full-scale units)

* ``w(T)``: paper 002's ``w0 [1 - a (T - T0)/2]`` (Young's modulus ``E0 [1 - a dT]``) or paper
  001's ``f0 + k T``; ``Q(T) = Q0 (T_K / T0_K)^-q_exponent`` (DOMAIN.md §5: rarefied-gas damping in a
  sealed cavity falls as T^-1/2; :data:`PAPER002_DRIVE` uses the exponent 1 of the sense model,
  :mod:`fxdsp.sim.gyro`, where thermoelastic loss adds to it).
* ``g_drive = gain * w0^2 / Q0``: at resonance and T0 a DAC amplitude d gives a pick-off amplitude
  ``gain * d``; elsewhere ``gain * d * (Q/Q0) (w0/w)^2``, so the amplitude loop has to follow Q.
* The DAC holds each word for one sample (zero-order hold) and takes effect one sample after the
  loop computed it (the FPGA's output register): the word computed from ADC sample n drives the
  interval [t_{n+1}, t_{n+2}). The drive's fundamental is therefore 1.5 samples late; the loop
  advances its carrier by that much (``drive.advance_samples``).
* Exact discretisation of the ODE over each sample with the force held (the matrix exponential,
  no integration error), its coefficients recomputed at every temperature step
  (``samples_per_temp``), so a ramp costs one exp/cos/sin per step, not per sample.
* The pick-off ADC: ``code = half_up(x * 2**fl + noise)`` saturated to its format and counted: the
  sensor's analog-to-digital conversion, not a fixed-point datapath (the loop's arithmetic starts
  at the code).

Everything is float64 in one numba loop; deterministic for a given noise array.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from fxdsp.fixed.kernels import HALF_UP, round_float

KELVIN = 273.15


@dataclass(frozen=True)
class DriveResonator:
    """A drive mode: resonance and Q against temperature, the drive gain and the pick-off noise."""

    f0_hz: float                 # resonance at t0_c
    t0_c: float = 25.0
    a_per_c: float = 0.0         # paper 002's law: w = w0 [1 - a (T - t0)/2] ...
    k_hz_per_c: float = 0.0      # ... or paper 001's: f = f0 + k (T - t0) (one of the two is 0)
    q0: float = 10000.0          # Q at t0_c
    q_exponent: float = 0.0      # Q = q0 (T_K / t0_K) ** -q_exponent
    gain: float = 1.0            # pick-off amplitude (FS) per DAC amplitude (FS) at resonance and t0
    noise_fs: float = 0.0        # pick-off noise, rms in ADC full-scale units, white at the sample rate

    def frequency_hz(self, temp_c):
        dt = np.asarray(temp_c, float) - self.t0_c
        return self.f0_hz * (1 - self.a_per_c * dt / 2) + self.k_hz_per_c * dt

    def quality(self, temp_c):
        return self.q0 * ((np.asarray(temp_c, float) + KELVIN) / (self.t0_c + KELVIN)) ** (-self.q_exponent)

    def tau_s(self, temp_c=None) -> float | np.ndarray:
        """The amplitude time constant 2Q/w (at t0_c when no temperature is given)."""
        t = self.t0_c if temp_c is None else temp_c
        return 2 * self.quality(t) / (2 * np.pi * self.frequency_hz(t))

    def with_(self, **changes) -> "DriveResonator":
        return replace(self, **changes)

    @classmethod
    def matching(cls, drive, noise_fs: float = 30e-6) -> "DriveResonator":
        """A mode a drive loop's table was designed for: resonance at its centre ``f_hz``, Q from its
        ``tau_s`` (Q = pi f tau), its ``resonator_gain``; no temperature dependence (a user's loop
        without a sensor model of its own)."""
        return cls(f0_hz=drive.f_hz, q0=np.pi * drive.f_hz * drive.tau_s, gain=drive.resonator_gain,
                   noise_fs=noise_fs)

    def coefficients(self, temp_c, fs_hz: float, freq_hz=None) -> np.ndarray:
        """Per temperature step: (a11, a12, a21, a22, b1, b2), the exact one-sample update of (x, v)
        with the force per unit DAC full scale held over the sample. ``freq_hz`` (per step)
        replaces the resonance law f(T); Q still follows the temperature."""
        temps = np.atleast_1d(np.asarray(temp_c, float))
        w = 2 * np.pi * (self.frequency_hz(temps) if freq_hz is None else np.atleast_1d(np.asarray(freq_hz, float)))
        q = self.quality(temps)
        w0 = 2 * np.pi * self.f0_hz
        g = self.gain * w0 * w0 / self.q0
        dt = 1.0 / fs_hz
        sigma = w / (2 * q)
        wd = w * np.sqrt(1 - 1 / (4 * q * q))
        e = np.exp(-sigma * dt)
        c, s = np.cos(wd * dt), np.sin(wd * dt)
        out = np.empty((temps.size, 6))
        out[:, 0] = e * (c + sigma / wd * s)
        out[:, 1] = e * s / wd
        out[:, 2] = -w * w * e * s / wd
        out[:, 3] = e * (c - sigma / wd * s)
        # response to a held unit force from rest, times the drive gain
        out[:, 4] = g * (1 - e * (c + sigma / wd * s)) / (w * w)
        out[:, 5] = g * e * s / wd
        return out


# Paper 002's MEMS drive mode (the sense model's, fxdsp.sim.gyro): 8014.3 Hz, silicon a = 60 ppm/C,
# Q = 20000 at 25 C falling as 1/T_K: tau = 2Q/w = 0.79 s at 25 C. Pick-off noise 30 uFS rms per
# sample (a 16-bit drive ADC's LSB is 31 uFS): about 90 dB in the 48 kHz band.
PAPER002_DRIVE = DriveResonator(f0_hz=8014.3, a_per_c=60e-6, q0=20000.0, q_exponent=1.0, gain=1.0, noise_fs=30e-6)
# Paper 001's metal cup resonator: f = 3837.471 + 0.0536 T Hz. Q is not given: metal (Ni-alloy) cup
# resonators reach a few thousand, limited by thermoelastic and anchor loss rather than gas, so it is
# taken constant at 5000 (tau = 0.41 s); the same pick-off noise.
PAPER001_DRIVE = DriveResonator(f0_hz=3837.471, t0_c=0.0, k_hz_per_c=0.0536, q0=5000.0, q_exponent=0.0,
                                gain=1.0, noise_fs=30e-6)


@njit(cache=True, inline="always")
def resonator_step(x, v, u, coef, k):
    """(x, v) one sample later under the held drive u (DAC full-scale units), coefficients of step k."""
    return (coef[k, 0] * x + coef[k, 1] * v + coef[k, 4] * u,
            coef[k, 2] * x + coef[k, 3] * v + coef[k, 5] * u)


@njit(cache=True, inline="always")
def adc_code(p, scale, lo, hi):
    """The pick-off ADC: nearest code (half_up), saturated; (code, saturated)."""
    c = round_float(p * scale, HALF_UP)
    if c > hi:
        return np.int64(hi), True
    if c < lo:
        return np.int64(lo), True
    return np.int64(c), False


@njit(cache=True)
def _open_drive(dac, dac_scale, coef, per_step, state, noise, adc_scale, lo, hi):
    """The resonator driven by a given DAC word sequence (open loop): the ADC codes and saturations.
    ``state`` = (x, v, previous DAC value) is read and written back."""
    n = dac.shape[0]
    codes = np.empty(n, dtype=np.int64)
    x, v, u = state[0], state[1], state[2]
    sat = 0
    for i in range(n):
        codes[i], s = adc_code(x + noise[i], adc_scale, lo, hi)
        sat += s
        x, v = resonator_step(x, v, u, coef, min(i // per_step, coef.shape[0] - 1))
        u = dac[i] * dac_scale
    state[0], state[1], state[2] = x, v, u
    return codes, sat


# the modes the built-in config's drive loops were designed for, by table
PRESETS = {"drive": PAPER002_DRIVE, "drive001": PAPER001_DRIVE}


def resonator_for(drive) -> DriveResonator:
    """The mode a drive loop runs on: the preset of a built-in table whose centre it kept, else the
    one its table was designed for (:meth:`DriveResonator.matching`)."""
    preset = PRESETS.get(drive.name)
    if preset is not None and abs(preset.frequency_hz(25.0) - drive.f_hz) <= drive.lock_range_hz:
        return preset
    return DriveResonator.matching(drive)
