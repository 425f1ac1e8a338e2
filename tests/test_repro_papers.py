"""The papers' figures reproduced through calibration -> config -> bit-exact compensation.

Every expected value below is the paper's (DOMAIN.md), typed here, with a stated tolerance; where the
simulated device cannot reach a paper's figure the test asserts the direction and says why."""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.repro import paper000, paper001, paper002, paper003

# paper 002
SF_BEFORE, BIAS_BEFORE = 316.66, 366.22
SF_AFTER, BIAS_AFTER = 69.67, 115.25
SF_EXT, BIAS_EXT = 154.97, 172.67
# paper 001
K_HZ_PER_C = 0.0536
F_AT_MINUS_10 = 3836.9354  # the printed data point
F0_PRINTED = 3837.4
# paper 003
KXY, CXY, LAMBDA = 0.103, -6.96e-8, -0.000374
CXY_REL_ERR = 0.0609


@pytest.fixture(scope="module")
def r002():
    # the methods on the repeatable device (the run-to-run repeatability and the paper's figures it
    # gives are tested in test_repro_repeatability.py)
    return paper002.reproduce(repeatability=None)


@pytest.fixture(scope="module")
def r001():
    return paper001.reproduce()


@pytest.fixture(scope="module")
def r000():
    return paper000.reproduce()


@pytest.fixture(scope="module")
def r003():
    return paper003.reproduce(n_freqs=21)


# --- paper 002 --------------------------------------------------------------------------------------

def test_002_uncompensated_figures_within_10_percent_of_the_paper(r002):
    assert r002["before"]["sf_ppm"] == pytest.approx(SF_BEFORE, rel=0.10)
    assert r002["before"]["bias"] == pytest.approx(BIAS_BEFORE, rel=0.10)


def test_002_integrated_rtd_compensation_at_least_as_good_as_the_paper(r002):
    """The paper's 69.67 ppm/C and 115.25 deg/h/C are run-to-run non-repeatability of its device; a
    device that repeats exactly beats them (with the repeatability model they come out of the model:
    test_repro_repeatability.py). Assert the repeatable device beats them and improves on the
    uncompensated device by at least the paper's factors (4.5x, 3.2x)."""
    row = r002["methods"]["integrated, linear x4 (paper)"]
    assert row["sf_ppm"] < SF_AFTER and row["bias"] < BIAS_AFTER
    assert r002["before"]["sf_ppm"] / row["sf_ppm"] > SF_BEFORE / SF_AFTER
    assert r002["before"]["bias"] / row["bias"] > BIAS_BEFORE / BIAS_AFTER
    assert row["overflows"] == 0


def test_002_external_sensor_worse_by_at_least_the_papers_ratio(r002):
    m = r002["methods"]
    ext, integ = m["external, linear x4 (paper)"], m["integrated, linear x4 (paper)"]
    assert ext["sf_ppm"] > SF_EXT / SF_AFTER * integ["sf_ppm"]
    assert ext["bias"] > BIAS_EXT / BIAS_AFTER * integ["bias"]
    # the thermal path alone gives the external bias figure within 25 % of the paper's
    assert ext["bias"] == pytest.approx(BIAS_EXT, rel=0.25)
    # ... and the package node sits between the die and the air
    assert integ["ramp_max_deg_h"] <= m["package, linear x4 (paper)"]["ramp_max_deg_h"] < ext["ramp_max_deg_h"]


def test_002_frequency_thermometer_and_lag_estimate_recover_the_external_device(r002):
    m = r002["methods"]
    ext, integ = m["external, linear x4 (paper)"], m["integrated, linear x4 (paper)"]
    freq = m["frequency thermometer, linear x4"]
    assert freq["sf_ppm"] < 1.5 * integ["sf_ppm"] + 1.0 and freq["bias"] < 1.5 * integ["bias"] + 1.0
    assert freq["ramp_max_deg_h"] < ext["ramp_max_deg_h"] / 20
    lag = m["external + identified lag, linear x4"]
    assert lag["bias"] < ext["bias"] / 5 and lag["ramp_max_deg_h"] < ext["ramp_max_deg_h"] / 5
    assert 0.5 * paper002.TAU_PACKAGE_S < lag["tau_s"] < 2 * paper002.TAU_PACKAGE_S


def test_002_quadratic_segments_cut_the_error_between_calibration_points(r002):
    m = r002["methods"]
    assert m["integrated, quadratic x2"]["ramp_max_deg_h"] < 0.7 * m["integrated, linear x4 (paper)"]["ramp_max_deg_h"]


# --- paper 001 --------------------------------------------------------------------------------------

def test_001_resonator_thermometer(r001):
    c = r001["cal"]
    assert c["k_hz_per_c"] == pytest.approx(K_HZ_PER_C, rel=0.01)
    f0_implied = F_AT_MINUS_10 + 10 * K_HZ_PER_C  # the paper's data point, not its rounded intercept
    assert c["f0_hz"] == pytest.approx(f0_implied, abs=0.005)
    assert c["max_freq_residual_hz"] <= 0.01  # the paper: at most 0.01 Hz


