"""Physical units follow the wires (no hand list of units). The expected units are the
papers' (a rate in deg/h, an acceleration in mg, a temperature in C), and the mismatches are
generated from the shipped chains: every subtraction's bias rewired from every output of the chain
in another unit must be refused, naming the chain and both wires."""

from __future__ import annotations

import copy

import pytest

from conftest import default_data
from fxdsp.chains import build
from fxdsp.config import Config
from fxdsp.errors import InputError
from fxdsp.units import QUANTITIES

DATA = default_data()
FS_DEGH = DATA["system"]["rate_full_scale_dps"] * 3600.0


def _config(data: dict) -> Config:
    return Config(data, source="<test>")


def _unit(design, inst: str, port: str) -> tuple[str, float]:
    p = design.instances[inst].ports[port]
    return p.unit, p.scale


def test_the_papers_outputs_are_in_the_papers_units():
    d = build()
    # paper 002: the sense ADC is a fraction of the rate full scale; the rate reads in deg/h
    assert _unit(d, "chain_paper002", "rate") == ("deg/h", FS_DEGH)
    assert _unit(d, "chain_paper002", "temp") == ("C", 1.0)
    # paper 001: the rate input and its compensated output in deg/h, the thermometer in C
    assert _unit(d, "chain_paper001", "rate") == ("deg/h", 1.0)
    assert _unit(d, "chain_paper001", "temp") == ("C", 1.0)
    # paper 000: (Df [Hz] - K0 [Hz]) / K1 [Hz/g] is g, read in mg
    assert _unit(d, "chain_paper000", "accel") == ("mg", 1e3)
    assert _unit(d, "piecewise_k1", "y") == ("Hz/g", 1.0)
    # SF(T) is a ratio read in ppm, the demodulator's phase in mrad
    assert _unit(d, "piecewise_sf", "y") == ("ppm", 1e6)
    assert _unit(d, "demod", "phase") == ("mrad", 1e3)


def _bias_rewires():
    """(chain, edited table, the two wire texts the error must name): every subtraction's bias input
    driven by every other output of its chain that carries a different unit."""
    d = build()
    for name, net in DATA["chain"].items():
        chain = d.chains[f"chain_{name}"]
        for line in net["wires"]:
            src, dst = (s.strip() for s in line.split("->"))
            inst, _, port = dst.rpartition(".")
            if not inst.startswith("bias_subtract") or port != "bias":
                continue
            want = d.instances[inst.replace(".", "_")].ports["x"].quantity
            for other in chain.netlist.order[:chain.netlist.order.index(inst)]:   # upstream: no loop
                o = d.instances[other.replace(".", "_")]
                for p in o.outputs:
                    if p.quantity and p.quantity != want and other != inst:
                        new = f"{other}.{p.name} -> {dst}"
                        wires = [new if w == line else w for w in net["wires"]]
                        yield name, {**net, "wires": wires}, new


CASES = list(_bias_rewires())


def test_every_shipped_chain_has_a_subtraction_to_mis_wire():
    """Every shipped chain with a subtraction (the papers'; a drive loop's chain has none)."""
    subtracting = {n for n, net in DATA["chain"].items() if any(i.startswith("bias_subtract") for i in net["instances"])}
    assert {c[0] for c in CASES} == subtracting >= {"paper000", "paper001", "paper002"}


@pytest.mark.parametrize("name,table,wire", CASES, ids=[f"{c[0]}:{c[2]}" for c in CASES])
def test_a_subtraction_of_two_units_names_the_chain_and_the_wire(name, table, wire):
    data = copy.deepcopy(DATA)
    data["chain"][name] = table
    with pytest.raises(InputError) as info:
        build(_config(data))
    msg = str(info.value)
    assert f"chain.{name}" in msg and wire in msg and "\n" not in msg, msg


def test_a_chain_the_project_never_declared_gets_its_units_from_its_wires():
    """RTD -> lag -> a deg/h bias table -> subtract from a rate: the rate output is in deg/h, though no
    table of the project names this chain; a divide by a table in an undeclared unit stays unknown
    rather than invented."""
    data = copy.deepcopy(DATA)
    data["piecewise"]["mine"] = {k: v for k, v in DATA["piecewise"]["bias001"].items() if k != "temp_format"}
    data["bias_subtract9"] = copy.deepcopy(DATA["bias_subtract001"])
    data["lag"]["temp_format"] = DATA["rtd"]["temp_format"]
    data["chain"]["mine"] = {
        "instances": ["rtd", "lag", "piecewise.mine", "bias_subtract9"],
        "inputs": ["code -> rtd.code", "w -> bias_subtract9.x"],
        "wires": ["rtd.temp -> lag.temp", "lag.te -> piecewise.mine.temp", "piecewise.mine.y -> bias_subtract9.bias"],
        "outputs": ["bias_subtract9.y -> rate", "lag.te -> die"]}
    d = build(_config(data))
    assert _unit(d, "chain_mine", "rate") == ("deg/h", 1.0)
    assert _unit(d, "chain_mine", "w") == ("deg/h", 1.0)   # one unit on both operands
    assert _unit(d, "chain_mine", "die") == ("C", 1.0)
    del data["piecewise"]["k1"]["unit"]
    d = build(_config(data))
    assert _unit(d, "sf_divide000", "y") == ("", 1.0)


@pytest.mark.parametrize("where", ["piecewise.k0.unit", "chain.paper000.input_units.df"])
@pytest.mark.parametrize("value", ["ppn", "", 3, "hz"])
def test_an_unknown_unit_is_refused_naming_the_field(where, value):
    data = copy.deepcopy(DATA)
    *path, key = where.split(".")
    node = data
    for k in path:
        node = node[k]
    node[key] = value
    with pytest.raises(InputError) as info:
        build(_config(data))
    msg = str(info.value)
    assert where in msg and all(q in msg for q in QUANTITIES), msg


@pytest.mark.parametrize("units, words", [
    ({"dff": "Hz"}, ("chain.paper000.input_units.dff", "'df'")),              # not a chain input
    ({"df": "C"}, ("chain.paper000", "df -> bias_subtract000.x")),           # contradicts what it drives
])
def test_input_units_must_name_a_chain_input_in_the_unit_it_drives(units, words):
    data = copy.deepcopy(DATA)
    data["chain"]["paper000"]["input_units"] = units
    with pytest.raises(InputError) as info:
        build(_config(data))
    assert all(w in str(info.value) for w in words), str(info.value)
