"""A folder output owns only its files (fxdsp.owned): every command that writes into a folder, run
for real on a folder that holds a user's own files, among them files with the very names the command
is about to write, leaves every one of them as it was and says so in one line (exit 2).

The user's files of the command's names are put there at the moment the command goes to write each
one (a wrapper of :func:`fxdsp.owned.guard_replace`, which every write into a folder output passes:
a staged file, a staged folder's files at the move, a journal appended in place). A write that
bypassed it would add or change a file the test did not put there, and fail the test.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from cli_walk import path_options
from conftest import run_cli
from fxdsp import owned
from fxdsp.outputs import OUT_DIR

# the cheapest real run of each command that writes a folder ({out}: the folder under test, {log}: a
# chamber log, {one_chain}: a user's config of paper 000's chain alone, {tmp}: a scratch folder); a
# new command or folder option fails test_every_folder_output_is_run until it is given one here
RUNS = {
    ("demo", "--out"): "demo --out {out}",
    ("vectors", "--out"): "vectors --out {out}",
    ("hdl-gen", "--out"): "hdl-gen --out {out}",
    ("budget", "--report"): "budget --config {one_chain} --report {out}",
    ("diagnose", "--report"): "diagnose {log} --report {out}",
    ("extend", "--out"): "extend {log} --no-rtl --out {out}",
    ("formal", "--out"): "formal --only rtd --out {out}",
    ("rtl", "--out"): "rtl --only rtd --out {out}",
    ("repro", "--report"): "repro --paper 003 --sweep-points 3 --quiet --report {out}",
    ("sweep montecarlo", "--out"): "sweep montecarlo --workers 0 --seeds 2 --temps 1 --samples 64 --out {out}",
    ("sweep hidden", "--out"): "sweep hidden --workers 0 --per-cause 1 --causes none --out {out}",
    ("sweep wordlength", "--out"): "sweep wordlength --workers 0 --chain chain_paper001 --target 1deg/h --out {out}",
    ("sweep rtl", "--out"): "sweep rtl --workers 0 --shards 1 --blocks rtd --out {out} --build-dir {tmp}/build",
    # caches of built simulator models, written in place under names of their own: a user's file
    # there is kept (each run above also leaves one in its cache)
    ("rtl", "--cache"): None,
    ("sweep rtl", "--build-dir"): None,
}
NEEDS = {"formal": "yosys-smtbmc", "rtl": "iverilog", "sweep rtl": "iverilog"}


def _tree(root: Path) -> dict[str, str]:
    return {p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def test_every_folder_output_is_run():
    """Read from the parsers and the commands' PATHS: a folder option without a run here fails."""
    folders = {(leaf.name, option) for leaf, option, kind in path_options() if kind == OUT_DIR}
    assert folders == set(RUNS), f"give these a run in RUNS: {sorted(folders - set(RUNS))}"


