"""Physics of the bench against the papers' published numbers and against textbook approximations
derived independently of the code (DOMAIN.md)."""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.sim import ThermalChain, generate_log
from fxdsp.sim.calibration import calibrate_paper000_records, compensate_paper000
from fxdsp.sim.gyro import DEG, METAL_GYRO, PAPER002_GYRO, fit_coupling, tempco
from fxdsp.sim.qvba import DEFAULT_PAIR, FREE_BEAM
from fxdsp.sim.qvba import tumble_run

PAPER002_TEMPS = np.array([-20.0, 0.0, 20.0, 40.0, 60.0])


# --- two-mode gyro (papers 003 and 002) ---------------------------------------------------------

def test_paper002_uncompensated_figures_are_the_right_order():
    g = PAPER002_GYRO
    sf_ppm = tempco(PAPER002_TEMPS, g.sf_mv_per_dps(PAPER002_TEMPS), relative=True) * 1e6
    bias = g.bias_deg_h(PAPER002_TEMPS)
    # paper 002 (shared/papers/002_*.txt) line 54: 316.66e-6 /C and 366.22 deg/h/C, "clearly non-linear"
    assert 0.5 * 316.66 < sf_ppm < 2 * 316.66
    assert 0.5 * 366.22 < tempco(PAPER002_TEMPS, bias) < 2 * 366.22
    slopes = np.diff(bias) / np.diff(PAPER002_TEMPS)
    assert slopes.max() > 1.5 * slopes.min()  # "clearly non-linear"


def test_resonance_and_q_follow_the_temperature_laws():
    g = PAPER002_GYRO
    wx, _ = g.omega(np.array([24.5, 25.5]))
    rel = (wx[1] - wx[0]) / wx.mean()
    assert rel == pytest.approx(-g.a_x_per_c / 2, rel=1e-3)  # E falls by a per C, w by a/2
    temps = np.linspace(-40, 80, 7)
    q = g.quality(temps)[0]
    assert np.all(np.diff(q) < 0)  # Q falls as the die warms
    # the damping coupling is a share of the damping: eta * Q stays constant
    eta = g.couplings(temps)[1]
    np.testing.assert_allclose(eta * q, eta[0] * q[0], rtol=1e-12)


def test_rate_channel_matches_the_textbook_coupling_biases():
    """At the reference temperature, in-phase bias = eta/2 - lambda wx/(2 Qx) (damping and force
    coupling) and quadrature = alpha/(2 wx), all in rad/s of equivalent rate."""
    g = PAPER002_GYRO
    wx, _ = g.omega(25.0)
    qx, _ = g.quality(25.0)
    alpha, eta, lam = g.couplings(25.0)
    rate, quad = g.channels(25.0, 0.0)
    expected_bias = (eta / 2 - lam * wx / (2 * qx)) / DEG * g.sf0_mv_per_dps
    expected_quad = alpha / (2 * wx) / DEG * g.sf0_mv_per_dps
    assert float(rate) == pytest.approx(expected_bias, rel=0.02)
    assert abs(float(quad)) == pytest.approx(expected_quad, rel=0.02)
    # Coriolis: linear in rate, 10 mV per deg/s at 25 C by construction of the reference
    r = np.array([-100.0, 0.0, 50.0, 200.0])
    out = g.channels(25.0, r)[0]
    assert np.allclose(np.diff(out) / np.diff(r), g.sf0_mv_per_dps, rtol=1e-9)


def _sweep():
    g = PAPER002_GYRO
    f = np.linspace(7990.0, 8050.0, 2001)  # through both modes
    wx, wy = g.omega(25.0)
    qx, qy = g.quality(25.0)
    return g, f, g.sweep(f), (wx / 2 / np.pi, qx, wy / 2 / np.pi, qy)


