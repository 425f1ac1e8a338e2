"""Lint: every RTL module through `iverilog -g2005 -Wall` and `verilator --lint-only -Wall`, at its
default parameters and at a few non-default ones; any warning fails, and so does any nonzero exit
status, with or without output. Plus `fxdsp hdl-gen --check`, and the rounding rule (tests/hdl/rtl_rules.py):
no module but fx_round rounds, checked on the parsed Verilog and proven on injected hand-written roundings."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest

import rtl_rules
from fxdsp.chains import build
from hdl_util import GEN, ROOT, RTL, lint_iverilog, lint_verilator, mutated_rtl

MODULES = sorted(p.stem for p in RTL.glob("*.v"))
# (module, {param: value}) beyond the defaults: other orders, section counts, modes, signedness
VARIANTS = [
    ("piecewise", {"ORDER": 3, "SEGMENTS": 1, "ACC_ALIGN": 0, "COEF_ALIGN": 0, "TOP_SHIFT": -2, "OUT_SHIFT": -1}),
    ("piecewise", {"ORDER": 2, "SEGMENTS": 6, "ROUNDING": 2, "OVERFLOW": 0, "OUT_SIGNED": 1}),
    ("iir", {"SECTIONS": 3, "ROUNDING": 3, "OVERFLOW": 0}),
    ("iir", {"ARCH": 1}),
    ("iir", {"ARCH": 1, "SECTIONS": 3, "ROUNDING": 3, "OVERFLOW": 0}),
    ("iir", {"ARCH": 1, "DATA_W": 16, "COEF_W": 16, "ACOEF_W": 16, "OUT_SHIFT": 14, "ACC_W": 34}),  # one-limb operands
    ("iir", {"ARCH": 1, "COEF_W": 20, "ACOEF_W": 20, "ACC_W": 50}),  # MAC product wider than the accumulator
    ("iir", {"ARCH": 1, "CHANNELS": 2}),  # the serial demod's two-channel low-pass engine
    ("iir", {"ARCH": 1, "CHANNELS": 3, "SECTIONS": 2, "ROUNDING": 2, "OVERFLOW": 0}),
    ("fx_mac_serial", {"A_W": 39, "B_W": 24}),
    ("fx_mac_serial", {"A_W": 2, "B_W": 17}),
    ("fx_mac_serial", {"A_W": 48, "B_W": 32, "VAR_N": 1}),  # shared by callers of different widths
    ("fx_mac_serial", {"A_W": 16, "B_W": 32, "VAR_N": 1}),   # VAR_N = 1: whole limbs
    # the external (shared) multiplier's bundle instead of an own fx_mac_serial
    ("fx_mac_port", {"EXT_MAC": 1}),
    ("fx_mac_port", {"EXT_MAC": 1, "VAR_N": 1, "A_W": 48, "B_W": 32}),
    ("iir", {"ARCH": 1, "EXT_MAC": 1}),
    ("iir", {"ARCH": 1, "CHANNELS": 2, "EXT_MAC": 1}),
    # one engine for different filters: a coefficient set per channel, the last channel a pass of its own
    ("iir", {"ARCH": 1, "CHANNELS": 3, "COEF_SETS": 3, "SPLIT": 1, "EXT_MAC": 1}),   # chain_paper002's
    ("iir", {"ARCH": 1, "CHANNELS": 2, "COEF_SETS": 2, "SPLIT": 1}),                 # a channel per pass
    ("iir", {"ARCH": 1, "CHANNELS": 4, "COEF_SETS": 4, "SPLIT": 1, "SECTIONS": 2}),  # three, then one
    ("demod", {"ARCH": 1, "EXT_MAC": 1, "AUX_LPF": 1}),
    ("demod", {"ARCH": 1, "AUX_LPF": 1, "LPF_SECTIONS": 2}),
    ("rtd", {"ARCH": 1, "EXT_MAC": 1}),
    ("piecewise", {"ARCH": 1, "EXT_MAC": 1}),
    ("demod", {"ARCH": 1, "EXT_MAC": 1}),
    # the reference an input (a drive loop's phase), and the wave pass (the drive loop's carrier)
    ("demod", {"REF": 1, "PHASE_TRIM": "64'd12345"}),
    ("demod", {"ARCH": 1, "REF": 1, "WAVE": 1, "EXT_MAC": 1, "MAC_A_W": 64, "MAC_B_W": 64}),
    ("demod", {"ARCH": 1, "REF": 1, "WAVE": 1, "AUX_LPF": 1, "LPF_SECTIONS": 2}),
    # the serial drive loop on its own multiplier and on an external one
    ("drive", {"ARCH": 1}),
    ("drive", {"ARCH": 1, "EXT_MAC": 1, "MAC_A_W": 64, "MAC_B_W": 80}),
    ("drive", {"ARCH": 1, "UPDATE_EVERY": 1, "LPF_SECTIONS": 1, "ROUNDING": 2, "OVERFLOW": 0}),
    ("sf_divide", {"UNROLL": 7, "SF_SIGNED": 1, "ROUNDING": 2}),
    ("sf_divide", {"UNROLL": 42, "OUT_SHIFT": -2}),
    ("sf_divide", {"ARCH": 1, "SF_SIGNED": 1, "ROUNDING": 2}),
    ("sf_divide", {"ARCH": 1, "UNROLL": 42, "OUT_SHIFT": -2, "OVERFLOW": 0}),
    ("demod", {"LPF_SECTIONS": 2, "ITERATIONS": 8, "ROUNDING": 0}),
    # serial demod (ARCH = 1)
    ("demod", {"ARCH": 1}),
    ("demod", {"ARCH": 1, "LPF_SECTIONS": 2, "ITERATIONS": 8, "ROUNDING": 0}),
    ("demod", {"ARCH": 1, "ROUNDING": 3, "OVERFLOW": 0, "LPF_ROUNDING": 3, "LPF_OVERFLOW": 0}),  # toward_zero / wrap
    ("demod", {"ARCH": 1, "INTERP_BITS": 0, "IN_W": 30, "ITERATIONS": 5}),  # plain table, x wider than the CORDIC
    ("fx_convert", {"SHIFT": -3, "OUT_SIGNED": 0, "OVERFLOW": 0}),
    ("fx_round", {"SHIFT": 40, "ROUNDING": 3}),
    ("lag", {"TEMP_W": 18, "GUARD": 0, "STATE_W": 19, "ROUNDING": 3, "OVERFLOW": 0}),
    ("lag", {"TEMP_W": 14, "GUARD": 2, "STATE_W": 17, "ALPHA_W": 24, "ALPHA_M": 16777215, "ALPHA_S": 24,
             "ROUNDING": 2}),
    ("lag", {"ALPHA_W": 4, "ALPHA_M": 8, "ALPHA_S": 70, "ROUNDING": 0}),
    # serial lag (ARCH = 1)
    ("lag", {"ARCH": 1}),
    ("lag", {"ARCH": 1, "DECIM": 5, "TEMP_W": 18, "GUARD": 0, "STATE_W": 19, "ROUNDING": 3, "OVERFLOW": 0}),
    ("lag", {"ARCH": 1, "TEMP_W": 14, "GUARD": 0, "STATE_W": 15, "ALPHA_W": 4, "ALPHA_M": 8, "ALPHA_S": 70,
             "ROUNDING": 2}),  # one-limb operands (d 16 bits, alpha 5), a shift beyond the product
    # serial rtd (ARCH = 1)
    ("rtd", {"ARCH": 1}),
    ("rtd", {"ARCH": 1, "ROUNDING": 3, "OVERFLOW": 0, "SHIFT": -2, "TEMP_W": 40}),  # left shift
    ("rtd", {"ARCH": 1, "ADC_W": 4, "LUT_INDEX_BITS": 3, "LUT_W": 8, "TEMP_W": 6, "SHIFT": 2,
             "ROUNDING": 2}),  # one fraction bit
    ("rtd", {"ARCH": 1, "ADC_W": 24, "LUT_INDEX_BITS": 4, "LUT_W": 32, "SHIFT": 30}),  # two-limb operands
    # serial piecewise, freq2temp (ARCH = 1)
    ("piecewise", {"ARCH": 1}),
    ("piecewise", {"ARCH": 1, "ORDER": 3, "SEGMENTS": 1, "ACC_ALIGN": 0, "COEF_ALIGN": 0, "TOP_SHIFT": -2,
                   "OUT_SHIFT": -1, "PROD_SHIFT": -1}),
    ("piecewise", {"ARCH": 1, "ORDER": 2, "SEGMENTS": 6, "ROUNDING": 2, "OVERFLOW": 0, "OUT_SIGNED": 1}),
    ("piecewise", {"ARCH": 1, "T_W": 12, "ACC_W": 16, "COEF_W": 12, "ACOEF_W": 12, "OUT_W": 10}),  # one-limb operands
    ("freq2temp", {"ARCH": 1}),
    ("freq2temp", {"ARCH": 1, "FREQ_W": 15, "KINV_W": 16, "SHIFT": 4, "ROUNDING": 3, "OVERFLOW": 0}),
]


@pytest.mark.parametrize("top", MODULES)
def test_iverilog_wall(top):
    out = lint_iverilog(top, {})
    assert out == "", out


@pytest.mark.parametrize("top", MODULES)
def test_verilator_wall(top):
    out = lint_verilator(top, {})
    assert out == "", out


@pytest.mark.parametrize("top,params", VARIANTS, ids=[f"{m}-{i}" for i, (m, _) in enumerate(VARIANTS)])
def test_lint_variants(top, params):
    out = lint_iverilog(top, params)
    assert out == "", out
    out = lint_verilator(top, params)
    assert out == "", out


# the chain tops hdl-gen writes (committed in hdl/gen, checked current by test_headers_rom_files_match_config)
GENERATED_TOPS = sorted(GEN.glob("chain_*.v"))


def test_every_chain_top_is_generated():
    """Every chain of the config whose members all have RTL (all of them, drive loops included) has a
    generated top, and no chain top is written by hand."""
    design = build()
    assert {p.stem for p in GENERATED_TOPS} == {n for n in design.chains if design.instances[n].hardware} \
        == set(design.chains)
    hand = [p.name for p in RTL.glob("*.v") if re.search(r"^\s*module\s+chain_", p.read_text(), re.M)]
    assert not hand, f"hand-written chain tops in {RTL}: {hand}"


# every generated top in both variants; the paper 002 top also with a divider faster than the bias pass
TOP_VARIANTS = [(p, {"ARCH": a}) for p in GENERATED_TOPS for a in (0, 1)]
TOP_VARIANTS += [(p, {"ARCH": 1, "DIV_UNROLL": 48}) for p in GENERATED_TOPS if p.stem == "chain_paper002"]


@pytest.mark.parametrize("top,params", TOP_VARIANTS, ids=[f"{p.stem}-{v}" for p, v in TOP_VARIANTS])
def test_generated_chain_tops_lint_clean(top, params):
    for run in (lint_iverilog, lint_verilator):
        out = run(top.stem, params, extra=(top,))
        assert out == "", out


@pytest.mark.parametrize("rc,output", [(1, ""), (3, "some diagnostic"), (0, "%Warning-WIDTH: something")])
@pytest.mark.parametrize("tool", ["iverilog", "verilator"])
def test_lint_runner_fails_on_any_exit_status_or_output(tool, rc, output, tmp_path, monkeypatch):
    """The runners themselves: a stand-in tool that exits nonzero silently, nonzero with text, or
    zero with a warning must each give a nonempty verdict (the old runner passed a silent failure)."""
    fake = tmp_path / tool
    fake.write_text(f"#!/bin/sh\n{'echo ' + repr(output) + ' >&2' if output else ''}\nexit {rc}\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{tmp_path}{os.pathsep}{os.environ.get('PATH', '')}")
    run = lint_iverilog if tool == "iverilog" else lint_verilator
    verdict = run("fx_round", {})
    assert verdict != ""
    if rc:
        assert f"exit status {rc}" in verdict
    if output:
        assert output in verdict


def test_headers_rom_files_match_config():
    proc = subprocess.run([sys.executable, "-m", "fxdsp.cli", "hdl-gen", "--check", "--out", str(GEN)],
                          capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr


def test_every_block_has_a_module_and_shared_primitives():
    names = {p.stem for p in RTL.glob("*.v")}
    assert {"rtd", "iir", "nco", "demod", "piecewise", "sf_divide", "bias_subtract", "freq2temp", "lag",
            "fx_round", "fx_fit"} <= names
    for p in [*RTL.glob("*.v"), *GENERATED_TOPS]:
        text = p.read_text()
        assert "`default_nettype none" in text, p.name
        if p.stem not in ("fx_round", "fx_fit", "fx_convert", "nco"):
            assert "half_up" in text, f"{p.name}: header must name the rounding modes"


def test_every_rounding_goes_through_fx_round():
    """One rounding implementation: no module but fx_round drops low bits of a value or builds a
    rounding constant, and every rounding mode reaches fx_round through a parameter."""
    problems = rtl_rules.check(RTL)
    assert problems == [], "\n".join(problems)


# Hand-written roundings injected into a copy of one module: (file, [(old, new)], rule expected).
# The first one is a *correct* half_up (the bit-exact tests could not see it): only this rule can.
INJECTIONS = {
    "half_up_by_shift": ("freq2temp.v", [
        ("    fx_convert_reg #(.IN_W(PW), .SHIFT(SHIFT),",
         "    wire signed [PW:0] ph = {p[PW-1], p} + ({{PW{1'b0}}, 1'b1} <<< (SHIFT - 1));\n"
         "    wire signed [PW-SHIFT:0] pr = ph >>> SHIFT;\n"
         "    fx_convert_reg #(.IN_W(PW - SHIFT + 1), .SHIFT(0),"),
        (".in_valid(in_valid), .x(p),", ".in_valid(in_valid), .x(pr),")], "power-of-two"),
    "half_constant_concat": ("bias_subtract.v", [
        ("    fx_convert_reg #(", "    wire signed [DW-1:0] dh = d_q + {{(DW-SHIFT){1'b0}}, 1'b1, {(SHIFT-1){1'b0}}};\n"
                               "    fx_convert_reg #("),
        (".x(d_q),", ".x(dh),")], "constant"),
    "half_literal": ("bias_subtract.v", [(".x(d_q),", ".x(d_q + 24'h000800),")], "constant"),
    "half_even_odd_bit": ("rtd.v", [("exact = (be <<< S) + prod;",
                                     "exact = (be <<< S) + prod + {{(EW-1){1'b0}}, prod[SHIFT]};")], "data-bit"),
    "toward_zero_mask": ("lag.v", [("p = d * m;", "p = d * m + (d[DW-1] ? {ALPHA_S{1'b1}} : {PW{1'b0}});")],
                         "constant"),
    "sticky_bit": ("piecewise.v", [("sum = (pe <<< AA) + (ce <<< CA);", "sum = (pe <<< AA) + (ce <<< CA) + |pe[AA:0];")],
                   "sticky-bit"),
    "floor_by_select": ("freq2temp.v", [("fx_convert_reg #(.IN_W(PW), .SHIFT(SHIFT)",
                                         "fx_convert_reg #(.IN_W(PW - SHIFT), .SHIFT(0)"),
                                        (".in_valid(in_valid), .x(p),", ".in_valid(in_valid), .x(p[PW-1:SHIFT]),")],
                        "select"),
    "floor_by_divide": ("bias_subtract.v", [(".x(d_q),", ".x(d_q / 4),")], "divide"),
    "state_truncated": ("lag.v", [("st     <= st_next;", "st     <= (st_next >>> GUARD) <<< GUARD;")], "right-shift"),
    "one_wire_shifted": ("iir.v", [("wire signed [AW-1:0] acc = ",
                                    "wire signed [AW-1:0] one = {{(AW-1){1'b0}}, 1'b1};\n"
                                    "            wire signed [AW-1:0] acc = (one <<< (OUT_SHIFT - 1)) + ")],
                         "power-of-two"),
    "hard_wired_mode": ("lag.v", [(".SHIFT(ALPHA_S), .ROUNDING(ROUNDING)", ".SHIFT(ALPHA_S), .ROUNDING(0)")],
                        "rounding mode must come from"),
    "default_mode": ("iir.v", [(".SHIFT(OUT_SHIFT), .ROUNDING(ROUNDING), ", ".SHIFT(OUT_SHIFT), ")], "at its default"),
    "cordic_shift_changed": ("cordic_vector.v", [("tx = cx + (cy >>> j);", "tx = cx + (cy >>> (j + 1));")], "cy>>>(j+1)"),
}


@pytest.mark.parametrize("key", sorted(INJECTIONS))
def test_rounding_rule_flags_an_injected_hand_written_rounding(key, tmp_path):
    file, edits, expect = INJECTIONS[key]
    problems = rtl_rules.check(mutated_rtl(tmp_path / "rtl", file, edits))
    assert problems, f"{key}: hand-written rounding in {file} not flagged"
    assert all(p.startswith(file) for p in problems), problems
    assert any(expect in p for p in problems), problems


def test_injected_half_up_compiles_so_only_the_rule_can_see_it(tmp_path):
    """The correct hand-written half_up above is real Verilog (compiles), not a strawman."""
    file, edits, _ = INJECTIONS["half_up_by_shift"]
    assert lint_iverilog("freq2temp", rtl=mutated_rtl(tmp_path / "rtl", file, edits)) == ""


def test_rounding_rule_reads_code_not_comments(tmp_path):
    """A rounding written in a comment or a string is not code: no finding."""
    rtl = mutated_rtl(tmp_path / "rtl", "bias_subtract.v", [(
        "    fx_convert_reg #(",
        "    // wire h = 1 << (SHIFT - 1); y = (d + h) >>> SHIFT; d[DW-1:SHIFT] + {15'd0, d[SHIFT]}\n"
        "    /* {S{1'b1}} |d[SHIFT-1:0] */\n    fx_convert_reg #(")])
    assert rtl_rules.check(rtl) == []
