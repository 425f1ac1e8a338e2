"""``fxdsp rtl``: the RTL regression of exactly the config given, through the package's harness.

* On a user's config (the sense ADC at 18 bits) it verifies that design: the vectors and headers it
  writes are those of the config (compared with ``fxdsp vectors`` / ``fxdsp hdl-gen`` of the same
  file, and the formats read back from the manifest are the user's), and both variants pass.
* With an injected RTL fault it exits 1, names the DUT and the first mismatch (checked against the
  model's own word at that sample, not against a number copied from the command), and leaves a
  waveform of a window around it that holds the DUT's signals.
* Bad input (an unknown block, a folder without Verilog) is one line and exit 2.
"""

from __future__ import annotations

import json
import re
import shutil
import tomllib

import numpy as np
import pytest

from fxdsp.owned import RECORD
from fxdsp.cli import main
from fxdsp.config import default_config_text
from fxdsp.hdl import RTL_DIR
from fxdsp.vectors import load
from hdl_util import require_simulator
from user_configs import adc18_text

# a user's own design: the sense ADC at 18 bits (the divider's input word), the rest as built in
ADC18 = adc18_text()
LONG = ["--long", "150"]


def _config(tmp_path):
    assert ADC18 != default_config_text()
    path = tmp_path / "adc18.toml"
    path.write_text(ADC18)
    assert tomllib.loads(ADC18)["sf_divide"]["in_format"] == "s18.17"
    return path


