"""The virtual test bench's logs: the contract's baseline holds exactly and every cause is the
contract's mechanism, checked by routes that do not reuse the code that injected it."""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.sim import SCENARIOS, generate_log, read_log, write_log

QUIET = {"noise": "off"}


def _poly_residual(x, y, order):
    coef = np.polynomial.polynomial.polyfit(x, y, order)
    return y - np.polynomial.polynomial.polyval(x, coef), coef


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_baseline_is_static_polynomial_linear_resonator_and_linear_rtd(scenario):
    log, truth = generate_log(scenario, effects={}, seed=3, noise="off", return_truth=True)
    t = log["temp_c"]
    # Te is what temp_c reads: no lag anywhere in the baseline
    np.testing.assert_array_equal(truth["Te"], t)
    # freq_hz is an exact straight line in temp_c, temp_c an exact straight line in ref_temp_c
    assert np.abs(_poly_residual(t, log["freq_hz"], 1)[0]).max() < 1e-6
    assert np.abs(_poly_residual(log["ref_temp_c"], t, 1)[0]).max() < 1e-9
    # output = B(T) + S(T) * rate with B, S cubic at most: a joint least-squares fit is exact
    rate = log["rate_dps"]
    x = t - 25.0
    design = np.column_stack([x ** i for i in range(4)] + [rate * x ** i for i in range(4)])
    coef, *_ = np.linalg.lstsq(design, log["output"], rcond=None)
    resid = log["output"] - design @ coef
    assert np.abs(resid).max() < 1e-6 * np.abs(log["output"]).max()


def test_baseline_has_no_heating_cooling_split_but_thermal_lag_has():
    base = generate_log("ramp", effects={}, seed=1, noise="off")
    lag = generate_log("ramp", effects={"thermal_lag": {"tau_s": 1200.0}}, seed=1, noise="off")
    for log, split_expected in ((base, False), (lag, True)):
        resid, _ = _poly_residual(log["temp_c"], log["output"], 3)
        dtdt = np.gradient(log["temp_c"], log["time_s"])
        heating, cooling = resid[dtdt > 1e-3].mean(), resid[dtdt < -1e-3].mean()
        split = abs(heating - cooling)
        if split_expected:
            assert split > 0.5  # mV: a 1200 s lag at 0.5 C/min is 10 C behind, ~10 mV of bias
        else:
            assert split < 1e-6


def test_thermal_lag_tau_recovered_from_the_resonator_thermometer():
    """Independent route: the resonator frequency is the die's thermometer (paper 001). Calibrate
    f(T) on settled dwell ends, turn freq into Te, and solve tau = (temp_c - Te) / (dTe/dt)."""
    tau = 1200.0  # 2 h dwells are 6 tau: the dwell ends are settled to 0.25 % of the lag
    log, truth = generate_log("ramp", effects={"thermal_lag": {"tau_s": tau}}, seed=7, return_truth=True)
    t, temp, freq = log["time_s"], log["temp_c"], log["freq_hz"]
    settled = np.zeros(t.size, bool)
    seg = truth["segment"]
    for s in np.unique(seg[truth["phase"] == "dwell"]):
        idx = np.flatnonzero(seg == s)
        settled[idx[-60:]] = True  # last 10 min of each 2 h dwell
    k, f0 = np.polyfit(temp[settled], freq[settled], 1)
    te = (freq - f0) / k
    window = 20  # 200 s central difference: averages the 0.001 Hz frequency noise
    dte = (te[2 * window:] - te[:-2 * window]) / (t[2 * window:] - t[:-2 * window])
    gap = (temp - te)[window:-window]
    moving = np.abs(dte) > 2e-3
    tau_est = np.sum(gap[moving] * dte[moving]) / np.sum(dte[moving] ** 2)
    assert tau_est == pytest.approx(tau, rel=0.03)


def _difference(scenario, effects, seed=5, **kw):
    """Effect log minus baseline log with the same seed: the noise cancels exactly because every
    channel has its own random stream."""
    base, truth = generate_log(scenario, effects={}, seed=seed, return_truth=True, **kw)
    eff = generate_log(scenario, effects=effects, seed=seed, **kw)
    return eff, base, truth


