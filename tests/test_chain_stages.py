"""The optional stages of chain_paper002 in the model: absent = today's chain,
byte for byte; the lag between the RTD readout and the coefficient engines; the phase trim of the
NCO reference, which rotates quadrature into rate (and, with a known pick-off phase error, removes
it); float reference and budget hybrid extended the same way. The RTL side is
tests/hdl/test_hdl_chain_stages.py."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from conftest import default_data, design_with, lag_edits
from fxdsp.blocks.lag import Lag
from fxdsp.budget.attribution import attribute
from fxdsp.chains import build
from fxdsp.config import Config
from fxdsp.fixed import to_float
from fxdsp.vectors import check, generate

ROOT = Path(__file__).parents[1]
CHAIN = "chain_paper002"
FS = default_data()["system"]["fs_hz"]


def with_lag(**lag):
    lag = {"rate_hz": FS, "tau_s": 0.002, **lag}
    return design_with(chains=True, **lag_edits(), **{f"lag.{k}": v for k, v in lag.items()})


# ---- absent = today ------------------------------------------------------------------------------
def test_a_config_without_the_stages_reproduces_every_committed_vector():
    """The acceptance test: the optional key left out entirely (no phase_trim_rad) gives the
    committed vectors byte for byte, as the shipped neutral value does."""
    data = copy.deepcopy(default_data())
    del data["demod"]["phase_trim_rad"]
    d = build(Config(data, source="<default>"))
    assert d.chains[CHAIN].stages == () and d.blocks["demod"].nco.trim == 0
    assert check(generate(d), ROOT / "vectors") == []


def test_the_check_sees_a_stage():
    """...and the same comparison fails once a stage is on (it can fail)."""
    problems = check(generate(design_with(chains=True, **{"demod.phase_trim_rad": 0.01})), ROOT / "vectors")
    for rel in ("demod/i.hex", "chain_paper002/rate.hex", "manifest.json"):
        assert any(p.startswith(f"differs: {rel} ") for p in problems), (rel, problems)
    assert not any("rtd/" in p or "lag/" in p for p in problems), problems


# ---- config -----------------------------------------------------------------------------------
def test_the_lag_stage_updates_at_a_divisor_of_the_chain_sample_rate():
    from conftest import edited_data

    data = edited_data(**lag_edits())
    d = build(Config(copy.deepcopy(data), source="<test>"))   # the shipped 10 Hz: every 9600th sample
    assert d.blocks["lag"].decimation == FS / data["lag"]["rate_hz"] and d.chains[CHAIN].sensor.lag is d.blocks["lag"]
    assert d.chains[CHAIN].MEMBERS[:2] == ("rtd", "lag") and d.ovf_bit(CHAIN, "lag.te") == 1
    for bad in (7.0, 2 * FS):   # not a whole number of samples; faster than the samples arrive
        data["lag"]["rate_hz"] = bad
        with pytest.raises(ValueError, match=r"^lag\.rate_hz: .* must divide system\.fs_hz"):
            build(Config(copy.deepcopy(data), source="<test>"))
    del data["lag"]["rate_hz"]   # derived: every sample
    d = build(Config(data, source="<test>"))
    assert d.blocks["lag"].rate_hz == FS and d.blocks["lag"].decimation == 1
    # the block alone (no lag stage) takes its stated rate as given, every input an update
    assert design_with(**{"lag.rate_hz": 7.0}).blocks["lag"].decimation == 1


@pytest.mark.parametrize("decimation", [3, 64])
def test_a_decimating_lag_matches_its_oracle_and_continues_across_a_cut(decimation):
    """The state moves on inputs 0, N, 2N, ... and holds between (the oracle, written from that rule);
    a run cut at any phase continues exactly; the float reference holds the same way."""
    from block_oracles import lag as lag_oracle

    lag = with_lag(rate_hz=FS / decimation, tau_s=0.05, state_guard_bits=8, rounding="floor").blocks["lag"]
    assert lag.decimation == decimation
    temp = lag.stimulus(np.random.default_rng(3), 3000)["temp"]
    whole = lag.run(temp=temp)
    assert whole.outputs["te"].tolist() == lag_oracle(lag, temp)
    held = whole.outputs["te"].reshape(-1)[: temp.size // decimation * decimation].reshape(-1, decimation)
    assert np.all(held == held[:, :1]), "the output changes only on an update's sample"
    for cut in (1, decimation + 1, 1001):
        head = lag.run(temp=temp[:cut])
        tail = lag.run(state=head.state, temp=temp[cut:])
        assert np.array_equal(np.concatenate([head.outputs["te"], tail.outputs["te"]]), whole.outputs["te"]), cut
    ref = lag.run_float(temp=temp)["te"]   # the reference on the real values of the same codes
    undecimated = Lag(lag.temp_format, lag.tau_s, lag.rate_hz, lag.alpha_bits, lag.g, lag.rules)
    assert np.array_equal(ref[::decimation], undecimated.run_float(temp=temp[::decimation])["te"])
    assert np.array_equal(ref, np.repeat(ref[::decimation], decimation)[:temp.size])
    with pytest.raises(ValueError, match="phase"):
        lag.set_state({**head.state, "phase": decimation})


def test_trim_word_is_the_nearest_phase_word_modulo_a_turn():
    nco = design_with(chains=True, **{"demod.phase_trim_rad": -0.3}).blocks["demod"].nco
    exact = (-0.3 / (2 * np.pi)) % 1.0 * 2.0**nco.phase_bits
    assert abs(nco.trim - exact) <= 0.5 and nco.trim > 2 ** (nco.phase_bits - 1)   # wrapped: a negative trim
    assert nco.phases(3)[0] == nco.trim      # the table is read at accumulator + trim
    assert nco.drive_phase(3)[0] == 0.0 and nco.reference_phase(3)[0] == -0.3


# ---- the stages change the output --------------------------------------------------------------
def _stimulus(d):
    return d.chains[CHAIN].stimulus(np.random.default_rng(5), 0)


def test_the_lag_feeds_the_engines_and_nothing_else():
    """With the lag, the chain's rate is the plain chain's rate evaluated at Te: the same chain with
    the RTD readout replaced by codes whose temperature is the lag's output gives the same rate."""
    plain, lagged = design_with(chains=True), with_lag()
    ins = _stimulus(plain)
    a = lagged.chains[CHAIN].run(**ins)
    b = plain.chains[CHAIN].run(**ins)
    assert np.array_equal(a.outputs["temp"], b.outputs["temp"])
    assert np.count_nonzero(a.outputs["rate"] != b.outputs["rate"]) > 0.9 * ins["vsa"].size
    te = lagged.blocks["lag"].run(temp=b.outputs["temp"]).outputs["te"]
    assert not np.array_equal(te, b.outputs["temp"])
    # the engines at Te, by hand, then the rest of the chain
    c = lagged.chains[CHAIN]
    sf = c.sensor.sf.run(temp=te).outputs["y"]
    v = c.sensor.divide.run(x=ins["vsa"], sf=sf).outputs["y"]
    i = c.sensor.demod.run(x=v).outputs["i"]
    r = c.sensor.subtract.run(x=i, bias=c.sensor.bias.run(temp=te).outputs["y"]).outputs["y"]
    assert np.array_equal(c.sensor.lpf.run(x=r).outputs["y"], a.outputs["rate"])
    assert "lag.te" in a.overflows


