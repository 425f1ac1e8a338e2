"""fxdsp budget: floor and margin against the ADCs, Allan deviation of the fixed-point error,
drive-frequency sweep, and a JSON that is strict and byte-reproducible.

Expectations are computed here from the definitions (power sum of the ADC sources, white-noise
Allan law, w(T) = w0 [1 - a (T - T0) / 2]), never copied from the code's output."""

from __future__ import annotations

import dataclasses
import json
import math

import allantools
import numpy as np
import pytest

from conftest import coarse_subtract, design_with
from fxdsp.budget.attribution import SourceResult, attribute
from fxdsp.budget.report import format_floor
from fxdsp.budget.floor import allan_chain, allan_figures, drive_band, drive_sweep, floor_of
from fxdsp.budget.hybrid import Source
from fxdsp.budget.static import static_error
from fxdsp.chains import build
from fxdsp.cli import main
from fxdsp.config import load_config
from fxdsp.float_vs_fixed import block_errors

ADC_CATEGORY = "ADC quantisation"


def _strict_json(text: str):
    def refuse(token):
        raise ValueError(f"non-finite JSON number {token}")
    return json.loads(text, parse_constant=refuse)


def _with_sources(att, sources):
    return dataclasses.replace(att, sources=sources)


def _fake(name: str, category: str, rms: float) -> SourceResult:
    return SourceResult(Source(name, category, "test", "test"), rms, 0.0, rms, 0.0)


@pytest.fixture(scope="module")
def att001(design):
    return attribute(design, "chain_paper001", "rate", n=1024)


# ---------------------------------------------------------------------------------------------
# floor and margin
# ---------------------------------------------------------------------------------------------
def test_floor_is_the_power_sum_of_the_adc_sources(att001):
    adc = [s.rms for s in att001.sources if s.source.category == ADC_CATEGORY]
    assert len(adc) >= 2 and all(r > 0 for r in adc)
    f = floor_of(att001)
    assert f.floor == pytest.approx(math.sqrt(sum(r * r for r in adc)), rel=1e-12)
    assert f.total == att001.total_rms
    assert f.margin_db == pytest.approx(20 * math.log10(att001.total_rms / f.floor), rel=1e-12)
    assert f.within == (f.margin_db <= 3.0)
    # the floor follows the ADC sources: each 4x louder -> floor 4x, margin 12.04 dB lower
    louder = [dataclasses.replace(s, rms=4 * s.rms) if s.source.category == ADC_CATEGORY else s
              for s in att001.sources]
    g = floor_of(_with_sources(att001, louder))
    assert g.floor == pytest.approx(4 * f.floor, rel=1e-12)
    assert g.margin_db == pytest.approx(f.margin_db - 20 * math.log10(4), abs=1e-9)


def test_only_non_adc_sources_at_half_the_total_or_more_are_dominant(att001):
    total = att001.total_rms
    base = [s for s in att001.sources if s.rms < total / 2]   # none of these is dominant
    injected = base + [_fake("test.loud", "data-path rounding", 0.51 * total),
                       _fake("test.quiet", "coefficient quantisation", 0.49 * total),
                       _fake("test.adc", ADC_CATEGORY, 10 * total)]
    f = floor_of(_with_sources(att001, injected))
    assert [n for n, _ in f.dominant] == ["test.loud"]
    # the big ADC source raises the floor above the total: a negative margin, within 3 dB
    assert f.margin_db < 0 and f.within
    assert "test.loud" in format_floor(f) and "test.quiet" not in format_floor(f)
    assert [d["name"] for d in json.loads(json.dumps(f.as_dict(), allow_nan=False))["dominant"]] == ["test.loud"]
    assert "none" in format_floor(floor_of(_with_sources(att001, base)))


