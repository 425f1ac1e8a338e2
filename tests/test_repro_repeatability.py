"""Run-to-run repeatability (fxdsp.sim.repeatability) and what it does to paper 002's figures; paper
003's channel correction (amplitude and phase, fxdsp.repro.paper003.channel_correction).

The paper's figures are typed here (DOMAIN.md); the statistic is the one the report prints: the
median over paper002.N_PAIRS calibration/verification run pairs."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from fxdsp.repro import paper002, paper003
from fxdsp.sim import generate_log
from fxdsp.repro.paper002 import PAPER002_REPEATABILITY
from fxdsp.sim.repeatability import Repeatability

SF_AFTER, BIAS_AFTER = 69.67, 115.25
CXY, KXY = -6.96e-8, 0.103
CXY_REL_ERR = 0.0609
INTEG = "integrated, linear x4 (paper)"


@pytest.fixture(scope="module")
def with_rep():
    return paper002.over_seeds(paper002.N_PAIRS, paper002.VERIFY_SCALE, PAPER002_REPEATABILITY, (INTEG,))


# --- the model ----------------------------------------------------------------------------------

def test_median_range_is_the_median_of_drawn_ranges():
    """paper002.median_range against draws: half of 400,000 drawn ranges of 5 normals lie below it
    (within 4 standard errors); for 2 draws the range is |N(0, 2)|, median sqrt(2) x 0.67449."""
    z = np.random.default_rng(0).standard_normal((400_000, 5))
    below = np.mean(z.max(axis=1) - z.min(axis=1) <= paper002.median_range(5))
    assert abs(below - 0.5) < 4 * np.sqrt(0.25 / len(z))
    assert paper002.median_range(2) == pytest.approx(np.sqrt(2) * 0.6744897501960817, rel=1e-9)


def test_magnitudes_follow_from_the_papers_figures():
    """sigma = range / (median range of 5 normals x sqrt 2), in the units of the dataclass; the
    median here from draws, the paper's figures typed above."""
    z = np.random.default_rng(1).standard_normal((400_000, 5))
    k = np.median(z.max(axis=1) - z.min(axis=1)) * np.sqrt(2)
    span_c = 80.0  # the paper's test span, -20..60 C
    assert PAPER002_REPEATABILITY.temp_bias_sigma * 3600 == pytest.approx(BIAS_AFTER * span_c / k, rel=0.005)
    assert PAPER002_REPEATABILITY.temp_sf_sigma == pytest.approx(SF_AFTER * 1e-6 * span_c / k, rel=0.005)


def test_off_by_default_and_zero_sigmas_change_nothing():
    base = generate_log("paper002", effects={}, seed=5)
    for rep in (None, Repeatability()):
        log = generate_log("paper002", effects={}, seed=5, repeatability=rep)
        for col in base:
            np.testing.assert_array_equal(log[col], base[col])
    with pytest.raises(ValueError, match="repeatability.temp_bias_sigma"):
        Repeatability(temp_bias_sigma=-1.0)
    with pytest.raises(ValueError, match="^repeatability: "):
        generate_log("paper002", effects={}, seed=5, repeatability={"temp_bias_sigma": 1.0})


def test_offsets_are_per_run_and_per_temperature_point():
    """On every dwell the output moves by S0 (turn-on + that point's draw) (no rate on the table),
    only the repeatability column of the seed's streams is new, and the same seed repeats the draw."""
    plain, truth0 = generate_log("paper002", effects={}, seed=3, return_truth=True)
    log, truth = generate_log("paper002", effects={}, seed=3, repeatability=PAPER002_REPEATABILITY, return_truth=True)
    d = truth["repeatability"]
    np.testing.assert_array_equal(d["setpoints_c"], [23.0, 60.0, 40.0, 20.0, 0.0, -20.0])
    s0 = truth["baseline"]["sf_poly"][0]
    for k, sp in enumerate(d["setpoints_c"]):
        sel = (truth["phase"] == "dwell") & (truth["setpoint_c"] == sp)
        want = s0 * (d["turn_on_bias"] + d["point_bias"][k])
        np.testing.assert_allclose(log["output"][sel] - plain["output"][sel], want, rtol=1e-9, atol=1e-9)
    assert len({round(float(v), 12) for v in d["point_bias"]}) == d["point_bias"].size
    np.testing.assert_array_equal(log["temp_c"], plain["temp_c"])
    again = generate_log("paper002", effects={}, seed=3, repeatability=PAPER002_REPEATABILITY, return_truth=True)[1]
    np.testing.assert_array_equal(again["repeatability"]["point_bias"], d["point_bias"])
    other = generate_log("paper002", effects={}, seed=4, repeatability=PAPER002_REPEATABILITY, return_truth=True)[1]
    assert not np.allclose(other["repeatability"]["point_bias"], d["point_bias"])


# --- paper 002 ----------------------------------------------------------------------------------

