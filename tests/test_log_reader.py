"""One log reader (the contract's, shared/spec/measured-data.md section 1) for every command that
reads a log: duplicate column names and a flat output are refused by name, non-finite rows are
dropped and counted, never passed on as NaN. The logs here are written as text from the contract,
not with fxdsp's own writer."""

from __future__ import annotations

import json
import math

import pytest

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