def test_a_coarse_truncating_stage_dominates_and_is_flagged():
    a = attribute(build(coarse_subtract("floor")), "chain_paper002", "rate", n=8192)   # 4 bits truncated: a bias
    expected = {s.source.name for s in a.sources
                if s.source.category != ADC_CATEGORY and s.rms >= a.total_rms / 2}
    f = floor_of(a)
    assert "bias_subtract.round" in expected
    assert {n for n, _ in f.dominant} == expected
    assert f.margin_db > 3 and not f.within
    assert "NOT within 3 dB" in format_floor(f) and "bias_subtract.round" in format_floor(f)


def test_an_output_no_adc_reaches_has_no_margin(att001):
    no_adc = [s for s in att001.sources if s.source.category != ADC_CATEGORY]
    f = floor_of(_with_sources(att001, no_adc))
    assert f.floor == 0 and f.margin_db is None and f.within is None
    assert "no ADC" in format_floor(f)
    _strict_json(json.dumps(f.as_dict(), allow_nan=False))
    silent = floor_of(dataclasses.replace(att001, total_rms=0.0, sources=[_fake("x", "data-path rounding", 0.0)]))
    assert silent.margin_db is None and silent.dominant == []
    _strict_json(json.dumps(silent.as_dict(), allow_nan=False))


# ---------------------------------------------------------------------------------------------
# Allan deviation
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def allan_default():
    """The Allan figures of the default design (one 2**20-sample run shared by the tests)."""
    return allan_chain(build(), "chain_paper002", ["rate"])[0]


def test_allan_figures_come_from_allantools_and_are_deterministic(allan_default):
    a = allan_default
    b = allan_chain(build(), "chain_paper002", ["rate"])[0]   # a fresh design, same config and seed
    assert np.array_equal(a.error, b.error) and np.array_equal(a.adev, b.adev)
    assert (a.bi_adev, a.bi_tau, a.adev_1s) == (b.bi_adev, b.bi_tau, b.adev_1s)
    fs = a.fs
    assert np.allclose(np.diff(np.log2(a.taus * fs)), 1.0) and a.taus[0] == pytest.approx(1 / fs)
    taus, adev, _, _ = allantools.oadev(a.error, rate=fs, data_type="freq", taus=a.taus)
    assert np.array_equal(adev, a.adev) and np.array_equal(taus, a.taus)
    k = int(np.argmin(adev))
    assert (a.bi_adev, a.bi_tau) == (adev[k], taus[k])
    assert a.flicker_floor == pytest.approx(adev[k] / 0.664)
    # the default record holds tau = 1 s several times: measured, not extrapolated
    assert a.error.size >= 4 * fs and a.measured_1s
    _, a1, _, _ = allantools.oadev(a.error, rate=fs, data_type="freq", taus=[1.0])
    assert a.adev_1s == a1[0] and a.arw == pytest.approx(a1[0] / 60)
    assert np.any(a.error) and np.all(np.isfinite(a.error))


def test_white_noise_allan_law_measured_and_extrapolated():
    """White rate noise of sigma at fs: adev(tau) = sigma / sqrt(tau fs), so adev(1 s) = sigma / sqrt(fs)."""
    rng = np.random.default_rng(11)
    fs, sigma = 1000.0, 2.0
    expect = sigma / math.sqrt(fs)
    short = allan_figures(rng.normal(0, sigma, 2000), fs)      # 2 s: tau = 1 s out of reach
    assert short["fit_taus"] and short["adev_1s"] == pytest.approx(expect, rel=0.15)
    long = allan_figures(rng.normal(0, sigma, 60000), fs)      # 60 s: measured
    assert not long["fit_taus"] and long["adev_1s"] == pytest.approx(expect, rel=0.2)
    # white noise keeps falling: the minimum is at the longest tau
    assert long["bi_tau"] == long["taus"][-1]


def test_allan_rejects_bad_parameters():
    with pytest.raises(ValueError, match="fs"):
        allan_figures(np.zeros(100), 0.0)
    with pytest.raises(ValueError, match="error"):
        allan_figures(np.zeros(3), 1.0)


# ---------------------------------------------------------------------------------------------
# drive-frequency sweep
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def sweep():
    return drive_sweep(load_config(), "chain_paper002", ["rate"])[0]