def test_ramp_rate_follows_the_chamber_ramp_rate():
    k = 50.0  # mV per C/s
    eff, base, truth = _difference("ramp", {"ramp_rate": {"k_per_c_per_s": k}})
    d = eff["output"] - base["output"]
    gain = truth["baseline"]["rtd_gain"]
    ramp = truth["phase"] == "ramp"
    inner = ramp & np.roll(ramp, 3) & np.roll(ramp, -3)  # away from the ramp ends
    # the contract's k * d(temp_c)/dt, with the chamber's ramp rate read from the chamber's own air
    # temperature (not re-typed from the programme) seen through the RTD's gain
    chamber_rate = np.gradient(truth["air_temp_c"], eff["time_s"])
    assert np.all(np.abs(chamber_rate[inner]) > 0)
    assert np.allclose(np.abs(d[inner]), k * gain * np.abs(chamber_rate[inner]), rtol=1e-6)
    dwell = (truth["phase"] == "dwell") & np.roll(truth["phase"] == "dwell", 3) & np.roll(truth["phase"] == "dwell", -3)
    assert np.abs(d[dwell]).max() < 1e-9
    np.testing.assert_array_equal(eff["freq_hz"], base["freq_hz"])


def test_hysteresis_sign_persists_through_dwells():
    h = 0.8
    eff, base, truth = _difference("ramp", {"hysteresis": {"h": h}})
    d = eff["output"] - base["output"]
    sp, phase, t = truth["setpoint_c"], truth["phase"], eff["time_s"]
    before = t < 3000.0
    assert np.allclose(d[before], 0.0)
    hot = (phase == "dwell") & (sp == 60.0)
    cold = (phase == "dwell") & (sp == -20.0)
    assert np.allclose(d[hot], h) and np.allclose(d[cold], -h)
    final = (phase == "dwell") & (sp == 25.0) & (t > 10000)
    assert np.allclose(d[final], h)  # last ramp was heating


def test_warmup_and_aging():
    eff, base, _ = _difference("paper001", {"warmup": {"a": 30.0, "tau_s": 1800.0},
                                            "aging_drift": {"r_per_h": 2.0}})
    d = eff["output"] - base["output"]
    t = eff["time_s"]
    assert d[0] == pytest.approx(30.0)
    i = np.searchsorted(t, 1800.0)
    assert d[i] == pytest.approx(30.0 / np.e + 2.0 * 0.5, rel=1e-9)
    late = t > 20 * 1800.0  # warm-up gone: pure drift r * hours
    slope = np.polyfit(t[late] / 3600.0, d[late], 1)[0]
    assert slope == pytest.approx(2.0, rel=1e-9)


def test_quadrature_leak_is_c_times_quad_and_quad_ignores_the_temperature_programme():
    c = 0.02
    eff, base, _ = _difference("paper002", {"quadrature_leak": {"c": c}})
    d = eff["output"] - base["output"]
    slope = np.polyfit(base["quad"], d, 1)[0]
    assert slope == pytest.approx(c, rel=0.01)  # regression on the *logged* (noisy) quad
    other = generate_log("ramp", effects={}, seed=5)
    n = min(other["quad"].size, base["quad"].size)
    # a different chamber programme, the same quadrature history: it does not depend on temperature
    np.testing.assert_array_equal(other["quad"][:n], base["quad"][:n])
    assert np.std(base["quad"]) > 10 * 0.01  # it does vary, well above its own noise


def test_sf_nonlinearity_is_cubic_in_rate():
    k3 = 1e-6
    eff, base, truth = _difference("paper002", {"sf_nonlinearity": {"k3": k3}}, noise="off")
    d = eff["output"] - base["output"]
    rate = base["rate_dps"]
    at = lambda r: np.median(d[rate == r])
    assert at(200.0) / at(100.0) == pytest.approx(8.0, rel=0.02)  # S(T) differs a little between dwells
    assert at(-200.0) == pytest.approx(-at(200.0), rel=1e-9)
    np.testing.assert_array_equal(d[rate == 0.0], 0.0)


def test_rtd_nonlinearity_bends_temp_c_against_the_reference():
    b = 2e-4
    log, truth = generate_log("paper000", effects={"rtd_nonlinearity": {"b_per_c": b}}, seed=2,
                              return_truth=True)
    _, coef = _poly_residual(log["ref_temp_c"] - 25.0, log["temp_c"], 2)
    assert coef[2] == pytest.approx(b * truth["baseline"]["rtd_gain"], rel=0.03)
    base = generate_log("paper000", effects={}, seed=2)
    _, coef0 = _poly_residual(base["ref_temp_c"] - 25.0, base["temp_c"], 2)
    assert abs(coef0[2]) < 0.03 * b


