"""Every command and every option, from the parsers (tests/cli_walk.py), probed with values of the
classes bad input comes in: numbers outside the option's domain (nan, inf, 1e400, negative counts,
text) and paths that are no usable path (empty, NUL, a folder for a file, a file for a folder, a
missing or file parent, an input reused as an output, an input that a folder output owns).

Each probe must end in exit 2 with one line naming the option, before the command's work starts (its
``run`` is replaced by one that records what it was given), nothing on disk changed; a value that is
accepted must reach the command inside the option's declared domain. A new command or option is
probed without anyone writing a probe for it.
"""

from __future__ import annotations

import argparse
import hashlib
import math
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cli_walk import argv_for, flag, leaves, only_with, path_options
from conftest import run_cli
from fxdsp.commands.options import Number
from fxdsp.outputs import IN, IN_DIR, OUT_DIR, OUT_FILE

LEAVES = leaves()
NUMERIC = [(leaf, a) for leaf in LEAVES for a in leaf.options() if isinstance(a.type, Number)]
PATHS = path_options()


def test_the_walk_sees_every_command():
    from fxdsp.cli import COMMANDS

    assert {leaf.words[0] for leaf in LEAVES} == set(COMMANDS)
    assert len(NUMERIC) >= 30 and len(PATHS) >= 35


def test_no_option_takes_a_bare_int_or_float():
    """``float`` takes nan and inf, ``int`` any negative: each numeric option declares its domain
    (fxdsp.commands.options), so that no command can be handed a number it never meant to take."""
    bare = [f"{leaf.name} {flag(a)}" for leaf in LEAVES for a in leaf.options() if a.type in (int, float)]
    assert not bare, f"declare a domain (fxdsp.commands.options) for: {bare}"


