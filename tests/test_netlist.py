"""Chains declared in the config: any valid netlist of the blocks is a model; every
wiring error names the chain, the wire and the field. The bad netlists are generated from the
shipped chains' own lines (every wire removed, repeated, misnamed, looped), not listed by hand."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from conftest import default_data, run_cli
from fxdsp.chains import build
from fxdsp.config import Config
from fxdsp.netlist import WiringError, with_stage, without_stage

DATA = default_data()
CHAINS = sorted(DATA["chain"])


def _with_chain(name: str, table: dict, data: dict | None = None) -> Config:
    data = copy.deepcopy(DATA if data is None else data)
    data["chain"][name] = table
    return Config(data, source="<test>")


def _error(name: str, table: dict) -> str:
    with pytest.raises(WiringError) as info:
        build(_with_chain(name, table))
    message = str(info.value)
    assert "\n" not in message
    return message


def _cases():
    """(chain, what, edited table, text the error must hold) for every line of every shipped chain."""
    for name in CHAINS:
        net = DATA["chain"][name]
        for i, line in enumerate(net["wires"]):
            src, dst = (s.strip() for s in line.split("->"))
            rest = net["wires"][:i] + net["wires"][i + 1:]
            yield name, f"open {dst}", {**net, "wires": rest}, f"input {dst} is left open"
            yield name, f"twice {dst}", {**net, "wires": net["wires"] + [line]}, f"{dst} is already driven"
            inst, _, port = dst.rpartition(".")
            bad = f"{src} -> {inst}.{port}x"
            yield name, f"port {dst}", {**net, "wires": rest + [bad]}, f"{inst} has no input '{port}x'"
            head, _, out = src.rpartition(".")
            bad = f"{head}.{out}x -> {dst}"
            yield name, f"output {src}", {**net, "wires": rest + [bad]}, f"{head} has no output '{out}x'"
            bad = f"nosuch.{out} -> {dst}"
            yield name, f"instance {src}", {**net, "wires": rest + [bad]}, "'nosuch' is not an instance"
        for line in net["outputs"]:
            yield name, f"output twice {line}", {**net, "outputs": net["outputs"] + [line]}, "is driven twice"
        # a loop: the first instance fed by a chain input is fed by the chain's last output instead
        first_in = net["inputs"][0]
        _, dst = (s.strip() for s in first_in.split("->"))
        last = next(s.strip() for s in net["outputs"][-1].split("->"))
        looped = {**net, "inputs": net["inputs"][1:], "wires": net["wires"] + [f"{last} -> {dst}"]}
        yield name, "loop", looped, "closes a loop"


CASES = list(_cases())


def test_the_generated_cases_cover_every_class_and_chain():
    kinds = {what.split()[0] for _, what, _, _ in CASES}
    assert kinds == {"open", "twice", "port", "output", "instance", "loop"} and {c for c, *_ in CASES} == set(CHAINS)
    assert len(CASES) >= 5 * sum(len(DATA["chain"][c]["wires"]) for c in CHAINS)


@pytest.mark.parametrize("name,what,table,needle", CASES, ids=[f"{c}:{w}" for c, w, _, _ in CASES])
def test_a_wiring_error_names_the_chain_the_wire_and_the_field(name, what, table, needle):
    message = _error(name, table)
    assert message.startswith(f"chain.{name}."), message
    assert needle in message, message


def test_a_format_mismatch_names_both_fields():
    """A stated format that disagrees with the output wired to it; one chain input, two formats."""
    data = copy.deepcopy(DATA)
    data["iir"]["data_format"] = "s30.22"
    with pytest.raises(ValueError) as info:
        build(Config(data, source="<test>"))
    assert str(info.value).startswith("iir.data_format: s30.22 must equal bias_subtract.out_format (wired by "
                                      "chain.paper002.wires: 'bias_subtract.y -> iir.x') (s24.22)"), info.value
    data = copy.deepcopy(DATA)
    data["piecewise"]["k1"]["temp_format"] = "s20.9"
    with pytest.raises(WiringError, match=r"^chain\.paper000\.inputs: 'temp -> piecewise\.k1\.temp': chain input "
                                          r"'temp' drives piecewise\.k0\.temp \(s18\.9\) and piecewise\.k1\.temp \(s20\.9\)"):
        build(Config(data, source="<test>"))


def test_a_bad_netlist_is_one_line_and_exit_2_from_the_cli(tmp_path):
    import tomllib  # noqa: F401 (the config written below must parse)

    from fxdsp.config import dumps

    name, _, table, needle = CASES[0]
    path = tmp_path / "bad.toml"
    path.write_text(dumps(_with_chain(name, table).data))
    code, err = run_cli(["vectors", "--config", str(path), "--out", str(tmp_path / "v")])
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "v").exists()


# ---- a chain the shipped config does not have ------------------------------------------------------
BRANCH = {"instances": ["rtd", "piecewise.bias", "piecewise.sf", "sf_divide"],
          "inputs": ["code -> rtd.code", "v -> sf_divide.x"],
          "wires": ["rtd.temp -> piecewise.sf.temp", "rtd.temp -> piecewise.bias.temp", "piecewise.sf.y -> sf_divide.sf"],
          "outputs": ["sf_divide.y -> scaled", "piecewise.bias.y -> bias", "rtd.temp -> temp"]}


def test_a_new_netlist_is_the_composition_of_its_blocks():
    """Branching, another order, no sensor: the chain's run is its blocks' runs wired by hand, its
    overflow vector in the order of its instances, its reference the blocks' references."""
    d = build(_with_chain("branch", BRANCH))
    chain = d.chains["chain_branch"]
    assert chain.MEMBERS == ("rtd", "piecewise_bias", "piecewise_sf", "sf_divide")
    assert [f[0] for f in d.ovf_fields("chain_branch")][0] == "rtd"
    ins = chain.stimulus(np.random.default_rng(4), 500)
    assert set(ins) == {"code", "v"}
    got = chain.run(**ins)
    b = d.blocks
    temp = b["rtd"].run(code=ins["code"]).outputs["temp"]
    sf = b["piecewise_sf"].run(temp=temp).outputs["y"]
    want = {"temp": temp, "bias": b["piecewise_bias"].run(temp=temp).outputs["y"],
            "scaled": b["sf_divide"].run(x=ins["v"], sf=sf).outputs["y"]}
    for port, value in want.items():
        assert np.array_equal(got.outputs[port], value), port
    ref = chain.run_float(**ins)
    t = b["rtd"].run_float(code=ins["code"])["temp"]
    assert np.allclose(ref["bias"], b["piecewise_bias"].reference(temp=t)["y"], rtol=0, atol=1e-12)


