"""Shared fixtures: the built-in design and config variants."""

from __future__ import annotations

import os

# One OpenBLAS thread per process, as the command line runs (fxdsp.threads: a report's bytes must
# not depend on the core count, and `pytest -n 2` on 2 cores would otherwise run a second BLAS thread
# per worker spinning for the other worker's core: test_diagnose_hidden.py alone 36.2 -> 20.1 s).
# Set before anything imports numpy (this is the first conftest pytest imports, in the xdist
# controller and in each worker; workers and every child inherit it). An explicit setting wins.
from fxdsp.threads import one_blas_thread  # noqa: E402  (imports nothing but os)

one_blas_thread()

import contextlib
import copy
import functools
import io
import tomllib
from unittest import mock

import pytest

from pathlib import Path

from fxdsp.chains import build
from fxdsp.config import Config, default_config_text


# shared/ (specs and real data) sits beside the checkout, in CI as on a developer's machine; a bare
# clone has none, so every test that reads it is marked with needs_shared()
SHARED = Path(__file__).resolve().parents[2] / "shared"


def needs_shared(*rel: str):
    """Skip marker for a test that reads these files of ../shared, with a reason naming the first
    one that is absent."""
    missing = [r for r in rel if not (SHARED / r).exists()]
    return pytest.mark.skipif(bool(missing), reason=f"../shared/{missing[0]} absent (no shared/ checkout "
                              "beside this one)" if missing else "")


@functools.lru_cache(maxsize=1)
def _default_parsed() -> dict:
    return tomllib.loads(default_config_text())


def default_data() -> dict:
    """The shipped config's data, the caller's own copy (parsed once: collection alone asked for it
    345 times, 4 s of TOML parsing in every pytest process)."""
    return copy.deepcopy(_default_parsed())


# the demodulator's NCO before the floor issue: full-turn tables addressed by the truncated phase of a
# 32-bit accumulator, no interpolation (injected to show the checks catch its phase bias)
OLD_NCO = {"demod.phase_bits": 32, "demod.lut_bits": 12, "demod.interp_bits": 0, "demod.lut_format": "s16.15"}


def edited_data(**edits) -> dict:
    """The default config's data with dotted-path edits, e.g. ``edited_data(**{"iir.rounding": "floor"})``."""
    data = copy.deepcopy(default_data())
    for dotted, value in edits.items():
        node = data
        *parents, key = dotted.split(".")
        for p in parents:
            node = node[p]
        node[key] = value
    return data


def without(*path: str) -> dict:
    """The default config's data with the key (or table) at ``path`` deleted."""
    data = copy.deepcopy(default_data())
    node = data
    for p in path[:-1]:
        node = node[p]
    del node[path[-1]]
    return data


def lag_edits() -> dict:
    """Dotted edits that put the lag into the paper 002 chain (the netlist edit extend makes)."""
    from fxdsp.netlist import with_stage

    net = with_stage(default_data()["chain"]["paper002"], "lag")
    return {"chain.paper002.instances": net["instances"], "chain.paper002.wires": net["wires"]}


def lag_chain() -> dict:
    """The same edit as nested tables, for a deep merge: {"chain": {"paper002": {...}}}."""
    e = lag_edits()
    return {"chain": {"paper002": {"instances": e["chain.paper002.instances"], "wires": e["chain.paper002.wires"]}}}


def coarse_subtract(rounding: str) -> Config:
    """The default config with a bias_subtract that drops 4 fraction bits (by ``rounding``) after the
    subtraction, and the final low-pass on that wire."""
    return Config(edited_data(**{"bias_subtract.out_format": "s20.18", "bias_subtract.rounding": rounding,
                                 "iir.data_format": "s20.18"}), source="<test>")


def design_with(chains: bool = False, **edits):
    """Build the design from the default config with dotted-path edits (see :func:`edited_data`;
    blocks only unless ``chains``)."""
    return build(Config(edited_data(**edits), source="<test>"), chains=chains)


def config_leaves(node, prefix=()):
    """Dotted paths (as tuples) of every leaf of a config table."""
    for k, v in node.items():
        if isinstance(v, dict):
            yield from config_leaves(v, prefix + (k,))
        else:
            yield prefix + (k,)


def run_cli(argv) -> tuple[int, str]:
    """``fxdsp argv`` in-process: (exit status, stderr); stdout is dropped. argparse's own refusals
    (SystemExit) count as their exit status."""
    from fxdsp.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            rc = main(argv)
        except SystemExit as exc:
            rc = exc.code
    return rc, err.getvalue()


@contextlib.contextmanager
def failing_writes(k: int | None, exc: type[BaseException]):
    """Every ``Path.write_text`` as usual, except that the k-th call raises ``exc`` (a Ctrl-C or a
    full disk in the middle of writing a command's outputs); k None: no failure."""
    original, calls = Path.write_text, {"n": 0}

    def write_text(self, *a, **kw):
        calls["n"] += 1
        if calls["n"] == k:
            raise exc("injected mid-write")
        return original(self, *a, **kw)

    with mock.patch.object(Path, "write_text", write_text):
        yield


