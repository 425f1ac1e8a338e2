"""`fxdsp extend` on a chain the project never declared: the calibration follows
the chain's sensor and writes the chain's own tables, and the remedies edit its netlist.

Each user config is the built-in one plus copies of block tables under new names, wired into a new
chain in another order, the way a user adds a second sensor. Evidence that the extension went
through the user's tables, not the built-in ones it was copied from:

* the built-in tables the copies were made from are left as they were, byte for byte as parsed
  TOML, and every changed key is one of the new chain's;
* gyro_rtd / gyro_freq: the held-out error through the new chain equals the built-in chain's on the
  same log (same physics, same words): a calibration written into the wrong table leaves the new
  chain's engines uncalibrated, and its error grows by orders of magnitude;
* thermometer (no sensor): the bit-exact chain on the log within a few output LSBs of the float
  polynomial it quantises, the lag inserted after the chain's temperature input.
"""

from __future__ import annotations

import json
import re
import tomllib

import numpy as np
import pytest

from fxdsp.cli import main
from fxdsp.config import default_config_text
from user_configs import leaves

SHORT = ["--duration-scale", "0.5", "--time-step", "30"]
HEADER = re.compile(r"^\[([^\]]+)\]", re.M)


def section(text: str, table: str) -> str:
    """The text of ``[table]`` (its header to the next header) in a TOML text."""
    heads = [(m.start(), m.group(1).strip()) for m in HEADER.finditer(text)]
    for k, (at, name) in enumerate(heads):
        if name == table:
            return text[at: heads[k + 1][0] if k + 1 < len(heads) else len(text)]
    raise KeyError(table)


def copied(text: str, renames: dict[str, str], edits: dict[str, dict] | None = None) -> str:
    """``[old]`` (and its sub-tables) written again as ``[new]`` for each rename; ``edits``: keys
    of a new table set to other values (TOML literals)."""
    out = []
    for old, new in renames.items():
        for name in [m.group(1).strip() for m in HEADER.finditer(text)]:
            if name == old or name.startswith(old + "."):
                body = section(text, name).replace(f"[{name}]", f"[{new}{name[len(old):]}]", 1)
                for key, value in (edits or {}).get(new, {}).items():
                    body, n = re.subn(rf"^{key}\s*=.*$", f"{key} = {value}", body, count=1, flags=re.M)
                    if n == 0:   # a key the table leaves to its wire: stated after the header
                        head, _, rest = body.partition("\n")
                        body = f"{head}\n{key} = {value}\n{rest}"
                out.append(body.rstrip() + "\n\n")
    return "".join(out)


def changed(a: dict, b: dict) -> set[str]:
    la, lb = leaves(a), leaves(b)
    return {k for k in la.keys() | lb.keys() if la.get(k) != lb.get(k)}


def run(capsys, *args) -> tuple[int, str]:
    code = main([str(a) for a in args])
    _, err = capsys.readouterr()
    return code, err


GYRO_RTD = {"rtd": "rtd2", "piecewise.sf": "piecewise.sf_hot", "piecewise.bias": "piecewise.bias_hot",
            "sf_divide": "sf_divide2", "demod": "demod2", "bias_subtract": "bias_subtract2", "iir": "iir2"}