def test_the_lag_is_a_netlist_edit_and_its_inverse():
    net = DATA["chain"]["paper002"]
    lagged = with_stage(net, "lag")
    assert lagged["instances"][:2] == ["rtd", "lag"] and "rtd.temp -> lag.temp" in lagged["wires"]
    assert "lag.te -> piecewise.sf.temp" in lagged["wires"] and "rtd.temp -> temp" in lagged["outputs"]
    back = without_stage(lagged, "lag")
    assert sorted(back["wires"]) == sorted(net["wires"]) and back["instances"] == net["instances"]
    d = build(_with_chain("paper002", lagged))
    assert d.chains["chain_paper002"].stages == ("lag",) and d.blocks["lag"].decimation > 1


def test_a_stage_goes_in_front_of_a_chain_input_and_comes_out_again():
    """The lag after a chain input (a thermometer read as a word, paper 000's temp): the input then
    drives the lag alone and the lag every port the input drove; the inverse restores the table."""
    net = DATA["chain"]["paper000"]
    lagged = with_stage(net, "lag", chain_input="temp")
    assert lagged["instances"][0] == "lag" and "temp -> lag.temp" in lagged["inputs"]
    assert {"lag.te -> piecewise.k0.temp", "lag.te -> piecewise.k1.temp"} <= set(lagged["wires"])
    assert not [line for line in lagged["inputs"] if line.startswith("temp ->") and "lag" not in line]
    back = without_stage(lagged, "lag")
    for key in ("inputs", "wires"):
        assert sorted(back[key]) == sorted(net[key]), key
    assert back["instances"] == net["instances"]
    data = default_data()
    data["lag"]["temp_format"] = data["piecewise"]["k0"]["temp_format"]
    data["chain"]["paper000"] = {k: v for k, v in lagged.items() if k != "sensor"}   # qvba reads temp itself
    d = build(Config(data, source="paper000 with a lag"))
    assert d.chains["chain_paper000"].stages == ("lag",)