def test_the_chain_with_stages_continues_from_its_state():
    chain = with_lag().chains[CHAIN]
    ins = _stimulus(design_with(chains=True))
    whole = chain.run(**ins)
    cut = ins["vsa"].size // 3
    head = chain.run(**{k: v[:cut] for k, v in ins.items()})
    assert set(head.state) == {"demod", "iir", "lag"}
    tail = chain.run(state=head.state, **{k: v[cut:] for k, v in ins.items()})
    for port in chain.outputs:
        assert np.array_equal(np.concatenate([head.outputs[port], tail.outputs[port]]), whole.outputs[port]), port


def _held(d, phase_error: float, rate_fs: float, quad_fs: float, n: int = 12000) -> float:
    """Mean rate output (FS) of the bit-exact chain, settled, at a held 25 C, for a sense signal
    SF (rate + bias) cos(w t + phi) + SF quad cos(w t + phi + pi/2): a pick-off phase error phi."""
    c = d.chains[CHAIN]
    t = np.full(n, 25.0)
    sf, bias = c.sensor.sf.reference(temp=t)["y"], c.sensor.bias.reference(temp=t)["y"]
    vsa = (c.sensor.demod.carrier(sf * (rate_fs + bias), phase_error, n)
           + c.sensor.demod.carrier(sf * quad_fs, phase_error + np.pi / 2, n))
    codes = c.sensor.digitise({"vsa": vsa, "rtd_frac": c.sensor.rtd.adc_fraction(t)})
    rate = to_float(c.run(**codes).outputs["rate"], c.outputs["rate"])
    return float(rate[n // 2:].mean())


def test_the_trim_rotates_quadrature_into_rate():
    """No phase error, a trim theta: I = R cos theta + Q sin theta (+ the bias's own rotation)."""
    theta, R, Q = 0.2, 0.05, 0.3
    got = _held(design_with(chains=True, **{"demod.phase_trim_rad": theta}), 0.0, R, Q)
    bias = design_with(chains=True).chains[CHAIN].sensor.bias.reference(temp=np.array([25.0]))["y"][0]
    want = R * np.cos(theta) + Q * np.sin(theta) + bias * (np.cos(theta) - 1)
    assert abs(got - want) < 2e-5, (got, want)
    assert abs(_held(design_with(chains=True), 0.0, R, Q) - R) < 2e-5


def test_the_trim_removes_a_known_phase_error():
    """Quadrature 0.3 FS, pick-off phase error phi = 0.05 rad (c = -tan phi): without the trim the
    rate reads -Q sin phi = -0.015 FS off; the trim -atan(c) = phi removes it; the opposite sign
    doubles it (so the criterion can fail)."""
    phi, R, Q = 0.05, 0.02, 0.3
    tol = 2e-5
    untrimmed = _held(design_with(chains=True), phi, R, Q)
    assert abs(untrimmed - (R - Q * np.sin(phi))) < 1e-3
    c = -np.tan(phi)
    trimmed = _held(design_with(chains=True, **{"demod.phase_trim_rad": -np.arctan(c)}), phi, R, Q)
    assert abs(trimmed - R) < tol, trimmed - R
    wrong = _held(design_with(chains=True, **{"demod.phase_trim_rad": np.arctan(c)}), phi, R, Q)
    assert abs(wrong - R) > 100 * tol and abs(wrong - R) > 1.5 * abs(untrimmed - R)


# ---- float reference and budget follow the stages -------------------------------------------------
@pytest.mark.parametrize("edits", [{"demod.phase_trim_rad": -2.2}, "lag", "lag/32"], ids=["trim", "lag", "lag/32"])
def test_float_reference_and_budget_hybrid_follow_the_stages(edits):
    if edits == "lag/32":   # updated on every 32nd sample
        d = with_lag(rate_hz=FS / 32)
    else:
        d = with_lag() if edits == "lag" else design_with(chains=True, **edits)
    chain = d.chains[CHAIN]
    ins = _stimulus(d)
    fixed = to_float(chain.run(**ins).outputs["rate"], chain.outputs["rate"])
    ref = chain.run_float(**ins)["rate"]
    plain = design_with(chains=True).chains[CHAIN].run_float(**ins)["rate"]
    n = ins["vsa"].size - 1024   # the saturating tail clips the fixed-point chain, not the float one
    err = np.abs(fixed - ref)[1000:n].max()
    assert err < 1e-4, err
    assert np.abs(fixed - plain)[1000:n].max() > 100 * err   # the reference without the stage is far off
    # the budget's hybrid with every source on is the bit-exact chain
    assert attribute(d, CHAIN, n=8192, keep_signals=False).hybrid_max_diff == 0.0
