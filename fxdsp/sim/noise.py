"""Sensor noise: white noise per channel, bias instability (flicker) and rate random walk.

Definitions (IEEE Std 952 conventions, expressed per logged sample so that they hold for any
``time_step_s``):

* white: independent N(0, sigma^2) per sample; Allan deviation sigma * sqrt(dt / tau), slope -1/2;
* bias instability B: flicker noise with PSD B^2 / (2 pi f) in IEEE 952's two-sided convention, i.e.
  one-sided B^2 / (pi f); Allan deviation floor B * sqrt(2 ln 2 / pi) ~ 0.664 B, slope 0;
* rate random walk K: a random walk whose increments have variance K^2 dt (K in output unit per
  sqrt(s)); Allan deviation K * sqrt(tau / 3), slope +1/2.

Default white levels (one sample of a 10 s log; chosen well below the thermal effects a diagnosis has
to find, but not zero so that "the noise alone would not explain it" is a real test):

=============  ================  ==========================================================
channel        sigma             why
=============  ================  ==========================================================
output         5e-4 x |S0|       0.0005 deg/s-equivalent of rate per sample (a tactical MEMS
                                 gyro averaged over 10 s); for paper 001 (output in deg/h) this
                                 is 1.8 deg/h, the order of the paper's 1..3 deg/h drift; for
                                 paper 000 (S0 = K1, per g) 0.5 mg, a MEMS-class level: a
                                 counter-limited quartz pair is nearer 20 ug (pass
                                 ``noise={"output": 2e-5 * K1}``, i.e. about 0.001 Hz)
temp_c         0.01 C            16-bit ADC behind the RTD bridge and a gain-16 amplifier
ref_temp_c     0.005 C           calibrated chamber probe
freq_hz        0.001 Hz          PLL frequency word averaged over 10 s (paper 001: fit residual
                                 at most 0.01 Hz)
quad           0.01 output unit  quadrature channel, same front end as the rate channel
=============  ================  ==========================================================

Giving the output noise in input units (times S at 25 C) keeps it meaningful in every scenario's
output unit (mV, deg/h, Hz). The same rule serves every scenario because the diagnosis engine's test
generator reproduces the levels with ``default_noise(S0)``.
"""

from __future__ import annotations

import math

import numpy as np
from fxdsp.errors import InputError

NOISE_KEYS = ("output", "temp_c", "ref_temp_c", "freq_hz", "quad", "bias_instability",
              "rate_random_walk")

# output white sigma in input units per sample (then times |S(t_ref)|)
DEFAULT_RELATIVE_OUTPUT = 5e-4
DEFAULT_WHITE = {"temp_c": 0.01, "ref_temp_c": 0.005, "freq_hz": 0.001, "quad": 0.01}


def default_noise(sf_at_ref: float) -> dict[str, float]:
    """Default noise levels for a sensor of scale factor ``sf_at_ref`` (output unit per input unit)."""
    out = {"output": DEFAULT_RELATIVE_OUTPUT * abs(sf_at_ref), **DEFAULT_WHITE}
    out.update(bias_instability=0.0, rate_random_walk=0.0)
    return out


def resolve_noise(overrides: dict | str | None, sf_at_ref: float) -> dict[str, float]:
    """Defaults updated by ``overrides``; ``overrides == "off"`` silences every channel."""
    levels = default_noise(sf_at_ref)
    if isinstance(overrides, str):
        if overrides != "off":
            raise InputError(f"noise: expected a mapping of levels or 'off', got {overrides!r}")
        return {k: 0.0 for k in levels}
    for key, value in (overrides or {}).items():
        if key not in levels:
            raise InputError(f"noise: unknown key {key!r}; expected one of {', '.join(NOISE_KEYS)}")
        value = float(value)
        if not (math.isfinite(value) and value >= 0):
            raise InputError(f"noise.{key}: must be a finite number >= 0, got {value!r}")
        levels[key] = value
    return levels


def white(rng: np.random.Generator, n: int, sigma: float) -> np.ndarray:
    return sigma * rng.standard_normal(n) if sigma > 0 else np.zeros(n)


def flicker(rng: np.random.Generator, n: int, dt: float, b: float) -> np.ndarray:
    """Flicker noise with one-sided PSD b^2 / (pi f), by shaping white noise in the frequency domain.

    Unit-variance white noise sampled at dt has a flat one-sided PSD of 2 dt; each bin is rescaled
    to the target PSD. The DC bin is dropped (a constant bias belongs to B(T), not to the noise).
    """
    if b <= 0 or n < 2:
        return np.zeros(n)
    spectrum = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, dt)
    gain = np.zeros_like(f)
    gain[1:] = np.sqrt(b * b / (np.pi * f[1:]) / (2 * dt))
    return np.fft.irfft(spectrum * gain, n)


def random_walk(rng: np.random.Generator, n: int, dt: float, k: float) -> np.ndarray:
    """Random walk with increment variance k^2 dt per sample, starting at zero."""
    if k <= 0:
        return np.zeros(n)
    steps = k * math.sqrt(dt) * rng.standard_normal(n)
    steps[0] = 0.0
    return np.cumsum(steps)


def output_noise(rng: np.random.Generator, n: int, dt: float, levels: dict[str, float]) -> np.ndarray:
    return (white(rng, n, levels["output"]) + flicker(rng, n, dt, levels["bias_instability"])
            + random_walk(rng, n, dt, levels["rate_random_walk"]))
