"""The command line: every runnable entry point is a registered `fxdsp` command that loads, only
the command being run is imported, and the commands run end to end (functional checks; speed is
not asserted)."""

from __future__ import annotations

import importlib
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import fxdsp
from fxdsp import cli
from fxdsp.cli import COMMANDS, build_parser, main
from fxdsp.chains import build


def test_demo_prints_every_block(tmp_path: Path, capsys):
    assert main(["demo", "--out", str(tmp_path / "v")]) == 0
    out = capsys.readouterr().out
    for name in build().all:
        assert f"\n{name}." in out
    assert (tmp_path / "v" / "manifest.json").exists()
    assert "RTD readout vs true temperature" in out


def test_bench_reports_ratios_and_agreement(tmp_path: Path, capsys):
    out = tmp_path / "bench.json"
    assert main(["bench", "--samples", "200000", "--repeat", "1", "--prefix-apytypes", "400",
                 "--prefix-fxpmath", "40", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    for lib in ("apytypes", "fxpmath"):
        assert res[lib]["bit_identical_samples"] == res[lib]["prefix_samples"]
        assert res[lib]["ratio_fxdsp_over_lib"] > 0
    assert res["biquad"]["samples_per_s"] > 0
    assert set(res["chains"]) == set(build().chains)   # every chain of the config is timed
    assert all(c["samples_per_s"] > 0 for c in res["chains"].values())
    # every drive loop of the config closed on its resonator, and the resonator alone
    assert set(res["drive"]) == {n for n, b in build().blocks.items() if type(b).__name__ == "Drive"} != set()
    assert all(r[k] > 0 for r in res["drive"].values() for k in ("fixed_samples_per_s", "float_samples_per_s",
                                                                   "resonator_samples_per_s"))


def test_bench_rejects_small_sample_counts(capsys):
    assert main(["bench", "--samples", "1000"]) == 2
    assert "200000" in capsys.readouterr().err


def test_every_registered_command_loads():
    build_parser()  # imports and configures every command module; any import error propagates
    for name, (module_name, _) in COMMANDS.items():
        module = importlib.import_module(module_name)
        assert callable(module.configure) and callable(module.run), name


def test_a_command_whose_module_fails_to_import_is_an_error(monkeypatch):
    monkeypatch.setitem(cli.COMMANDS, "broken", ("fxdsp.no_such_module", "a command still being built"))
    with pytest.raises(ModuleNotFoundError, match="fxdsp.no_such_module"):
        main(["broken"])
    with pytest.raises(ModuleNotFoundError):
        build_parser()


def test_only_the_command_being_run_is_imported():
    code = ("import sys; from fxdsp.cli import main\n"
            "try:\n    main(['diagnose', '--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.startswith('fxdsp.') or m == 'numba'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    loaded = out.strip().splitlines()[-1]
    assert "fxdsp.commands.diagnose" in loaded
    assert "numba" not in loaded and "fxdsp.commands.demo" not in loaded and "fxdsp.chains" not in loaded


def test_no_module_has_an_entry_point_of_its_own():
    # every runnable job is an `fxdsp` sub-command: no private argparse main, no __main__ block
    package = Path(fxdsp.__file__).parent
    for path in package.rglob("*.py"):
        if path == package / "cli.py":
            continue
        text = path.read_text(encoding="utf-8")
        assert not re.search(r"__name__\s*==\s*['\"]__main__['\"]|ArgumentParser\(", text), path


def test_diagnose_rtd_names_the_curvature_of_a_callendar_van_dusen_table(tmp_path: Path, capsys):
    from fxdsp.diagnose.rtd import IEC60751, cvd_law

    t = np.arange(-50.0, 151.0)
    table = tmp_path / "pt100.csv"
    table.write_text("temperature_c,resistance_ohm\n" +
                     "".join(f"{a:g},{r:.4f}\n" for a, r in zip(t, cvd_law(**IEC60751).resistance(t))))
    assert main(["diagnose-rtd", str(table)]) == 0
    out = capsys.readouterr().out
    assert all(re.search(rf"^{key} +max \|error\|", out, re.M) for key in ("linear", "cvd_fit", "cvd_iec60751"))
    assert "rtd_nonlinearity" in out.splitlines()[-1]
    assert main(["diagnose-rtd", str(table), "--range", "0", "2"]) == 2
    assert "--range" in capsys.readouterr().err


def test_diagnose_hidden_prints_the_confusion_matrix(capsys):
    assert main(["diagnose-hidden", "--per-cause", "1", "--causes", "none,hysteresis"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("truth / found") and "2 cases in" in out
    assert re.search(r"^hysteresis +\d", out, re.M)
    assert main(["diagnose-hidden", "--per-cause", "1", "--causes", "no_such_cause"]) == 2
    assert "no_such_cause" in capsys.readouterr().err


def test_diagnose_bench_times_a_log(capsys):
    assert main(["diagnose-bench", "--rows", "500"]) == 0
    assert re.search(r"^ +\d+ rows: +[\d.]+ s  -> thermal_lag", capsys.readouterr().out, re.M)
    assert main(["diagnose-bench", "--rows", "10"]) == 2


@pytest.mark.parametrize("given, want", [(None, "1"), ("3", "3")])
def test_the_command_line_runs_one_blas_thread_unless_told(given, want):
    """fxdsp.threads: the command line sets OPENBLAS_NUM_THREADS=1 before numpy loads (a report's bytes
    do not depend on the core count), and an explicit setting wins. In a fresh interpreter: this
    one's numpy is loaded already, with the suite's setting."""
    import os

    from fxdsp.threads import VARIABLE

    env = {k: v for k, v in os.environ.items() if k != VARIABLE}
    if given is not None:
        env[VARIABLE] = given
    probe = ("import os, sys, fxdsp.cli; print('numpy' in sys.modules, os.environ.get(%r))" % VARIABLE)
    out = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", want]
