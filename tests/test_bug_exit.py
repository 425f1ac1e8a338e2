"""Bad input is a type; anything else is a bug.

The command line turns only :class:`fxdsp.errors.InputError` (raised by the validation of what the
user controls), an OSError and a TOML or UTF-8 decode error into one line and exit status 2. Any
other exception, such as a numpy shape error or a wrong argument type deep in the library, is a bug:
its traceback is printed and the exit status is ``fxdsp.cli.BUG`` (70), so it is never reported to
the user as their mistake. The commands are read from ``fxdsp.cli.COMMANDS``: a new command is
covered without a new test.
"""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pytest

from cli_walk import argv_for, leaves
from fxdsp import cli
from fxdsp.errors import InputError, InputTypeError


def _run(argv, capsys):
    try:
        code = cli.main(argv)
    except SystemExit as exc:   # the parser's own refusal: one line and its status
        code = exc.code
    return code, capsys.readouterr().err


def test_a_numpy_error_deep_in_a_command_is_a_bug_with_its_traceback(monkeypatch, capsys, tmp_path):
    from fxdsp.blocks.rtd import Rtd

    def broken(self, log, code):
        return np.zeros(3) + np.zeros(4)    # a shape error: numpy's ValueError, not the user's input

    monkeypatch.setattr(Rtd, "stream", broken)   # deep in every run of the RTD block
    code, err = _run(["vectors", "--out", str(tmp_path / "v")], capsys)
    assert code == cli.BUG
    assert "Traceback (most recent call last)" in err and "operands could not be broadcast" in err
    assert "internal error: a bug in fxdsp" in err


def test_bad_input_deep_in_a_command_is_one_line_and_exit_2(monkeypatch, capsys, tmp_path):
    from fxdsp.blocks.rtd import Rtd

    def refused(self, log, code):
        raise InputError("rtd.adc_format: a value the user gave")

    monkeypatch.setattr(Rtd, "stream", refused)
    code, err = _run(["vectors", "--out", str(tmp_path / "v")], capsys)
    assert code == 2
    assert err.strip() == "fxdsp vectors: error: rtd.adc_format: a value the user gave"


COMMANDS = sorted(cli.COMMANDS)
BUGS = [ValueError("operands could not be broadcast"), TypeError("unsupported operand"), KeyError("rtd"),
        IndexError("index 3 is out of bounds"), AttributeError("'NoneType' object has no attribute 'x'"),
        ZeroDivisionError("division by zero"), AssertionError("an invariant")]
INPUTS = [InputError("--frob: bad"), InputTypeError("rtd.r0: expected a number"),
          FileNotFoundError(2, "No such file or directory", "missing.csv")]


CASES = [(exc, "bug") for exc in BUGS] + [(exc, "input") for exc in INPUTS]


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("exc, kind", CASES, ids=[type(e).__name__ for e, _ in CASES])
def test_every_command_tells_a_bug_from_bad_input(monkeypatch, capsys, tmp_path, command, exc, kind):
    """Any other exception raised by a command: its traceback and the bug status; bad input: one
    line naming it and exit 2."""
    module = importlib.import_module(cli.COMMANDS[command][0])

    def run(args):
        raise exc

    monkeypatch.setattr(module, "run", run)
    monkeypatch.setattr(module, "PATHS", {}, raising=False)
    code, err = _run([command, *_required(command, tmp_path)], capsys)
    if kind == "bug":
        assert code == cli.BUG, err
        assert "Traceback (most recent call last)" in err and type(exc).__name__ in err
    else:
        assert code == 2, err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
        assert err.startswith(f"fxdsp {command}: error: ")


def _required(command: str, tmp: Path) -> list[str]:
    """The least argv that parses, read from the command's own parser (its first subcommand's)."""
    leaf = next(leaf for leaf in leaves() if leaf.words[0] == command)
    return argv_for(leaf, tmp)[1:]


NON_FINITE_SNR = (("nan", "10"), ("inf", "10"), ("1e400", "10"), ("5", "inf"))


@pytest.mark.parametrize("argv", [["diagnose-hidden", "--per-cause", "1"], ["sweep", "hidden", "--per-cause", "1"]])
@pytest.mark.parametrize("snr", [("nan", "10"), ("inf", "10"), ("1e400", "10"), ("0", "10"), (" -1", "10"), ("5", "inf"),
                                 ("10", "5")])
