"""Nothing lost: outputs checked before any work, written aside and moved into place together; an
interrupt or a late error leaves the previous outputs whole and no partial ones.

Every check here is also run with ``FXDSP_UNSAFE_DIRECT_WRITES=1`` (writes straight into the targets)
and must then fail: that is how the tests show they can catch the loss they guard against.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import signal
import subprocess
import sys
import re
import time
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cli_walk import argv_for, path_options
from conftest import failing_writes, run_cli
from fxdsp.cli import COMMANDS, main
from fxdsp.errors import InputError
from fxdsp.outputs import DIRECT_ENV
from fxdsp.sim import generate_log, write_log

REPO = Path(__file__).resolve().parents[1]


def snapshot(root: Path) -> dict[str, str]:
    """Every file and folder under ``root``: relative path -> sha256 (folders: 'dir')."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root).as_posix()
        out[rel] = "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def record_as_written(folder: Path, names=None) -> None:
    """List files of ``folder`` (default: every file but the record) in its ownership record, with
    their present content: as if fxdsp had written them there."""
    from fxdsp.owned import RECORD, file_sha256, read_record, record_text

    files = [p for p in folder.rglob("*") if p.is_file() and p.name != RECORD] if names is None else \
        [folder / n for n in names]
    entries = read_record(folder) | {p.relative_to(folder).as_posix(): file_sha256(p) for p in files}
    (folder / RECORD).write_text(record_text(entries))


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


