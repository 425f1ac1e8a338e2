"""Log reading and bad input of `fxdsp diagnose` (shared/spec/measured-data.md, sections 1 and 4)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fxdsp.cli import main
from fxdsp.logfile import parse_mapping, read_log
from fxdsp.errors import InputError


def _canonical_rows(n=400, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 10.0
    temp = 25.0 + 10.0 * np.sin(t / 2000.0)
    out = 1.0 + 0.02 * temp + 0.001 * rng.standard_normal(n)
    return t, temp, out


def _write(path, header, rows, comments=()):
    lines = [f"# {c}" for c in comments] + [",".join(header)]
    lines += [",".join(str(v) for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def _run(capsys, *argv):
    code = main(["diagnose", *map(str, argv)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _assert_one_line_error(code, err, *words):
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for word in words:
        assert word in lines[0].lower(), lines[0]


# -- reading -------------------------------------------------------------------------------------
def test_canonical_columns_in_any_order_with_comments(tmp_path):
    t, temp, out = _canonical_rows(50)
    path = _write(tmp_path / "log.csv", ["output", "time_s", "temp_c"], zip(out, t, temp),
                  comments=["written by a test", "scenario: none"])
    log = read_log(path)
    assert len(log) == 50 and log.dropped == 0
    np.testing.assert_allclose(log.columns["time_s"], t)
    np.testing.assert_allclose(log.columns["temp_c"], temp)
    np.testing.assert_allclose(log.columns["output"], out)


def test_foreign_log_with_mapping_dates_and_sentinels(tmp_path):
    stamps = ["30/12/2024-23:59:50", "30/12/2024-23:59:59", "31/12/2024-00:00:10",
              "31/12/2024-23:59:59", "01/01/2025-00:00:09"]
    box = ["22.5", "-1e+38", "22.7", "22.8", "9.9e37"]
    dut = ["1.00001", "1.00002", "nan", "1.00004", "1.00005"]
    text = "date;box;dut;\n" + "".join(f"{d};{b};{v};\n" for d, b, v in zip(stamps, box, dut))
    path = tmp_path / "foreign.dsv"
    path.write_text(text)
    log = read_log(path, parse_mapping(["time_s=date", "temp_c=box", "output=dut"]), ";", "%d/%m/%Y-%H:%M:%S")
    # rows 2 (-1e38), 3 (nan) and 5 (9.9e37) are dropped; seconds count from the first kept row,
    # across midnight and new year: 23:59:50 -> next day 23:59:59 is 86409 s
    assert log.dropped == 3
    np.testing.assert_allclose(log.columns["time_s"], [0.0, 86409.0])
    np.testing.assert_allclose(log.columns["temp_c"], [22.5, 22.8])


def test_strptime_fallback_for_formats_the_fast_path_does_not_know(tmp_path):
    path = tmp_path / "iso.csv"
    path.write_text("when,T,y\n2024-Oct-20 01:00:00,20,1\n2024-Oct-20 01:01:30,21,2\n")
    log = read_log(path, parse_mapping(["time_s=when", "temp_c=T", "output=y"]), ",", "%Y-%b-%d %H:%M:%S")
    np.testing.assert_allclose(log.columns["time_s"], [0.0, 90.0])


def test_sentinel_and_nan_rows_are_dropped_and_counted_in_the_report(tmp_path, capsys):
    t, temp, out = _canonical_rows(400)
    rows = [list(r) for r in zip(t, temp, out)]
    rows[10][1] = "9.9e37"
    rows[20][2] = "-1e38"
    rows[30][2] = "nan"
    rows[40][1] = ""
    path = _write(tmp_path / "log.csv", ["time_s", "temp_c", "output"], rows)
    code, out_text, err = _run(capsys, path, "--json", tmp_path / "r.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["rows"] == {**report["rows"], "used": 396, "dropped": 4}


# -- bad input: one line on stderr, exit 2 ------------------------------------------------------
def test_missing_column(tmp_path, capsys):
    t, temp, out = _canonical_rows(20)
    path = _write(tmp_path / "log.csv", ["time_s", "temp_c"], zip(t, temp))
    _assert_one_line_error(*_run(capsys, path, "--json", tmp_path / "r.json")[::2], "missing column", "output")
    assert not (tmp_path / "r.json").exists()


def test_missing_mapped_source_column(tmp_path, capsys):
    t, temp, out = _canonical_rows(20)
    path = _write(tmp_path / "log.csv", ["time_s", "temp_c", "output"], zip(t, temp, out))
    code, _, err = _run(capsys, path, "--map", "temp_c=box_temp", "--json", tmp_path / "r.json")
    _assert_one_line_error(code, err, "missing column", "box_temp")


def test_empty_file(tmp_path, capsys):
    path = tmp_path / "empty.csv"
    path.write_text("")
    code, _, err = _run(capsys, path, "--json", tmp_path / "r.json")
    _assert_one_line_error(code, err, "empty")


def test_header_without_rows(tmp_path, capsys):
    path = tmp_path / "header.csv"
    path.write_text("# nothing logged\ntime_s,temp_c,output\n")
    code, _, err = _run(capsys, path, "--json", tmp_path / "r.json")
    _assert_one_line_error(code, err, "no data rows")


def test_no_usable_rows(tmp_path, capsys):
    path = _write(tmp_path / "log.csv", ["time_s", "temp_c", "output"],
                  [(0, 25, "9.9e37"), (10, "-1e38", 1.0), (20, "nan", "inf")])
    code, _, err = _run(capsys, path, "--json", tmp_path / "r.json")
    _assert_one_line_error(code, err, "no usable rows")


def test_non_monotonic_time(tmp_path, capsys):
    t, temp, out = _canonical_rows(200)
    t = t.copy()
    t[100] = t[98]  # equal stamps are allowed by the contract (non-decreasing) ...
    t[150] = t[140]  # ... going back is not
    path = _write(tmp_path / "log.csv", ["time_s", "temp_c", "output"], zip(t, temp, out))
    code, _, err = _run(capsys, path, "--json", tmp_path / "r.json")
    _assert_one_line_error(code, err, "non-monotonic")


def test_unparseable_date(tmp_path, capsys):
    path = tmp_path / "log.dsv"
    path.write_text("date;T;y\n20/10/2024-01:18:45;23;1\n20/10/2024 01:19:08;23;1\n")
    code, _, err = _run(capsys, path, "--map", "time_s=date", "--map", "temp_c=T", "--map", "output=y",
                        "--delimiter", ";", "--time-format", "%d/%m/%Y-%H:%M:%S", "--json", tmp_path / "r.json")
    _assert_one_line_error(code, err, "cannot parse date", "row 2")


def test_impossible_date(tmp_path, capsys):
    path = tmp_path / "log.dsv"
    path.write_text("date;T;y\n28/02/2024-01:18:45;23;1\n31/02/2024-01:19:08;23;1\n")
    code, _, err = _run(capsys, path, "--map", "time_s=date", "--map", "temp_c=T", "--map", "output=y",
                        "--delimiter", ";", "--time-format", "%d/%m/%Y-%H:%M:%S", "--json", tmp_path / "r.json")
    _assert_one_line_error(code, err, "impossible date")


def test_unknown_map_target(tmp_path, capsys):
    t, temp, out = _canonical_rows(20)
    path = _write(tmp_path / "log.csv", ["time_s", "temp_c", "output"], zip(t, temp, out))
    code, _, err = _run(capsys, path, "--map", "temperature=temp_c", "--json", tmp_path / "r.json")
    _assert_one_line_error(code, err, "unknown target", "temperature")


def test_missing_file(tmp_path, capsys):
    code, _, err = _run(capsys, tmp_path / "nope.csv", "--json", tmp_path / "r.json")
    _assert_one_line_error(code, err, "nope.csv")


def test_parse_mapping_rejects_malformed_items():
    with pytest.raises(InputError):
        parse_mapping(["temp_c"])
    assert parse_mapping([" temp_c = box_temp "]) == {"temp_c": "box_temp"}


def test_a_target_mapped_twice_is_refused():
    with pytest.raises(InputError, match="time_s is already mapped to 't'"):   # the last would win, silently
        parse_mapping(["time_s=t", "time_s=box"])


def test_one_column_is_read_as_one_quantity(tmp_path):
    """Found by a probe: time mapped as temperature too was diagnosed (exit 0), a wrong answer. A
    column mapped twice is refused; a canonical column mapped to another quantity is read as that
    one only, not also under its own name."""
    t, temp, out = _canonical_rows(50)
    path = _write(tmp_path / "log.csv", ["time_s", "temp_c", "output", "ref_temp_c"],
                  zip(t, temp, out, temp + 0.5))
    with pytest.raises(InputError, match="column 't' is already mapped to time_s"):
        read_log(_write(tmp_path / "f.csv", ["t", "output"], zip(t, out)), {"time_s": "t", "temp_c": "t"})
    log = read_log(path, {"temp_c": "ref_temp_c"})
    assert np.allclose(log.columns["temp_c"], temp + 0.5) and not log.has("ref_temp_c")


def test_equal_time_stamps_are_allowed(tmp_path, capsys):
    t, temp, out = _canonical_rows(400)
    t = t.copy()
    t[200] = t[199]  # non-decreasing is the contract
    path = _write(tmp_path / "log.csv", ["time_s", "temp_c", "output"], zip(t, temp, out))
    code, _, err = _run(capsys, path, "--json", tmp_path / "r.json")
    assert code == 0, err
    assert json.loads((tmp_path / "r.json").read_text())["rows"]["used"] == 400


def test_two_readings_per_stamp_give_the_same_diagnosis():
    """Two different readings per time stamp (two loggers merged, or channels written on separate
    lines): derivatives see zero-length intervals, which the shared mechanisms must handle; a
    ramp-rate term, which lives on d(temp_c)/dt, must still be found with its coefficient."""
    from fxdsp.diagnose.api import diagnose_log
    from fxdsp.logfile import Log
    from fxdsp.sim import generate_log

    effects = {"ramp_rate": {"k_per_c_per_s": 400.0}}
    a = generate_log(scenario="paper002", effects=effects, seed=4, columns=("rate_dps", "freq_hz"))
    b = generate_log(scenario="paper002", effects=effects, seed=5, columns=("rate_dps", "freq_hz"))
    assert np.array_equal(a["time_s"], b["time_s"])  # same programme, independent noise
    merged = {k: np.column_stack([a[k], b[k]]).ravel() for k in a}
    diag = diagnose_log(Log(columns=merged, source="<two readings per stamp>"))
    assert diag.causes == ["ramp_rate"]
    assert abs(diag.parameters["ramp_rate"]["k_per_c_per_s"] / 400.0 - 1.0) < 0.25


def test_isolated_spikes_are_flagged_but_steps_and_ramps_are_not():
    from fxdsp.diagnose.model import spike_rows

    rng = np.random.default_rng(1)
    y = 1e-3 * rng.standard_normal(600)
    y[100:] += 5.0  # a rate-table step
    y[300:400] += np.linspace(0, 30, 100)  # a steep ramp
    y[0] = 40.0  # the first reading of a meter (tckit's 4.67 V in a 1 V channel)
    y[500] -= 0.5
    flags = spike_rows(y)
    assert sorted(np.flatnonzero(flags)) == [0, 500]


def _degenerate(kind: str):
    """A canonical log with a reference and a resonator (section 1), one column degenerate in a way
    the contract allows."""
    t, temp, out = _canonical_rows(400)
    t, temp = t.copy(), temp.copy()
    ref = temp - 0.1
    freq = 5000.0 - 0.3 * temp + 0.001 * np.random.default_rng(1).standard_normal(t.size)
    if kind == "reference never moves":
        ref[:] = 25.0
    elif kind == "nothing moves":
        temp[:], ref[:] = 25.0, 25.0
    elif kind == "first rows share a stamp":
        t[:6] = 0.0
    return ["time_s", "temp_c", "output", "ref_temp_c", "freq_hz"], zip(t, temp, out, ref, freq)


@pytest.mark.parametrize("kind", ["reference never moves", "nothing moves", "first rows share a stamp"])
def test_degenerate_columns_within_the_contract_are_diagnosed(kind, tmp_path, capsys):
    """A stability run at one temperature, a reference thermometer held in a bath, a logger that
    stamps its first readings at once: valid logs. A straight line or a quadratic fitted to a column
    with one distinct value (np.polyfit's SVD fails on it) was an internal error (exit 70)."""
    header, rows = _degenerate(kind)
    path = _write(tmp_path / "log.csv", header, rows)
    code, _, err = _run(capsys, path, "--json", tmp_path / "r.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["rows"]["used"] == 400 and "remaining" in report
    ignored = [n for n in report["notes"] if "'ref_temp_c'" in n and "was ignored" in n]
    assert bool(ignored) == (kind == "reference never moves"), report["notes"]   # below: why ignored


# -- a reference that does not move ---------------------------------------------------------------
# The contract has temp_c equal to ref_temp_c up to an offset and a gain. A probe left in a bath,
# stuck or disconnected, logs one reading (or a few hundredths of a degree of noise) while temp_c
# follows the chamber: read as the reference, the temperature channel's residual was temp_c's whole
# programme and a diagnosis named a ramp-rate term (a paper001 simulation with a 400 s lag). Such a
# column is ignored with a note, so the log gets the diagnosis it would get without it.
def _logged_reference_log(column: str = "ref_temp_c"):
    """The first 500-row lag log of the independent generator (written from the contract) whose
    draw logs ``column`` (a reference thermometer)."""
    from independent.chamber_logs import generate
    for seed in range(5000, 5050):
        log = generate(("thermal_lag",), seed, rows=500)
        if column in log.columns:
            return {k: np.asarray(v, float) for k, v in log.columns.items()}
    raise AssertionError(f"no seed of 5000..5049 logs {column}")


def _without_notes(diag):
    from fxdsp.diagnose.report import report_dict
    report = report_dict(diag)
    report.pop("notes")
    return json.dumps(report, sort_keys=True, default=str)


@pytest.mark.parametrize("still", ["one reading", "a probe's noise"])
def test_a_reference_that_does_not_move_is_ignored_with_a_note(still):
    from fxdsp.diagnose.api import diagnose_columns
    cols = _logged_reference_log()
    ref = np.full(cols["temp_c"].size, 23.4)
    if still == "a probe's noise":
        ref += 0.01 * np.random.default_rng(3).standard_normal(ref.size)
    absent = {k: v for k, v in cols.items() if k != "ref_temp_c"}
    stuck = diagnose_columns({**cols, "ref_temp_c": ref}, "stuck")
    assert _without_notes(stuck) == _without_notes(diagnose_columns(absent, "stuck"))
    assert any("'ref_temp_c'" in n and "was ignored" in n for n in stuck.notes), stuck.notes
    assert not any("ref_temp_c" in n for n in diagnose_columns(cols, "moving").notes)   # a real one is read


@pytest.mark.parametrize("column", ["freq_hz", "quad"])
def test_a_stuck_readout_is_ignored_with_a_note(column):
    """A resonator counter or a quadrature input that logs one value throughout carries nothing; fitted
    as a channel, a stuck freq_hz made a true lag fail there (it must explain freq_hz too). The log
    gets the diagnosis it would get without the column, and a note says why."""
    from fxdsp.diagnose.api import diagnose_columns
    cols = _logged_reference_log(column)
    absent = {k: v for k, v in cols.items() if k != column}
    once = np.full(cols["time_s"].size, np.nan)
    once[len(once) // 2] = cols[column][0]        # read once, empty everywhere else: one value too
    baseline = _without_notes(diagnose_columns(absent, "stuck"))
    for values in (np.full(cols["time_s"].size, cols[column][0]), once):
        stuck = diagnose_columns({**cols, column: values}, "stuck")
        assert _without_notes(stuck) == baseline
        assert any(f"'{column}'" in n and "was ignored" in n for n in stuck.notes), stuck.notes
    assert not any(f"'{column}'" in n for n in diagnose_columns(cols, "moving").notes)   # a live one is read


@pytest.mark.parametrize("column", ["freq_hz", "quad"])
def test_the_log_records_which_column_it_ignored_and_why(column):
    """What a command that needs the column says (calibrate's one line) is read from the record, the
    same words as the note, not found again by searching the notes' text."""
    from fxdsp.logfile import Log
    cols = _logged_reference_log(column)
    log = Log(columns={**cols, column: np.full(cols["time_s"].size, cols[column][0])})
    assert list(log.ignored) == [column] and column not in log.columns
    assert log.notes == [log.ignored[column]] and "was ignored" in log.ignored[column]
    assert Log(columns=cols).ignored == {}


def test_calibrate_says_it_ignored_a_reference_that_does_not_move(tmp_path, capsys):
    """`fxdsp calibrate` fits against ref_temp_c when the log has one; a still one is ignored (the
    fit is the one without the column) and the result says so instead of fitting around it silently."""
    from fxdsp.sim import generate_log, write_log

    log = generate_log("paper001", effects={}, seed=1)
    stuck = {**log, "ref_temp_c": np.full(len(log["temp_c"]), 23.4)}
    absent = {k: v for k, v in log.items() if k != "ref_temp_c"}
    results = {}
    for name, cols in (("stuck", stuck), ("absent", absent)):
        write_log(tmp_path / f"{name}.csv", cols)
        assert main(["calibrate", "--paper", "001", str(tmp_path / f"{name}.csv"),
                     "--json", str(tmp_path / f"{name}.json")]) == 0
        results[name] = json.loads((tmp_path / f"{name}.json").read_text())
    capsys.readouterr()
    notes = results["stuck"].pop("notes")
    assert any("'ref_temp_c'" in n and "was ignored" in n for n in notes), notes
    assert "notes" not in results["absent"] and results["stuck"] == results["absent"]


def test_calibrate_says_why_a_column_it_needs_was_ignored(tmp_path, capsys):
    """Paper 001's calibration needs freq_hz; a log whose counter is stuck has the column, and the one
    line must say that the reader ignored it and why, not only that it is missing."""
    from fxdsp.sim import generate_log, write_log

    log = generate_log("paper001", effects={}, seed=1)
    write_log(tmp_path / "stuck.csv", {**log, "freq_hz": np.full(len(log["temp_c"]), 31250.0)})
    code = main(["calibrate", "--paper", "001", str(tmp_path / "stuck.csv")])
    _assert_one_line_error(code, capsys.readouterr().err, "needs the freq_hz column", "'freq_hz' holds one value",
                           "ignored")


@pytest.mark.parametrize("paper,column", [("001", "freq_hz"), ("002", "rate_dps")])
def test_calibrate_apply_says_why_a_column_the_second_log_lacks_was_ignored(tmp_path, capsys, paper, column):
    """--apply runs the calibrated compensation on a second log; one whose needed column holds only the
    logger's sentinel has the column, and the reader drops it. The compensation indexed the missing
    column (paper 001: a KeyError, exit 70); it is refused by name, with the reader's reason."""
    from fxdsp.sim import generate_log, write_log

    log = generate_log(f"paper{paper}", effects={}, seed=1)
    write_log(tmp_path / "good.csv", log)
    write_log(tmp_path / "dead.csv", {**log, column: np.full(len(log["temp_c"]), 9.9e37)})
    code = main(["calibrate", "--paper", paper, str(tmp_path / "good.csv"), "--apply", str(tmp_path / "dead.csv"),
                 "--json", str(tmp_path / "c.json")])
    _assert_one_line_error(code, capsys.readouterr().err, f"needs the {column} column",
                           f"'{column}' has no usable value", "ignored")


def test_an_ignored_reference_costs_no_row(tmp_path, capsys):
    """A stuck probe whose logger also writes "no reading" placeholders or empty cells: the column is
    ignored, so its bad cells must not drop rows that every read column holds well (they did: the
    reader dropped rows first and the column was ignored after)."""
    t, temp, out = _canonical_rows(400)
    ref = ["9.9e37" if i % 40 == 0 else ("" if i % 40 == 7 else "21.5") for i in range(t.size)]
    path = _write(tmp_path / "log.csv", ["time_s", "temp_c", "output", "ref_temp_c"], zip(t, temp, out, ref))
    code, _, err = _run(capsys, path, "--json", tmp_path / "r.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["rows"] == {"used": 400, "dropped": 0, "dropped_invalid": 0, "dropped_spikes": 0}, report["rows"]
    assert any("'ref_temp_c'" in n and "was ignored" in n for n in report["notes"]), report["notes"]
