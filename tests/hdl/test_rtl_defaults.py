"""The RTL's parameter defaults are the default design (tests/hdl/rtl_defaults.py): a block's are the
generator's values for the default config, and a part of one block has that block's. Shown able to
fail on a copy of the RTL with one default put back to a value it once had, one per rule."""

from __future__ import annotations

import pytest

import rtl_defaults
from fxdsp.chains import build
from fxdsp.config import load_config
from hdl_util import RTL, mutated_rtl


@pytest.fixture(scope="module")
def design():
    return build(load_config())


def test_every_default_is_the_default_designs(design):
    problems = rtl_defaults.problems(RTL, design)
    assert problems == [], "\n".join(problems)


def test_the_rules_read_every_block_and_part(design):
    """Neither rule is empty: every block of the config has its generated parameters compared, and
    the parts fed by one block (nco by demod, drive_pi by drive) are compared with it."""
    reps = rtl_defaults.representatives(design)
    assert {i.block.datapath.MODULE for n, i in design.hardware.items() if not i.members} == set(reps)
    fed = {(child, parent) for parent, _, child, _ in rtl_defaults.pass_throughs(RTL)}
    assert {("nco", "demod"), ("drive_pi", "drive"), ("mix_lpf", "demod")} <= fed


# (file, old, new, what the line must name): a stale default of each kind
STALE = {
    "block": ("demod.v", "parameter integer MIX_SHIFT     = 20,", "parameter integer MIX_SHIFT     = 14,",
              "demod.MIX_SHIFT = 14; the generator writes 20"),
    "block_constant": ("demod.v", "parameter [63:0]  FTW           = 64'd23456248059221,",
                       "parameter [63:0]  FTW           = 64'd23456248059220,", "demod.FTW"),
    "block_file": ("piecewise.v", 'BP_FILE    = "piecewise_sf_bp.hex"', 'BP_FILE    = "piecewise_bp.hex"',
                   "piecewise.BP_FILE"),
    "part": ("nco.v", "parameter integer CORR_SHIFT  = 37,", "parameter integer CORR_SHIFT  = 36,",
             "nco.CORR_SHIFT = 36, but demod passes its CORR_SHIFT = 37 on"),
}


@pytest.mark.parametrize("key", sorted(STALE))
def test_a_stale_default_is_named(key, design, tmp_path):
    file, old, new, expect = STALE[key]
    problems = rtl_defaults.problems(mutated_rtl(tmp_path / "rtl", file, [(old, new)]), design)
    assert problems and expect in problems[0], problems   # (a block's stale default may be passed on too)