@pytest.fixture(scope="module")
def log(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("log") / "run.csv"
    assert run_cli(["simulate", "--scenario", "paper001", "--time-step", "30", "--seed", "3", "--out", str(path)])[0] == 0
    return path


@pytest.fixture(scope="module")
def one_chain(tmp_path_factory) -> Path:
    """The default config cut down to paper 000's chain and its blocks (a budget of every chain of
    the default config and its 33 plots took 25 s)."""
    import tomllib

    from fxdsp.config import default_config_text, dumps

    data = tomllib.loads(default_config_text())
    chain = data["chain"]["paper000"]
    blocks = {inst.split(".")[0] for inst in chain["instances"]}
    data = {k: v for k, v in data.items() if k in blocks | {"stimulus", "system"}}
    data["chain"] = {"paper000": chain}
    data["piecewise"] = {k: v for k, v in data["piecewise"].items()
                         if not isinstance(v, dict) or f"piecewise.{k}" in chain["instances"]}
    path = tmp_path_factory.mktemp("cfg") / "paper000.toml"
    path.write_text(dumps(data, "# paper 000's chain alone"))
    return path


CASES = [k for k, v in RUNS.items() if v is not None]


@pytest.mark.parametrize("command, option", CASES, ids=[f"{c} {o}" for c, o in CASES])
def test_a_users_files_in_a_folder_output_survive_the_command(tmp_path, log, one_chain, monkeypatch, command, option):
    import shutil

    if command in NEEDS and shutil.which(NEEDS[command]) is None:
        pytest.skip(f"{NEEDS[command]} is not installed")
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("the user's notes\n")
    (out / "sub").mkdir()
    (out / "sub" / "data.csv").write_text("t,x\n0,1\n")
    (tmp_path / "cache").mkdir()
    (tmp_path / "cache" / "notes.txt").write_text("kept\n")
    (tmp_path / "build").mkdir()
    (tmp_path / "build" / "notes.txt").write_text("kept\n")
    planted = {}
    real = owned.guard_replace

    def plant_then_guard(final):
        path = Path(final).resolve()
        if path.is_relative_to(out.resolve()) and not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(f"the user's own {path.name}\n")
            planted[path.relative_to(out.resolve()).as_posix()] = path.read_text()
        return real(final)

    monkeypatch.setattr(owned, "guard_replace", plant_then_guard)
    argv = RUNS[(command, option)].format(out=out, log=log, one_chain=one_chain, tmp=tmp_path).split()
    code, err = run_cli(argv)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "was not written by fxdsp" in err, (argv, code, err)
    assert planted, "the command wrote nothing into its folder"
    expected = {"notes.txt": hashlib.sha256(b"the user's notes\n").hexdigest(),
                "sub/data.csv": hashlib.sha256(b"t,x\n0,1\n").hexdigest(),
                **{rel: hashlib.sha256(text.encode()).hexdigest() for rel, text in planted.items()}}
    assert _tree(out) == expected, "a file the user did not put there was written, or one of theirs changed"
    assert not list(tmp_path.rglob(".fxdsp-staging-*"))
    for cache in ("cache", "build"):
        assert (tmp_path / cache / "notes.txt").read_text() == "kept\n"


def test_a_file_changed_since_fxdsp_wrote_it_is_not_replaced(tmp_path):
    out = tmp_path / "gen"
    assert run_cli(["hdl-gen", "--out", str(out)])[0] == 0
    record = (out / owned.RECORD).read_text()
    assert "rtd_params.vh" in record
    edited = (out / "rtd_params.vh").read_text() + "// my edit\n"
    (out / "rtd_params.vh").write_text(edited)
    code, err = run_cli(["hdl-gen", "--out", str(out)])
    assert code == 2 and "rtd_params.vh was changed since fxdsp wrote it" in err, err
    assert (out / "rtd_params.vh").read_text() == edited and (out / owned.RECORD).read_text() == record
    (out / "rtd_params.vh").unlink()   # the user lets it go: written again
    assert run_cli(["hdl-gen", "--out", str(out)])[0] == 0 and (out / owned.RECORD).read_text() == record


def test_a_journal_of_that_name_that_fxdsp_did_not_write_is_kept(tmp_path):
    """A sweep appends its journal in place: a user's file of that name is refused, even with --fresh."""
    out = tmp_path / "s"
    out.mkdir()
    (out / "journal.jsonl").write_text('{"fxdsp_sweep_journal": 1}\n')
    argv = ["sweep", "hidden", "--workers", "0", "--per-cause", "1", "--causes", "none", "--out", str(out), "--fresh"]
    code, err = run_cli(argv)
    assert code == 2 and "journal.jsonl was not written by fxdsp" in err, err
    assert (out / "journal.jsonl").read_text() == '{"fxdsp_sweep_journal": 1}\n'


def test_the_committed_folders_are_recorded_as_fxdsps():
    """The repository's generated folders carry their record, so `fxdsp vectors`, `hdl-gen` and
    `repro --report docs` replace their own files there (and docs/log-format.md, written by hand,
    is not listed)."""
    repo = Path(__file__).resolve().parents[1]
    for folder in ("vectors", "hdl/gen", "docs"):
        entries = owned.read_record(repo / folder)
        assert entries, folder
        for rel, digest in entries.items():
            assert owned.file_sha256(repo / folder / rel) == digest, f"{folder}/{rel} differs from its record"
    assert "log-format.md" not in owned.read_record(repo / "docs")
    assert {p.relative_to(repo / "vectors").as_posix() for p in (repo / "vectors").rglob("*") if p.is_file()} \
        - {owned.RECORD} == set(owned.read_record(repo / "vectors"))