def test_001_quadratic_bias_close_to_the_papers_fit(r001):
    q = r001["cal"]["bias_poly"]
    assert q[2] == pytest.approx(-0.25, rel=0.03) and q[1] == pytest.approx(-36.92, rel=0.03)
    assert q[0] == pytest.approx(1469.5, abs=5.0)
    # 15 deg/h rather than the paper's 1: the calibration reference lags the die by a few 0.01 C,
    # which rescales the T axis by 0.35 % (the k above); compensation is unaffected (next checks)
    assert r001["fit_vs_paper_max_deg_h"] < 15.0
    assert r001["verify_residual_max_deg_h"] < 15.0 < r001["verify_raw_span_deg_h"] / 100


def test_001_random_drift_about_3_to_about_1(r001):
    assert 2.5 < r001["drift_before"] < 5.0
    assert 0.6 < r001["drift_after"] < 1.4
    assert r001["drift_after"] / r001["drift_before"] < 1 - 0.60  # the paper: about -65 %


def test_001_rounded_intercept_is_caught(r001):
    assert r001["thermometer_check"]["ok"]
    bad = r001["thermometer_check_rounded"]
    assert not bad["ok"]
    expected = (F_AT_MINUS_10 + 10 * K_HZ_PER_C - F0_PRINTED) / K_HZ_PER_C  # 1.33 C
    assert bad["mean_error_c"] == pytest.approx(expected, abs=0.05)
    assert r001["data_point_error_rounded_c"] == pytest.approx(expected, abs=0.05)
    assert abs(r001["data_point_error_c"]) < 0.1
    assert r001["verify_residual_rounded_max_deg_h"] > 5 * r001["verify_residual_max_deg_h"]


def test_001_static_run_rejects_bad_input():
    with pytest.raises(ValueError, match="hours"):
        paper001.static_run(hours=0)


# --- paper 000 --------------------------------------------------------------------------------------

def test_000_uncompensated_spread_inside_the_papers_range(r000):
    assert 10.0 <= r000["k0_before_mg"] <= 35.0
    assert 8e-4 <= r000["k1_before"] <= 1.6e-3


def test_000_run1_coefficients_on_run2_bit_exact(r000):
    assert r000["k0_after_mg"] < 1.0
    assert r000["k1_after"] < 5e-5
    assert r000["overflows"] == 0
    rec = paper000.reproduce_records()
    assert rec["k0_after_mg"] < 1.0 and rec["k1_after"] < 5e-5


def test_000_split_rejects_a_single_pass():
    from fxdsp.sim import generate_log
    log = generate_log("paper000", effects={}, seed=1)
    first, _ = paper000.split_runs(log)
    with pytest.raises(ValueError, match="^log: "):
        paper000.split_runs(first)


# --- paper 003 --------------------------------------------------------------------------------------

def test_003_identification_through_the_fixed_point_demodulator(r003):
    f = r003["filtered"]
    assert r003["measure"]["overflows"] == 0
    assert f["kxy"] == pytest.approx(KXY, rel=0.01)
    assert f["cxy"] == pytest.approx(CXY, rel=CXY_REL_ERR)  # the paper's 6.09 %
    assert f["lambda_yx"] == pytest.approx(LAMBDA, rel=0.10)
    assert f["r2"] >= 0.99


def test_003_low_pass_filter_is_what_makes_the_damping_coupling_identifiable(r003):
    raw, filt, avg = r003["raw"], r003["filtered"], r003["averaged"]
    assert abs(raw["cxy"] / CXY - 1) > 0.5  # the paper: > 1000 % on raw data
    assert abs(raw["cxy"] / CXY - 1) > 10 * abs(filt["cxy"] / CXY - 1)
    assert abs(avg["cxy"] / CXY - 1) < CXY_REL_ERR / 2


def test_003_mismatch_and_its_correction_are_reported(r003):
    mm = r003["mismatch"]["phase"]
    assert mm["phase_offset_rad"] == pytest.approx(np.deg2rad(0.5))
    assert abs(mm["filtered, uncorrected"]["cxy"] / CXY - 1) > CXY_REL_ERR
    assert abs(mm["filtered, corrected"]["cxy"] / CXY - 1) < CXY_REL_ERR


def test_003_uncorrected_phase_mismatch_ruins_the_damping_coupling():
    freqs = np.linspace(*paper003.SPAN_HZ, 11)
    m = paper003.measure(freqs, phase_offset_rad=np.deg2rad(0.5))
    ident = paper003.identify(freqs, m["filtered"])
    assert abs(ident["cxy"] / CXY - 1) > 0.2  # 0.5 deg moves the stiffness term into it
    assert ident["kxy"] == pytest.approx(KXY, rel=0.01)
    with pytest.raises(ValueError, match="freqs_hz"):
        paper003.measure([8000.0, 8010.0])
