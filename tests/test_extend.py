"""`fxdsp extend` end to end: a log in; the extended config, its golden vectors, Verilog
headers, a cocotb regression on that config and a report out. The simulated logs come from
`fxdsp simulate` with one injected cause each (a thermal lag, a quadrature leak, both); the real
one is the tckit 1 V transfer log. Each report's held-out gain and bit-exact status are asserted,
and each stage is shown to be what produced the gain: with it turned off the gain is gone.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from conftest import SHARED, needs_shared
from fxdsp.chains import build
from fxdsp.cli import main
from fxdsp.config import Config
from fxdsp.logfile import read_log
from fxdsp.extend.evaluate import compensate002, heldout_rows_rate_table
from fxdsp.netlist import with_stage

ROOT = Path(__file__).parents[1]
TCKIT_REL = "data/tckit/hp3458abx_hp34420a_tcsweep_1vdc_nplc100_test2_oct2024.dsv"
# vbl6: a channel the diagnosis names thermal_lag on (tests/test_extend_user_design.py extends vbl5,
# and a simulated lag beside a cause without a remedy)
TCKIT_ARGS = ["--map", "time_s=date", "--map", "temp_c=box_temp", "--map", "output=vbl6", "--delimiter", ";",
              "--time-format", "%d/%m/%Y-%H:%M:%S"]
needs_icarus = pytest.mark.skipif(shutil.which("iverilog") is None, reason="iverilog is not installed")

# name -> (simulate effects, seed, the stages the extension must add)
LOGS = {"lag": (["thermal_lag.tau_s=1500"], 1, {"lag"}),
        "quad": (["quadrature_leak=0.2"], 2, {"trim"}),
        "both": (["thermal_lag.tau_s=1500", "quadrature_leak=0.05"], 3, {"lag", "trim"}),
        "rtd": (["rtd_nonlinearity=-0.0005"], 9, {"cvd"}),
        "hysteresis": (["hysteresis=0.3"], 4, set()),
        "turnover": (["frequency_nonlinearity=0.0005"], 7, {"order"})}


def simulate(folder: Path, name: str, seed: int | None = None) -> Path:
    effects, default_seed, _ = LOGS[name]
    path = folder / f"{name}_{seed or default_seed}.csv"
    scenario = "paper001" if name == "turnover" else "paper002"
    args = ["simulate", "--scenario", scenario, "--seed", str(seed or default_seed), "--out", str(path)]
    for e in effects:
        args += ["--effect", e]
    assert main(args) == 0
    return path


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("extend_logs")
    return {name: simulate(folder, name) for name in LOGS}


def extend(args, capsys) -> tuple[int, str, str]:
    code = main(["extend", *map(str, args)])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def extended(logs, tmp_path_factory):
    """`fxdsp extend LOG` of a simulated log once per log for the module (several tests read the same
    extension: its report, model and config): name -> (exit status, stdout, stderr, the --out folder).
    Nothing writes into the folder afterwards. BOTH with its RTL regression (when Icarus is installed:
    test_extend_a_simulated_paper002_log checks it), the others --no-rtl."""
    done = {}

    def get(name: str):
        if name not in done:
            out = tmp_path_factory.mktemp(f"{name}_extended") / "ext"
            rtl = name == "both" and shutil.which("iverilog") is not None
            so, se = io.StringIO(), io.StringIO()
            with contextlib.redirect_stdout(so), contextlib.redirect_stderr(se):
                code = main(["extend", str(logs[name]), "--out", str(out), *([] if rtl else ["--no-rtl"])])
            done[name] = (code, so.getvalue(), se.getvalue(), out)
        return done[name]
    return get


@pytest.fixture(scope="module")
def both_extended(extended):
    return extended("both")


@needs_icarus
@pytest.mark.parametrize("name", ["lag", "quad", "both", "rtd"])
def test_extend_a_simulated_paper002_log(logs, extended, name):
    # the RTL regression of the extended config on the log whose remedies change the RTL's parameters
    # in the most ways (both: the lag and the phase trim); the single lag and trim remedies are the
    # same stages, each a subset of both's; the RTD table (rtd) is checked on its own block below
    rtl = name == "both"
    code, stdout, err, out = extended(name)
    assert code == 0, err
    rep = json.loads((out / "report.json").read_text())
    stages = LOGS[name][2]
    assert rep["chain"] == "paper002" and {r["stage"] for r in rep["remedies"]} == stages
    # bit-exact: every block of the chain and the top, on this config's generated parameters
    reg = rep["regression"]
    if rtl:
        assert reg["passed"] and {"chain_paper002", "demod", "piecewise_sf"} <= set(reg["blocks"])
        assert ("lag (per update)" in reg["blocks"]) == ("lag" in stages)
        assert "bit-exact" in stdout
    else:
        assert reg is None and "bit-exact" not in stdout
    if name == "rtd" and shutil.which("iverilog") is not None:
        # the Callendar-Van Dusen table the remedy wrote, through the RTL rtd on Icarus, bit for bit
        from fxdsp.extend import hardware
        from fxdsp.extend.roles import roles_of

        design = build(Config(tomllib.loads((out / "config.toml").read_text()), source="ext"))
        reg = hardware.regression(design, roles_of(design, "paper002"), False, only=("rtd",))
        assert reg["passed"] and list(reg["blocks"]) == ["rtd"], reg
    # held out: rows the calibration never read, and the remedies' gain on them
    h, s = rep["heldout"], rep["summary"]
    assert 0 < h["heldout_rows"] < h["rows"]
    # the RTD's curvature is mostly absorbed by the calibration's segments already: the CVD table's
    # gain on the output is small, its effect on the temperature the engines see is not
    assert s["gain"] > {"quad": 2.0, "rtd": 1.05}.get(name, 3.0), s
    if name == "rtd":
        v = h["variants"]
        assert v["before"]["temp_vs_ref_c"] > 5 * v["after"]["temp_vs_ref_c"], v
    assert all(v["overflows"] == 0 for v in h["variants"].values())
    # each stage produced its share. Recalibrated without it, the gain it brought is gone (for a
    # single stage that variant is "before" by construction, so the check is made on the other
    # ablation there); and in the extended config itself, the stage switched off while the tables
    # stay as calibrated, the held-out error grows
    columns = read_log(logs[name]).columns
    held = heldout_rows_rate_table(columns)
    tau = next((r["parameters"]["tau_s"] for r in rep["remedies"] if r["stage"] == "lag"), None)
    config = (out / "config.toml").read_text()

    def rms(on):
        err, _ = compensate002(columns, config, on, tau, h["trim_rad"] or 0.0)
        return float(np.sqrt(np.mean(err[held] ** 2)))

    with_all = rms(stages)
    for stage in stages:
        assert rms(stages - {stage}) > 1.5 * with_all, stage
        if stages != {stage}:
            assert h["variants"][f"without {stage}"]["rms"] > 1.1 * s["rms_after"], stage
    # the config, the headers and the vectors are this extension's
    cfg = tomllib.loads((out / "config.toml").read_text())
    build(Config(cfg, source="ext"))
    hdl = out / "hdl"
    assert ("lag" in cfg["chain"]["paper002"]["instances"]) == ("lag" in stages)
    assert (" u_lag (" in (hdl / "chain_paper002.v").read_text()) == ("lag" in stages)
    if "lag" in stages:
        decim = round(cfg["system"]["fs_hz"] / cfg["lag"]["rate_hz"])
        assert f".DECIM({decim})" in (hdl / "lag_params.vh").read_text() and decim > 1
    assert (cfg["demod"]["phase_trim_rad"] != 0) == ("trim" in stages)
    assert (cfg["rtd"]["law"] == "cvd") == ("cvd" in stages)
    manifest = json.loads((out / "vectors" / "manifest.json").read_text())
    assert ("lag" in manifest["blocks"]["chain_paper002"]["parameters"]["blocks"]) == ("lag" in stages)
    assert (out / "heldout_error.png").stat().st_size > 0 and "Held-out" in (out / "report.md").read_text()
    # what the held-out error follows: each remedy's signature (a lag's d(temp_c)/dt, a trim's quad)
    # is structure in the error with the stage off (before, or the other stages on); with every stage
    # on it is gone, or what is left of the structure is a tenth of it at most
    signature = {"lag": "d(temp_c)/dt", "trim": "quad"}
    rem = rep["remaining"]
    assert set(rem) == set(h["variants"])
    for stage in stages & signature.keys():
        off = rem["before" if stages == {stage} else f"without {stage}"]
        assert off["significant"] and signature[stage] in off["against"], (stage, off)
        assert signature[stage] not in rem["after"]["against"] or rem["after"]["rms"] < 0.1 * off["rms"], \
            (stage, rem["after"], off)
    assert rem["after"]["rms"] < rem["before"]["rms"] and rem["before"]["fraction"] <= 1.0
    assert "What the error still follows" in (out / "report.md").read_text()


@needs_icarus
def test_extend_a_paper001_log_whose_resonator_turns_over(logs, tmp_path, capsys):
    """The frequency thermometer is linear; a turnover k2 (Te - 25)^2 bends T_f, and the remedy is a
    cubic bias in T_f. Auto picks the paper001 chain (freq_hz, no rate-table steps)."""
    out = tmp_path / "ext"
    second = simulate(tmp_path, "turnover", seed=17)
    code, _, err = extend([logs["turnover"], "--apply", second, "--out", out], capsys)
    assert code == 0, err
    rep = json.loads((out / "report.json").read_text())
    assert rep["chain"] == "paper001" and [r["stage"] for r in rep["remedies"]] == ["order"]
    assert rep["regression"]["passed"] and "chain_paper001" in rep["regression"]["blocks"]
    assert rep["summary"]["gain"] > 1.5 and rep["calibration"]["thermometer_check"]["ok"], rep["summary"]
    cfg = tomllib.loads((out / "config.toml").read_text())
    base = tomllib.loads((out / "config_base.toml").read_text())
    assert len(cfg["piecewise"]["bias001"]["coefficients"][0]) == 4
    assert len(base["piecewise"]["bias001"]["coefficients"][0]) == 3
    assert rep["applied"]["gain"] > 1.5, rep["applied"]   # fitted on run 1, applied to run 2


def test_a_cause_without_a_remedy_is_one_line_and_exit_2_with_strict(logs, tmp_path, capsys):
    """--strict keeps the refusal (without it the cause is reported uncompensated and the run goes
    on: tests/test_extend_user_design.py)."""
    out = tmp_path / "ext"
    code, _, err = extend([logs["hysteresis"], "--strict", "--out", out, "--no-rtl"], capsys)
    assert code == 2 and err.count("\n") == 1 and "hysteresis has no hardware remedy" in err, err
    assert not out.exists()   # nothing half-written


def test_bad_chain_is_one_line_and_exit_2(logs, tmp_path, capsys):
    code, _, err = extend([logs["lag"], "--chain", "gyro", "--out", tmp_path / "x", "--no-rtl"], capsys)
    assert code == 2 and err.count("\n") == 1 and "--chain" in err


def test_fit_on_one_run_apply_on_another(logs, both_extended, tmp_path, capsys):
    """Run 2 is `fxdsp simulate --model` replaying the model run 1's extension wrote (another seed:
    other noise, other quadrature wander); the configs fitted on run 1 compensate it."""
    code, _, err, first = both_extended
    assert code == 0, err
    model = json.loads((first / "model.json").read_text())
    assert set(model["effects"]) == {"thermal_lag", "quadrature_leak"}
    second = tmp_path / "replay.csv"
    assert main(["simulate", "--scenario", "paper002", "--model", str(first / "model.json"),
                 "--seed", "13", "--out", str(second)]) == 0
    code, stdout, err = extend([logs["both"], "--apply", second, "--out", tmp_path / "ext", "--no-rtl"], capsys)
    assert code == 0, err
    applied = json.loads((tmp_path / "ext" / "report.json").read_text())["applied"]
    assert applied["log"] == second.name and applied["gain"] > 3.0, applied
    assert "applied to" in stdout


def test_same_log_same_bytes(logs, extended, tmp_path, capsys):
    """A second extension of the quad log (the first: the module's, in another folder) writes the same bytes."""
    code, _, err, first = extended("quad")
    assert code == 0, err
    assert extend([logs["quad"], "--out", tmp_path / "o2", "--no-rtl"], capsys)[0] == 0
    for name in ("report.json", "config.toml", "vectors/manifest.json", "hdl/demod_params.vh"):
        assert (first / name).read_bytes() == (tmp_path / "o2" / name).read_bytes(), name


@needs_icarus
def test_the_regression_fails_on_a_mutated_rtl(tmp_path):
    """The same regression on an RTL copy whose lag rounds its output by floor instead of the
    configured half_up must report a mismatch (so 'bit-exact' in a report is evidence). (Its state
    step's rounding would not show: 20 guard bits put it 2**-20 codes below the output.)"""
    from fxdsp.extend import hardware
    from fxdsp.extend.roles import roles_of

    cfg = Config(tomllib.loads((ROOT / "fxdsp" / "configs" / "default.toml").read_text()), source="default")
    cfg.data["chain"]["paper002"] = with_stage(cfg.data["chain"]["paper002"], "lag")
    cfg.data["lag"]["tau_s"] = 5.0
    design = build(cfg)
    rtl = tmp_path / "rtl"
    shutil.copytree(ROOT / "hdl" / "rtl", rtl)
    text = (rtl / "lag.v").read_text()
    old = "fx_convert #(.IN_W(STATE_W), .SHIFT(GUARD), .ROUNDING(ROUNDING)"
    assert text.count(old) == 1
    (rtl / "lag.v").write_text(text.replace(old, "fx_convert #(.IN_W(STATE_W), .SHIFT(GUARD), .ROUNDING(0)"))
    roles = roles_of(design, "paper002")
    good = hardware.regression(design, roles, True, only=("lag (per update)",))
    bad = hardware.regression(design, roles, True, rtl_dir=rtl, only=("lag (per update)",))
    assert good["passed"] and not bad["passed"], (good, bad)


@needs_icarus
@needs_shared(TCKIT_REL)
def test_extend_the_tckit_log(tmp_path, capsys):
    out = tmp_path / "ext"
    code, stdout, err = extend([SHARED / TCKIT_REL, *TCKIT_ARGS, "--out", out], capsys)
    assert code == 0, err
    rep = json.loads((out / "report.json").read_text())
    assert rep["chain"] == "thermometer" and [r["stage"] for r in rep["remedies"]] == ["lag"]
    # the thermometer chain is a config chain: its members and its generated top, the lag per update
    assert rep["regression"]["passed"] and set(rep["regression"]["blocks"]) == {
        "piecewise_bias001", "bias_subtract001", "chain_thermometer", "lag"}
    ext = tomllib.loads((out / "config.toml").read_text())
    assert ext["chain"]["thermometer"]["instances"] == ["lag", "piecewise.bias001", "bias_subtract001"]
    s = rep["summary"]
    assert s["gain"] > 2.0, s
    # the lag carries the gain: the final config's bit-exact chain with its lag bypassed (the cubic
    # fitted on Te, fed the thermometer's T) leaves much more of the output's temperature dependence
    from fxdsp.logfile import parse_mapping
    from fxdsp.extend.configure import thermometer_chain
    from fxdsp.extend.evaluate import thermometer_bitexact, thermometer_words
    from fxdsp.extend.roles import own_thermometer_roles

    columns = read_log(SHARED / TCKIT_REL, parse_mapping(TCKIT_ARGS[1:6:2]), ";", TCKIT_ARGS[-1]).columns
    design = build(Config(copy.deepcopy(ext), source="ext"))
    roles = own_thermometer_roles()
    codes = thermometer_words(design, roles, columns, rep["remedies"][0]["parameters"]["tau_s"])
    on = thermometer_bitexact(design, roles, codes, columns["output"], None)["rms_compensated"]
    ext["chain"]["thermometer"] = thermometer_chain(False, ext["chain"]["thermometer"]["fs_hz"])   # the lag bypassed
    off = thermometer_bitexact(build(Config(ext, source="ext, no lag")), roles, {"T": codes["T"], "format": codes["format"]},
                               columns["output"], None)["rms_compensated"]
    assert off > 2 * on, (on, off)
    # the hardware arithmetic adds nothing the compensation would notice: a few output LSBs
    b = rep["bitexact_chain"]
    assert b["overflows"] == 0 and b["max_abs_vs_float"] < 4 * b["lsb"], b
    assert b["max_abs_vs_float"] < 0.05 * s["rms_after"]


def test_calibrate_keeps_an_extended_configs_stages(logs, both_extended, tmp_path, capsys):
    """`fxdsp calibrate --config EXT --apply LOG2`: the extension's stages stay in the recalibrated
    config, the fit is made with them in place, and the second run is compensated through them (the
    quadrature wander and the lag no longer leak into the bias points: a lower bias tempco than the
    plain calibration's on the same two runs)."""
    code, _, err, ext_dir = both_extended
    assert code == 0, err
    second = simulate(tmp_path, "both", seed=13)
    results = {}
    for name, extra in (("extended", ["--config", ext_dir / "config.toml"]), ("plain", [])):
        out = tmp_path / f"{name}.json"
        args = ["calibrate", "--paper", "002", logs["both"], *extra, "--config-out", tmp_path / f"{name}.toml",
                "--apply", second, "--json", out]
        assert main(list(map(str, args))) == 0, capsys.readouterr().err
        results[name] = json.loads(out.read_text())
    ext, plain = results["extended"], results["plain"]
    assert ext["config"]["stages"] == ["lag", "trim"] and ext["apply"]["stages"] == ["lag", "trim"]
    assert "stages" not in plain["apply"]
    cfg = tomllib.loads((tmp_path / "extended.toml").read_text())
    assert "lag" in cfg["chain"]["paper002"]["instances"] and cfg["demod"]["phase_trim_rad"] != 0
    assert ext["apply"]["bias_tempco_deg_h_after"] < 0.5 * plain["apply"]["bias_tempco_deg_h_after"], \
        (ext["apply"], plain["apply"])


@pytest.mark.parametrize("seed", [3, 5])
def test_a_short_logs_held_out_error_still_shows_its_lag(seed, tmp_path, capsys):
    """A paper002 run with its holds cut to 0.3: the rows outside the rate tables (the held-out error)
    are about a tenth of the log, in a few stretches. The lag the extension compensates is most of the
    error before; its size must be measured on those stretches, not by folds of the whole log, which
    leave a stretch with no training row near it and extrapolate a column there (the size came out 0
    and the structure was called noise)."""
    log = tmp_path / "short.csv"
    assert main(["simulate", "--scenario", "paper002", "--effect", "thermal_lag=900", "--seed", str(seed),
                 "--duration-scale", "0.3", "--time-step", "20", "--out", str(log)]) == 0
    code, _, err = extend([log, "--no-rtl", "--out", tmp_path / "ext"], capsys)
    assert code == 0, err
    rep = json.loads((tmp_path / "ext" / "report.json").read_text())
    before, after = rep["remaining"]["before"], rep["remaining"]["after"]
    assert before["significant"] and "d(temp_c)/dt" in before["against"], before
    assert before["fraction"] > 0.5 and after["rms"] < 0.3 * before["rms"], (before, after)


def test_the_reports_say_what_the_reader_set_aside(tmp_path, capsys):
    """A reference thermometer that never moves is ignored by the log reader (fxdsp.logfile); the
    extension's report (JSON and markdown) carries the reader's and the diagnosis's notes, as
    `fxdsp diagnose`'s does, and those of the second run it is applied to (--apply), instead of
    extending and applying around the column silently."""
    from fxdsp.sim import generate_log, write_log

    logs = []
    for seed in (3, 4):   # the log extended, and a second run the extension is applied to (--apply)
        cols = generate_log("paper002", effects={"thermal_lag": {"tau_s": 900.0}}, seed=seed, duration_scale=0.3)
        logs.append(tmp_path / f"stuck{seed}.csv")
        write_log(logs[-1], {**cols, "ref_temp_c": np.full(len(cols["temp_c"]), 23.4)})
    code, _, err = extend([logs[0], "--apply", logs[1], "--no-rtl", "--out", tmp_path / "ext"], capsys)
    assert code == 0, err
    report = json.loads((tmp_path / "ext" / "report.json").read_text())
    md = (tmp_path / "ext" / "report.md").read_text()
    said = []
    for notes in (report["diagnosis"]["notes"], report["applied"].get("notes", [])):
        ignored = [n for n in notes if "'ref_temp_c'" in n and "was ignored" in n]
        assert ignored, notes
        said.append(f"* {ignored[0]}")
    assert all(md.count(line) == said.count(line) for line in said), md