def test_002_repeatability_gives_the_papers_after_compensation_figures_within_30_percent(with_rep):
    """The reported statistic (median over the run pairs, quick verification run, as `fxdsp repro`)."""
    st = with_rep["stats"][INTEG]
    assert len(with_rep["pairs"]) == paper002.N_PAIRS >= 25
    assert st["sf_ppm"]["median"] == pytest.approx(SF_AFTER, rel=0.30)
    assert st["bias"]["median"] == pytest.approx(BIAS_AFTER, rel=0.30)
    # single pairs spread around it: the paper's value is inside the 10..90 % band, not a lucky seed
    assert st["sf_ppm"]["p10"] < SF_AFTER < st["sf_ppm"]["p90"]
    assert st["bias"]["p10"] < BIAS_AFTER < st["bias"]["p90"]


def test_002_without_repeatability_the_device_beats_the_paper_by_far(with_rep):
    off = paper002.over_seeds(5, paper002.VERIFY_SCALE, None, (INTEG,))["stats"][INTEG]
    assert off["sf_ppm"]["max"] < SF_AFTER / 10 and off["bias"]["max"] < BIAS_AFTER / 10
    # the uncompensated figures do not need the repeatability (its median stays within 10 %)
    before = with_rep["stats"]["before"]
    assert before["sf_ppm"]["median"] == pytest.approx(316.66, rel=0.10)
    assert before["bias"]["median"] == pytest.approx(366.22, rel=0.10)


def test_002_turn_on_component_alone_is_inert():
    """A constant per run cancels in (max - min): it is the per-point component that makes the figures."""
    rep = paper002.turn_on_only(PAPER002_REPEATABILITY)
    assert rep.turn_on_bias_sigma > 0 and rep.temp_bias_sigma == 0
    st = paper002.over_seeds(5, paper002.VERIFY_SCALE, rep, (INTEG,))["stats"][INTEG]
    assert st["sf_ppm"]["max"] < SF_AFTER / 10 and st["bias"]["max"] < BIAS_AFTER / 10


def test_002_paper_length_run_meets_the_derivation():
    """Points at the calibration temperatures: the median lands on the paper's figures (within 15 %)."""
    st = paper002.over_seeds(paper002.N_PAIRS, 1.0, PAPER002_REPEATABILITY, (INTEG,))["stats"][INTEG]
    assert st["sf_ppm"]["median"] == pytest.approx(SF_AFTER, rel=0.15)
    assert st["bias"]["median"] == pytest.approx(BIAS_AFTER, rel=0.15)


def test_002_repro_uses_the_repeatability_by_default():
    params = inspect.signature(paper002.reproduce).parameters
    assert params["repeatability"].default is PAPER002_REPEATABILITY
    assert params["n_pairs"].default == paper002.N_PAIRS
    with pytest.raises(ValueError, match="n_pairs"):
        paper002.seed_pairs(0)
    with pytest.raises(ValueError, match="methods"):
        paper002.run_pair(methods=("no such method",))


# --- paper 003 ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def freqs003():
    return np.linspace(*paper003.SPAN_HZ, 21)


def test_003_correction_brings_cxy_under_the_paper_with_half_a_degree_mismatch(freqs003):
    case = paper003.mismatch_case(freqs003, np.deg2rad(0.5), 0.0, seed=1)
    unc, cor = case["filtered, uncorrected"], case["filtered, corrected"]
    assert case["overflows"] == 0
    assert abs(unc["cxy"] / CXY - 1) > CXY_REL_ERR  # the mismatch alone breaks the paper's accuracy
    assert abs(cor["cxy"] / CXY - 1) < CXY_REL_ERR  # the paper's correction restores it
    assert cor["kxy"] == pytest.approx(KXY, rel=0.01) and cor["r2"] >= 0.99
    c = case["correction"]
    # the modal tests find the mismatch: resonance phases -90 deg + channel offset
    assert np.degrees(c["phase_y_rad"] - c["phase_x_rad"]) == pytest.approx(0.5, abs=0.05)
    assert c["resonance_phase_x_deg"] == pytest.approx(-90.0, abs=0.05)


def test_003_gain_ratio_correction_removes_a_sense_gain_error(freqs003):
    case = paper003.mismatch_case(freqs003, np.deg2rad(0.5), 0.02, seed=1)
    assert case["correction"]["gain_ratio"] == pytest.approx(1.02, rel=2e-3)
    assert abs(case["filtered, uncorrected"]["kxy"] / KXY - 1) > 0.015  # 2 % gain -> 2 % on every coefficient
    cor = case["filtered, corrected"]
    assert cor["kxy"] == pytest.approx(KXY, rel=0.005)
    assert abs(cor["cxy"] / CXY - 1) < CXY_REL_ERR


def test_003_correction_of_matched_channels_changes_little(freqs003):
    m = paper003.measure(freqs003, seed=1)
    corr = paper003.channel_correction(m["gain"], seed=2)
    assert abs(corr["phase_y_rad"] - corr["phase_x_rad"]) < np.deg2rad(0.05)
    assert corr["gain_ratio"] == pytest.approx(1.0, rel=2e-3)
    s = paper003.correct(m["filtered"], corr)
    assert np.max(np.abs(s / m["filtered"] - 1)) < 2e-3
    with pytest.raises(ValueError, match="gain"):
        paper003.channel_correction(0.0)