def test_frequency_nonlinearity_is_a_turnover_in_te():
    k2 = -0.003
    log = generate_log("paper000", effects={"frequency_nonlinearity": {"k2_hz_per_c2": k2}}, seed=2)
    _, coef = _poly_residual(log["temp_c"] - 25.0, log["freq_hz"], 2)
    assert coef[2] == pytest.approx(k2, rel=0.01)
    base = generate_log("paper000", effects={}, seed=2)
    np.testing.assert_array_equal(log["output"], base["output"])  # output untouched


def test_deterministic_and_seed_dependent():
    a = generate_log("random", effects={"thermal_lag": {"tau_s": 900.0}}, seed=11)
    b = generate_log("random", effects={"thermal_lag": {"tau_s": 900.0}}, seed=11)
    c = generate_log("random", effects={"thermal_lag": {"tau_s": 900.0}}, seed=12)
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    assert a["time_s"].size != c["time_s"].size or not np.array_equal(a["temp_c"], c["temp_c"])


def test_random_programmes_vary_and_stay_in_the_chamber_range():
    ends = set()
    for seed in range(6):
        log, truth = generate_log("random", effects={}, seed=seed, noise="off", return_truth=True)
        air = truth["air_temp_c"]
        assert -30.0 <= air.min() and air.max() <= 70.0
        assert np.all(np.diff(log["time_s"]) > 0)
        assert air.max() - air.min() > 10.0  # an actual temperature programme
        ends.add(round(float(log["time_s"][-1])))
    assert len(ends) == 6


def test_columns_and_sizes():
    log = generate_log("paper002", effects={}, seed=1, columns=("freq_hz",))
    assert list(log) == ["time_s", "temp_c", "output", "freq_hz"]
    assert 2000 < log["time_s"].size < 10000  # a few thousand rows at the default 10 s
    short = generate_log("paper002", effects={}, seed=1, columns="", time_step_s=30.0, duration_scale=0.5)
    assert list(short) == ["time_s", "temp_c", "output"]
    assert short["time_s"].size < log["time_s"].size / 3
    assert np.all(np.diff(short["time_s"]) == 30.0)


@pytest.mark.parametrize("kwargs, field", [
    ({"scenario": "paper999"}, "scenario"),
    ({"effects": {"thermal_lag": {"tau": 1.0}}}, "tau"),
    ({"effects": {"lag": {"tau_s": 1.0}}}, "lag"),
    ({"effects": {"warmup": {"a": 1.0}}}, "tau_s"),
    ({"effects": {"thermal_lag": {"tau_s": -5.0}}}, "tau_s"),
    ({"effects": {"hysteresis": {"h": "big"}}}, "h"),
    ({"columns": ("temperature",)}, "columns"),
    ({"seed": -1}, "seed"),
    ({"time_step_s": 0.0}, "time_step_s"),
    ({"noise": {"outptu": 1.0}}, "noise"),
])
def test_bad_arguments_raise_value_error_naming_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        generate_log(**{"scenario": "ramp", "effects": {}, **kwargs})


def test_write_and_read_back(tmp_path):
    log = generate_log("paper001", effects={"aging_drift": {"r_per_h": 1.0}}, seed=4)
    path = tmp_path / "run.csv"
    write_log(path, log, header_comments={"scenario": "paper001", "seed": 4})
    lines = path.read_text().splitlines()
    assert lines[0] == "# scenario: paper001" and lines[1] == "# seed: 4"
    assert lines[2] == "time_s,temp_c,output,ref_temp_c,rate_dps,freq_hz,quad"
    back, comments = read_log(path)
    assert comments == {"scenario": "paper001", "seed": "4"}
    for key in log:
        np.testing.assert_allclose(back[key], log[key], rtol=1e-11, atol=1e-9)
    with pytest.raises(ValueError, match="output"):
        write_log(tmp_path / "bad.csv", {"time_s": [0.0], "temp_c": [1.0]})
    with pytest.raises(OSError) as exc:   # an I/O failure names its file (the CLI prints it on one line)
        write_log(tmp_path / "missing-dir" / "x.csv", log)
    assert exc.value.filename.endswith("x.csv")