# ---- paper 000 ------------------------------------------------------------------------------------
def test_paper000_is_the_papers_acceleration_within_a_microg():
    """a = (Df - K0(t)) / K1(t), t = T - 25 C, with K0, K1 the cubics of the config (written here from
    the paper's formula, not from the blocks): the float reference equals it, the bit-exact chain
    is within 2 ug of it, and the sensor's Df round-trips the acceleration it was made from."""
    d = build()
    chain = d.chains["chain_paper000"]
    nom = chain.sensor.nominal_analog(np.random.default_rng(9), 8000)
    codes = nom["codes"]
    temp = codes["temp"] * 2.0 ** -9
    df = codes["df"] * 2.0 ** -16

    def cubic(table):
        c = DATA["piecewise"][table]["coefficients"][0]
        t = temp - DATA["piecewise"][table]["t0_c"]
        return sum(ci * t ** i for i, ci in enumerate(c))

    truth = (df - cubic("k0")) / cubic("k1")
    ref = chain.run_float(**codes)["accel"]
    assert np.max(np.abs(ref - truth)) < 1e-12
    fixed = chain.real_outputs(chain.run(**codes))["accel"]
    err = fixed - truth
    assert np.sqrt(np.mean(err ** 2)) < 1e-6 and np.max(np.abs(err)) < 2e-6, (np.sqrt(np.mean(err ** 2)), err.max())
    assert np.max(np.abs(fixed - nom["accel_g"])) < 2e-5   # counter noise 1e-4 Hz = 2 ug rms


# ---- every chain's top is generated; the engines it shares come from the netlist ------------------
def test_every_chain_gets_a_generated_top_and_shares_engines_by_wiring_and_format(tmp_path):
    """Every chain of a config, and only those, has a generated top among the sources; in paper 002's
    serial top bias(T) is SF(T)'s engine's second coefficient set (same temperature, same breakpoints
    and formats) and the output low-pass the demodulator's filter engine's third channel. Moving a
    breakpoint of bias(T), or giving the output low-pass another rounding, splits the engine: a
    shared engine is decided by wiring and format, not by name. The schedule counts the sharing (the
    bias pass after SF's, on the one multiplier)."""
    from fxdsp.hdl import harness as hh
    from fxdsp.hdl.schedule import chain_schedule
    from fxdsp.hdl.sharing import engine_sharing

    def tops(design):
        return {p.name for p in hh.rtl_sources(None, design, tmp_path) if p.name.startswith("chain_")}

    d = build()
    assert tops(d) == {f"{c}.v" for c in d.chains if d.instances[c].hardware} == {
        "chain_paper000.v", "chain_paper001.v", "chain_paper001_loop.v", "chain_paper002.v", "chain_paper002_drive.v",
        "chain_paper002_loop.v"}
    shares = engine_sharing(d, "chain_paper002")
    assert {g: (s.kind, s.host) for g, s in shares.items()} == {"piecewise.bias": ("set", "piecewise.sf"),
                                                              "iir": ("aux", "demod")}
    _, start = chain_schedule(d, "chain_paper002")
    sf_start, sf_cycles = start["piecewise.sf"]
    assert start["piecewise.bias"][0] == sf_start + sf_cycles          # the second pass as SF's leaves
    assert start["demod"][0] > sum(start["piecewise.bias"])            # not on the multiplier meanwhile
    data = copy.deepcopy(DATA)
    data["piecewise"]["bias"]["breakpoints_c"] = [0.0, 21.0, 40.0]
    data["iir"]["rounding"] = "half_even"
    split = build(Config(data, source="<test>"))
    assert engine_sharing(split, "chain_paper002") == {}
    assert " u_piecewise_bias (" in hh.hp.generated_tops(split)["chain_paper002.v"]
    data = copy.deepcopy(DATA)
    del data["chain"]["paper001"], data["chain"]["paper001_loop"]
    data["piecewise"]["bias001"]["temp_format"] = str(d.blocks["freq2temp"].temp_format)
    data["bias_subtract001"]["bias_format"] = str(d.blocks["piecewise_bias001"].out_format)
    without = build(Config(data, source="<test>"))
    assert "chain_paper001.v" not in tops(without) and "chain_paper002.v" in tops(without)


