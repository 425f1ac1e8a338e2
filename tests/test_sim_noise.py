"""Noise of the bench: the Allan deviation (computed by allantools, not by us) has the textbook
slopes and levels: -1/2 for white noise, a flat floor of 0.664 B for bias instability, +1/2 and
K sqrt(tau/3) for rate random walk."""

from __future__ import annotations

import allantools
import numpy as np
import pytest

from fxdsp.sim import generate_log
from fxdsp.sim import noise

N = 2 ** 17
DT = 0.5  # not 1 s, so that a sqrt(dt) slip in a noise generator shows


def _adev(x, taus):
    t, ad, _, _ = allantools.oadev(x, rate=1.0 / DT, data_type="freq", taus=taus)
    return t, ad


def _slope(t, ad):
    return np.polyfit(np.log10(t), np.log10(ad), 1)[0]


def test_white_noise_slope_minus_half():
    x = noise.white(np.random.default_rng(1), N, 0.3)
    t, ad = _adev(x, np.logspace(0, 3, 13))
    assert _slope(t, ad) == pytest.approx(-0.5, abs=0.05)
    np.testing.assert_allclose(ad, 0.3 * np.sqrt(DT / t), rtol=0.15)  # sigma per sample


def test_bias_instability_floor():
    b = 0.02
    x = noise.flicker(np.random.default_rng(2), N, DT, b)
    t, ad = _adev(x, np.logspace(1, 3.5, 11))
    assert abs(_slope(t, ad)) < 0.1
    floor = b * np.sqrt(2 * np.log(2) / np.pi)
    assert np.median(ad) == pytest.approx(floor, rel=0.2)


def test_rate_random_walk_slope_plus_half():
    k = 1e-3
    x = noise.random_walk(np.random.default_rng(3), N, DT, k)
    t, ad = _adev(x, np.logspace(1, 3.5, 11))
    assert _slope(t, ad) == pytest.approx(0.5, abs=0.1)
    np.testing.assert_allclose(np.median(ad / np.sqrt(t / 3)), k, rtol=0.25)


def test_combined_output_noise_has_a_minimum_between_white_and_random_walk():
    levels = {"output": 0.3, "bias_instability": 0.0, "rate_random_walk": 1e-3}
    x = noise.output_noise(np.random.default_rng(4), N, DT, levels)
    t, ad = _adev(x, np.logspace(0, 4, 17))
    i = int(np.argmin(ad))
    assert 0 < i < len(ad) - 1
    # white and RRW lines cross where 0.3 / sqrt(tau) = 1e-3 sqrt(tau / 3): tau ~ 520 s
    assert 100.0 < t[i] < 3000.0


def test_log_noise_is_white_at_the_documented_level():
    log, truth = generate_log("paper001", effects={}, seed=9, return_truth=True)
    resid = log["output"] - truth["output"]
    sigma = noise.DEFAULT_RELATIVE_OUTPUT * abs(truth["baseline"]["sf_poly"][0])
    dt = truth["time_step_s"]
    t, ad, _, _ = allantools.oadev(resid, rate=1 / dt, data_type="freq", taus=dt * np.array([1, 2, 4, 8, 16, 32, 64]))
    assert _slope(t, ad) == pytest.approx(-0.5, abs=0.08)
    assert np.std(resid) == pytest.approx(sigma, rel=0.05)
    for channel in ("temp_c", "ref_temp_c", "freq_hz"):
        assert np.std(log[channel] - truth[channel]) == pytest.approx(truth["noise"][channel], rel=0.05)


def test_noise_off_and_bad_keys():
    log, truth = generate_log("ramp", effects={}, seed=1, noise="off", return_truth=True)
    np.testing.assert_array_equal(log["output"], truth["output"])
    with pytest.raises(ValueError, match="bias_instability"):
        generate_log("ramp", effects={}, noise={"bias_instability": -1.0})