@pytest.mark.hdl
def test_rtl_verifies_the_users_config(tmp_path, capsys):
    require_simulator("icarus")
    cfg = _config(tmp_path)
    out = tmp_path / "rtl"
    assert main(["rtl", "--config", str(cfg), "--only", "sf_divide", "--sim", "icarus", *LONG,
                 "--out", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["passed"] and [r["dut"] for r in report["duts"]] == ["sf_divide", "sf_divide (serial)"]
    for row in report["duts"]:
        assert set(row["streams"]) == {"golden", "random", "corners", "long"}
        assert all(s["ok"] and s["samples"] > 0 for s in row["streams"].values())
        assert row["cycles_per_sample"] and row["cycles_per_sample"] >= 1
    # what it verified is the user's design: its vectors and headers are those of the same config
    assert main(["vectors", "--config", str(cfg), "--out", str(tmp_path / "vec")]) == 0
    assert main(["hdl-gen", "--config", str(cfg), "--out", str(tmp_path / "gen")]) == 0
    for sub, ref in (("vectors", tmp_path / "vec"), ("hdl", tmp_path / "gen")):
        mine = sorted(p.relative_to(out / sub) for p in (out / sub).rglob("*") if p.is_file())
        theirs = sorted(p.relative_to(ref) for p in ref.rglob("*") if p.is_file() and p.name != RECORD)
        assert mine == theirs
        assert all((out / sub / p).read_bytes() == (ref / p).read_bytes() for p in mine)
    ins, _, entry = load(out / "vectors", "sf_divide")
    assert entry["inputs"]["x"]["format"] == "s18.17"
    assert "MISMATCH" not in capsys.readouterr().out


@pytest.mark.hdl
def test_an_injected_fault_is_named_with_its_first_mismatch_and_a_waveform(tmp_path, capsys, monkeypatch):
    require_simulator("icarus")
    monkeypatch.chdir(tmp_path)   # --rtl given relative, as a user types it (every simulator's build finds it)
    rtl = tmp_path / "rtl_src"
    shutil.copytree(RTL_DIR, rtl)
    src = rtl / "sf_divide.v"
    text = src.read_text()
    site = "qb_v = ~t_v[DW+1];"     # the division step takes r >= d as r > d
    assert text.count(site) == 1
    src.write_text(text.replace(site, "qb_v = ~t_v[DW+1] & (t_v[DW:0] != 0);"))
    out = tmp_path / "out"
    capsys.readouterr()
    assert main(["rtl", "--only", "sf_divide", "--rtl", "rtl_src", *LONG, "--out", str(out)]) == 1
    printed = capsys.readouterr().out
    report = json.loads((out / "report.json").read_text())
    assert not report["passed"]
    row = report["duts"][0]
    m = row["first_mismatch"]
    assert m["dut"] == "sf_divide" and m["stream"] == "golden" and m["port"] == "y"
    assert "mismatch" in row["streams"]["long"]["errors"][0], row["streams"]["long"]   # built, and caught
    # the expected word is the model's, read from the golden vectors the command wrote
    _, outs, _ = load(out / "vectors", "sf_divide")
    assert m["expected_value"] == int(outs["y"][m["sample"]]) != m["got_value"]
    assert f"MISMATCH sf_divide: golden stream, sample {m['sample']}, port y: got {m['got_value']}" in printed
    # a waveform around it, holding the DUT's signals over the window
    waves = [w for w in row["waves"] if w["stream"] == "golden"]
    assert waves and waves[0]["outputs"][0] <= m["sample"] <= waves[0]["outputs"][1]
    vcd = (out / waves[0]["file"]).read_text()
    assert "$scope module dut $end" in vcd and re.search(r"\$var \w+ \d+ \S+ out_valid \$end", vcd)
    assert len(re.findall(r"^#\d+", vcd, re.M)) > 20
    assert "sf_divide" in (out / "report.md").read_text() and "First mismatches" in (out / "report.md").read_text()


@pytest.mark.parametrize("argv, words", [
    (["--only", "sf_divid"], ("--only", "sf_divide")),
    (["--only", "chain_paper002_lop"], ("--only", "'chain_paper002_lop'", "chain_paper002_loop")),
    (["--only", ","], ("--only",)),
    (["--long", "0"], ("--long",)),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, argv, words):
    rc = main(["rtl", *argv, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and all(w in err for w in words)
    assert not (tmp_path / "o").exists()


def test_a_folder_without_verilog_is_bad_input(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    rc = main(["rtl", "--rtl", str(tmp_path / "empty"), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and "--rtl" in err and len(err.strip().splitlines()) == 1


@pytest.mark.hdl
def test_rtl_that_does_not_build_is_a_failure_quoting_the_compiler(tmp_path, capsys):
    """A user's RTL that does not compile is a failing DUT with the simulator's first error (the
    file and line), exit 1 and the report written: never a traceback."""
    require_simulator("icarus")
    rtl = tmp_path / "rtl_src"
    shutil.copytree(RTL_DIR, rtl)
    with open(rtl / "bias_subtract.v", "a") as f:
        f.write("\nmodule broken(input wire a; endmodule\n")
    out = tmp_path / "out"
    capsys.readouterr()
    assert main(["rtl", "--only", "bias_subtract", "--rtl", str(rtl), "--long", "50", "--out", str(out)]) == 1
    printed = capsys.readouterr().out
    row = json.loads((out / "report.json").read_text())["duts"][0]
    assert not row["passed"] and row["first_mismatch"] is None
    errors = [e for s in row["streams"].values() for e in s["errors"]]
    assert errors and all(e.startswith("build failed: ") and "bias_subtract.v" in e for e in errors)
    assert "MISMATCH bias_subtract: golden stream: build failed:" in printed and "bias_subtract.v" in printed


# ---- a chain of the user's own, written from the docs (README, the default config's comments) ------
USER_CHAIN = default_config_text() + '''
[piecewise.tc]            # the user's bias polynomial in T - 25 C, deg/h, two segments
breakpoints_c = [10.0]
coefficients = [[2.0, 0.1, 0.001], [2.5, 0.12, 0.0]]
t0_c = 25.0
coef_format = ["s24.16", "s24.20", "s24.24"]
acc_format = "s40.24"
out_format = "s24.12"
rounding = "half_even"
overflow = "saturate"

[bias_subtract2]
in_format = "s24.12"
out_format = "s24.12"
rounding = "half_up"
overflow = "wrap"

[chain.user]              # branching, and listed in another order than the data flows
instances = ["bias_subtract2", "piecewise.tc", "rtd"]
inputs = ["rate -> bias_subtract2.x", "code -> rtd.code"]
wires = ["rtd.temp -> piecewise.tc.temp", "piecewise.tc.y -> bias_subtract2.bias"]
outputs = ["bias_subtract2.y -> rate_c", "rtd.temp -> temp", "piecewise.tc.y -> bias"]
'''


@pytest.mark.hdl
def test_rtl_verifies_a_chain_the_project_never_saw(tmp_path):
    """Its top is generated from its netlist; both variants pass every stream; a fault in the
    generated top's schedule (a member started before what drives it is ready) is caught."""
    require_simulator("icarus")
    cfg = tmp_path / "user.toml"
    cfg.write_text(USER_CHAIN)
    out = tmp_path / "rtl"
    assert main(["rtl", "--config", str(cfg), "--only", "chain_user", "--sim", "icarus", "--long", "300",
                 "--out", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert [r["dut"] for r in report["duts"]] == ["chain_user", "chain_user (serial)"] and report["passed"]
    assert (out / "hdl" / "chain_user.v").is_file()


@pytest.mark.hdl
def test_a_fault_in_a_generated_top_is_caught(tmp_path, monkeypatch):
    from fxdsp.hdl import chain_top

    require_simulator("icarus")
    real = chain_top.chain_top

    def early(design, name):   # the subtraction no longer waits for the polynomial
        text = real(design, name)
        if name != "chain_user":
            return text
        assert " & done_piecewise_tc" in text
        return text.replace(" & done_piecewise_tc", "")

    monkeypatch.setattr(chain_top, "chain_top", early)
    cfg = tmp_path / "user.toml"
    cfg.write_text(USER_CHAIN)
    code = main(["rtl", "--config", str(cfg), "--only", "chain_user", "--sim", "icarus", "--long", "100",
                 "--out", str(tmp_path / "rtl")])
    assert code == 1
    report = json.loads((tmp_path / "rtl" / "report.json").read_text())
    assert not report["passed"] and report["duts"][0]["dut"] == "chain_user"


@pytest.mark.hdl
def test_rtl_runs_on_a_config_without_the_papers_chains(tmp_path):
    """A config without paper 001's chain: only its own chains' tops are generated and compiled, and a
    block of it builds and passes."""
    from fxdsp.chains import build
    from fxdsp.config import dumps

    require_simulator("icarus")
    d = build()
    data = tomllib.loads(default_config_text())
    del data["chain"]["paper001"]
    data["piecewise"]["bias001"]["temp_format"] = str(d.blocks["freq2temp"].temp_format)
    data["bias_subtract001"]["bias_format"] = str(d.blocks["piecewise_bias001"].out_format)
    cfg = tmp_path / "no001.toml"
    cfg.write_text(dumps(data))
    assert main(["rtl", "--config", str(cfg), "--only", "bias_subtract001", "--sim", "icarus", "--long", "200",
                 "--out", str(tmp_path / "rtl")]) == 0


def test_streams_that_share_a_run_keep_their_own_segments_cycles_and_errors(monkeypatch, tmp_path):
    """A DUT's golden, random and corner streams run in one cocotb run (one simulator start); the
    driver's summary numbers the segments of the whole run (the contract of fxdsp.hdl.cocotb_stream:
    ``segment_cycles``, ``error_segments``, each mismatch's ``segment``), and each stream's record
    must read as if it had run alone: a wrong word in the corners' second segment fails the corners
    alone, numbered 1, with that segment's inputs and gap."""
    from fxdsp.hdl import regression as rg
    from fxdsp.hdl.params import design_files
    from hdl_util import design_of

    design = design_of()
    runs = []

    def one_run(design, name, segments, d, models, **kw):
        runs.append(segments)
        k = len(segments) - 2   # the corners' second segment (back to back from reset)
        return {"cycles": 150, "seconds": 0.0, "errors": [f"{segments[k]['label']} port te: 1 mismatch(es)"],
                "error_segments": [k], "segment_cycles": [10 * (i + 1) for i in range(len(segments))],
                "mismatches": [{"segment": k, "port": "te", "sample": 5, "got": 1, "expected": 2, "count": 1,
                                "of": 9}]}

    monkeypatch.setattr(rg.hh, "run_cocotb", one_run)
    names = ["golden", "random", "corners"]
    files = design_files(design)["vectors"]
    out = rg._py_streams(design, rg.Dut("lag", None), names, files, "icarus", dict.fromkeys(names, 7), tmp_path,
                         None, None)
    # what each stream would have run alone: its segments, in order, each with its own gap
    alone = {n: rg._stream(design, rg.Dut("lag", None), n, files, "icarus", 7, None) for n in names}
    assert len(runs) == 1 and [s["label"] for s in runs[0]] == [f"segment {i}" for n in names
                                                                for i in range(len(alone[n][0]))]
    assert [s["gap"] for s in runs[0]] == [s.get("gap", alone[n][2]) for n in names for s in alone[n][0]]
    assert len({s["gap"] for s in runs[0]}) > 1, "the streams' gaps must differ for the check to mean anything"
    assert out["golden"][0]["ok"] and out["random"][0]["ok"] and out["golden"][1] is None
    first = np.cumsum([0] + [len(alone[n][0]) for n in names])   # each stream's first segment in the run
    assert [out[n][0]["cycles"] for n in names] == [sum(10 * (k + 1) for k in range(first[i], first[i + 1]))
                                                    for i, n in enumerate(names)]
    record, mismatch, inputs, gapped = out["corners"]
    assert not record["ok"] and record["errors"] == ["segment 1 port te: 1 mismatch(es)"]
    corners, _, corners_gap = alone["corners"]
    assert mismatch["segment"] == 1 and mismatch["sample"] == 5
    assert gapped == bool(corners[1].get("gap", corners_gap))
    assert len(next(iter(inputs.values()))) == len(next(iter(runs[0][3]["inputs"].values())))