# ---- a chain at its own sample rate ---------------------------------------------------------------
def _slow_chain(data: dict, fs_hz, table: str = "iir2") -> Config:
    """``data`` with a chain of one low-pass (``table``) fed at ``fs_hz``."""
    data = copy.deepcopy(data)
    if table == "iir2":
        data["iir2"] = copy.deepcopy(DATA["iir"])
        data["iir2"]["data_format"] = "s24.22"
    data["chain"]["slow"] = {"instances": [table], "inputs": [f"x -> {table}.x"], "wires": [],
                             "outputs": [f"{table}.y -> y"],
                             "fs_hz": fs_hz}
    return Config(data, source="<test>")


def test_a_chain_at_its_own_rate_designs_its_filters_at_that_rate():
    """The low-pass of a chain fed at 20 kS/s is the scipy design of its cut-off at 20 kS/s (what the
    config states); the same table at [system].fs_hz elsewhere is not."""
    import scipy.signal as sps

    d = build(_slow_chain(DATA, 20000.0))
    cfg = DATA["iir"]
    want = sps.butter(cfg["order"], cfg["cutoff_hz"], fs=20000.0, output="sos")
    assert np.allclose(d.blocks["iir2"].sos, want, rtol=0, atol=1e-12)
    assert not np.allclose(d.blocks["iir"].sos, want, atol=1e-6)
    assert d.chains["chain_slow"].fs_hz == 20000.0 and d.chains["chain_paper002"].fs_hz == DATA["system"]["fs_hz"]


def test_a_timed_block_in_chains_of_two_rates_is_an_error_naming_both():
    with pytest.raises(WiringError) as info:
        build(_slow_chain(DATA, 20000.0, table="iir"))
    msg = str(info.value)
    assert "chain.slow.fs_hz" in msg and "system.fs_hz" in msg and msg.startswith("iir:"), msg


@pytest.mark.parametrize("value", [0, -1.0, "fast", float("nan"), True])
def test_a_chain_rate_must_be_a_positive_number(value):
    with pytest.raises((ValueError, TypeError)) as info:
        build(_slow_chain(DATA, value))
    assert "chain.slow.fs_hz" in str(info.value)


# ---- chain port names the generated top cannot carry ------------------------------------------------
def _port_renames():
    """(chain, edited table, the new name): each shipped chain's first input and first output renamed
    to reserved words of both languages, to the top's own ports and registers, and to the names the
    generated top gives its members (README: ``go_<member>``; ``u_<member>`` its instances)."""
    tops = {n.removeprefix("chain_") for n, i in build().instances.items() if i.members and i.hardware}
    for name, net in sorted(DATA["chain"].items()):
        if name not in tops:   # no generated top (a member without RTL): nothing to refuse
            continue
        member = net["instances"][-1].replace(".", "_")
        for field in ("inputs", "outputs"):
            line = net[field][0]
            a, b = (s.strip() for s in line.split("->"))
            old = a if field == "inputs" else b
            for new in ("output", "logic", "clk", "busy", f"go_{member}", f"u_{member}"):
                edited = [(f"{new} -> {y.strip()}" if field == "inputs" else f"{x.strip()} -> {new}")
                          if (x.strip() if field == "inputs" else y.strip()) == old else ln
                          for ln in net[field] for x, y in [ln.split("->")]]
                # a renamed input keeps its stated unit
                units = {"input_units": {new if k == old else k: v for k, v in net["input_units"].items()}} \
                    if field == "inputs" and "input_units" in net else {}
                yield name, {**net, field: edited, **units}, new


