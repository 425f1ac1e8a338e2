"""Honest parameters: a number the log cannot determine is reported as unidentified, with the
reason, and no cause is named on it; a candidate whose fit is worse than the baseline is a failed
fit, not a number. Logs are written here from the contract (their own programme and lag
integration), not with fxdsp.sim or fxdsp.mechanisms."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fxdsp.diagnose.api import diagnose_columns
from fxdsp.diagnose.context import Candidate
from fxdsp.diagnose.identify import TAU_LENGTHS, judge
from fxdsp.diagnose.report import _candidate_entry, report_dict

from independent.confusion import plain_numbers_of_unidentified


def lag_log(tau_s: float, hours: float, seed: int, dt: float = 20.0) -> dict:
    """Chamber cycling +-20 C around 25 C (1 C/min ramps, 2 h dwells); the element follows through a
    first-order lag integrated by small Euler steps; output = 2 mV/C * Te + white noise."""
    rng = np.random.default_rng(seed)
    fine = 1.0
    tf = np.arange(0.0, hours * 3600.0, fine)
    period = 2 * (2400 + 7200)
    phase = tf % period
    up = np.clip(phase / 2400.0, 0, 1) - np.clip((phase - 9600) / 2400.0, 0, 1)
    chamber = 5.0 + 40.0 * up
    te = np.empty_like(chamber)
    te[0] = chamber[0]
    for i in range(1, tf.size):
        te[i] = te[i - 1] + fine * (chamber[i - 1] - te[i - 1]) / tau_s
    keep = np.arange(0, tf.size, int(dt / fine))
    t, temp, te = tf[keep], chamber[keep], te[keep]
    return {"time_s": t, "temp_c": temp + rng.normal(0, 0.01, t.size),
            "output": 2.0 * te + rng.normal(0, 0.01, t.size)}


def _report(log: dict) -> dict:
    diag = diagnose_columns(log, source="test")
    return json.loads(json.dumps(report_dict(diag)))


def test_a_lag_longer_than_the_log_is_not_named_and_says_why():
    log = lag_log(tau_s=60 * 3600.0, hours=20.0, seed=1)
    report = _report(log)
    assert "thermal_lag" not in report["causes"], report["causes"]
    assert plain_numbers_of_unidentified(report) == []
    # the slow effect is not hidden either: it is listed, unidentified, with the reason in words
    slow = {c: p for c, p in report["not_identified"].items() if "tau_s" in p}
    assert slow, report["not_identified"]
    for params in slow.values():
        assert params["tau_s"]["identified"] is False and params["tau_s"]["why"]
    assert "not named" in report["explanation"]


def test_a_lag_the_log_resolves_is_named_with_identified_numbers():
    log = lag_log(tau_s=900.0, hours=20.0, seed=2)
    report = _report(log)
    assert report["cause"] == "thermal_lag"
    assert report["parameters"]["tau_s"] == pytest.approx(900.0, rel=0.25)
    p = report["parameters_by_cause"]["thermal_lag"]["tau_s"]
    assert p["identified"] is True and p["value"] == report["parameters"]["tau_s"]
    assert plain_numbers_of_unidentified(report) == []


@pytest.mark.parametrize("value,sd,at_bound,ok", [
    (1000.0, 50.0, False, True),
    (1000.0, 1500.0, False, False),  # uncertainty larger than the value
    (1000.0, 50.0, True, False),  # fit at its bound
    (1e4 * TAU_LENGTHS, 50.0, False, False),  # tau beyond a quarter of a 1e4 s log
    (float("nan"), 1.0, False, False),
    (1000.0, None, False, False),
])
def test_identification_rules(value, sd, at_bound, ok):
    assert judge("tau_s", value, sd, duration_s=1e4 + 1, at_bound=at_bound).identified is ok


def test_a_failed_fit_is_reported_without_numbers():
    class _Diag:
        causes: list = []

    worse = Candidate(cause="thermal_lag", channel="output", evidence=-5000.0, ratio=0.008, rms_before=6.1,
                      rms_after=771.0, nonlinear={"tau_s": 60.0}, nonlinear_sd={"tau_s": 1.0})
    assert worse.failed and not worse.accepted_by_rule
    entry = _candidate_entry(_Diag(), worse)
    assert entry["fit"] == "failed" and entry["why"]
    assert not any(k in entry for k in ("parameters", "rms_after", "ratio", "score"))
