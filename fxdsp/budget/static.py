"""Quasi-static stimulus of the paper 002 chain: chamber-like constant temperatures.

The chain's nominal stimulus sweeps -20..60 C in 8192 samples (85 ms, ~1000 C/s), so a coarse
temperature word's rounding error becomes a ~500 Hz sawtooth that the 50 Hz output low-pass averages
away: a word-length search on that stimulus alone would accept a 2 C temperature LSB. Here the
temperature is held at random chamber points (as in a real test, where it moves by 1e-7 C per
sample) and the error is measured after the filters have settled.
"""

from __future__ import annotations

import numpy as np

POINTS = 16
HOLD = 1536
SETTLED = 1024   # samples at the end of each hold that are measured


def static_stimulus(chain, seed: int) -> tuple[dict, np.ndarray]:
    rng = np.random.default_rng([seed, 77])
    temps = rng.uniform(-20.0, 60.0, POINTS)
    t_c = np.repeat(temps, HOLD)
    rate = np.repeat(np.where(np.arange(POINTS) % 2 == 0, 0.0, 0.2), HOLD)
    stim = chain.sensor.sensor_inputs(t_c, rate, quad_fs=0.05, rng=rng, noise_fs=1e-3)
    keep = (np.arange(t_c.size) % HOLD) >= HOLD - SETTLED
    return stim, keep


def static_error(design, chain_name: str = "chain_paper002", port: str = "rate") -> dict:
    """rms / max / mean of bit-exact minus float on the settled parts, in the port's stored units,
    plus the overflow count."""
    chain = design.chains[chain_name]
    stim, keep = static_stimulus(chain, design.seed)
    res = chain.run(**stim)
    ref = chain.run_float(**stim)
    e = (chain.real_outputs(res)[port] - ref[port])[keep]
    return {"rms": float(np.sqrt(np.mean(e**2))), "max_abs": float(np.abs(e).max()), "mean": float(e.mean()),
            "samples": int(e.size), "overflows": res.overflows.total}
