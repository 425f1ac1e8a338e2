"""Every block's bit-exact model against an independent Python-integer oracle (tests/block_oracles.py),
for several rounding/overflow rules and word lengths, on the corner-case stimulus."""

from __future__ import annotations

import numpy as np
import pytest

import block_oracles as oracle
from conftest import design_with

RULES = [("half_up", "saturate"), ("floor", "wrap"), ("half_even", "saturate"), ("toward_zero", "wrap")]


def _pick(stim: dict, n: int, seed: int = 0) -> dict:
    """The first corner-case samples plus a random subset, the same rows for every port."""
    size = len(next(iter(stim.values())))
    rng = np.random.default_rng(seed)
    rows = np.unique(np.concatenate([np.arange(min(size, n // 2)), rng.choice(size, min(size, n // 2), replace=False)]))
    return {k: v[rows] for k, v in stim.items()}


@pytest.mark.parametrize("rounding,overflow", RULES)
def test_rtd(rounding, overflow):
    d = design_with(**{"rtd.rounding": rounding, "rtd.overflow": overflow, "rtd.temp_format": "s14.6"})
    b = d.blocks["rtd"]
    st = _pick(b.stimulus(np.random.default_rng(1), 400), 300)
    assert b.run(**st).outputs["temp"].tolist() == oracle.rtd(b, st["code"])


@pytest.mark.parametrize("rounding,overflow", RULES)
def test_iir(rounding, overflow):
    d = design_with(**{"iir.rounding": rounding, "iir.overflow": overflow, "iir.order": 4,
                       "iir.data_format": "s18.16", "iir.cutoff_hz": 2000.0, "iir.num_format": "s24.26"})
    b = d.blocks["iir"]
    x = b.stimulus(np.random.default_rng(2), 200)["x"][:1400]  # impulses, steps, corners, saturating square
    b.reset()
    got = b.run(x=x)
    assert got.outputs["y"].tolist() == oracle.iir(b, x)
    if overflow == "saturate":
        assert got.overflows.total > 0, "the stimulus must drive the filter into saturation"


def test_iir_without_error_feedback_matches_oracle():
    d = design_with(**{"iir.error_feedback": "off", "iir.data_format": "s16.14"})
    b = d.blocks["iir"]
    x = b.nominal_stimulus(np.random.default_rng(3), 500)["x"]
    assert b.filter(x).tolist() == oracle.iir(b, x)


@pytest.mark.parametrize("name", ["piecewise_sf", "piecewise_bias", "piecewise_bias001", "piecewise_k0", "piecewise_k1"])
@pytest.mark.parametrize("rounding,overflow", RULES[:2] + RULES[3:])
def test_piecewise(name, rounding, overflow):
    table = "piecewise." + name.split("_", 1)[1]
    d = design_with(**{f"{table}.rounding": rounding, f"{table}.overflow": overflow})
    b = d.blocks[name]
    st = _pick(b.stimulus(np.random.default_rng(4), 200), 160)
    assert b.run(**st).outputs["y"].tolist() == oracle.piecewise(b, st["temp"])


@pytest.mark.parametrize("rounding,overflow", RULES)
def test_sf_divide(rounding, overflow):
    d = design_with(**{"sf_divide.rounding": rounding, "sf_divide.overflow": overflow, "sf_divide.guard_bits": 7})
    b = d.blocks["sf_divide"]
    st = _pick(b.stimulus(np.random.default_rng(5), 200), 400)
    assert (st["sf"] == 0).any(), "division by zero must be in the stimulus"
    res = b.run(**st)
    assert res.outputs["y"].tolist() == oracle.sf_divide(b, st["x"], st["sf"])
    assert res.overflows["sf_divide.zero"] == int(np.count_nonzero((st["sf"] == 0) & (st["x"] != 0)))


@pytest.mark.parametrize("rounding,overflow", RULES)
def test_bias_subtract(rounding, overflow):
    d = design_with(**{"bias_subtract.rounding": rounding, "bias_subtract.overflow": overflow,
                       "bias_subtract.out_format": "s20.17"})
    b = d.blocks["bias_subtract"]
    st = _pick(b.stimulus(np.random.default_rng(6), 200), 300)
    assert b.run(**st).outputs["y"].tolist() == oracle.bias_subtract(b, st["x"], st["bias"])


@pytest.mark.parametrize("rounding,overflow", RULES)
def test_freq2temp(rounding, overflow):
    d = design_with(**{"freq2temp.rounding": rounding, "freq2temp.overflow": overflow})
    b = d.blocks["freq2temp"]
    st = _pick(b.stimulus(np.random.default_rng(7), 200), 300)
    assert b.run(**st).outputs["temp"].tolist() == oracle.freq2temp(b, st["f"])


@pytest.mark.parametrize("rounding,overflow", RULES)
def test_demod_mixer_and_cordic(rounding, overflow):
    d = design_with(**{"demod.rounding": rounding, "demod.overflow": overflow, "demod.lut_bits": 8,
                       "demod.phase_offset_turns": 0.1})
    b = d.blocks["demod"]
    x = b.stimulus(np.random.default_rng(8), 100)["x"][:600]
    b.reset()
    from fxdsp.fixed import OverflowLog
    i, q = b.mix(OverflowLog(), x)
    oi, oq = oracle.demod_mix(b, x)
    assert i.tolist() == oi and q.tolist() == oq
    # CORDIC on every corner of the I/Q plane, including the axes and full scale
    f = b.data_format
    vals = np.array([f.min_int, -12345, -1, 0, 1, 777, f.max_int], dtype=np.int64)
    ii, qq = np.repeat(vals, vals.size), np.tile(vals, vals.size)
    from fxdsp.blocks.demod import cordic_vector
    xk, z = cordic_vector(ii, qq, b.work_format, b.angle_format, b.iterations)
    ox, oz = oracle.cordic(b, ii, qq)
    assert xk.tolist() == ox and z.tolist() == oz


def test_demod_streams_in_chunks_like_one_run(design):
    """State (NCO phase, filters) carries across calls: two halves equal one whole."""
    b = design.blocks["demod"]
    x = b.nominal_stimulus(np.random.default_rng(9), 5000)["x"]
    b.reset()
    whole = b.run(x=x).outputs
    b.reset()
    first = b.run(x=x[:2345]).outputs
    second = b.run(x=x[2345:]).outputs
    b.reset()
    for port in ("i", "q", "amp", "phase"):
        assert np.array_equal(np.concatenate([first[port], second[port]]), whole[port])


def test_chain_paper002_is_the_composition_of_its_blocks(design):
    c = design.chains["chain_paper002"]
    st = c.nominal_stimulus(np.random.default_rng(10), 8192)
    c.reset()
    out = c.run(**st).outputs
    blk = design.blocks
    temp = blk["rtd"].run(code=st["rtd_code"]).outputs["temp"]
    sf = blk["piecewise_sf"].run(temp=temp).outputs["y"]
    v = blk["sf_divide"].run(x=st["vsa"], sf=sf).outputs["y"]
    blk["demod"].reset()
    i = blk["demod"].run(x=v).outputs["i"]
    bias = blk["piecewise_bias"].run(temp=temp).outputs["y"]
    r = blk["bias_subtract"].run(x=i, bias=bias).outputs["y"]
    rate = blk["iir"].filter(r)
    assert np.array_equal(out["temp"], temp) and np.array_equal(out["rate"], rate)


@pytest.mark.parametrize("rounding,overflow", RULES)
def test_lag(rounding, overflow):
    d = design_with(**{"lag.rounding": rounding, "lag.overflow": overflow, "lag.tau_s": 5.0, "lag.alpha_bits": 12})
    b = d.blocks["lag"]
    st = b.stimulus(np.random.default_rng(11), 300)
    b.reset()
    assert b.run(**st).outputs["te"].tolist() == oracle.lag(b, st["temp"])
