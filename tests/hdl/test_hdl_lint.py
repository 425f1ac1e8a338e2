"""Lint: every RTL module through `iverilog -g2005 -Wall` and `verilator --lint-only -Wall`, at its
default parameters and at a few non-default ones; any warning fails. Plus `fxdsp hdl-gen --check`."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest

from hdl_util import ROOT, RTL, rtl_sources

GEN = ROOT / "hdl" / "gen"
MODULES = sorted(p.stem for p in RTL.glob("*.v"))
# (module, {param: value}) beyond the defaults: other orders, section counts, modes, signedness
VARIANTS = [
    ("piecewise", {"ORDER": 3, "SEGMENTS": 1, "ACC_ALIGN": 0, "COEF_ALIGN": 0, "TOP_SHIFT": -2, "OUT_SHIFT": -1}),
    ("piecewise", {"ORDER": 2, "SEGMENTS": 6, "ROUNDING": 2, "OVERFLOW": 0, "OUT_SIGNED": 1}),
    ("iir", {"SECTIONS": 3, "ROUNDING": 3, "OVERFLOW": 0}),
    ("sf_divide", {"UNROLL": 7, "SF_SIGNED": 1, "ROUNDING": 2}),
    ("sf_divide", {"UNROLL": 42, "OUT_SHIFT": -2}),
    ("demod", {"LPF_SECTIONS": 2, "ITERATIONS": 8, "ROUNDING": 0}),
    ("fx_convert", {"SHIFT": -3, "OUT_SIGNED": 0, "OVERFLOW": 0}),
    ("fx_round", {"SHIFT": 40, "ROUNDING": 3}),
    ("lag", {"GUARD": 0, "STATE_W": 19, "ROUNDING": 3, "OVERFLOW": 0}),
    ("lag", {"TEMP_W": 14, "GUARD": 2, "STATE_W": 17, "ALPHA_W": 24, "ALPHA_M": 16777215, "ALPHA_S": 24,
             "ROUNDING": 2}),
    ("lag", {"ALPHA_W": 4, "ALPHA_M": 8, "ALPHA_S": 70, "ROUNDING": 0}),
]


def _clean(proc) -> str:
    return (proc.stdout + proc.stderr).strip()


def _iverilog(top: str, params: dict) -> str:
    if shutil.which("iverilog") is None:
        pytest.skip("iverilog is not installed")
    cmd = ["iverilog", "-g2005", "-Wall", "-I", str(GEN), "-o", "/dev/null", "-s", top]
    cmd += [f"-P{top}.{k}={v}" for k, v in params.items()]
    return _clean(subprocess.run(cmd + [str(p) for p in rtl_sources()], capture_output=True, text=True))


def _verilator(top: str, params: dict) -> str:
    if shutil.which("verilator") is None:
        pytest.skip("verilator is not installed (lint only)")
    cmd = ["verilator", "--lint-only", "-Wall", f"-I{GEN}", "--top-module", top]
    cmd += [f"-G{k}={v}" for k, v in params.items()]
    proc = subprocess.run(cmd + [str(p) for p in rtl_sources()], capture_output=True, text=True)
    return _clean(proc) if proc.returncode or _clean(proc) else ""


@pytest.mark.parametrize("top", MODULES)
def test_iverilog_wall(top):
    out = _iverilog(top, {})
    assert out == "", out


@pytest.mark.parametrize("top", MODULES)
def test_verilator_wall(top):
    out = _verilator(top, {})
    assert out == "", out


@pytest.mark.parametrize("top,params", VARIANTS, ids=[f"{m}-{i}" for i, (m, _) in enumerate(VARIANTS)])
def test_lint_variants(top, params):
    assert _iverilog(top, params) == ""
    assert _verilator(top, params) == ""


def test_headers_rom_files_match_config():
    proc = subprocess.run([sys.executable, "-m", "fxdsp.cli", "hdl-gen", "--check", "--out", str(GEN)],
                          capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr


def test_every_block_has_a_module_and_shared_primitives():
    names = {p.stem for p in RTL.glob("*.v")}
    assert {"rtd", "iir", "nco", "demod", "piecewise", "sf_divide", "bias_subtract", "freq2temp", "lag",
            "chain_paper002", "chain_paper001", "fx_round", "fx_fit"} <= names
    # one rounding implementation, one fit: no block computes its own rounding constant or clamp
    for p in RTL.glob("*.v"):
        if p.stem in ("fx_round", "fx_fit", "fx_convert"):
            continue
        text = p.read_text()
        assert "`default_nettype none" in text, p.name
        assert "half_up" in text or p.stem == "nco", f"{p.name}: header must name the rounding modes"