def test_an_snr_range_that_sizes_nothing_is_bad_input(tmp_path, capsys, argv, snr):
    """Found by a probe of the numeric options: a non-finite SNR reached numpy's draw (a traceback
    once bugs were told apart) and an SNR <= 0 drew causes too small to be in the log they label."""
    out = ["--out", str(tmp_path / "sweep")] if argv[0] == "sweep" else []
    code, err = _run([*argv, *out, "--snr", *snr], capsys)   # " -1": a negative value argparse takes
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    # nan and inf: refused by the option's type (fxdsp.commands.options); the rest by the range check
    said = "argument --snr: need a finite number" if snr in NON_FINITE_SNR else "--snr: need finite 0 < LO <= HI"
    assert said in err, err


# -- found by probing the log commands with degenerate logs ------------------------------------------
@pytest.fixture(scope="module")
def nanosecond_log(tmp_path_factory) -> Path:
    """A chamber run whose time stamps are 1 ns apart: every window of the calibrations is longer
    than the log (a plateau search once asked scipy for a filter of 10^12 samples: MemoryError)."""
    from fxdsp.sim import generate_log, write_log

    log = generate_log("paper002", {}, seed=3, duration_scale=0.2)
    log["time_s"] = np.arange(log["time_s"].size) * 1e-9
    path = tmp_path_factory.mktemp("ns") / "ns.csv"
    write_log(path, log)
    return path


@pytest.mark.parametrize("argv", [["calibrate", "--paper", "002"], ["calibrate", "--paper", "001"],
                                  ["extend", "--no-rtl", "--out", "{tmp}/ext"]])
def test_a_log_shorter_than_every_calibration_window_is_one_line(nanosecond_log, tmp_path, capsys, argv):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    code, err = _run([argv[0], str(nanosecond_log), *argv[1:]], capsys)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and err.startswith(f"fxdsp {argv[0]}: error: log: "), err


def test_a_non_finite_result_names_its_key():
    from fxdsp.outputs import json_text

    with pytest.raises(InputError, match=r"diagnose report: key 'candidates\.1\.ratio' of the result is not a "
                                         r"finite number"):
        json_text({"candidates": [{"ratio": 1.0}, {"ratio": float("inf")}]}, "diagnose report")


def test_a_log_whose_thermometer_is_flat_is_diagnosed(tmp_path, capsys):
    """An isothermal run (temp_c constant, its reference varying) once gave an infinite held-out
    ratio for the RTD curvature: nothing before and nothing after is no gain, not an infinite one."""
    import json

    from fxdsp.sim import generate_log, write_log

    log = generate_log("paper002", {}, seed=5, duration_scale=0.2)
    log["temp_c"] = np.full_like(log["temp_c"], 25.0)
    write_log(tmp_path / "flat.csv", log)
    code, err = _run(["diagnose", str(tmp_path / "flat.csv"), "--json", str(tmp_path / "r.json")], capsys)
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    assert all(np.isfinite(c["ratio"]) for c in report["candidates"] if "ratio" in c)


@pytest.mark.parametrize("text, argv, said", [
    ("stamp,box,out\n" + "".join(f"2024-01-01 00:00:{s:02d},{25 + s / 100},{s}\n" for s in range(60)),
     ["--map", "time_s=stamp", "--map", "temp_c=box", "--map", "output=out"],
     "column 'stamp' (mapped to time_s) holds no number, e.g. '2024-01-01 00:00:00': date-time stamps need "
     "--time-format"),
    ("t;box;out\n" + "".join(f"{10 * s};25,{s:02d};{s}\n" for s in range(60)),
     ["--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out"],
     "column 'box' (mapped to temp_c) holds no number, e.g. '25,00': a decimal comma"),
])
def test_a_column_of_no_numbers_is_named_with_its_likely_reason(tmp_path, capsys, text, argv, said):
    """Found by probing foreign logs: both once said only 'no usable rows'."""
    (tmp_path / "log.csv").write_text(text)
    code, err = _run(["diagnose", str(tmp_path / "log.csv"), *argv], capsys)
    assert code == 2 and said in err and len(err.strip().splitlines()) == 1, err
