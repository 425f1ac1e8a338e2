"""(c) Corner cases through every block and both tops, each as three streams on the same DUT:
reset in mid-stream with samples in flight, then the corner list back to back, then again with
gapped valid. Two designs with narrowed formats force saturation / wrap and rounding ties:
full scale, minimum negative, rounding ties, saturation, SF at and near zero, temperatures
exactly on (and next to) breakpoints, frequencies at f0. The one-sample-per-clock RTL on Icarus; the serial variants on Icarus (a window
of the streams) and on Verilator (whole)."""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.blocks.base import corner_codes, tie_codes
from hdl_util import SERIAL, SIMULATORS, design_of, icarus_samples, icarus_window, run_cocotb, segment

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
    "narrow_half_up_saturate": _NARROW,
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
BLOCKS = ["rtd", "iir", "demod", "piecewise_sf", "piecewise_bias", "piecewise_bias001", "piecewise_k0",
          "piecewise_k1", "sf_divide", "bias_subtract", "bias_subtract001", "freq2temp", "lag", "chain_paper001",
          "chain_paper002"]
EXTRA = {"chain_paper002": {"DIV_UNROLL": 14}, "sf_divide": {"UNROLL": 2}}
_designs: dict = {}


def design(key):
    if key not in _designs:
        _designs[key] = design_of(DESIGNS[key])
    return _designs[key]


def rtd_ties(block) -> np.ndarray:
    """Every ADC code whose exact interpolated value sits on a rounding tie (searched exhaustively)."""
    fmt, s, shift = block.adc_format, block.datapath.frac_bits, block.datapath.shift
    code = np.arange(fmt.min_int, fmt.max_int + 1, dtype=np.int64)
    u = code - fmt.min_int
    idx = u >> s
    base = block.lut[idx]
    exact = (base << s) + (block.lut[idx + 1] - base) * (u & ((1 << s) - 1))
    if shift <= 0:
        return code[:0]
    tie = (exact & ((1 << shift) - 1)) == (1 << (shift - 1))
    return code[tie][:200]


def corners(d, name, rng) -> dict[str, np.ndarray]:
    block = d.all[name]
    head = {k: v[:400] for k, v in block.stimulus(rng, 32).items()}
    extra: dict[str, np.ndarray] = {}
    if name == "rtd":
        extra = {"code": rtd_ties(block)}
    elif name.startswith("piecewise"):
        bp = block.breakpoints
        t0 = int(block.t0[0])
        fmt = block.temp_format
        vals = np.concatenate([bp, bp - 1, bp + 1, [t0 - 1, t0, t0 + 1], corner_codes(fmt)])
        extra = {"temp": np.clip(vals, fmt.min_int, fmt.max_int).astype(np.int64)}
    elif name == "sf_divide":
        cx = corner_codes(block.in_format)
        fs = block.sf_format
        sfs = np.array([0, 1, 2, 3, fs.max_int, fs.max_int - 1, 1 << fs.fl, (1 << fs.fl) + 1]
                       + ([-1, -2, fs.min_int] if fs.signed else []), dtype=np.int64)
        sfs = sfs[(sfs >= fs.min_int) & (sfs <= fs.max_int)]
        extra = {"x": np.repeat(cx, sfs.size), "sf": np.tile(sfs, cx.size)}
    elif name.startswith("bias_subtract"):
        ties = tie_codes(block.in_format, 2)
        extra = {"x": ties, "bias": np.zeros(ties.size, np.int64)}
    elif name == "freq2temp":
        f0 = block.f0
        extra = {"f": np.array([f0 - 2, f0 - 1, f0, f0 + 1, f0 + 2], np.int64)}
    elif name == "lag":
        # starts away from 0 and from where the aborted first stream leaves the state, so the
        # state must be primed again on the first sample after the reset; full-scale alternation
        # and steps (slew over the whole range), then +-1 code steps (rounding of tiny d)
        fmt = block.temp_format
        alt = np.where(np.arange(200) % 2 == 0, fmt.max_int, fmt.min_int)
        small = np.repeat(np.array([1, 0, -1, 0, 2, -2, 0]), 12)
        extra = {"temp": np.r_[np.full(20, 3 * fmt.max_int // 4), alt, np.full(60, fmt.max_int),
                               np.full(60, fmt.min_int), np.full(30, 0), small].astype(np.int64)}
    elif name in ("iir", "demod"):
        fmt = block.inputs["x"]
        alt = np.where(np.arange(600) % 2 == 0, fmt.max_int, fmt.min_int)
        steps = np.r_[np.full(300, fmt.max_int), np.full(300, fmt.min_int), np.full(50, 0)]
        extra = {"x": np.r_[alt, steps].astype(np.int64)}
    elif name == "chain_paper002":
        fv, fc = block.inputs["vsa"], block.inputs["rtd_code"]
        codes = np.r_[corner_codes(fc), (np.arange(32) << block.rtd.s) + fc.min_int]
        vs = np.resize(np.r_[corner_codes(fv), fv.max_int, fv.min_int], codes.size)
        extra = {"vsa": vs.astype(np.int64), "rtd_code": codes.astype(np.int64)}
    elif name == "chain_paper001":
        ff, fr = block.inputs["f"], block.inputs["rate_in"]
        f0 = block.f2t.f0
        fs = np.r_[corner_codes(ff), [f0 - 1, f0, f0 + 1]]
        extra = {"f": fs.astype(np.int64), "rate_in": np.resize(corner_codes(fr), fs.size).astype(np.int64)}
    out = {}
    for k, v in head.items():
        e = extra.get(k)
        out[k] = np.concatenate([e, v]) if e is not None and len(e) else v
    n = min(len(v) for v in out.values())
    return {k: v[:n] for k, v in out.items()}


@pytest.mark.hdl
@pytest.mark.parametrize("key", sorted(DESIGNS))
@pytest.mark.parametrize("name", BLOCKS)
def test_corners_reset_gaps(key, name):
    """One sample per clock: Icarus runs these streams in seconds; a Verilator run would cost a C++
    build per (block, design) for nothing Icarus does not already check (the same RTL, golden on
    both simulators); the serial variants' corners run on both."""
    corner_streams(key, name, "icarus")


@pytest.mark.hdl
@pytest.mark.parametrize("key", sorted(DESIGNS))
@pytest.mark.parametrize("name", sorted(SERIAL))
@pytest.mark.parametrize("sim", SIMULATORS)
def test_corners_reset_gaps_serial(key, name, sim):
    """The serial variant: the reset lands mid-schedule, back-to-back valid meets in_ready low."""
    corner_streams(key, name, sim, SERIAL[name], "_serial")


def corner_streams(key, name, sim, extra=None, suffix=""):
    d = design(key)
    rng = np.random.default_rng(3)
    stim = corners(d, name, rng)
    if extra is not None and sim == "icarus":  # a serial DUT: a window on Icarus, whole on Verilator
        stim = icarus_window(stim, icarus_samples(name))
    n = len(next(iter(stim.values())))
    first = {k: v[: max(8, n // 3)] for k, v in stim.items()}
    segs = [segment(d, name, first, abort_after=max(4, n // 4)),  # reset with samples in flight
            segment(d, name, stim, gap=0.0),                      # back to back from reset
            segment(d, name, stim, gap=0.5)]                      # gapped valid from reset
    params = EXTRA.get(name) if extra is None else {**EXTRA.get(name, {}), **extra}
    run_cocotb(d, name, segs, f"corner_{key}_{name}{suffix}", seed=11, extra_params=params, sim=sim)
