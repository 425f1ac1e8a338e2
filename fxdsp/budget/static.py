"""Quasi-static stimulus of a chain with a sensor: chamber-like constant temperatures.

A nominal stimulus sweeps its temperature range in a few thousand samples (paper 002's: -20..60 C
in 85 ms, ~1000 C/s), so a coarse temperature word's rounding error becomes a fast sawtooth that an
output low-pass averages away: a word-length search on that stimulus alone would accept a 2 C
temperature LSB. Here the temperature is held at random chamber points of the sensor's range (as in
a real test, where it moves by 1e-7 C per sample), the physical input alternating between 0 and the
sensor's chamber level, and the error is measured after the chain's filters have settled.
"""

from __future__ import annotations

import numpy as np
from fxdsp.errors import InputError

POINTS = 16
HOLD = 1536
SETTLED = 1024   # samples at the end of each hold that are measured


def static_stimulus(chain, seed: int) -> tuple[dict, np.ndarray]:
    sensor = chain.sensor
    if sensor is None:
        raise InputError(f"{chain.name}: the quasi-static stimulus needs the chain's sensor (its table's 'sensor')")
    rng = np.random.default_rng([seed, 77])
    temps = rng.uniform(*sensor.CHAMBER_C, POINTS)
    t_c = np.repeat(temps, HOLD)
    level = np.repeat(np.where(np.arange(POINTS) % 2 == 0, 0.0, sensor.CHAMBER_LEVEL), HOLD)
    stim = sensor.held_inputs(t_c, level, rng)
    keep = (np.arange(t_c.size) % HOLD) >= HOLD - SETTLED
    return stim, keep


def static_errors(design, chain_name: str) -> dict[str, dict]:
    """Per chain output: rms / max / mean of bit-exact minus float on the settled parts, in the
    port's stored units, plus the chain's overflow count (one run of each model for every output)."""
    chain = design.chain(chain_name, "the quasi-static error")
    stim, keep = static_stimulus(chain, design.seed)
    res = chain.run(**stim)
    ref = chain.run_float(**stim)
    got = chain.real_outputs(res)
    out = {}
    for port in chain.outputs:
        e = (got[port] - ref[port])[keep]
        out[port] = {"rms": float(np.sqrt(np.mean(e**2))), "max_abs": float(np.abs(e).max()),
                     "mean": float(e.mean()), "samples": int(e.size), "overflows": res.overflows.total}
    return out


def static_error(design, chain_name: str, port: str) -> dict:
    """:func:`static_errors` of one output."""
    return static_errors(design, chain_name)[port]