@pytest.fixture(scope="module")
def log(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("log") / "run.csv"
    write_log(path, generate_log("paper001", effects={}, seed=3, duration_scale=0.05))
    return path


# ---- bad paths: refused before any work, one line, nothing touched -------------------------------
def _probes(tmp: Path, log: Path) -> list[tuple[list[str], str]]:
    afile, adir = tmp / "a_file.txt", tmp / "a_dir"
    return [
        (["vectors", "--out", str(afile)], "--out"),
        (["demo", "--out", str(afile)], "--out"),
        (["hdl-gen", "--out", str(afile)], "--out"),
        (["hdl-gen", "--out", str(tmp / "missing" / "gen")], "--out"),
        (["budget", "--report", str(afile)], "--report"),
        (["budget", "--json", str(adir)], "--json"),
        (["budget", "--json", str(afile / "x.json")], "--json"),
        (["budget", "--json", str(tmp / "same.json"), "--report", str(tmp / "r"), "--config-out",
          str(tmp / "same.json"), "--optimise", "--target", "40deg/h"], "--config-out"),
        (["diagnose", str(log), "--report", str(tmp / "rep"), "--model-out", str(tmp / "nodir" / "m.json")],
         "--model-out"),
        (["diagnose", str(log), "--json", str(log)], "--json"),
        (["calibrate", "--paper", "001", str(log), "--config-out", str(log)], "--config-out"),
        (["calibrate", "--paper", "001", str(log), "--json", str(adir)], "--json"),
        (["simulate", "--scenario", "ramp", "--out", str(adir)], "--out"),
        (["simulate", "--scenario", "ramp", "--model", str(adir), "--out", str(tmp / "x.csv")], "--model"),
        (["bench", "--json", str(adir)], "--json"),
        (["hw-report", "--out", str(adir)], "--out"),
        (["repro", "--report", str(afile)], "--report"),
        (["diagnose-rtd", str(adir)], "table"),
        (["vectors", "--config", str(afile), "--out", str(afile)], "--out"),
        (["budget", "--json", str(afile) + "/."], "--json"),             # pathlib would read it as a_file.txt
        (["sweep", "montecarlo", "--out", str(afile)], "--out"),
        (["sweep", "hidden", "--out", str(tmp / "missing" / "s")], "--out"),
        (["sweep", "wordlength", "--target", "1deg/h", "--config", str(adir), "--out", str(tmp / "s")], "--config"),
        (["sweep", "rtl", "--rtl", str(afile), "--out", str(tmp / "s")], "--rtl"),
        (["sweep", "rtl", "--build-dir", str(afile), "--out", str(tmp / "s")], "--build-dir"),
        (["diagnose", str(log), "--model-out", str(adir) + "/"], "--model-out"),
    ]


def test_bad_output_paths_refused_before_any_work(tmp_path, log, capsys, monkeypatch):
    (tmp_path / "a_file.txt").write_text("keep me\n")
    (tmp_path / "a_dir").mkdir()
    (tmp_path / "a_dir" / "inside.txt").write_text("keep me too\n")
    before = snapshot(tmp_path)

    def work_started(args):
        raise AssertionError(f"{args.command}: the work started before its paths were refused")

    for argv, option in _probes(tmp_path, log):
        # the command's own work must never begin: refused by the path check alone
        monkeypatch.setattr(importlib.import_module(COMMANDS[argv[0]][0]), "run", work_started)
        assert main(argv) == 2, argv
        assert option in one_line_error(capsys), argv
        assert snapshot(tmp_path) == before, f"{argv} touched the tree"


# ---- a late failure: staged outputs dropped, previous ones whole ----------------------------------
def _interrupted_vectors(tmp_path, monkeypatch, capsys, exc) -> tuple[int, dict, dict]:
    """A previous vector set that differs from the new one in every file (or a mix could not be
    seen), then ``fxdsp vectors`` again with ``exc`` raised at its 20th file write: (status, tree
    before, tree after)."""
    out = tmp_path / "v"
    assert main(["vectors", "--out", str(out)]) == 0
    (out / "manifest.json").write_text((out / "manifest.json").read_text().replace('"seed"', '"seed_old"'))
    for p in out.rglob("*.hex"):
        p.write_text("0\n")
    record_as_written(out)   # as another version of fxdsp would have written them
    before = snapshot(out)
    capsys.readouterr()
    with failing_writes(20, exc):
        status = main(["vectors", "--out", str(out)])
    return status, before, snapshot(out)


@pytest.mark.parametrize("exc, status", [(KeyboardInterrupt, 130), (OSError, 2)])
def test_vectors_interrupted_mid_write_leave_the_previous_set(tmp_path, monkeypatch, capsys, exc, status):
    got, before, after = _interrupted_vectors(tmp_path, monkeypatch, capsys, exc)
    assert got == status
    one_line_error(capsys)
    assert after == before
    assert not list(tmp_path.glob(".fxdsp-staging-*")), "the staging folder is removed"


def test_direct_writes_would_be_caught(tmp_path, monkeypatch, capsys):
    """The same injected interrupt with the staging switched off leaves a mix: the check above fails."""
    monkeypatch.setenv(DIRECT_ENV, "1")
    got, before, after = _interrupted_vectors(tmp_path, monkeypatch, capsys, KeyboardInterrupt)
    assert got == 130 and after != before


def test_diagnose_late_failure_writes_no_report(tmp_path, log, monkeypatch, capsys):
    """The model is written last; if it fails, the report and JSON written before it are dropped too."""
    import fxdsp.diagnose.report as report

    calls = {"n": 0}
    original = report.write_json

    def failing(path, data):
        calls["n"] += 1
        if calls["n"] == 2:  # the --model-out write
            raise OSError(28, "No space left on device", str(path))
        return original(path, data)

    monkeypatch.setattr(report, "write_json", failing)
    rc = main(["diagnose", str(log), "--json", str(tmp_path / "d.json"), "--report", str(tmp_path / "rep"),
               "--model-out", str(tmp_path / "m.json")])
    assert rc == 2 and "No space left" in one_line_error(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


# ---- a real Ctrl-C: one line, exit 130, the previous log whole or the new one complete ------------
def test_simulate_sigint_keeps_the_previous_log(tmp_path):
    # a 46 MB log (generation, formatting, writing) interrupted at three points; at least one of
    # them must really interrupt it, or the test would pass without exercising Ctrl-C at all
    codes = []
    for k, delay in enumerate((0.5, 1.0, 1.4)):
        out = tmp_path / f"run{k}" / "log.csv"
        out.parent.mkdir()
        out.write_text("previous log\n")
        env = {**os.environ, "PYTHONPATH": str(REPO)}
        # SIGINT handled here while the child starts, so that the child does not inherit it ignored:
        # pytest started as a background job of a shell without job control (`make test &`, some CI
        # runners) ignores SIGINT, and so would every child, which then always ran to the end
        previous = signal.signal(signal.SIGINT, signal.default_int_handler)
        try:
            proc = subprocess.Popen([sys.executable, "-m", "fxdsp.cli", "simulate", "--scenario", "paper002",
                                     "--time-step", "0.1", "--out", str(out)], stderr=subprocess.PIPE,
                                    stdout=subprocess.PIPE, text=True, env=env)
        finally:
            signal.signal(signal.SIGINT, previous)
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
        # -SIGINT: the signal landed during the interpreter's start-up, before Python's own handler
        # (a loaded machine): nothing written yet, the previous log must still be there
        assert proc.returncode in (0, 130, -signal.SIGINT), err
        codes.append(proc.returncode)
        lines = err.strip().splitlines()
        assert "Traceback" not in err and len(lines) <= 1, err
        text = out.read_text()
        if proc.returncode != 0:
            assert text == "previous log\n"
        else:  # finished before the signal: a complete log
            assert text.splitlines()[-1].count(",") == text.splitlines()[-2].count(",")
        assert not list(out.parent.glob(".fxdsp-staging-*"))
    assert 130 in codes, f"no run was interrupted (exit codes {codes})"


# ---- fuzz: colliding and malformed paths on the fast commands -------------------------------------
KINDS = ("new", "existing_file", "existing_dir", "under_file", "missing_parent", "same_as_config")


def _path(tmp: Path, kind: str, name: str) -> Path:
    return {"new": tmp / name, "existing_file": tmp / "file.txt", "existing_dir": tmp / "dir",
            "under_file": tmp / "file.txt" / name, "missing_parent": tmp / "nope" / name,
            "same_as_config": tmp / "cfg.toml"}[kind]


@settings(max_examples=30, deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(command=st.sampled_from(["hdl-gen", "vectors", "hdl-gen --check", "vectors --check"]),
       kind=st.sampled_from(KINDS), second=st.sampled_from(["", "--config-is-out"]),
       fail_at=st.one_of(st.none(), st.integers(1, 45)), fail=st.sampled_from([KeyboardInterrupt, OSError]))
def test_fuzz_paths_exit_0_or_2_and_outputs_whole_or_untouched(tmp_path_factory, command, kind, second, fail_at,
                                                               fail):
    """Bad, colliding and good paths, with a Ctrl-C or a disk error injected at the fail_at-th file
    write: exit 0 (complete, valid outputs), 1 (a --check difference), 2 or 130 (one line, the tree
    exactly as before)."""
    tmp = tmp_path_factory.mktemp("fuzz")
    from fxdsp.config import default_config_text

    (tmp / "cfg.toml").write_text(default_config_text())
    (tmp / "file.txt").write_text("keep\n")
    (tmp / "dir").mkdir()
    target = _path(tmp, kind, "out")
    name, *flags = command.split()
    config = target if second else tmp / "cfg.toml"
    argv = [name, "--config", str(config), "--out", str(target), *flags]
    before = snapshot(tmp)
    with failing_writes(fail_at, fail):
        rc, err = run_cli(argv)
    assert rc in (0, 1, 2, 130), err
    assert "Traceback" not in err
    if rc in (2, 130):
        assert len(err.strip().splitlines()) == 1, err
        assert snapshot(tmp) == before
    elif rc == 0 and not flags:
        assert run_cli([name, "--config", str(config), "--out", str(target), "--check"])[0] == 0  # complete
    assert not list(tmp.rglob(".fxdsp-staging-*"))


def test_simulate_disk_full_mid_write_keeps_the_previous_log(tmp_path, capsys):
    """A full disk after the file was opened (truncated) and partly written: the previous log stays."""
    out = tmp_path / "log.csv"
    out.write_text("previous log\n")

    def disk_full(self, data, *a, **kw):
        with open(self, "w", encoding="utf-8") as f:   # opening truncates, as a real write does
            f.write(data[: len(data) // 2])
        raise OSError(28, "No space left on device", str(self))

    with mock.patch.object(Path, "write_text", disk_full):
        assert main(["simulate", "--scenario", "ramp", "--out", str(out)]) == 2
    line = one_line_error(capsys)
    assert "No space left" in line and line.endswith(str(out))   # the target is named, not its staging copy
    assert out.read_text() == "previous log\n"
    assert not list(tmp_path.glob(".fxdsp-staging-*"))


def test_written_files_hold_no_folder_or_clock(tmp_path, capsys):
    """Same inputs -> same bytes wherever the files lie: no absolute path, time or host is written."""
    from fxdsp.config import default_config_text

    cfg = tmp_path / "my.toml"
    cfg.write_text(default_config_text())
    texts = []
    for run in ("a", "b"):
        out = tmp_path / run
        out.mkdir()
        assert main(["vectors", "--config", str(cfg), "--out", str(out / "v")]) == 0
        assert main(["budget", "--config", str(cfg), "--json", str(out / "b.json")]) == 0
        texts.append(((out / "v" / "manifest.json").read_text(), (out / "b.json").read_text()))
    capsys.readouterr()
    assert texts[0] == texts[1]
    for text in texts[0]:
        assert str(tmp_path) not in text and "my.toml" in text


def test_a_generated_set_is_replaced_as_a_whole(tmp_path, capsys):
    """A file of the previous set that the new one does not produce is removed with the move, so the
    folder holds exactly the new set (``--check`` clean); files of other kinds are left alone."""
    out = tmp_path / "gen"
    assert main(["hdl-gen", "--out", str(out)]) == 0
    (out / "old_block_table.hex").write_text("0\n")   # e.g. a ROM of an NCO design since replaced
    record_as_written(out, ["old_block_table.hex"])
    (out / "notes.txt").write_text("mine\n")
    (out / "users_table.hex").write_text("1\n")      # the user's, of the set's kind: kept
    assert main(["hdl-gen", "--out", str(out), "--check"]) == 1
    assert main(["hdl-gen", "--out", str(out)]) == 0
    assert not (out / "old_block_table.hex").exists() and (out / "notes.txt").read_text() == "mine\n"
    assert (out / "users_table.hex").read_text() == "1\n"
    capsys.readouterr()
    assert main(["hdl-gen", "--out", str(out), "--check"]) == 1   # the check still names it
    assert "unexpected: users_table.hex" in capsys.readouterr().err
    (out / "users_table.hex").unlink()
    assert main(["hdl-gen", "--out", str(out), "--check"]) == 0
    capsys.readouterr()


def test_a_vector_set_removes_only_what_its_manifest_listed(tmp_path, capsys):
    import json as _json

    out = tmp_path / "v"
    assert main(["vectors", "--out", str(out)]) == 0
    manifest = _json.loads((out / "manifest.json").read_text())
    manifest["blocks"]["gone"] = {"inputs": {"x": {"file": "gone/x.hex"}}, "outputs": {}}
    (out / "manifest.json").write_text(_json.dumps(manifest))
    (out / "gone").mkdir()
    (out / "gone" / "x.hex").write_text("0\n")          # listed by the previous manifest: removed
    record_as_written(out, ["manifest.json", "gone/x.hex"])
    (out / "stray.hex").write_text("0\n")               # not listed: someone else's, kept
    assert main(["vectors", "--out", str(out)]) == 0
    assert not (out / "gone" / "x.hex").exists() and (out / "stray.hex").exists()
    capsys.readouterr()


# ---- every path option of every command, from the parsers: an empty or blank value --------------
@pytest.mark.parametrize("value", ["", "   "])
def test_an_empty_path_is_refused_by_every_option_of_every_command(tmp_path, monkeypatch, capsys, value):
    """Generated from the parsers (a new command or path option is covered without a new probe):
    an empty or blank path is one line naming the option, exit 2, before any work, nothing written
    (pathlib reads "" as ".": unchecked, `--out ''` wrote the vectors into the current folder)."""
    cases = path_options()
    assert len({leaf.words for leaf, _, _ in cases}) >= 12 and any(kind == "out-dir" for _, _, kind in cases)
    monkeypatch.chdir(tmp_path)
    for leaf, option, kind in cases:
        module = leaf.module
        work = tmp_path / "_".join([*leaf.words, option.strip("-")])
        work.mkdir()
        argv = argv_for(leaf, work, {option: [value]})
        before = snapshot(tmp_path)

        def work_started(args, argv=argv):
            raise AssertionError(f"{argv}: the work started with an empty path")

        monkeypatch.setattr(module, "run", work_started)
        assert main(argv) == 2, argv
        err = one_line_error(capsys)
        assert option in err and "empty path" in err, (argv, err)
        assert snapshot(tmp_path) == before, argv


def test_an_input_that_is_not_text_is_named_by_every_input_option(tmp_path, monkeypatch, capsys):
    """Every input file option of every command (from the parsers) reads UTF-8 text: a
    gzip-compressed file, a binary one, one in Latin-1 and one in UTF-16 are each one line naming the
    option and the file, exit 2, before any work (a reader's UnicodeDecodeError named neither)."""
    import gzip

    bad = {"gzip-compressed": gzip.compress(b"t_s,temp_c\n0,25\n" * 50),
           "binary": b"t_s,temp_c\n" + bytes(range(256)),
           "not UTF-8": "t_s,temp_c\n0,25 \u00b0C\n".encode("latin-1"),
           "UTF-16": "t_s,temp_c\n0,25\n".encode("utf-16")}
    cases = [(leaf, option) for leaf, option, kind in path_options() if kind == "in"]
    assert len({option for _, option in cases}) >= 5
    for leaf, option in cases:
        module = leaf.module
        for what, data in bad.items():
            work = tmp_path / "_".join([*leaf.words, option.strip("-"), what.replace(" ", "_")])
            work.mkdir()
            path = work / "input.file"
            path.write_bytes(data)
            argv = argv_for(leaf, work, {option: [str(path)]})

            def work_started(args, argv=argv):
                raise AssertionError(f"{argv}: the work started on a file that is not text")

            monkeypatch.setattr(module, "run", work_started)
            assert main(argv) == 2, argv
            err = one_line_error(capsys)
            assert option in err and str(path) in err and what in err, (argv, err)


# -- non-finite numbers are never written ------------------------------------------------------------
NON_FINITE_FILES = {
    "log.csv": ("# a comment\ntime_s,temp_c,output\n0,25,1.5\n10,25.1,{v}\n", "column 'output' at line 4"),
    "report.json": ('{{"gain": {{"ratio": {v}}}, "rows": 3}}\n', "key 'gain.ratio'"),
    "cal.toml": ("[piecewise.sf]\ncoefficients = [[1.0, {v}]]\n", "key 'piecewise.sf.coefficients.0.1'"),
}


@pytest.mark.parametrize("name", sorted(NON_FINITE_FILES))
@pytest.mark.parametrize("token", ["nan", "inf", "-inf", "NaN", "Infinity", "-Infinity"])
def test_a_non_finite_number_in_a_numeric_output_is_refused_and_nothing_moves(tmp_path, name, token):
    from fxdsp.outputs import staged

    template, where = NON_FINITE_FILES[name]
    if name.endswith(".json") and token.lower() in ("inf", "-inf", "nan") and token != "NaN":
        token = {"inf": "Infinity", "-inf": "-Infinity", "nan": "NaN"}[token]   # JSON's spellings
    if name.endswith(".toml"):
        token = token.lower().replace("infinity", "inf")                       # TOML's spellings
    target, other = tmp_path / name, tmp_path / "other.txt"
    target.write_text("previous\n")
    with pytest.raises(InputError, match=f"{re.escape(str(target))}: {re.escape(where)} is not a finite number"):
        with staged() as stage:
            stage.write_text(other, "a file written beside it\n")
            stage.write_text(target, template.format(v=token))
    assert target.read_text() == "previous\n" and not other.exists()


@pytest.mark.parametrize("name", sorted(NON_FINITE_FILES))
def test_finite_numbers_and_words_that_only_look_alike_pass(tmp_path, name):
    from fxdsp.outputs import staged

    template, _ = NON_FINITE_FILES[name]
    with staged() as stage:
        stage.write_text(tmp_path / name, template.format(v="1e300"))
        stage.write_text(tmp_path / "notes.md", "| ratio | nan |\n")   # Markdown is read, not parsed
    assert (tmp_path / name).exists()


def test_a_simulation_that_overflows_is_one_line_and_no_log(tmp_path, capsys):
    out = tmp_path / "run.csv"
    code = main(["simulate", "--scenario", "paper002", "--effect", "warmup.a=1e308", "--effect", "warmup.tau_s=1",
                 "--effect", "aging_drift=1e308", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert err.strip().splitlines() == [f"fxdsp simulate: error: {out}: column 'output' at line 7 is not a finite "
                                        "number (nan or inf); nothing written"]


# -- a folder output owns only its files --------------------------------------------------------------
# Every deletion the package makes outside fxdsp/outputs.py (whose Stage removes only the files a set's
# own manifest listed), each reviewed: it deletes only a folder the code itself named and made.
DELETIONS = {
    # the Verilator model cache: an incomplete model or run-time folder named by its content digest
    "fxdsp/hdl/simulators.py": 4,
    # `fxdsp rtl`'s work folders <dut>_<stream> and <dut>_cocotb (its cocotb streams' one run), inside
    # the run's own work folder
    "fxdsp/hdl/regression.py": 1,
    # `sweep rtl`: a shard's own folder shard_NNNN/<block> under --build-dir, or its temporary root
    "fxdsp/sweep/rtl.py": 2,
}
_DELETE = re.compile(r"rmtree\(|\.unlink\(|os\.remove\(|os\.unlink\(|\.rmdir\(")


def test_no_module_deletes_a_file_it_did_not_name_and_make():
    """A new deletion anywhere in the package fails here until it is reviewed and listed: a command
    writing into a folder must never remove a file it did not write (a user's file beside its outputs)."""
    package = REPO / "fxdsp"
    found = {}
    for path in sorted(package.rglob("*.py")):
        rel = str(path.relative_to(REPO))
        if rel == "fxdsp/outputs.py":
            continue
        n = len(_DELETE.findall(path.read_text(encoding="utf-8")))
        if n:
            found[rel] = n
    assert found == DELETIONS


def test_a_folder_output_keeps_a_users_file_and_replaces_its_own(tmp_path):
    from fxdsp.outputs import staged

    out = tmp_path / "out"
    out.mkdir()
    (out / "mine.txt").write_text("the user's\n")
    (out / "report.md").write_text("an old report\n")
    with staged() as stage:
        folder = stage.dir(out)
        (folder / "report.md").write_text("the new report\n")
        (folder / "plots").mkdir()
        (folder / "plots" / "a.png").write_bytes(b"png")
    assert (out / "mine.txt").read_text() == "the user's\n"
    assert (out / "report.md").read_text() == "the new report\n" and (out / "plots" / "a.png").exists()
