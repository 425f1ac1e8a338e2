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
                       "iir.data_format": "s18.16", "iir.cutoff_hz": 2000.0, "iir.num_format": "s24.26",
                       "iir.den_format": "s28.26"})
    b = d.blocks["iir"]
    x = b.stimulus(np.random.default_rng(2), 200)["x"][:1400]  # impulses, steps, corners, saturating square
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


@pytest.mark.parametrize("interp_bits", [0, 1, 7])
@pytest.mark.parametrize("rounding,overflow", RULES)
def test_demod_mixer_and_cordic(rounding, overflow, interp_bits):
    d = design_with(**{"demod.rounding": rounding, "demod.overflow": overflow, "demod.lut_bits": 8,
                       "demod.interp_bits": interp_bits, "demod.phase_offset_turns": 0.1,
                       "demod.lut_format": "s16.15"})
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
    xk, z = cordic_vector(ii, qq, b.datapath)
    ox, oz = oracle.cordic(b, ii, qq)
    assert xk.tolist() == ox and z.tolist() == oz


def test_demod_streams_in_chunks_like_one_run(design):
    """State (NCO phase, filters) carries across calls as scipy's zi/zf: two halves equal one whole."""
    b = design.blocks["demod"]
    x = b.nominal_stimulus(np.random.default_rng(9), 5000)["x"]
    whole = b.run(x=x).outputs
    head = b.run(x=x[:2345])
    first, second = head.outputs, b.run(x=x[2345:], state=head.state).outputs
    for port in ("i", "q", "amp", "phase"):
        assert np.array_equal(np.concatenate([first[port], second[port]]), whole[port])


def _chain_rows(stim: dict, step: int, tail: int, n_nominal: int = 8192) -> dict:
    """Every ``step``-th sample of the nominal part plus the first ``tail`` samples after it (the
    full-scale corner): a short stream with the same coverage, fast enough for the oracles."""
    rows = np.r_[0:n_nominal:step, n_nominal:n_nominal + tail]
    return {k: v[rows] for k, v in stim.items()}


def test_chain_paper002_equals_the_oracles_composed_from_the_config(design):
    """The chain against the independent integer oracles (tests/block_oracles.py) wired as paper 002's
    figure 4: RTD -> SF(T) -> divide -> demod (I) -> - bias(T) -> low-pass. The oracles read only the
    blocks' parameters (built here from the config, blocks only), so a block computing wrongly in
    the chain is caught, unlike a recomposition of the chain's own block objects."""
    c = design.chains["chain_paper002"]
    st = _chain_rows(c.stimulus(np.random.default_rng(10), 8192), step=8, tail=256)
    res = c.run(**st)
    p = design_with()  # the same config, blocks only: parameters for the oracles
    temp = oracle.rtd(p.blocks["rtd"], st["rtd_code"])
    sf = oracle.piecewise(p.blocks["piecewise_sf"], temp)
    v = oracle.sf_divide(p.blocks["sf_divide"], st["vsa"], sf)
    demod = p.blocks["demod"]
    i = oracle.iir(demod.lpf_i, oracle.demod_mix(demod, v)[0])
    bias = oracle.piecewise(p.blocks["piecewise_bias"], temp)
    r = oracle.bias_subtract(p.blocks["bias_subtract"], i, bias)
    rate = oracle.iir(p.blocks["iir"], r)
    assert res.outputs["temp"].tolist() == temp
    assert res.outputs["rate"].tolist() == rate
    # the stream is worth checking: every SF segment is used and the sense input reaches full scale
    bps = p.blocks["piecewise_sf"].breakpoints
    assert min(temp) < int(bps[0]) and max(temp) > int(bps[-1])
    fmt = c.inputs["vsa"]
    assert st["vsa"].max() == fmt.max_int and st["vsa"].min() == fmt.min_int


def test_chain_paper001_equals_the_oracles_composed_from_the_config(design):
    """Paper 001's chain (f -> T -> quadratic bias -> subtract) against the oracles, likewise."""
    c = design.chains["chain_paper001"]
    st = c.stimulus(np.random.default_rng(12), 600)
    res = c.run(**st)
    p = design_with()
    temp = oracle.freq2temp(p.blocks["freq2temp"], st["f"])
    bias = oracle.piecewise(p.blocks["piecewise_bias001"], temp)
    rate = oracle.bias_subtract(p.blocks["bias_subtract001"], st["rate_in"], bias)
    assert res.outputs["temp"].tolist() == temp
    assert res.outputs["rate"].tolist() == rate


@pytest.mark.parametrize("rounding,overflow", RULES)
def test_lag(rounding, overflow):
    d = design_with(**{"lag.rounding": rounding, "lag.overflow": overflow, "lag.tau_s": 5.0, "lag.alpha_bits": 12})
    b = d.blocks["lag"]
    st = b.stimulus(np.random.default_rng(11), 300)
    assert b.run(**st).outputs["te"].tolist() == oracle.lag(b, st["temp"])


NARROW_NCO = {"drive.phase_bits": 16, "drive.lut_bits": 8, "drive.interp_bits": 8, "drive.lut_format": "s12.11",
              # the demodulator on the loop's NCO takes its width: its table and interpolation must fit it
              "demod002.lut_bits": 8, "demod002.interp_bits": 8, "demod02.lut_bits": 8, "demod02.interp_bits": 8}


@pytest.mark.parametrize("rounding,overflow,lpf_rules,update,narrow", [
    (r, o, lr, u, n) for (r, o), lr, u, n in zip(RULES, RULES[1:] + RULES[:1], (8, 1, 3, 8), (False, True, False, True))])
def test_drive(rounding, overflow, lpf_rules, update, narrow):
    """The drive loop against its oracle: corner codes and a saturating pick-off (mixers and DAC
    at their limits, the PIs at theirs), then a pick-off in lock stepping 0.5 Hz (the PLL tracking),
    with the control update every 1, 3 or 8 samples; two with a narrow NCO, where one LSB of the
    carrier's advance reaches the table. The low-pass has rules of its own (its table's, as its RTL's
    LPF_ parameters), different from the loop's."""
    d = design_with(**{"drive.rounding": rounding, "drive.overflow": overflow, "drive.lpf.rounding": lpf_rules[0],
                       "drive.lpf.overflow": lpf_rules[1], "drive.update_every": update,
                       **(NARROW_NCO if narrow else {})})
    b = d.blocks["drive"]
    corners = b.stimulus(np.random.default_rng(5), 64)["x"][:300]
    locked = b.nominal_stimulus(np.random.default_rng(6), 4096)["x"][2000:2300]
    x = np.concatenate([corners, locked])
    got = b.run(x=x)
    want = oracle.drive(b, x)
    for port in ("dac", "f", "amp", "phase", "nco"):
        assert got.outputs[port].tolist() == want[port], port
    assert len(set(want["f"])) > 3, "the frequency word must move"
