"""The known-baseline oracle (independent.oracle) recovers every parameter of the contract's causes
exactly from a log without noise, and on a noisy log misses where the noise puts it: the measure that
tells a diagnosis's parameter miss from the log's own limit must itself be right."""

from __future__ import annotations

import numpy as np
import pytest

from .chamber_logs import generate
from .oracle import detection_z, known_baseline_parameters, known_noise_estimate, relative_errors

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


@pytest.mark.parametrize("cause, kw", [("aging_drift", {}), ("hysteresis", {"noise": "flicker"})],
                         ids=["aging-walk", "hysteresis-flicker"])
def test_the_known_noise_estimate_has_the_sd_it_reports(cause, kw):
    """Over logs of many seeds (the generator's own noise, drawn afresh each time), the known-noise
    estimate's error in units of its reported sd is a standard normal: the covariance the detection
    z rests on is the generator's. (A walk left out of it gives an sd of errors of 4.7 on the aging
    logs, flicker left out 7.1 on the hysteresis ones.)"""
    errors = []
    for seed in range(9000, 9040):
        log = generate((cause,), seed, rows=500, **kw)
        estimate, sd = known_noise_estimate(log, cause)
        errors.append((estimate - next(iter(log.truth[cause].values()))) / sd)
    assert abs(np.mean(errors)) < 0.4 and 0.7 < np.std(errors) < 1.35, (np.mean(errors), np.std(errors))
    assert detection_z(log, cause) == pytest.approx(abs(next(iter(log.truth[cause].values()))) / sd)