# ---- the order of the test files under `pytest -n 2 --dist loadfile` -----------------------------
# pytest-xdist hands out whole files, by default the files with the most tests first, which puts the
# long single-test files (the mutation proofs, ~20-40 s each) last, on one worker while the other
# idles. Longest first instead (LPT scheduling; the tail is then a few short files): seconds of each
# file >= 5 s, measured in a cold `make test` of a fresh clone on a 2-core machine (only their order
# counts); every other file after them in collection order. The wheel's file comes after the big HDL
# files: by then the run has compiled the numba kernels its installed package loads
# (test_wheel._seed_numba_cache).
# A wrong or stale number costs wall time, never a test.
FILE_SECONDS = {
    "hdl/test_hdl_golden.py": 68,
    "hdl/test_hdl_loop.py": 56,
    "hdl/test_hdl_long_blocks.py": 46,
    "test_extend.py": 41,
    "hdl/test_formal.py": 37,
    "hdl/test_hdl_corners.py": 35,
    "test_diagnose_independent.py": 30,
    "test_diagnose_remaining.py": 30,
    "test_sweep.py": 30,
    "test_drive.py": 29,
    "hdl/test_mutation_serial.py": 26,
    "hdl/test_hdl_random.py": 25,
    "test_outputs.py": 23,
    "test_budget_floor.py": 21,
    "hdl/test_hdl_lint.py": 20,
    "hdl/test_mutation.py": 20,
    "test_budget.py": 19,
    "test_diagnose_hidden.py": 19,
    "test_wheel.py": 18,
    "hdl/test_rtl_command.py": 17,
    "hdl/test_hdl_chain_stages.py": 15,
    "test_extend_user_design.py": 13,
    "test_fixed_properties.py": 13,
    "test_extend_any_chain.py": 11,
    "test_owned.py": 11,
    "test_config_errors.py": 10,
    "test_fixed_mutation.py": 10,
    "test_diagnose_logio.py": 9,
    "test_diagnose_selection.py": 9,
    "test_cli_walk.py": 8,
    "test_repro_repeatability.py": 8,
    "test_diagnose_uncertainty.py": 7,
    "test_hw_report.py": 7,
    "hdl/test_hdl_long_chains.py": 6,
    "test_cli_commands.py": 6,
    "hdl/test_cocotb_driver.py": 5,
}
TESTS = Path(__file__).resolve().parent
# the HDL tests' run folders hold no test, but tens of thousands of files after a run: each worker
# walked them all at collection (~2 s of a re-run's start)
collect_ignore = ["hdl/sim_build"]


def pytest_configure(config):
    # keep the collection order below (xdist's --dist loadscope/loadfile would re-sort by test count)
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


# ---- the slow tier ------------------------------------------------------------------------------
# `make test` makes each check once on each thing it checks: each RTL module and architecture, each
# rounding and overflow rule, each cause, each command. A test (or a parameter of one) marked
# `slow` repeats a check it already makes on something that exercises no other code: another
# instance of the same module, another parameter set or seed over the same rules, the same DUT on a
# second simulator, a second log of the same cause; or it measures a rate (the confusion matrices).
# FXDSP_SLOW=1 runs them too: before a release, and after a change to what they repeat.
def slow_wanted(value: str | None) -> bool:
    """FXDSP_SLOW's value: set and not 0."""
    return (value or "").strip() not in ("", "0")


SLOW = slow_wanted(os.environ.get("FXDSP_SLOW"))
SLOW_REASON = "slow tier: repeats a check make test makes once (FXDSP_SLOW=1 runs it)"


def tiered(params, keep) -> list:
    """``params`` (values or pytest.param), the ones ``keep(values)`` rejects put in the slow tier.
    A filter that keeps none is an error: the check would leave make test altogether (mark the test
    slow instead, where that is meant)."""
    out, kept = [], 0
    for p in params:
        values, pid, marks = (p.values, p.id, p.marks) if isinstance(p, type(pytest.param(0))) else (
            p if isinstance(p, tuple) else (p,), None, ())
        if keep(values if len(values) > 1 else values[0]):
            kept += 1
        else:
            marks = (*marks, pytest.mark.slow)
        out.append(pytest.param(*values, id=pid, marks=marks))
    if out and not kept:
        raise ValueError(f"tiered: every one of {len(out)} cases is in the slow tier")
    return out


def _skip_the_slow_tier(items) -> None:
    if SLOW:
        return
    for item in items:
        mark = item.get_closest_marker("slow")
        if mark is not None:
            item.add_marker(pytest.mark.skip(reason=mark.kwargs.get("reason", SLOW_REASON)))


def pytest_collection_modifyitems(session, config, items):
    """The slow tier skipped unless FXDSP_SLOW; files by FILE_SECONDS, longest first (stable: each
    file's tests stay together, in order)."""
    _skip_the_slow_tier(items)
    first: dict[str, int] = {}
    for i, item in enumerate(items):
        first.setdefault(str(item.path), i)

    def cost(item) -> int:
        try:
            rel = Path(item.path).resolve().relative_to(TESTS).as_posix()
        except ValueError:
            return 0
        return FILE_SECONDS.get(rel, 0)

    items.sort(key=lambda item: (-cost(item), first[str(item.path)]))


@pytest.fixture(scope="session")
def design():
    return build()


def diagnose_schema() -> dict:
    """The packaged copy of the contract's report schema plus the `remaining` object of the
    contract's section 5, which its text requires and its schema will list once reports carry it
    (names and meanings from measured-data.md, section 5)."""
    from fxdsp.schemas import diagnose_report_schema

    schema = copy.deepcopy(diagnose_report_schema())
    schema["required"] = [*schema["required"], "remaining"]
    schema["properties"]["remaining"] = {
        "type": "object", "required": ["significant", "rms", "fraction", "against", "explanation"],
        "properties": {"significant": {"type": "boolean"}, "rms": {"type": "number", "minimum": 0},
                       "fraction": {"type": "number", "minimum": 0},
                       "against": {"type": "array", "items": {"type": "string", "minLength": 1}},
                       "explanation": {"type": "string", "minLength": 1}}}
    return schema
