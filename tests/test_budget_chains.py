"""The budget's attribution composes any chain from its netlist (fxdsp.budget.hybrid.HYBRIDS): chains
the project never declared, with and without a sensor, with outputs the papers' chains leave
unread (the demodulator's Q, amplitude and phase, an engine's output). The evidence is the bit-exact
chain itself: with every source on, the hybrid must reproduce it exactly, and with every source off
it must be the chain's float reference; each member contributes the sources of its kind."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from conftest import edited_data
from fxdsp.budget.attribution import attribute
from fxdsp.budget.hybrid import HYBRIDS, Switch, chain_analog, chain_sources, run_chain
from fxdsp.chains import build
from fxdsp.config import Config

# chains no config of the project declares: the paper 002 blocks composed differently
USER_CHAINS = {
    # the demodulator's every output read; the SF engine's output as a chain output; no sensor
    "taps": {"instances": ["rtd", "piecewise.sf", "sf_divide", "demod", "piecewise.bias", "bias_subtract", "iir"],
             "inputs": ["vsa -> sf_divide.x", "rtd_code -> rtd.code"],
             "wires": ["rtd.temp -> piecewise.sf.temp", "rtd.temp -> piecewise.bias.temp",
                       "piecewise.sf.y -> sf_divide.sf", "sf_divide.y -> demod.x", "demod.i -> bias_subtract.x",
                       "piecewise.bias.y -> bias_subtract.bias", "bias_subtract.y -> iir.x"],
             "outputs": ["iir.y -> rate", "demod.q -> quad", "demod.amp -> amp", "demod.phase -> phase",
                         "piecewise.sf.y -> sf"]},
    # the same with the paper 002 sensor: its ADCs are sources too
    "sensed": {"sensor": "gyro_rtd",
               "instances": ["rtd", "piecewise.sf", "sf_divide", "demod", "piecewise.bias", "bias_subtract", "iir"],
               "inputs": ["vsa -> sf_divide.x", "rtd_code -> rtd.code"],
               "wires": ["rtd.temp -> piecewise.sf.temp", "rtd.temp -> piecewise.bias.temp",
                         "piecewise.sf.y -> sf_divide.sf", "sf_divide.y -> demod.x",
                         "demod.i -> bias_subtract.x", "piecewise.bias.y -> bias_subtract.bias",
                         "bias_subtract.y -> iir.x"],
               "outputs": ["iir.y -> rate", "demod.q -> quad", "bias_subtract.y -> unfiltered"]},
}


@pytest.fixture(scope="module")
def design():
    data = edited_data()
    for name, table in USER_CHAINS.items():
        data.setdefault("chain", {})[name] = copy.deepcopy(table)
    return build(Config(data, source="<user chains>"))


def _all_chains(design):
    return list(design.chains)


def test_every_chain_is_attributed_from_its_netlist(design):
    """For every chain of the design (the papers' and the user's) and every output: all sources on
    is the bit-exact chain, to the LSB."""
    assert {"chain_taps", "chain_sensed"} <= set(design.chains)
    for name, chain in design.chains.items():
        for port in chain.outputs:
            a = attribute(design, name, port, n=4096, keep_signals=False)
            assert a.hybrid_max_diff == 0.0, f"{name}.{port}: all-on hybrid differs from the bit-exact chain"
            assert np.isfinite(a.total_rms)


def test_all_off_is_the_float_reference(design):
    """With no source on, the hybrid of a chain without ADCs (no sensor) is its float reference on
    the same inputs."""
    chain = design.chains["chain_taps"]
    stim = chain_analog(chain, np.random.default_rng(5), 4096)
    nodes = run_chain(chain, stim["analog"], Switch())
    ref = chain.run_float(**stim["codes"])
    for port in chain.outputs:
        np.testing.assert_allclose(nodes[port], ref[port], rtol=1e-9, atol=1e-12 * np.abs(ref[port]).max(),
                                   err_msg=f"chain_taps.{port}")


def test_sources_follow_the_members_and_the_sensor(design):
    """Each member contributes its kind's sources under its own name; a chain with a sensor adds one
    ADC per chain input, a chain without one none."""
    for name, chain in design.chains.items():
        sources = chain_sources(chain)
        names = [s.name for s in sources]
        assert len(names) == len(set(names)), f"{name}: a source named twice"
        wanted = chain.wanted()
        for inst in chain.netlist.order:
            iid = inst.replace(".", "_")
            own = HYBRIDS[chain.kinds[inst]].sources(iid, chain.members[inst], wanted[inst])
            assert [s.name for s in own] == [s.name for s in sources if s.stage == iid and s.kind != "adc"]
        adc = [s.name for s in sources if s.kind == "adc"]
        assert adc == ([f"adc.{i}" for i in chain.netlist.inputs] if chain.sensor is not None else [])
    taps = [s.name for s in chain_sources(design.chains["chain_taps"])]
    assert "demod.cordic" in taps   # amp and phase are read: the CORDIC is a source


def test_a_source_switched_on_moves_its_output(design):
    """Can fail: a source that is listed but never applied leaves the output at the float value."""
    chain = design.chains["chain_sensed"]
    stim = chain_analog(chain, np.random.default_rng(9), 4096)
    ref = run_chain(chain, stim["analog"], Switch())
    moved = {s.name: float(np.abs(run_chain(chain, stim["analog"], Switch(on=[s.name]))[s.node] - ref[s.node]).max())
             for s in chain_sources(chain)}
    still = [n for n, d in moved.items() if d == 0.0]
    assert not still, f"sources that change nothing at their own node: {still}"


def test_every_chain_has_the_word_length_knobs_of_its_members(design):
    """The search's knobs come from the members' kinds: every chain of the config (the user's too)
    has them, each names a field its config holds, and a knob moves its field."""
    from fxdsp.budget.optimise import _field_defaults, _get, knob_value, knobs_of, set_knob

    data = design.config.data
    for name, chain in design.chains.items():
        knobs = knobs_of(data, name)
        assert knobs, f"{name}: no knobs"
        tables = {f[0] for k in knobs for f in k.fields}
        members = set(chain.netlist.instances)
        assert {t.split(".lpf")[0] for t in tables} <= members, f"{name}: a knob outside the chain"
        defaults = _field_defaults(data, name)
        for k in knobs:
            edited = copy.deepcopy(data)
            set_knob(edited, k, knob_value(data, k) + 1, defaults)
            assert knob_value(edited, k) == knob_value(data, k) + 1
            assert all(_get(edited, f) != _get(data, f) for f in k.fields)
