"""The one description of each datapath, the instance table and the state contract.

* every model is pure: ``run`` and ``reference`` twice on the same input give the same output,
  and a stream cut anywhere and continued with the returned state equals one whole run;
* wired formats are derived: the design built from the shipped config has every connected input
  in the format of the output that drives it, and stating it agrees or fails naming both fields;
* no code default shadows the shipped TOML: leaving out any key either fails naming it or builds
  exactly the same design;
* the datapath descriptions are frozen, and the instance table's ovf fields account for every
  overflow counter a block reports.
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

from conftest import config_leaves, default_data, without
from fxdsp.errors import InputError
from fxdsp.chains import build
from fxdsp.config import Config

DESIGN = build()
NAMES = list(DESIGN.all)


def _stim(name: str, n: int = 3000):
    return DESIGN.all[name].stimulus(np.random.default_rng([7, NAMES.index(name)]), n)


@pytest.mark.parametrize("name", NAMES)
def test_run_and_reference_are_pure(name):
    block = DESIGN.all[name]
    stim = _stim(name)
    a, b = block.run(**stim), block.run(**stim)
    for port in block.outputs:
        assert np.array_equal(a.outputs[port], b.outputs[port]), port
    assert dict(a.overflows) == dict(b.overflows)
    ra, rb = block.run_float(**stim), block.run_float(**stim)
    for port in block.outputs:
        assert np.array_equal(ra[port], rb[port], equal_nan=True), port


@pytest.mark.parametrize("name", NAMES)
def test_stream_continues_from_the_returned_state(name):
    block = DESIGN.all[name]
    stim = _stim(name)
    n = len(next(iter(stim.values())))
    whole = block.run(**stim)
    cut = n // 3
    head = block.run(**{k: v[:cut] for k, v in stim.items()})
    tail = block.run(state=head.state, **{k: v[cut:] for k, v in stim.items()})
    for port in block.outputs:
        assert np.array_equal(np.concatenate([head.outputs[port], tail.outputs[port]]), whole.outputs[port]), port
    # a fresh run after all that is still the first run: nothing leaked into the block
    again = block.run(**stim)
    for port in block.outputs:
        assert np.array_equal(again.outputs[port], whole.outputs[port]), port


def test_state_of_a_stateful_block_matters():
    """The state test above must be able to fail: a continued stream is not a fresh one."""
    iir = DESIGN.blocks["iir"]
    x = np.full(200, iir.data_format.max_int // 2, dtype=np.int64)
    head = iir.run(x=x)
    assert not np.array_equal(iir.run(x=x, state=head.state).outputs["y"], head.outputs["y"])
    with pytest.raises(ValueError, match="iir: state"):
        iir.run(x=x, state=np.zeros(3))


# ---- wired formats ------------------------------------------------------------------------------
# (input instance.port, driving instance.port): every wire of the config's chains, from their netlists
WIRES = sorted({(f"{dst.instance.replace('.', '_')}.{dst.port}", f"{src.instance.replace('.', '_')}.{src.port}")
                for chain in DESIGN.chains.values() for dst, src in chain.netlist.drivers.items()
                if not isinstance(src, str)})


def _fmt(design, wire):
    inst, port = wire.split(".")
    return design.instances[inst].ports[port].format


def test_the_wires_include_the_papers_chains():
    """The list above is the netlists': it holds the papers' wires (a netlist that lost one would shrink it)."""
    assert {("sf_divide.sf", "piecewise_sf.y"), ("iir.x", "bias_subtract.y"), ("sf_divide000.sf", "piecewise_k1.y"),
            ("bias_subtract001.bias", "piecewise_bias001.y"), ("demod002.ref", "drive.nco"),
            ("freq2temp.f", "drive001.f"), ("demod02.ref", "drive.nco"), ("iir02.x", "bias_subtract02.y")} \
        <= set(WIRES) and len(WIRES) == 19


@pytest.mark.parametrize("dst,src", WIRES)
def test_wired_inputs_follow_their_driver(dst, src):
    """Change the driver's format in the config: the input it drives follows, nothing restated."""
    from fxdsp.blocks.kinds import kind_of

    data = copy.deepcopy(default_data())
    inst = DESIGN.instances[src.split(".")[0]]
    sec = data
    for part in inst.config_path.split("."):
        sec = sec[part]
    key = kind_of(inst.config_path).output_keys[src.split(".")[1]]
    old = _fmt(DESIGN, src)
    # narrower: every width check still holds (a width stated as bits, a format otherwise)
    sec[key] = old.wl - 1 if isinstance(sec[key], int) else f"{'s' if old.signed else 'u'}{old.wl - 1}.{old.fl - 1}"
    if dst in STATED:   # an input of another chain too: its format stated, the mismatch refused by name
        with pytest.raises(ValueError, match=rf"{dst.split('.')[0]}\.\w+: .* must equal"):
            build(Config(data, source="<test>"))
        return
    d = build(Config(data, source="<test>"))
    assert _fmt(d, src) != old
    assert _fmt(d, dst) == _fmt(d, src)