def test_sweep_spans_the_band_of_the_temperature_law(sweep):
    f0 = load_config().data["demod"]["f_hz"]
    a, t0 = 60e-6, 25.0
    w = [f0 * (1 - a * (t - t0) / 2) for t in (-40.0, 85.0)]
    f = np.array([p.f_hz for p in sweep.points])
    assert f0 in f   # the nominal (exact-ratio) frequency is measured too
    even = f[f != f0]
    assert even.size >= 21
    assert even.min() == pytest.approx(min(w), rel=1e-12) and even.max() == pytest.approx(max(w), rel=1e-12)
    assert np.allclose(np.diff(even), (max(w) - min(w)) / (even.size - 1))
    assert drive_band(f0) == pytest.approx((min(w), max(w)), rel=1e-12)


def test_sweep_points_are_measured_at_their_own_frequency(sweep):
    p = sweep.points[0]
    d = design_with(chains=True, **{"demod.f_hz": p.f_hz})
    rate = next(s for s in block_errors(d, "chain_paper002") if s.port == "rate")
    st = static_error(d, "chain_paper002", "rate")
    scale = d.rate_full_scale_dps * 3600
    assert (p.rms, p.mean) == pytest.approx((rate.rms * rate.scale, rate.mean * rate.scale), rel=1e-12)
    assert (p.static_rms, p.static_mean) == pytest.approx((st["rms"] * scale, st["mean"] * scale), rel=1e-12)
    assert len({q.rms for q in sweep.points}) > 1   # the frequency reaches the measurement


def test_sweep_at_f0_is_section_1s_chain_row(design, sweep):
    f0 = design.config.data["demod"]["f_hz"]
    rate = next(s for s in block_errors(design, "chain_paper002") if s.port == "rate")
    p = next(q for q in sweep.points if q.f_hz == f0)
    assert p.rms == pytest.approx(rate.rms * rate.scale, rel=1e-12)


def test_sweep_worst_values_and_bad_parameters(sweep):
    d = sweep.as_dict()
    assert d["worst_abs"]["rms"]["value"] == max(p.rms for p in sweep.points)
    assert d["worst_abs"]["mean"]["value"] == max(abs(p.mean) for p in sweep.points)
    with pytest.raises(ValueError, match="points"):
        drive_sweep(load_config(), "chain_paper002", ["rate"], points=1)
    with pytest.raises(ValueError, match="temp_range_c"):
        drive_band(8000.0, temp_range_c=(85.0, -40.0))


