"""One log reader (the contract's, shared/spec/measured-data.md section 1) for every command that
reads a log: duplicate column names and a flat output are refused by name, non-finite rows are
dropped and counted, never passed on as NaN. The logs here are written as text from the contract,
not with fxdsp's own writer."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from conftest import run_cli
from fxdsp.cli import main


def _csv(path, header: str, rows) -> str:
    path.write_text(header + "\n" + "\n".join(",".join(f"{v:.9g}" for v in r) for r in rows) + "\n")
    return str(path)


def _ramp_rows(n=3000, nan_at=None):
    """temp steps -20..60 C in 5 plateaus, output linear in T plus a small ripple, 10 s sampling."""
    rows = []
    for i in range(n):
        t = 10.0 * i
        temp = -20.0 + 20.0 * min(4, i * 5 // n)
        out = 10.0 * (1 + 3e-4 * temp) * 0.5 + 1e-3 * math.sin(i)
        rows.append((t, temp, out if i != nan_at else float("nan"), temp))
    return rows


COMMANDS = [["diagnose", "{log}"], ["calibrate", "--paper", "001", "{log}"]]


@pytest.mark.parametrize("cmd", COMMANDS)
def test_duplicate_column_names_are_refused(tmp_path, capsys, cmd):
    log = _csv(tmp_path / "dup.csv", "time_s,temp_c,output,output", _ramp_rows(50))
    assert main([c.format(log=log) for c in cmd]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'output'" in err[0] and "more than once" in err[0]


@pytest.mark.parametrize("cmd", COMMANDS)
def test_flat_output_is_refused_by_name(tmp_path, capsys, cmd):
    rows = [(r[0], r[1], 5.0, r[3]) for r in _ramp_rows(200)]
    log = _csv(tmp_path / "flat.csv", "time_s,temp_c,output,ref_temp_c", rows)
    assert main([c.format(log=log) for c in cmd]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "output" in err[0] and "flat" in err[0]


@pytest.mark.parametrize("hole", ["nan", "", "9.9e37", "-1e38", "inf"])
def test_calibrate_drops_a_bad_row_instead_of_writing_nan(tmp_path, capsys, hole):
    """A paper 002 chamber log with one unusable output cell (empty, NaN, an instrument's sentinel)."""
    from fxdsp.sim import generate_log

    log = generate_log("paper002", effects={}, seed=1)
    names = list(log)
    lines = [",".join(names)] + [",".join(f"{log[c][i]:.12g}" for c in names) for i in range(len(log["time_s"]))]
    clean = tmp_path / "clean.csv"
    clean.write_text("\n".join(lines) + "\n")
    k = names.index("output")
    row = lines[777].split(",")
    row[k] = hole
    lines[777] = ",".join(row)
    holed = tmp_path / "holed.csv"
    holed.write_text("\n".join(lines) + "\n")
    fits = []
    for path in (clean, holed):
        js = tmp_path / (path.stem + ".json")
        assert main(["calibrate", "--paper", "002", str(path), "--json", str(js)]) == 0
        fits.append(json.loads(js.read_text(), parse_constant=lambda c: pytest.fail(f"{c} in the JSON")))
    capsys.readouterr()
    a, b = fits[0]["sf"]["slopes"], fits[1]["sf"]["slopes"]
    assert a == pytest.approx(b, rel=1e-2)   # one dropped row of thousands barely moves the fit


def test_calibrate_accepts_repeated_time_stamps(tmp_path, capsys):
    """The contract allows two readings per stamp: the sampling interval is that of distinct stamps."""
    from fxdsp.sim import generate_log

    log = generate_log("paper002", effects={}, seed=1)
    names = list(log)
    lines = [",".join(names)]
    for i in range(len(log["time_s"])):
        row = ",".join(f"{log[c][i]:.12g}" for c in names)
        lines += [row, row]
    path = tmp_path / "twice.csv"
    path.write_text("\n".join(lines) + "\n")
    assert main(["calibrate", "--paper", "002", str(path), "--json", str(tmp_path / "c.json")]) == 0
    json.loads((tmp_path / "c.json").read_text())


def test_rtd_table_reader_refuses_a_log(tmp_path, capsys):
    path = _csv(tmp_path / "log.csv", "time_s,temp_c,output,ref_temp_c", _ramp_rows(20))
    assert main(["diagnose-rtd", path]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "temperature_c,resistance_ohm" in err[0]


def _pt100(temps):
    """A Pt100 table at ``temps`` (IEC 60751's constants, the standard's own numbers)."""
    a, b, c = 3.9083e-3, -5.775e-7, -4.183e-12
    return [(t, 100.0 * (1 + a * t + b * t * t + (c * (t - 100.0) * t ** 3 if t < 0 else 0.0))) for t in temps]


# tables a least-squares fit returns numbers for that mean nothing: fewer distinct temperatures than
# the Callendar-Van Dusen constants (R0, A, B; C too with rows below 0 C), or a resistance that does
# not rise with temperature (a linear law of beta <= 0 reads no temperature)
_DEGENERATE_TABLES = {
    "one temperature": ([25.0] * 60, None),
    "two temperatures": ([20.0, 80.0] * 30, None),
    "three temperatures, some below 0 C": ([-30.0, 20.0, 80.0] * 20, None),
    "resistance never moves": (list(range(-20, 40)), lambda r: 110.0),
    "resistance falls": (list(range(-20, 40)), lambda r: 250.0 - r),
}


@pytest.mark.parametrize("case", sorted(_DEGENERATE_TABLES))
def test_a_table_the_laws_cannot_be_fitted_to_is_one_line(tmp_path, capsys, case):
    temps, bend = _DEGENERATE_TABLES[case]
    rows = [(t, bend(r) if bend else r) for t, r in _pt100(temps)]
    path = _csv(tmp_path / "table.csv", "temperature_c,resistance_ohm", rows)
    assert main(["diagnose-rtd", path]) == 2
    out, err = capsys.readouterr()
    err = err.strip().splitlines()
    assert len(err) == 1 and ("temperature_c" in err[0] or "resistance_ohm" in err[0]), err
    assert out == ""


@pytest.mark.parametrize("argv", [["budget", "--target", "-1deg/h"], ["budget", "--bogus"], ["simulate"],
                                  ["vectors", "--out"]])
def test_argument_errors_are_one_line(argv, capsys):
    assert main(argv) == 2   # the parser's refusal is returned as every other status
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error:" in err[0]


# ---- fuzz: logs built from the contract's grammar, then damaged ------------------------------------
_COLUMNS = ["time_s", "temp_c", "output", "ref_temp_c", "rate_dps", "freq_hz", "quad"]
_DAMAGE = ["nan", "", "inf", "-inf", "9.9e37", "-1e38", "x", "1,2", '"3"']


@st.composite
def damaged_logs(draw):
    cols = ["time_s", "temp_c", "output"] if draw(st.booleans()) else []   # often a usable log
    cols += draw(st.lists(st.sampled_from(_COLUMNS[3:]), unique=True, max_size=4))
    if not cols or draw(st.integers(0, 4)) == 0:
        cols.append(draw(st.sampled_from(_COLUMNS)))   # a missing required or a duplicated column
    n = draw(st.integers(0, 400))
    step = draw(st.sampled_from([10.0, 10.0, 1.0, 0.0, -1.0]))
    repeat = draw(st.integers(1, 2))
    lines = [",".join(cols)]
    for i in range(n):
        t = (i // repeat) * step
        temp = -20.0 + 80.0 * i / max(n, 1)
        values = {"time_s": t, "temp_c": temp, "output": 1.0 + 1e-3 * temp + 1e-4 * math.sin(i),
                  "ref_temp_c": temp + 0.1, "rate_dps": 0.0, "freq_hz": 3837.0 + 0.05 * temp, "quad": 1e-3}
        lines.append(",".join(f"{values[c]:.9g}" for c in cols))
    for _ in range(draw(st.integers(0, 5))):
        if n:
            i = draw(st.integers(1, n))
            cells = lines[i].split(",")
            cells[draw(st.integers(0, len(cells) - 1))] = draw(st.sampled_from(_DAMAGE))
            lines[i] = ",".join(cells)
    if n and draw(st.booleans()):
        lines[-1] = lines[-1][: len(lines[-1]) // 2]   # a logger stopped mid-line
    return "\n".join(lines) + "\n"


@settings(max_examples=40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(text=damaged_logs(), command=st.sampled_from(["diagnose", "calibrate"]))
def test_fuzz_damaged_logs_give_a_result_or_one_line(tmp_path_factory, text, command):
    tmp = tmp_path_factory.mktemp("log")
    path = tmp / "log.csv"
    path.write_text(text)
    out = tmp / "r.json"
    argv = ["diagnose", str(path), "--json", str(out)] if command == "diagnose" else \
        ["calibrate", "--paper", "002", str(path), "--json", str(out)]
    rc, err = run_cli(argv)
    event(f"{command} exit {rc}")
    assert rc in (0, 2)
    if rc == 2:
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
        assert not out.exists()
    else:
        json.loads(out.read_text(), parse_constant=lambda c: pytest.fail(f"{c} in the JSON"))


# ---- fuzz: numeric options given values outside their range --------------------------------------
_NUMERIC = [(["simulate", "--scenario", "ramp", "--out", "{tmp}/s.csv"], "--time-step"),
            (["simulate", "--scenario", "ramp", "--out", "{tmp}/s.csv"], "--duration-scale"),
            (["simulate", "--scenario", "ramp", "--out", "{tmp}/s.csv"], "--seed"),
            (["bench"], "--repeat"), (["bench"], "--samples"), (["bench"], "--prefix-fxpmath"),
            (["budget"], "--margin"), (["repro", "--paper", "003"], "--sweep-points"),
            (["calibrate", "--paper", "002", "{tmp}/none.csv"], "--order"),
            (["diagnose-hidden"], "--per-cause")]
_BAD_NUMBERS = ["-1", "0", "nan", "inf", "-inf", "1e400", "x", "", "1.5e-300", "-0"]


@settings(max_examples=40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=st.sampled_from(_NUMERIC), value=st.sampled_from(_BAD_NUMBERS))
def test_fuzz_bad_numbers_are_one_line(tmp_path_factory, case, value):
    """Exit 2 with one line (argparse's own errors included), or a run that accepts the value; never
    a traceback. Values a command may legitimately accept (a seed of 0) are allowed to pass."""
    tmp = tmp_path_factory.mktemp("opt")
    argv, option = case
    full = [a.format(tmp=tmp) for a in argv] + [f"{option}={value}"]
    rc, err = run_cli(full)   # argparse's own refusals (type=int) included
    assert "Traceback" not in err
    if rc != 0:
        assert rc == 2 and len(err.strip().splitlines()) == 1, (full, err)