# wired inputs that another chain reads as its own input (chain_paper001's f): their format is stated
STATED = {f"{e.instance.replace('.', '_')}.{e.port}" for chain in DESIGN.chains.values()
          for ends in chain.netlist.inputs.values() for e in ends}


def test_shipped_config_states_no_wired_format():
    data = default_data()
    assert "data_format" not in data["iir"] and "data_format" not in data["demod"]["lpf"]


def test_stated_wired_format_that_agrees_is_accepted():
    data = copy.deepcopy(default_data())
    data["iir"]["data_format"] = data["bias_subtract"]["out_format"]
    assert build(Config(data, source="<test>")).blocks["iir"].data_format == DESIGN.blocks["iir"].data_format


# ---- code defaults ------------------------------------------------------------------------------
def _fingerprint(design):
    return {n: b.parameters() for n, b in design.all.items()} | {
        "_": (design.seed, design.samples, design.fs_hz, design.rate_full_scale_dps)}


@pytest.mark.parametrize("path", [".".join(p) for p in config_leaves(default_data())])
def test_no_code_default_shadows_the_shipped_config(path):
    data = without(*path.split("."))
    try:
        design = build(Config(data, source="<test>"))
    except InputError as exc:   # bad input (exit 2); any other exception is a bug (exit 70)
        assert str(exc).startswith(f"{path}: missing"), exc
        return
    assert _fingerprint(design) == _fingerprint(DESIGN), f"{path}: a code default differs from the shipped value"


# ---- datapath descriptions ---------------------------------------------------------------------
@pytest.mark.parametrize("name", [n for n, i in DESIGN.instances.items() if not i.members])
def test_datapath_is_frozen(name):
    dp = DESIGN.instances[name].block.datapath
    first = dataclasses.fields(dp)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(dp, first, 0)
    for f in dataclasses.fields(dp):
        value = getattr(dp, f.name)
        if hasattr(value, "words"):
            with pytest.raises(ValueError):
                value.words[...] = 0


@pytest.mark.parametrize("name", NAMES)
def test_ovf_fields_cover_every_counter(name):
    """The RTL's ovf vector (from the instance table) and the model's counters name the same things:
    a counter the table does not know would be a flag the RTL test never compares."""
    result = DESIGN.all[name].run(**_stim(name, 500))
    counters = {c for _, c, _ in DESIGN.ovf_fields(name)}
    # a chain using a demodulator's I and Q only: the RTL flags the amp fit, the model never
    # computes it (tests/hdl masks that flag)
    chain = DESIGN.chains.get(name)
    unused = set() if chain is None else {f"{t}.amp" for t, k in chain.kinds.items()
                                          if k == "demod" and not chain.wanted()[t] & {"amp", "phase"}}
    assert set(dict(result.overflows)) == counters - unused


def test_instance_table_has_one_name_per_instance():
    for name, inst in DESIGN.instances.items():
        assert name == inst.config_path.replace(".", "_")
        assert inst.block is DESIGN.all[name]
        assert {p.name for p in inst.inputs} == set(inst.block.inputs)