# ---------------------------------------------------------------------------------------------
# the CLI: text, strict JSON without wall-clock time, byte-identical, report
# ---------------------------------------------------------------------------------------------
def test_budget_json_is_strict_and_complete(tmp_path, capsys):
    """(Same config -> the same bytes, wherever the files lie: test_outputs runs the budget twice.)"""
    j1, rep = tmp_path / "b1.json", tmp_path / "report"
    assert main(["budget", "--json", str(j1), "--report", str(rep)]) == 0
    text = capsys.readouterr().out
    out = _strict_json(j1.read_text())
    assert "seconds" not in out
    assert {(f["chain"], f["port"]) for f in out["floor"]} == {(a["chain"], a["port"]) for a in out["attribution"]}
    for f, a in zip(out["floor"], out["attribution"]):
        adc = [s["rms"] for s in a["sources"] if s["category"] == ADC_CATEGORY]
        assert f["floor"] == pytest.approx(math.sqrt(sum(r * r for r in adc)), rel=1e-12)
        assert f["total"] == a["total_rms"]
        assert {d["name"] for d in f["dominant"]} == {s["name"] for s in a["sources"] if s["category"] != ADC_CATEGORY
                                                     and 0 < s["rms"] and s["rms"] >= a["total_rms"] / 2}
    # the Allan deviation and the drive sweep: every output a demodulator reaches (paper 002's rate only)
    assert [(a["chain"], a["port"]) for a in out["allan"]] == [("chain_paper002", "rate")]
    assert [(s["chain"], s["port"]) for s in out["drive_sweep"]] == [("chain_paper002", "rate")]
    allan = out["allan"][0]
    assert allan["curve"] and allan["arw"]["value"] == pytest.approx(allan["arw"]["adev_1s"] / 60)
    assert allan["arw"]["unit"] == "deg/sqrt(h)"
    assert len(out["drive_sweep"][0]["points"]) >= 21
    # the quasi-static error of every output of a chain with a sensor
    sensed = {n for n, c in build().chains.items() if c.sensor is not None}
    assert {(s["chain"], s["port"]) for s in out["static"]} == {(a["chain"], a["port"]) for a in out["attribution"]
                                                                if a["chain"] in sensed}
    # one floor line per attributed output, the paper 000 acceleration among them
    assert text.count("\nfloor: ") == len(out["floor"]) and ("chain_paper000", "accel") in {
        (f["chain"], f["port"]) for f in out["floor"]}
    assert "bias instability" in text and "deg/sqrt(h)" in text
    assert "0.664" in text and "worst over the band" in text
    # every drive loop at the range's ends and room temperature, locked within 4 tau, near its floor
    assert sorted((lb["table"], lb["scenario"]) for lb in out["drive_loop"]) == sorted(
        (t, f"{c:g} C") for t in ("drive", "drive001") for c in (-40, 25, 85))
    for lb in out["drive_loop"]:
        assert lb["fixed"]["lock_tau"] < 4 and lb["within"], lb
        assert lb["fixed"]["t_noise_mc"] == pytest.approx(lb["fixed"]["f_noise_hz"] / abs(lb["k_hz_per_c"]) * 1e3)
    assert "6. drive loops" in text
    md = (rep / "budget.md").read_text()
    assert "## 6. Drive loops" in md
    assert "allan_chain_paper002.rate.png" in md and (rep / "allan_chain_paper002.rate.png").stat().st_size > 0
    assert "### Floor and margin" in md and (rep / "drive_sweep_chain_paper002.rate.png").exists()
    for a in out["attribution"]:   # every chain output attributed, and plotted
        assert f"attribution_{a['chain']}.{a['port']}.png" in md


# the floor issue's requirement over the band the drive loop covers (not a reading of the code): within
# 3 dB of the ADC floor (the power sum of the ADC sources at this output), no bias beyond 0.05 deg/h
def test_rate_error_at_the_floor_over_the_drive_band(design, sweep):
    a = attribute(design, "chain_paper002", "rate", n=8192)
    floor = math.sqrt(sum(s.rms**2 for s in a.sources if s.source.category == ADC_CATEGORY))
    limit = floor * 10 ** (3 / 20)
    for p in sweep.points:
        assert p.rms <= limit and abs(p.mean) <= 0.05, f"{p.f_hz} Hz: {p} (limit {limit:.3g})"
        assert p.static_rms <= limit and abs(p.static_mean) <= 0.05, f"{p.f_hz} Hz (chamber points): {p}"
        assert p.overflows == 0


def _long_tau_trend(a) -> float:
    """adev at the longest tau over adev at ~0.1 s of the Allan figures ``a``: < 1 when the error
    averages down (white), > 1 when it wanders (a drift: e.g. an open-loop NCO whose tuning-word error
    accumulates phase)."""
    taus, adev = np.asarray(a.taus), np.asarray(a.adev)
    return float(adev[-1] / adev[np.argmin(np.abs(taus - 0.1))])


def test_fixed_point_error_averages_down_without_drift(allan_default):
    assert _long_tau_trend(allan_default) < 1.0


def test_tuning_word_drift_shows_in_the_allan_deviation():
    """The same check catches an accumulator too short for its tuning word (40 bits at f/fs = 1/12)."""
    assert _long_tau_trend(allan_chain(design_with(chains=True, **{"demod.phase_bits": 40}), "chain_paper002", ["rate"])[0]) > 1.5
