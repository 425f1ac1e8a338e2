"""A parameter's reported uncertainty must cover the noise the log carries (fxdsp.diagnose.uncertainty):
on logs of the independent generator whose noise wanders (a random walk, flicker), the delete-a-group
jackknife alone reported an aging slope 11.6 sds and a warm-up's time constant 13.8 sds from the truth
(the matrices' worst); the truth must now lie within 3 reported sds."""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.diagnose.uncertainty import _spread
from independent.chamber_logs import generate
from independent.confusion import diagnose_independent


@pytest.mark.parametrize("causes, seed, kw", [(("aging_drift",), 5010, {}),
                                              (("warmup",), 5016, {"noise": "flicker"})],
                         ids=["aging-walk-5010", "warmup-flicker-5016"])
def test_the_truth_lies_within_three_reported_sds(causes, seed, kw):
    log = generate(causes, seed, **kw)
    diag = diagnose_independent(log)
    assert sorted(diag.causes) == sorted(causes)
    for cause in causes:
        for name, value in log.truth[cause].items():
            got, sd = diag.parameters[cause][name], diag.uncertainty[cause][name]
            assert abs(got - value) <= 3.0 * sd, f"{cause}.{name}: {got:.4g} +- {sd:.3g}, truth {value:.4g}"


def test_the_spread_is_one_sd_and_a_time_constants_is_on_its_log_axis():
    rng = np.random.default_rng(5)
    draws = rng.normal(10.0, 2.0, 20000)
    assert _spread(draws, log_axis=False) == pytest.approx(2.0, rel=0.03)
    # a few draws far out (a time constant run to its grid's end) do not decide it
    assert _spread(np.r_[draws, np.full(500, 1e6)], log_axis=False) == pytest.approx(2.0, rel=0.06)
    tau = 3000.0 * np.exp(rng.normal(0.0, 0.2, 20000))
    assert _spread(tau, log_axis=True) == pytest.approx(3000.0 * 0.2, rel=0.05)


def test_a_noise_free_log_reports_its_parameters_as_determined():
    """Without noise the final model determines every parameter: no sd may stay from an earlier
    stage of the search (a lag's time constant tried before the quadrature leak joined kept a 24 %
    jackknife sd from then, 158.5 s on a truth of 665 s)."""
    log = generate(("thermal_lag", "quadrature_leak"), 5003)
    log.columns["output"] = log.hidden["output_clean"]
    log.columns["quad"] = log.hidden["quad_true"]
    diag = diagnose_independent(log)
    assert sorted(diag.causes) == ["quadrature_leak", "thermal_lag"]
    for cause, truth in log.truth.items():
        for name, value in truth.items():
            got, sd = diag.parameters[cause][name], diag.uncertainty[cause][name]
            assert sd < 0.01 * abs(got), f"{cause}.{name}: {got:.4g} +- {sd:.3g}"
            assert abs(got - value) <= 3.0 * sd, f"{cause}.{name}: {got:.4g} +- {sd:.3g}, truth {value:.4g}"


def test_a_parameter_one_group_holds_is_not_judged_by_deleting_that_group():
    """The project simulator's scale-factor cubic 5010: the rate-table session that carries all of
    k3 lies within one of the jackknife's 20 contiguous groups. Deleting that group left fits that do
    not determine k3 (sd 3.2e-8 on a value of 3.37e-8; 1.3e-5 on whitened rows), and the cause was set
    aside as undetermined. The interleaved folds see it (results.CONCENTRATED)."""
    from fxdsp.diagnose.results import CONCENTRATED, largest_group_share
    from independent.confusion import ProjectLog

    log = ProjectLog(("sf_nonlinearity",), 5010)
    d = diagnose_independent(log)
    assert d.causes == ["sf_nonlinearity"], (d.causes, d.notes)
    truth = log.truth["sf_nonlinearity"]["k3"]
    k3, sd = d.parameters["sf_nonlinearity"]["k3"], d.uncertainty["sf_nonlinearity"]["k3"]
    assert abs(k3 - truth) < 3 * sd < 0.1 * abs(truth), (k3, sd, truth)
    x, names = d.context.design("output", d.state)
    assert largest_group_share(x, names.index("sf_nonlinearity"), d.context.blocks) > CONCENTRATED