GYRO_RTD_CHAIN = '''[chain.mygyro]
sensor = "gyro_rtd"
instances = ["iir2", "bias_subtract2", "demod2", "sf_divide2", "piecewise.bias_hot", "piecewise.sf_hot", "rtd2"]
inputs = ["rtd_word -> rtd2.code", "sense -> sf_divide2.x"]
input_units = {sense = "FS"}
wires = ["piecewise.bias_hot.y -> bias_subtract2.bias", "rtd2.temp -> piecewise.bias_hot.temp",
         "sf_divide2.y -> demod2.x", "piecewise.sf_hot.y -> sf_divide2.sf", "rtd2.temp -> piecewise.sf_hot.temp",
         "demod2.i -> bias_subtract2.x", "bias_subtract2.y -> iir2.x"]
outputs = ["iir2.y -> omega"]
'''
GYRO_FREQ = {"freq2temp": "freq2temp2", "piecewise.bias001": "piecewise.zro", "bias_subtract001": "bias_subtract7"}
GYRO_FREQ_CHAIN = '''[chain.myres]
sensor = "gyro_freq"
instances = ["bias_subtract7", "piecewise.zro", "freq2temp2"]
inputs = ["gyro -> bias_subtract7.x", "fres -> freq2temp2.f"]
input_units = {gyro = "deg/h"}
wires = ["piecewise.zro.y -> bias_subtract7.bias", "freq2temp2.temp -> piecewise.zro.temp"]
outputs = ["bias_subtract7.y -> compensated_rate"]
'''
THERMO = {"piecewise.bias001": "piecewise.q3", "bias_subtract001": "bias_subtract3"}
THERMO_CHAIN = '''[chain.mythermo]
instances = ["bias_subtract3", "piecewise.q3"]
inputs = ["reading -> bias_subtract3.x", "t_word -> piecewise.q3.temp"]
wires = ["piecewise.q3.y -> bias_subtract3.bias"]
outputs = ["bias_subtract3.y -> out"]
'''


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    folder = tmp_path_factory.mktemp("any_chain")
    base = default_config_text()
    rtd_temp = tomllib.loads(base)["rtd"]["temp_format"]
    configs = {"gyro_rtd": base + "\n" + copied(base, GYRO_RTD) + GYRO_RTD_CHAIN,
               "gyro_freq": base + "\n" + copied(base, GYRO_FREQ) + GYRO_FREQ_CHAIN,
               # the user's thermometer reads the RTD's word, the lag's (the lag goes in front of it)
               "thermometer": base + "\n" + copied(base, THERMO, {"piecewise.q3": {"temp_format": f'"{rtd_temp}"'}})
               + THERMO_CHAIN}
    paths = {}
    for name, text in configs.items():
        paths[name] = folder / f"{name}.toml"
        paths[name].write_text(text)
    logs = {"gyro_rtd": ("paper002", ["thermal_lag.tau_s=1500", "quadrature_leak=0.05"], []),
            "gyro_freq": ("paper001", ["frequency_nonlinearity=0.0005"], []),
            "thermometer": ("ramp", ["thermal_lag.tau_s=1500"], ["--columns", ""])}
    for name, (scenario, effects, extra) in logs.items():
        args = ["simulate", "--scenario", scenario, "--seed", "3", *SHORT, *extra, "--out", folder / f"{name}.csv"]
        for e in effects:
            args += ["--effect", e]
        assert main([str(a) for a in args]) == 0
    return folder, paths


def extended(capsys, folder, paths, name, chain, *more):
    out = folder / f"ext_{name}_{chain}"
    code, err = run(capsys, "extend", folder / f"{name}.csv", "--config", paths[name], "--chain", chain, "--no-rtl",
                    *more, "--out", out)
    assert code == 0, err
    return json.loads((out / "report.json").read_text()), tomllib.loads((out / "config.toml").read_text())


@pytest.mark.parametrize("name, chain, builtin, renames", [
    ("gyro_rtd", "mygyro", "paper002", GYRO_RTD), ("gyro_freq", "myres", "paper001", GYRO_FREQ)])
def test_a_users_sensor_chain_is_calibrated_in_its_own_tables(made, capsys, name, chain, builtin, renames):
    folder, paths = made
    user = tomllib.loads(paths[name].read_text())
    rep, cfg = extended(capsys, folder, paths, name, chain)
    assert rep["chain"] == chain and rep["procedure"] == name
    diff = changed(user, cfg)
    mine = tuple(renames.values()) + (f"chain.{chain}", "lag", "system")
    assert diff and all(k.startswith(mine) for k in diff), sorted(diff)
    # every calibrated value is written (a one-segment table keeps its empty breakpoints)
    assert {k for k in rep["design"]["calibrated_keys"] if not k.endswith("breakpoints_c")} <= diff
    assert all(k.startswith(mine) for k in rep["design"]["calibrated_keys"] + rep["design"]["remedy_keys"])
    # the same log through the built-in chain: the same remedies and the same held-out error
    ref, _ = extended(capsys, folder, paths, name, builtin)
    assert [r["stage"] for r in rep["remedies"]] == [r["stage"] for r in ref["remedies"]] != []
    for key in ("rms_before", "rms_after"):
        assert np.isclose(rep["summary"][key], ref["summary"][key], rtol=1e-9, atol=0), (rep["summary"], ref["summary"])
    if name == "gyro_rtd":   # the lag is a netlist edit of the user's chain, the trim its demodulator's
        assert cfg["chain"]["mygyro"]["instances"][-2:] == ["rtd2", "lag"]
        assert "rtd2.temp -> lag.temp" in cfg["chain"]["mygyro"]["wires"]
        assert cfg["demod2"]["phase_trim_rad"] != 0 and cfg["demod"]["phase_trim_rad"] == 0
        assert "lag" not in cfg["chain"]["paper002"]["instances"]