def test_frequency_sweep_identifies_paper003_couplings():
    g, f, s, modes = _sweep()
    fit = fit_coupling(f, s, *modes)
    assert fit["r2"] > 0.99
    # paper 003's reported kxy, cxy, lambda_yx (shared/papers/003_*.txt line 221: -0.000374,
    # -6.96e-8 N s/m, 0.103 N/m), with the model's effective mass
    assert fit["alpha"] * g.mass_kg == pytest.approx(0.103, rel=1e-6)
    assert fit["eta"] * g.mass_kg == pytest.approx(-6.96e-8, rel=1e-6)
    assert fit["lambda_yx"] == pytest.approx(-0.000374, rel=1e-6)


def test_channel_phase_mismatch_ruins_the_damping_coupling_but_not_the_stiffness_coupling():
    g, f, s, modes = _sweep()
    alpha, eta, lam = g.couplings(25.0)
    fit = fit_coupling(f, s * np.exp(1j * np.deg2rad(0.5)), *modes)
    err_eta = abs(fit["eta"] / eta - 1)
    err_alpha = abs(fit["alpha"] / alpha - 1)
    assert err_eta > 0.1 and err_eta > 100 * err_alpha
    # an amplitude (conversion gain) error scales all three alike: it is corrected by one ratio
    fit_gain = fit_coupling(f, 1.05 * s, *modes)
    for key, true in (("alpha", alpha), ("eta", eta), ("lambda_yx", lam)):
        assert fit_gain[key] / true == pytest.approx(1.05, rel=1e-9)


def test_metal_gyro_laws_match_the_printed_data_point():
    # paper 001 (shared/papers/001_*.txt): line 149 f(-10 C) = 3836.9354 Hz, line 155 f = 0.0536T+3837.4
    assert float(METAL_GYRO.frequency(-10.0)) == pytest.approx(3836.9354, abs=1e-3)
    assert float(METAL_GYRO.temperature(METAL_GYRO.frequency(37.0))) == pytest.approx(37.0)
    # the printed intercept 3837.4 would shift every temperature by about -1.33 C
    assert (3837.4 - METAL_GYRO.f0_hz) / METAL_GYRO.k_hz_per_c == pytest.approx(-1.33, abs=0.01)


# --- quartz beam pair (paper 000) ----------------------------------------------------------------

def test_free_beam_turns_over_and_bonded_beam_is_nearly_linear_and_steeper_hot():
    t = np.linspace(-40.0, 80.0, 121)
    free = FREE_BEAM.thermal(t)
    assert np.ptp(free) < 8.0
    assert np.any(np.diff(free) > 0) and np.any(np.diff(free) < 0)  # a turnover inside the range
    bonded = DEFAULT_PAIR.tension.thermal(t)
    assert 10.0 < np.ptp(bonded) < 100.0  # "tens of Hz"
    resid = bonded - np.polyval(np.polyfit(t, bonded, 1), t)
    assert 1 - np.var(resid) / np.var(bonded) > 0.97  # nearly linear: a line explains > 97 %
    slope = np.gradient(bonded, t)
    assert np.all(slope > 0)  # no turnover once bonded
    assert slope[-1] > 2 * slope[0]  # flatter cold, steeper hot


def test_pair_scale_factor_and_bias_variation_before_compensation():
    t = np.linspace(-40.0, 60.0, 101)
    k1 = DEFAULT_PAIR.k1(t)
    # paper 000 (shared/papers/000_*.txt): line 24 K1 about 52 Hz/g, rising with temperature;
    # line 44 K0 varies 10..35 mg and K1 8e-4..1.6e-3 over the range
    assert float(DEFAULT_PAIR.k1(25.0)) == pytest.approx(52.0, abs=1.0)
    assert np.all(np.diff(k1) > 0)
    assert 8e-4 <= np.ptp(k1) / k1.mean() <= 1.6e-3
    k0_mg = 1000.0 * DEFAULT_PAIR.k0(t) / k1
    assert 10.0 <= np.ptp(k0_mg) <= 35.0


