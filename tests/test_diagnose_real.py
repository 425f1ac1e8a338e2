"""Real data: the tckit air-bath sweep (a 1 V transfer through a nanovoltmeter in a bath) and the
published Pt100 table. The assertions are physics read from the raw data, not the engine's numbers."""

from __future__ import annotations

from conftest import SHARED, needs_shared

import json

import jsonschema
import numpy as np
import pytest

from fxdsp.cli import main
from fxdsp.logfile import parse_mapping, read_log
from fxdsp.diagnose.rtd import IEC60751, cvd_law, fit_cvd, fit_linear, linear_temperature, load_table, rtd_study
from conftest import diagnose_schema

TCKIT_REL = "data/tckit/hp3458abx_hp34420a_tcsweep_1vdc_nplc100_test2_oct2024.dsv"
PT100_REL = "data/pt100_table/pt100_table.csv"
TCKIT, PT100 = SHARED / TCKIT_REL, SHARED / PT100_REL
TCKIT_ARGS = ["--map", "time_s=date", "--map", "temp_c=box_temp", "--map", "output=vbl5",
              "--delimiter", ";", "--time-format", "%d/%m/%Y-%H:%M:%S"]
needs_tckit, needs_pt100 = needs_shared(TCKIT_REL), needs_shared(PT100_REL)


def _dwell_relaxation_time_s(t, box, v, plateau):
    """Time constant of the output's exponential settling while the bath holds still: a static
    model says the output is constant there; a lag says it relaxes with the lag's time constant."""
    idx = np.flatnonzero(plateau)
    run = max(np.split(idx, np.flatnonzero(np.diff(idx) > 5) + 1), key=len)
    tt, vv = t[run] - t[run[0]], v[run]
    best = None
    for tau in np.geomspace(300.0, 1e5, 400):
        a = np.column_stack([np.ones_like(tt), np.exp(-tt / tau)])
        r = vv - a @ np.linalg.lstsq(a, vv, rcond=None)[0]
        if best is None or r @ r < best[1]:
            best = (tau, r @ r)
    return best[0], tt[-1]


@needs_tckit
def test_tckit_log_is_read_through_the_mapping():
    log = read_log(TCKIT, parse_mapping(TCKIT_ARGS[1:6:2]), ";", "%d/%m/%Y-%H:%M:%S")
    t = log.columns["time_s"]
    # README: about 38 h, one row every ~21 s, 6311 rows; the mapped columns hold no sentinel
    assert len(log) + log.dropped == 6311
    assert 37.5 < t[-1] / 3600 < 38.5
    assert 20 < np.median(np.diff(t)) < 23
    assert 17.5 < log.columns["temp_c"].min() and log.columns["temp_c"].max() < 35.5


@needs_tckit
def test_tckit_vbl5_lags_the_bath(tmp_path, capsys):
    report = tmp_path / "tckit.json"
    code = main(["diagnose", str(TCKIT), *TCKIT_ARGS, "--json", str(report), "--report", str(tmp_path / "rep")])
    assert code == 0, capsys.readouterr().err
    data = json.loads(report.read_text())
    jsonschema.validate(data, diagnose_schema())

    log = read_log(TCKIT, parse_mapping(TCKIT_ARGS[1:6:2]), ";", "%d/%m/%Y-%H:%M:%S")
    t, box, v = log.columns["time_s"], log.columns["temp_c"], log.columns["output"]
    # the first row's 4.67 V is a non-physical reading (README), set aside as a spike
    assert data["rows"]["dropped"] >= 1 and data["rows"]["used"] + data["rows"]["dropped"] == 6311
    # raw-data physics: in both long dwells (35 C and 18 C, ~3 h each) the output keeps settling
    hot, hot_len = _dwell_relaxation_time_s(t, box, v, box > box.max() - 0.15)
    cold, cold_len = _dwell_relaxation_time_s(t, box, v, box < box.min() + 0.15)
    assert hot_len > 2.5 * 3600 and cold_len > 2.5 * 3600

    # so the discrepancy is dynamic (a lag), not static in temperature and not a ramp-only term
    assert data["cause"] == "thermal_lag"
    tau = data["parameters"]["tau_s"]
    assert 0.5 * min(hot, cold) < tau < 2.0 * max(hot, cold), (tau, hot, cold)
    assert data["uncertainty"]["tau_s"] < 0.3 * tau
    assert data["gain"]["channel"] == "output" and data["gain"]["heldout"] and data["gain"]["ratio"] > 1.3
    assert (tmp_path / "rep" / "residuals.png").exists()


@needs_pt100
def test_pt100_linear_law_is_wrong_and_callendar_van_dusen_fixes_it():
    t, r = load_table(PT100)
    assert t[0] == -200 and t[-1] == 850 and r.size == 1051
    study = rtd_study(t, r)
    linear, cvd, iec = study["linear"], study["cvd_fit"], study["cvd_iec60751"]
    # a straight line through a curve with B/A = -1.5e-4 /C over 1050 C misreads by degrees, while
    # a 0.01 ohm table rounding is 0.03 C and the README's transcription errors 0.015 ohm (0.04 C)
    assert linear["error"].max_abs_c > 5.0
    assert cvd["error"].max_abs_c < 0.1 and iec["error"].max_abs_c < 0.1
    assert linear["error"].rms_c > 100 * cvd["error"].rms_c
    assert cvd["A"] == pytest.approx(IEC60751["A"], rel=1e-3)
    assert cvd["B"] == pytest.approx(IEC60751["B"], rel=1e-2)
    assert cvd["R0"] == pytest.approx(100.0, abs=0.01)
    # the diagnosis engine names the cause from a linear readout against the table's temperature
    assert study["diagnosis"]["causes"] == ["rtd_nonlinearity"]


@needs_pt100
def test_pt100_curvature_matches_callendar_van_dusen_above_zero():
    t, r = load_table(PT100)
    keep = t >= 0  # no C term: a linear readout is exactly T + (B/A) T^2 up to offset and gain
    study = rtd_study(t[keep], r[keep])
    b = study["diagnosis"]["parameters"]["rtd_nonlinearity"]["b_per_c"]
    ratio = IEC60751["B"] / IEC60751["A"]
    # T + q T^2 = (1 + 50 q) T + q (T - 25)^2 - 625 q: per unit gain, b = q / (1 + 50 q)
    assert b == pytest.approx(ratio / (1 + 50 * ratio), rel=0.02)


def test_callendar_van_dusen_round_trip():  # no shared data: the IEC 60751 law itself
    temps = np.linspace(-200, 850, 300)
    law = cvd_law(**IEC60751)
    res = law.resistance(temps)
    np.testing.assert_allclose(law.temperature(res), temps, atol=1e-9)
    fit = fit_cvd(temps, res)
    for key in ("R0", "A", "B", "C"):
        assert fit[key] == pytest.approx(IEC60751[key], rel=1e-6)
    r0, beta = fit_linear(temps, res)
    assert np.max(np.abs(linear_temperature(res, r0, beta) - temps)) > 5.0