def test_a_users_thermometer_chain_gets_its_lag_in_front_of_its_temperature_input(made, capsys):
    folder, paths = made
    user = tomllib.loads(paths["thermometer"].read_text())
    rep, cfg = extended(capsys, folder, paths, "thermometer", "mythermo", "--widen")
    assert rep["chain"] == "mythermo" and rep["procedure"] == "thermometer"
    assert [r["stage"] for r in rep["remedies"]] == ["lag"] and rep["summary"]["gain"] > 2, rep["summary"]
    net = cfg["chain"]["mythermo"]
    assert net["instances"][0] == "lag" and "t_word -> lag.temp" in net["inputs"]
    assert "lag.te -> piecewise.q3.temp" in net["wires"]
    diff = changed(user, cfg)
    assert all(k.startswith(("piecewise.q3", "bias_subtract3", "chain.mythermo", "lag.")) for k in diff), sorted(diff)
    # the user's bit-exact chain (its lag apart, at the log's rate) is the float polynomial it
    # quantises, to within the user's word lengths: the copied deg/h formats round the reading to
    # 1/64 and c2 (s24.18) into the s32.14 accumulator, up to 0.03 output units at 60 C, a third
    # of what the compensation leaves; coefficients written anywhere but the chain's own engine
    # leave its paper 001 polynomial there, tens of units off
    b = rep["bitexact_chain"]
    assert b["overflows"] == 0 and b["max_abs_vs_float"] < 0.5 * rep["summary"]["rms_after"], (b, rep["summary"])


def test_a_chain_extend_has_no_calibration_for_is_one_line(made, capsys):
    folder, paths = made
    code, err = run(capsys, "extend", folder / "gyro_rtd.csv", "--chain", "paper000", "--no-rtl",
                    "--out", folder / "x")
    assert code == 2 and err.count("\n") == 1 and "qvba" in err, err
    code, err = run(capsys, "extend", folder / "gyro_rtd.csv", "--chain", "mygyro", "--no-rtl", "--out", folder / "x")
    assert code == 2 and err.count("\n") == 1 and "mygyro" in err and "paper002" in err, err
    # a thermometer chain whose compensated reading is not among its outputs (it was a traceback)
    hidden = folder / "hidden.toml"
    hidden.write_text(paths["thermometer"].read_text().replace('outputs = ["bias_subtract3.y -> out"]',
                                                               'outputs = ["piecewise.q3.y -> q"]'))
    code, err = run(capsys, "extend", folder / "thermometer.csv", "--config", hidden, "--chain", "mythermo",
                    "--widen", "--no-rtl", "--out", folder / "x")
    assert code == 2 and err.count("\n") == 1 and "bias_subtract3.y" in err and "chain.mythermo" in err, err
    assert not (folder / "x").exists()


@pytest.mark.parametrize("config", ["default.toml", "formal_narrow.toml"])
def test_an_unknown_chain_is_refused_naming_every_choice_once(config):
    """The choices --chain takes are listed whole: auto, each chain of the config, and the thermometer
    extend writes; a config without chains (formal_narrow) lists auto and the thermometer alone (it
    printed "expected auto,  or thermometer")."""
    from importlib.resources import files

    from fxdsp.chains import build
    from fxdsp.errors import InputError
    from fxdsp.extend.roles import OWN_THERMOMETER, resolve

    design = build(str(files("fxdsp") / "configs" / config))
    chains = [n.removeprefix("chain_") for n in design.chains]
    with pytest.raises(InputError) as err:
        resolve("no_such_chain", design, {"time_s": [], "output": []}, config)
    choices = str(err.value).split("expected ", 1)[1]
    names = re.split(r", | or ", choices)
    # every choice once, none empty: auto, each chain, the thermometer
    assert len(names) == len(set(names)) and sorted(names) == sorted({"auto", *chains, OWN_THERMOMETER}), str(err.value)