def _snapshot(root: Path) -> dict[str, str]:
    return {p.relative_to(root).as_posix(): ("dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest())
            for p in sorted(root.rglob("*"))}


def _probe(monkeypatch, leaf, argv, tmp: Path):
    """(exit status, stderr, the args the command was given or None): ``run`` replaced."""
    given_args = []
    monkeypatch.setattr(leaf.module, "run", lambda args: given_args.append(args) or 0)
    before = _snapshot(tmp)
    code, err = run_cli(argv)
    assert "Traceback" not in err, (argv, err)
    if code != 0:
        assert code == 2 and len(err.strip().splitlines()) == 1 and not given_args, (argv, code, err)
        assert _snapshot(tmp) == before, argv
    return code, err, (given_args[0] if given_args else None)


# ---- numbers -----------------------------------------------------------------------------------------
NOT_NUMBERS = ["nan", "NaN", "inf", "-inf", "Infinity", "1e400", "-1e400", "", " ", "abc", "1,5", "0x10", "--", "1e"]
_numbers = st.one_of(st.sampled_from(NOT_NUMBERS),
                     st.integers(-10**30, 10**30).map(str),
                     st.floats(allow_nan=True, allow_infinity=True).map(repr),
                     st.integers(-5, 300_000).map(str))


def _in_domain(value, dom: Number) -> bool:
    """The declaration read independently of its parser: kind, finite, lo .. hi."""
    if dom.kind is int and (isinstance(value, bool) or not isinstance(value, int)):
        return False
    if dom.kind is float and not (isinstance(value, float) and math.isfinite(value)):
        return False
    if dom.lo is not None and (value <= dom.lo if dom.lo_open else value < dom.lo):
        return False
    return dom.hi is None or value <= dom.hi


@pytest.mark.parametrize("leaf, action", NUMERIC, ids=[f"{leaf.name} {flag(a)}" for leaf, a in NUMERIC])
@settings(max_examples=25, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=_numbers)
def test_a_number_outside_its_domain_never_reaches_the_command(tmp_path_factory, monkeypatch, leaf, action, text):
    tmp = tmp_path_factory.mktemp("n")
    n = action.nargs if isinstance(action.nargs, int) else 1
    option = flag(action)
    argv = argv_for(leaf, tmp, {option: [text] * n})
    if action.option_strings and n == 1:   # "-1" alone reads as an option: --opt=VALUE, as its error says
        i = argv.index(option)
        argv[i:i + 2] = [f"{option}={text}"]
    code, err, args = _probe(monkeypatch, leaf, argv, tmp)
    dom = action.type
    if code == 0:
        got = getattr(args, action.dest)
        for v in (got if isinstance(got, list) else [got]):
            assert _in_domain(v, dom), (argv, v)
    else:
        assert option in err or action.dest in err or (action.metavar and str(action.metavar) in err), (argv, err)
    stripped = text.strip().lower()
    if stripped in ("nan", "inf", "-inf", "infinity", "1e400", "-1e400", "", "abc"):
        assert code == 2, (argv, err)


# ---- paths -------------------------------------------------------------------------------------------
def _existing(tmp: Path) -> None:
    """The file and the folder the values below point at."""
    (tmp / "a_file.txt").write_text("x\n")
    (tmp / "a_dir").mkdir(exist_ok=True)


def _bad_values(kind: str, tmp: Path) -> dict[str, str]:
    """class -> a value that is no usable path of ``kind`` (see :func:`_existing`)."""
    values = {"empty": "", "blank": "   ", "NUL": str(tmp / "a\0b")}
    if kind in (IN, OUT_FILE):
        values |= {"a folder": str(tmp / "a_dir"), "trailing separator": str(tmp / "new.txt") + "/",
                   "dot": str(tmp / "a_file.txt") + "/."}
    if kind in (OUT_FILE, OUT_DIR):
        values |= {"missing parent": str(tmp / "nope" / "x"), "under a file": str(tmp / "a_file.txt" / "x")}
    if kind in (IN_DIR, OUT_DIR):
        values |= {"a file": str(tmp / "a_file.txt")}
    return values


PATH_CASES = [(leaf, option, kind, what) for leaf, option, kind in PATHS
              for what in _bad_values(kind, Path("."))]


@pytest.mark.parametrize("leaf, option, kind, what", PATH_CASES,
                         ids=[f"{leaf.name} {o} {w}" for leaf, o, _, w in PATH_CASES])
def test_a_path_that_is_no_usable_path_is_refused_before_any_work(tmp_path, monkeypatch, leaf, option, kind, what):
    _existing(tmp_path)
    value = _bad_values(kind, tmp_path)[what]
    code, err, _ = _probe(monkeypatch, leaf, argv_for(leaf, tmp_path, {option: [value]}), tmp_path)
    assert code == 2 and option in err, (what, err)


PAIRS = [(leaf, a, b) for leaf in LEAVES for a, ka in leaf.paths().items() for b, kb in leaf.paths().items()
         if a < b and (ka in (OUT_FILE, OUT_DIR) or kb in (OUT_FILE, OUT_DIR))]


@pytest.mark.parametrize("leaf, first, second", PAIRS, ids=[f"{leaf.name} {a}={b}" for leaf, a, b in PAIRS])
def test_one_path_for_two_options_where_one_writes_is_refused(tmp_path, monkeypatch, leaf, first, second):
    """An input reused as an output, or two outputs on one path (each kind: an existing file, a
    folder, a new name)."""
    _existing(tmp_path)
    for target in ("a_file.txt", "a_dir", "new"):
        value = str(tmp_path / target)
        code, err, _ = _probe(monkeypatch, leaf, argv_for(leaf, tmp_path, {first: [value], second: [value]}), tmp_path)
        assert code == 2 and (first in err or second in err), (target, err)


OWNED_INPUTS = [(leaf, i, o) for leaf in LEAVES for i, ki in leaf.paths().items() if ki == IN
                for o, ko in leaf.paths().items() if ko == OUT_DIR]


@pytest.mark.parametrize("leaf, inp, out", OWNED_INPUTS, ids=[f"{leaf.name} {i} in {o}" for leaf, i, o in OWNED_INPUTS])
def test_an_input_that_its_folder_output_owns_is_refused_before_any_work(tmp_path, monkeypatch, leaf, inp, out):
    """A previous run's output handed back as this run's input, in the folder this run writes: it
    may be written over, so it is refused; the same file not written by fxdsp is left to the run."""
    from fxdsp.owned import RECORD, file_sha256, record_text

    folder = tmp_path / "out"
    folder.mkdir()
    given_file = folder / "given.toml"
    given_file.write_text("# a file\n")
    argv = argv_for(leaf, tmp_path, {inp: [str(given_file)], out: [str(folder)]})
    code, err, args = _probe(monkeypatch, leaf, argv, tmp_path)
    assert code == 0, err   # not fxdsp's: the run may start (a write over it is refused at the end)
    (folder / RECORD).write_text(record_text({"given.toml": file_sha256(given_file)}))
    code, err, _ = _probe(monkeypatch, leaf, argv, tmp_path)
    assert code == 2 and inp in err and "fxdsp wrote" in err, err


_PATHLIKE = re.compile(r"(^|_)(out|json|report|config|model|apply|log|table|rtl|cache|dir|file)(_|$)|\.(csv|json|toml|md)$|"
                       r"^(DIR|LOG\d?|FILE)$")


def test_every_option_that_names_a_file_is_declared_a_path():
    """A file option outside the command's PATHS would be read or written unchecked (not text, an
    input reused as an output, a folder for a file ...): by its name or metavar, none is."""
    undeclared = [f"{leaf.name} {flag(a)}" for leaf in LEAVES for a in leaf.options()
                  if flag(a) not in leaf.paths() and not isinstance(a, argparse._StoreTrueAction)
                  and (_PATHLIKE.search(a.dest) or (isinstance(a.metavar, str) and _PATHLIKE.search(a.metavar)))]
    assert not undeclared, f"declare in the command's PATHS: {undeclared}"


# ---- options that only mean something beside another ----------------------------------------------
ONLY = [(leaf, opt) for leaf in LEAVES for opt in only_with(leaf)]


def _given(action: argparse.Action, tmp: Path, kind: str | None) -> list[str]:
    """A value of ``action`` other than its default: a flag set, another choice, a path of its kind,
    the lowest of its numeric domain's integers above the default, else a word."""
    if action.nargs == 0:
        return []
    if action.choices:
        return [next(str(c) for c in sorted(action.choices) if c != action.default)]
    if kind is not None:
        return [str(tmp / ("in.txt" if kind == IN else "in_dir" if kind == IN_DIR else f"out_{action.dest}"))]
    if isinstance(action.type, Number):
        dom = action.type
        v = next(v for v in (dom.lo, 0, 1, 2, 0.1, 0.25) if v is not None and v != action.default
                 and _in_domain(dom.kind(v), dom))
        return [str(dom.kind(v))]
    return ["chain_paper001" if action.dest == "chain" else "1"]


@pytest.mark.parametrize("leaf, option", ONLY, ids=[f"{leaf.name} {o}" for leaf, o in ONLY])
def test_an_option_without_what_it_needs_is_refused_and_beside_it_runs(tmp_path, monkeypatch, leaf, option):
    """Read from each command's ONLY_WITH: the option given alone is one line naming it and what it
    needs, exit 2, before any work; given beside its first condition it reaches the command."""
    action = next(a for a in leaf.options() if flag(a) == option)
    value = _given(action, tmp_path, leaf.paths().get(option))
    # alone: none of its conditions holds (an option it must go without given too)
    against = [w for c in only_with(leaf)[option] if c.startswith("not ")
               for a in leaf.options() if flag(a) == c[len("not "):]
               for w in (flag(a), *_given(a, tmp_path, leaf.paths().get(flag(a))))]
    alone = argv_for(leaf, tmp_path) + [option, *value] + against
    code, err, _ = _probe(monkeypatch, leaf, alone, tmp_path)
    assert code == 2 and f"{option}: only " in err and len(err.strip().splitlines()) == 1, (alone, err)
    beside = argv_for(leaf, tmp_path, {option: value})
    code, err, args = _probe(monkeypatch, leaf, beside, tmp_path)
    assert code == 0 and args is not None, (beside, err)