@pytest.mark.parametrize("name,table,new", list(_port_renames()))
def test_a_chain_port_the_generated_top_cannot_carry_is_refused_naming_the_line(name, table, new):
    from fxdsp.errors import InputError
    from fxdsp.hdl.chain_top import chain_top

    d = build(_with_chain(name, table))          # the model runs any name ...
    with pytest.raises(InputError) as info:       # ... the RTL generator refuses it, naming the chain
        chain_top(d, f"chain_{name}")
    assert f"chain.{name}." in str(info.value) and repr(new) in str(info.value), str(info.value)


# ---- own multipliers and words read ahead (paper 002's whole design) --------------------------------
@pytest.mark.parametrize("value,needle", [(["nosuch"], "'nosuch' is not an instance of the chain"),
                                          (["drive", "drive"], "'drive' is listed twice"),
                                          ("drive", "expected a list of the chain's instances"),
                                          ([1], "expected a list of the chain's instances")])
def test_an_own_multiplier_that_is_not_a_member_once_is_refused_naming_the_field(value, needle):
    table = {**DATA["chain"]["paper002_loop"], "own_multiplier": value}
    message = _error("paper002_loop", table)
    assert message.startswith("chain.paper002_loop.own_multiplier: ") and needle in message, message


def test_an_own_multiplier_without_a_bundle_is_refused_naming_the_member():
    from fxdsp.errors import InputError
    from fxdsp.hdl.chain_top import chain_top

    table = {**DATA["chain"]["paper002_loop"], "own_multiplier": ["drive", "sf_divide"]}
    with pytest.raises(InputError, match=r"chain\.paper002_loop\.own_multiplier: 'sf_divide' has no shared-multiplier"):
        chain_top(build(_with_chain("paper002_loop", table)), "chain_paper002_loop")


def test_the_loop_runs_beside_the_sense_path_and_its_reference_is_read_ahead():
    """In paper 002's whole design the drive loop keeps its own multiplier and the sense demodulator
    reads the loop's nco ahead (drive.v nco_next): the sense path starts with the loop and the
    demodulator before the loop's result, so a sample takes the longer of the two, not their sum.
    Without own_multiplier the loop takes turns on the one multiplier and the sample takes both."""
    from fxdsp.hdl.chain_top import chain_top
    from fxdsp.hdl.schedule import chain_schedule, member_cycles

    d = build()
    per, start = chain_schedule(d, "chain_paper002_loop")
    loop_start, loop_cycles = start["drive"]
    assert start["rtd"][0] == loop_start
    assert start["demod02"][0] < loop_start + loop_cycles
    sense_end = max(b + c for m, (b, c) in start.items() if m != "drive")
    assert per == 3 + max(loop_start + loop_cycles, sense_end)
    top = chain_top(d, "chain_paper002_loop")
    assert "if (accept) drive_nco_ahead_q <= drive_nco_next;" in top and ".ref_phase(drive_nco_ahead_q)" in top
    assert "want_demod02 = busy & ~started_demod02 & done_sf_divide & demod02_in_ready;" in top   # not done_drive
    table = {k: v for k, v in DATA["chain"]["paper002_loop"].items() if k != "own_multiplier"}
    shared = build(_with_chain("paper002_loop", table))
    per_shared, _ = chain_schedule(shared, "chain_paper002_loop")
    assert per_shared >= member_cycles(shared, "drive") + member_cycles(shared, "demod02") > per
