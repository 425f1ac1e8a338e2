"""(c) Corner cases through one instance of each block module and every top, as streams on the same DUT (the
other instances' formats and corner codes: the golden vectors and random parameter sets): reset in
mid-stream with samples in flight, then the corner list with gapped valid (on Verilator also back to
back before it; on Icarus back-to-back valid is the golden vectors' stream). Two designs with narrowed formats force saturation / wrap and rounding ties:
full scale, minimum negative, rounding ties, saturation, SF at and near zero, temperatures
exactly on (and next to) breakpoints, frequencies at f0. The one-sample-per-clock RTL on Icarus; the
serial variants on Icarus (a window of the streams, the half_up / saturate design) and on Verilator
(whole, the half_even / wrap design: the chain tops, whose members are every serial block with its
shared multiplier, and a serial block that no chain holds)."""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.hdl.stimuli import corners
from hdl_util import SERIAL, SIMULATORS, covering_tops, design_of, icarus_samples, icarus_window, one_per_module, \
    run_cocotb, segment, with_copies

_NARROW = {
    "rtd": {"temp_format": "s14.7"},                        # +-64 C: the LUT range saturates
    "freq2temp": {"temp_format": "s12.5"},                  # +-64 C
    "bias_subtract": {"out_format": "s23.21"},              # one fraction bit dropped: ties
    "iir": {"data_format": "s23.21", "num_format": "s24.32", "den_format": "s28.26"},
    "bias_subtract001": {"out_format": "s24.5"},
    "sf_divide": {"out_format": "s22.20"},
    "lag": {"tau_s": 0.4, "alpha_bits": 8, "state_guard_bits": 2},   # alpha 0.22, ties every few steps
}
DESIGNS = {
    "narrow_half_up_saturate": with_copies(_NARROW),
    "narrow_half_even_wrap": {
        **{k: {**v, "rounding": "half_even", "overflow": "wrap"} for k, v in _NARROW.items()},
        # SF(T) with steps at the breakpoints (the default is continuous there): the segment
        # rule "a breakpoint belongs to the upper segment" becomes visible
        "piecewise": {"sf": {"rounding": "half_even", "overflow": "wrap",
                             "coefficients": [[0.99, 2.1e-4], [1.0, 2.7e-4], [0.98, 3.3e-4], [1.01, 3.9e-4]]},
                      "bias": {"rounding": "half_even", "overflow": "wrap", "out_format": "s20.18"},
                      "bias001": {"overflow": "wrap"}, "k0": {"overflow": "wrap"}},
        "demod": {"rounding": "half_even", "overflow": "wrap", "lpf": {"overflow": "wrap"}},
    },
}
DESIGNS["narrow_half_even_wrap"] = with_copies(DESIGNS["narrow_half_even_wrap"])
# one instance per block module and the chain tops that hold every module between them: resets anywhere
# and gaps test a module's protocol (every instance's own formats: golden vectors with their corner
# codes, the random parameter sets; every top's own schedule: its serial corners below, on Icarus)
_D = design_of()
BLOCKS = sorted(n for n in one_per_module(_D) if not _D.instances[n].members or n in covering_tops(_D))
EXTRA = {"chain_paper002": {"DIV_UNROLL": 14}, "sf_divide": {"UNROLL": 2}}
_designs: dict = {}


def design(key):
    if key not in _designs:
        _designs[key] = design_of(DESIGNS[key])
    return _designs[key]


@pytest.mark.hdl
@pytest.mark.parametrize("key", sorted(DESIGNS))
@pytest.mark.parametrize("name", BLOCKS)
def test_corners_reset_gaps(key, name):
    """One sample per clock: Icarus runs these streams in seconds; a Verilator run would cost a C++
    build per (block, design) for nothing Icarus does not already check (the same RTL, golden on
    both simulators); the serial variants' corners run on both."""
    corner_streams(key, name, "icarus")


# the serial variants: every one on Icarus on the half_up / saturate design (a window of each stream);
# on Verilator (whole streams) on the design with every rule changed (half_even, wrap, stepped SF), the
# chain tops that hold every block module between them (hdl_util.covering_tops: every serial block is
# a member of one, in its shared mode) and any serial block that no chain of the design holds: a
# Verilator model is a C++ build of 2-20 s per (DUT, design), and a fresh
# clone builds every one of them. (The serial blocks' rounding and overflow rules on Icarus: the
# random parameter sets, floor / wrap, half_even and toward_zero among them, one set per DUT in make
# test and each DUT under every set in the slow tier; every rounding is the one fx_round.)
def _serial_cases() -> list:
    d = design_of(DESIGNS["narrow_half_even_wrap"])
    in_chain = {m for inst in d.instances.values() for m in inst.members}
    out = [pytest.param(n, "narrow_half_up_saturate", "icarus", id=f"{n}-narrow_half_up_saturate-icarus")
           for n in sorted(SERIAL)]
    if "verilator" in SIMULATORS:
        cover = covering_tops(d)
        out += [pytest.param(n, "narrow_half_even_wrap", "verilator", id=f"{n}-narrow_half_even_wrap-verilator")
                for n in sorted(SERIAL) if n in cover or not (d.instances[n].members or n in in_chain)]
    return out


@pytest.mark.hdl
@pytest.mark.parametrize("name, key, sim", _serial_cases())
def test_corners_reset_gaps_serial(key, name, sim):
    """The serial variant: the reset lands anywhere in a schedule, back-to-back valid meets in_ready
    low, the data inputs carry random words while in_valid is low."""
    corner_streams(key, name, sim, SERIAL[name], "_serial")


def corner_streams(key, name, sim, extra=None, suffix=""):
    d = design(key)
    rng = np.random.default_rng(3)
    stim = corners(d, name, rng)
    if extra is not None and sim == "icarus":  # a serial DUT: a window on Icarus, whole on Verilator
        stim = icarus_window(stim, icarus_samples(d, name))
    n = len(next(iter(stim.values())))
    first = {k: v[: max(8, n // 3)] for k, v in stim.items()}
    segs = [segment(d, name, first, abort_after=max(4, n // 4))]  # reset with samples in flight
    if sim != "icarus":   # on Icarus the golden vectors stream back to back (~1.7 k samples/s for demod)
        segs.append(segment(d, name, stim, gap=0.0))               # back to back from reset
    segs.append(segment(d, name, stim, gap=0.5))                    # gapped valid from reset
    params = EXTRA.get(name) if extra is None else {**EXTRA.get(name, {}), **extra}
    run_cocotb(d, name, segs, f"corner_{key}_{name}{suffix}", seed=11, extra_params=params, sim=sim)
