"""The known-baseline oracle (independent.oracle) recovers every parameter of the contract's causes
exactly from a log without noise, and on a noisy log misses where the noise puts it: the measure that
tells a diagnosis's parameter miss from the log's own limit must itself be right."""

from __future__ import annotations

import numpy as np
import pytest

from .chamber_logs import generate
from .oracle import known_baseline_parameters, relative_errors

# every cause of the contract but the thermal lag (its time constant is not estimated), one each
# alone and in the pairs and a triple that overlap most (hysteresis and a ramp term share the ramps'
# sign; a warm-up and a drift share the log's start)
LABELS = [("hysteresis", "ramp_rate"), ("warmup", "sf_nonlinearity", "aging_drift"), ("quadrature_leak",),
          ("rtd_nonlinearity", "frequency_nonlinearity"), ("thermal_lag", "aging_drift")]


def _without_noise(log):
    h = log.hidden
    clean = {"output": h["output_clean"], "temp_c": h["temp_true"], "freq_hz": h["freq_clean"]}
    log.columns = {k: (clean[k] if k in clean else v) for k, v in log.columns.items()}
    return log


@pytest.mark.parametrize("causes", LABELS, ids=["+".join(c) for c in LABELS])
def test_the_oracle_recovers_every_parameter_without_noise(causes):
    log = _without_noise(generate(causes, 7100))
    errors = relative_errors(log, known_baseline_parameters(log))
    expected = {f"{c}.{p}" for c in causes for p in log.truth[c] if c != "thermal_lag"}
    assert set(errors) == expected
    assert max(errors.values()) < 1e-6, errors


def test_the_oracle_misses_where_the_noise_does():
    """Noise added to the clean drift: the oracle's slope is the clean one plus the noise's own
    least-squares slope, so its error is what that noise alone gives."""
    log = _without_noise(generate(("aging_drift",), 7101))
    t = log.columns["time_s"]
    r = log.truth["aging_drift"]["r_per_h"]
    rng = np.random.default_rng(3)
    walk = np.cumsum(rng.standard_normal(t.size))
    walk *= 0.5 * abs(r) * np.ptp(t) / 3600.0 / max(np.ptp(walk), 1e-12)   # half the drift's span
    log.columns = {**log.columns, "output": log.columns["output"] + walk}
    x = np.column_stack([np.ones_like(t), t / 3600.0])
    noise_slope = np.linalg.lstsq(x, walk, rcond=None)[0][1]
    got = known_baseline_parameters(log)["aging_drift"]["r_per_h"]
    assert got == pytest.approx(r + noise_slope, rel=1e-9)
    assert abs(noise_slope) > 1e-3 * abs(r)   # the walk moved it: the comparison above means something