def test_tumble_run1_coefficients_hold_on_run2():
    records = tumble_run(DEFAULT_PAIR, (-40.0, -20.0, 0.0, 20.0, 40.0, 60.0), np.random.default_rng(5))
    cal = calibrate_paper000_records(records, run=1)
    run2 = [r for r in records if r["run"] == 2]
    t = np.array([r["temp_c"] for r in run2])
    e = {a: np.array([r["E"][a] for r in run2]) for a in (0, 90, 180, 270)}
    # compensated accelerations: 0 g at 90/270 deg, +-1 g at 0/180 deg
    level = (compensate_paper000(cal, t, e[90]) + compensate_paper000(cal, t, e[270])) / 2
    k1_est = (e[0] - e[180]) / 2
    k1_cal = np.polynomial.polynomial.polyval(t - 25.0, cal["k1_poly"])
    assert np.abs(level).max() * 1000 < 1.0  # K0 within 1 mg
    assert np.abs(k1_est / k1_cal - 1).max() < 5e-5  # K1 within 5e-5
    # and without compensation (constants at 25 C) K0 would be off by more than 10 mg somewhere
    raw = ((e[90] + e[270]) / 2 - float(DEFAULT_PAIR.k0(25.0))) / float(DEFAULT_PAIR.k1(25.0))
    assert np.abs(raw).max() * 1000 > 10.0


# --- heat path (paper 002's integrated vs external sensor) ---------------------------------------

def test_heat_path_orders_air_package_die_and_settles():
    chain = ThermalChain()
    log, truth = generate_log("ramp", effects={}, seed=1, noise="off", thermal=chain, return_truth=True)
    air, pkg, die = truth["air_temp_c"], truth["package_temp_c"], truth["die_temp_c"]
    heating = np.gradient(air, log["time_s"]) > 0
    heating &= np.roll(heating, 6)  # a minute into the ramp: the stages have started to trail
    assert np.all(air[heating] > pkg[heating]) and np.all(pkg[heating] > die[heating])
    # long ramp at 0.5 C/min: each stage trails its input by about rate * tau
    i = np.flatnonzero(heating)[-1]
    assert air[i] - pkg[i] == pytest.approx(0.5 / 60 * chain.tau_package_s, rel=0.05)
    assert pkg[i] - die[i] == pytest.approx(0.5 / 60 * chain.tau_die_s, rel=0.05)
    assert abs(die[-1] - air[-1]) < 0.01  # the last 2 h dwell (8 package tau) settles everything
    # RTD on the die: it reads Te itself; RTD on the package: it leads Te while heating
    np.testing.assert_allclose(log["temp_c"], truth["Te"], rtol=0, atol=1e-12)
    pkg_log, pkg_truth = generate_log("ramp", effects={}, seed=1, noise="off",
                                      thermal=ThermalChain(rtd_node="package"), return_truth=True)
    assert np.all(pkg_log["temp_c"][heating][10:] > pkg_truth["Te"][heating][10:])


def test_pt_element_in_the_bridge_read_with_a_linear_law_bends_like_cvd():
    """A real Pt element read with the paper's linear law: the readout error is the CVD curvature,
    B/A (T - 25)^2 to first order (IEC 60751: B/A = -1.478e-4 /C), and the diagnosis names it."""
    from fxdsp.diagnose.api import diagnose_log
    from fxdsp.logfile import Log
    from fxdsp.sim import generate_log

    log = generate_log(scenario="paper001", seed=2, columns=("ref_temp_c",), rtd_element="pt_bridge",
                       noise={"temp_c": 0.002, "ref_temp_c": 0.002})
    ref, temp = log["ref_temp_c"], log["temp_c"]
    curv = np.polyfit(ref - 25.0, temp - ref, 2)[0]
    assert abs(curv / (-5.775e-7 / 3.9083e-3) - 1.0) < 0.1
    ideal = generate_log(scenario="paper001", seed=2, columns=("ref_temp_c",))
    assert abs(np.polyfit(ideal["ref_temp_c"] - 25, ideal["temp_c"] - ideal["ref_temp_c"], 2)[0]) < 0.1 * abs(curv)
    diag = diagnose_log(Log(columns=log, source="<sim>"))
    assert "rtd_nonlinearity" in diag.causes
