"""Calibration -> quantised TOML config -> bit-exact log compensation (fxdsp.repro), checked against
independent float arithmetic written here (numpy polyval, plain division), not against the code under
test."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from fxdsp.chains import build
from fxdsp.config import default_config_text
from fxdsp.fixed import Format
from fxdsp.repro.bitexact import Compensator000, Compensator001, Compensator002
from fxdsp.repro.calconfig import (FS_MV, config_from_text, config_text, fit_format, paper000_tables,
                                   paper001_tables, paper002_tables, set_table_keys)
from fxdsp.repro.calibrate import calibrate002, fit_segments
from fxdsp.repro.points import rate_table_points, tempco
from fxdsp.sim import generate_log


@pytest.fixture(scope="module")
def noiseless002():
    log = generate_log("paper002", effects={}, seed=1, noise="off")
    cal = calibrate002(log)
    return log, cal, config_text(paper002_tables(cal))


def _polyval_segments(fit, t):
    bp = np.asarray(fit["breakpoints_c"])
    seg = np.searchsorted(bp, t, side="right")
    return np.array([np.polyval(fit["coefficients"][s][::-1], x) for x, s in zip(t, seg)])


def test_fit_format_holds_the_value_with_headroom_and_rejects_nan():
    for v in (0.9, 1.0, 3.0e-4, 120.0, -36.92, 1469.5):
        fmt = Format.parse(fit_format([v]))
        assert fmt.wl == 24
        assert abs(v) <= fmt.max_value / 2  # one bit of headroom
        assert abs(v) > fmt.max_value / 8  # and not wasteful: the finest such format
    with pytest.raises(ValueError, match="coef"):
        fit_format([np.nan], name="coef")


def test_set_table_keys_rewrites_only_the_named_table_and_rejects_unknown_keys():
    text = default_config_text()
    out = set_table_keys(text, "piecewise.bias001", {"t0_c": 5.0})
    new, old = tomllib.loads(out), tomllib.loads(text)
    assert new["piecewise"]["bias001"]["t0_c"] == 5.0
    assert new["piecewise"]["k0"]["t0_c"] == old["piecewise"]["k0"]["t0_c"] == 25.0
    with pytest.raises(ValueError, match=r"\[rtd\]\.no_such_key"):
        set_table_keys(text, "rtd", {"no_such_key": 1})


def test_fit_segments_linear_and_quadratic_are_exact_through_their_points():
    t = np.array([-20.0, 0.0, 20.0, 40.0, 60.0])
    v = 1.0 + 3e-4 * t + 2e-6 * t ** 2
    lin = fit_segments(t, v, 1)
    assert lin["breakpoints_c"] == [0.0, 20.0, 40.0] and len(lin["coefficients"]) == 4
    quad = fit_segments(t, v, 2)
    assert quad["breakpoints_c"] == [20.0]
    tt = np.linspace(-20, 60, 81)
    np.testing.assert_allclose(_polyval_segments(quad, tt), 1.0 + 3e-4 * tt + 2e-6 * tt ** 2, atol=1e-12)
    with pytest.raises(ValueError, match="order"):
        fit_segments(t, v, 4)


def test_calibrated_config_builds_and_changes_only_calibrated_tables(noiseless002):
    _, _, text = noiseless002
    build(config_from_text(text))
    new, old = tomllib.loads(text), tomllib.loads(default_config_text())
    changed = {k for k in old if new[k] != old[k]}
    assert changed == {"piecewise", "sf_divide", "system"}
    assert {k for k in old["piecewise"] if new["piecewise"][k] != old["piecewise"][k]} == {"sf", "bias"}


def test_piecewise_tables_match_the_float_fit_within_quantisation(noiseless002):
    _, cal, text = noiseless002
    d = build(config_from_text(text))
    t = np.linspace(-25.0, 65.0, 181)
    tf = d.blocks["piecewise_sf"].temp_format
    code = np.floor(t * 2 ** tf.fl).astype(np.int64)  # any temperature code
    tq = code / 2 ** tf.fl
    sf_block, bias_block = d.blocks["piecewise_sf"], d.blocks["piecewise_bias"]
    sf = sf_block.run(temp=code).outputs["y"] * sf_block.out_format.lsb
    expect_sf = _polyval_segments(cal["sf"], tq) / cal["sf_nominal"]
    assert np.abs(sf - expect_sf).max() < 2 * sf_block.out_format.lsb   # output rounding + coefficient steps
    bias = bias_block.run(temp=code).outputs["y"] * bias_block.out_format.lsb
    expect_bias = _polyval_segments(cal["bias"], tq) * cal["sf_nominal"] / FS_MV
    assert np.abs(bias - expect_bias).max() < 2 ** -20


def test_bit_exact_compensation_equals_float_and_recovers_the_table_rate(noiseless002):
    log, cal, text = noiseless002
    comp = Compensator002(config_from_text(text))
    out = comp.compensate(log)
    assert out["overflows"].total == 0
    # float oracle with the same (bit-exact) temperature: output / SF(T) - bias(T)
    tq = out["temp_c"]
    float_rate = log["output"] / _polyval_segments(cal["sf"], tq) - _polyval_segments(cal["bias"], tq)
    assert np.abs(out["rate_dps"] - float_rate).max() < 3e-4  # deg/s: LSBs of s24.23, u24.22 (x 200 deg/s), s24.22
    pts = rate_table_points(log, output=out["rate_dps"])
    np.testing.assert_allclose(pts["sf"], 1.0, atol=2e-5)  # deg/s per deg/s
    assert np.abs(pts["bias"]).max() * 3600 < 2.0  # deg/h at the calibration temperatures
    raw = rate_table_points(log)
    assert tempco(raw["temp_c"], raw["sf"], True) * 1e6 > 100 * tempco(pts["temp_c"], pts["sf"], True) * 1e6


def test_bad_log_values_are_one_line_value_errors(noiseless002):
    log, _, text = noiseless002
    comp = Compensator002(config_from_text(text))
    bad = dict(log, output=np.where(np.arange(log["output"].size) == 3, np.nan, log["output"]))
    with pytest.raises(ValueError, match="^output: "):
        comp.compensate(bad)
    with pytest.raises(ValueError, match="log_s"):
        rate_table_points(log, log_s=0.0)
    with pytest.raises(ValueError, match="sf_nominal"):
        paper002_tables({"sf_nominal": 0.0, "sf": {}, "bias": {}})


def test_paper001_and_000_configs_compensate_bit_exactly_against_float():
    cal1 = {"f0_hz": 3837.471, "k_hz_per_c": 0.0536, "bias_poly": [1469.5, -36.92, -0.25]}
    comp1 = Compensator001(config_from_text(config_text(paper001_tables(cal1))))
    t = np.linspace(-10, 50, 61)
    f = 3837.471 + 0.0536 * t
    q = 1469.5 - 36.92 * t - 0.25 * t ** 2
    out = comp1.compensate({"freq_hz": f, "output": q + 3.0})
    np.testing.assert_allclose(out["temp_c"], t, atol=0.003)
    np.testing.assert_allclose(out["rate_deg_h"], 3.0, atol=0.25)  # 0.003 C x 50 deg/h/C + LSBs
    cal0 = {"t_ref_c": 25.0, "k0_poly": [120.0, 0.01, -2e-5, 1e-7], "k1_poly": [51.9, 6.2e-4, 0.0, 0.0]}
    comp0 = Compensator000(config_from_text(config_text(paper000_tables(cal0))))
    temps = np.linspace(-40, 60, 11)
    tt = temps - 25
    k0 = 120.0 + 0.01 * tt - 2e-5 * tt ** 2 + 1e-7 * tt ** 3
    k1 = 51.9 + 6.2e-4 * tt
    a = np.linspace(-1, 1, 11)
    res = comp0.compensate(temps, k0 + k1 * a)
    assert res["overflows"].total == 0
    assert np.abs(res["accel_g"] - a).max() < 2e-6  # g: format LSBs, far below the paper's 1 mg
