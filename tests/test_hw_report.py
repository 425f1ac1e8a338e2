"""The hardware report as data: hdl/HW_REPORT.json holds the same table as hdl/HW_REPORT.md, is found
through fxdsp.hdl.hwreport.hw_report_path(), and is what the budget reads."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from fxdsp.chains import build

from fxdsp.hdl import hwplan, hwreport, synthesis
from fxdsp.hdl.hwreport import hw_report_path, load_hw_report, report_json, synthesised_cost
from fxdsp.hdl.hwreport_md import markdown
from fxdsp.hdl.synthesis import UP5K, XC7A35T

ROOT = Path(__file__).parents[1]


def test_committed_json_holds_the_markdown_table():
    # the package's copy is the checkout's report (a link), so an installed package reads the same rows
    assert hw_report_path().resolve() == (ROOT / "hdl" / "HW_REPORT.json").resolve()
    report = load_hw_report()
    # the Markdown written from the JSON's rows is the committed Markdown, byte for byte
    assert markdown(report["rows"], report["target_mhz"], report.get("source_sha256", "")) == \
        (ROOT / "hdl" / "HW_REPORT.md").read_text()


def test_json_is_written_from_the_rows_hw_report_collects(tmp_path):
    rows = [{"name": "rtd", "module": "rtd", "LUT": 301, "MAC16": 2, "FF": 20, "BRAM": 0, "fmax": 21.83, "note": "",
             "CARRY": 7, "seconds": 3.2},
            {"name": "demod", "module": "demod", "note": "timed out after 1200 s", "seconds": 1200.0}]
    path = tmp_path / "HW_REPORT.json"
    path.write_text(report_json(rows, 40.0, UP5K))
    got = load_hw_report(path)["rows"]
    assert got[0] == {"name": "rtd", "module": "rtd", "LC": None, "LUT": 301, "FF": 20, "CARRY": 7, "MAC16": 2,
                      "BRAM": 0, "GB": None, "fmax": 21.83, "fmax_seeds": None, "critical_seed": None,
                      "critical_path": None, "cycles_per_sample": None, "cycle_budget": None, "target": None, "warnings": None,
                      "note": "", "sha256": None, "xc7": {"LUT": None, "DSP48E1": None, "FF": None, "BRAM36": None, "BRAM18": None,
                                          "LUTRAM": None, "SRL": None, "warnings": None, "note": ""}}
    assert got[1]["LUT"] is None and got[1]["fmax"] is None and got[1]["note"].startswith("timed out")
    rows[0]["xc7"] = {"LUT": 150, "DSP48E1": 2, "FF": 20, "BRAM36": 0, "BRAM18": 1, "LUTRAM": 0, "SRL": 0,
                      "seconds": 2.5}
    path.write_text(report_json(rows, 40.0, UP5K, "", XC7A35T))
    data = load_hw_report(path)
    assert data["device_xc7"]["DSP48E1"] == 90
    assert data["rows"][0]["xc7"] == {"LUT": 150, "DSP48E1": 2, "FF": 20, "BRAM36": 0, "BRAM18": 1, "LUTRAM": 0,
                                      "SRL": 0, "warnings": None, "note": ""}
    assert "| 150 | 2 | 20 | 0/1 |" in markdown(data["rows"], 40.0)
    assert load_hw_report(tmp_path / "absent.json") is None


def test_committed_report_has_the_xc7_columns_for_every_row():
    """Every row of the committed report carries the yosys synth_xilinx (Artix-7) estimate: integer
    LUT, DSP48E1, FF and block-RAM counts (a failed or timed-out xc7 run would leave them null)."""
    report = load_hw_report()
    assert report.get("device_xc7", {}).get("name") == XC7A35T["name"]
    assert report["rows"]
    for row in report["rows"]:
        xc7 = row.get("xc7")
        assert isinstance(xc7, dict), f"{row['name']}: no xc7 columns (run make hw-report)"
        for key in ("LUT", "DSP48E1", "FF", "BRAM36", "BRAM18"):
            assert isinstance(xc7.get(key), int) and xc7[key] >= 0, f"{row['name']}: xc7 {key} = {xc7.get(key)!r}"
        assert xc7["LUT"] > 0, row["name"]


def test_budget_reads_the_json_through_the_locator(tmp_path, monkeypatch):
    rows = {r["name"]: r for r in load_hw_report()["rows"]}
    committed = synthesised_cost()
    assert set(committed) == set(rows) and committed["iir"] == {"lut": rows["iir"]["LUT"], "mac16": rows["iir"]["MAC16"]}
    report = tmp_path / "HW_REPORT.json"
    report.write_text(json.dumps({"rows": [{"name": "iir", "LUT": 10, "MAC16": None}]}))
    monkeypatch.setattr(hwreport, "hw_report_path", lambda: report)
    assert synthesised_cost() == {"iir": {"lut": 10.0, "mac16": 0.0}}
    report.unlink()
    assert synthesised_cost() is None


def test_committed_report_is_current_for_the_rtl_and_default_config():
    """A change to any RTL source, generated header or ROM makes the committed report stale: rerun
    `make hw-report` (yosys + nextpnr-ice40) and commit hdl/HW_REPORT.md and .json."""
    from fxdsp.chains import build
    from fxdsp.hdl.hwreport import source_hash

    design = build()
    report = load_hw_report()
    assert report.get("source_sha256") == source_hash(design), "hdl/HW_REPORT.* is stale: run make hw-report"
    from fxdsp.hdl.hwplan import variants

    # a row per instance, and one per resource-shared variant of a block (e.g. the serial iir)
    assert {r["name"] for r in report["rows"]} == set(design.hardware) | set(variants(design))
    # and each row's own hash is that of what it synthesises now (what a regeneration reuses)
    from fxdsp.hdl.hwplan import expected_row_hashes

    expected = expected_row_hashes(design, report["target_mhz"])
    stale = [r["name"] for r in report["rows"] if r.get("sha256") != expected[r["name"]]]
    assert not stale, f"rows {stale} of hdl/HW_REPORT.* are stale: run make hw-report"


def _copy_rtl(tmp_path, monkeypatch) -> Path:
    rtl = tmp_path / "hdl" / "rtl"
    rtl.mkdir(parents=True)
    for p in (ROOT / "hdl" / "rtl").glob("*.v"):
        (rtl / p.name).write_text(p.read_text())
    monkeypatch.setattr(hwreport, "RTL_DIR", rtl)
    return rtl


def test_row_hash_changes_for_exactly_the_rows_that_read_a_changed_file(tmp_path, monkeypatch):
    """A change to nco_phase.v (read by nco.v and the serial demod) re-runs the rows that synthesise it
    (demod, the paper 002 chain) and no other;
    a change to a shared primitive re-runs every row that instantiates it."""
    from fxdsp.chains import build
    from fxdsp.hdl.hwplan import expected_row_hashes

    design = build()
    before = expected_row_hashes(design, 40.0)
    rtl = _copy_rtl(tmp_path, monkeypatch)
    assert expected_row_hashes(design, 40.0) == before
    (rtl / "nco_phase.v").write_text((rtl / "nco_phase.v").read_text().replace("1'b1}", "1'b0}", 1))
    after = expected_row_hashes(design, 40.0)
    changed = {row for row in before if before[row] != after[row]}
    assert {"demod", "demod (ARCH=1)", "chain_paper002", "chain_paper002 (ARCH=1)"} <= changed
    assert not changed & {"rtd", "iir", "chain_paper001", "piecewise_sf (ARCH=1)", "sf_divide"}
    text = (rtl / "fx_round.v").read_text()
    assert text.count("assign c = half;") == 1
    (rtl / "fx_round.v").write_text(text.replace("assign c = half;", "assign c = half + one;"))
    assert all(before[row] != h for row, h in expected_row_hashes(design, 40.0).items())  # every block rounds
    assert expected_row_hashes(design, 41.0)["rtd"] != before["rtd"]   # another target clock is another run


def test_previous_rows_are_reused_only_under_the_same_tools_and_when_complete():
    from fxdsp.hdl.hwplan import reusable_rows

    good = {"sha256": "a", "LUT": 10, "xc7": {"LUT": 5}}
    failed = {"sha256": "b", "LUT": None, "xc7": {"LUT": 5}}
    no_xc7 = {"sha256": "c", "LUT": 10, "xc7": {"LUT": None}}
    tools = {"yosys": "Yosys 0.23"}
    prev = {"tools": tools, "target_mhz": 40.0, "rows": [good, failed, no_xc7]}
    assert set(reusable_rows(prev, tools, 40.0, need_xc7=True)) == {"a"}
    assert set(reusable_rows(prev, tools, 40.0, need_xc7=False)) == {"a", "c"}
    assert reusable_rows(prev, {"yosys": "Yosys 0.40"}, 40.0, True) == {}
    assert reusable_rows(prev, tools, 48.0, True) == {}
    assert reusable_rows(None, tools, 40.0, True) == {}


def test_source_hash_sees_a_one_character_rtl_change(tmp_path, monkeypatch):
    from fxdsp.chains import build
    from fxdsp.hdl.hwreport import source_hash

    design = build()
    before = source_hash(design)
    rtl = _copy_rtl(tmp_path, monkeypatch)
    assert source_hash(design) == before
    (rtl / "nco_phase.v").write_text((rtl / "nco_phase.v").read_text().replace("1'b1}", "1'b0}", 1))
    assert source_hash(design) != before


def test_a_module_larger_than_the_device_is_not_sent_to_the_placer():
    from fxdsp.hdl.hwplan import too_big

    assert too_big({"MAC16": UP5K["MAC16"], "LUT": UP5K["LUT"]}) == ""
    assert "SB_MAC16" in too_big({"MAC16": UP5K["MAC16"] + 1, "LUT": 10})
    assert "LUT4" in too_big({"MAC16": 0, "LUT": UP5K["LUT"] + 1})


def test_only_reruns_its_rows_and_keeps_the_reports_other_current_rows(tmp_path, monkeypatch, capsys):
    """`hw-report --fresh --only rtd` on a copy of the committed report: rtd's rows are synthesised again
    (the tools faked here), every other row comes over unchanged, none is lost; a stale row not asked
    for is left out with a message rather than kept as if current."""
    import argparse
    import shutil as sh

    from fxdsp.commands import hw_report as report_cli

    out = tmp_path / "HW_REPORT.md"
    sh.copy(ROOT / "hdl" / "HW_REPORT.json", out.with_suffix(".json"))
    committed = load_hw_report(out.with_suffix(".json"))
    monkeypatch.setattr(report_cli.shutil, "which", lambda tool: "/usr/bin/" + tool)
    monkeypatch.setattr(report_cli, "tool_versions", lambda: committed["tools"])
    monkeypatch.setattr(report_cli, "synth", lambda *a, **k: {"LUT": 1, "MAC16": 0, "FF": 1, "BRAM": 0, "CARRY": 0})
    monkeypatch.setattr(report_cli, "synth_xc7", lambda *a, **k: {"LUT": 1, "DSP48E1": 0, "FF": 1, "BRAM36": 0,
                                                                 "BRAM18": 0, "LUTRAM": 0, "SRL": 0})
    monkeypatch.setattr(report_cli, "place_route", lambda *a, **k: (99.0, "", {1: 99.0}, {"fmax": 99.0, "seed": 1}))
    parser = argparse.ArgumentParser()
    report_cli.configure(parser)

    def rerun(*argv):
        assert report_cli.run(parser.parse_args(["--out", str(out), *argv])) == 0
        return {r["name"]: r for r in load_hw_report(out.with_suffix(".json"))["rows"]}

    rows = rerun("--fresh", "--only", "rtd")
    before = {r["name"]: r for r in committed["rows"]}
    assert list(rows) == list(before)
    assert all(rows[n]["LUT"] == 1 for n in rows if n.startswith("rtd"))
    assert all(rows[n] == before[n] for n in rows if not n.startswith("rtd"))
    # a row made stale (its hash no longer the current one) and not asked for is dropped, said on stderr
    data = json.loads(out.with_suffix(".json").read_text())
    next(r for r in data["rows"] if r["name"] == "iir")["sha256"] = "0" * 64
    out.with_suffix(".json").write_text(json.dumps(data))
    capsys.readouterr()
    rows = rerun("--only", "rtd")
    assert "iir" not in rows and "iir (ARCH=1)" in rows
    assert "iir: not in --only" in capsys.readouterr().err


def test_a_budget_row_is_judged_on_its_slowest_seed():
    """A chain's budget row is placed with several seeds; its Fmax target holds only when every seed
    meets it (one seed is one draw of the placer), and a seed that did not place fails it. Its block
    RAM and its cycles per sample (the generated top's schedule, in the row) are judged too."""
    row = {"name": "chain_paper002 (ARCH=1)", "module": "chain_paper002", "LUT": 2500, "MAC16": 1, "FF": 2000,
           "BRAM": 19, "fmax": 41.2, "fmax_seeds": {"1": 41.2, "2": 39.6, "3": 40.8}, "note": "",
           "cycles_per_sample": 361, "cycle_budget": 416,
           "target": {"lut4": 2640.0, "mac16": 8.0, "bram": 20.0, "mhz": 40.0}}
    text = markdown([row], 40.0)
    assert "BRAM met (19)" in text and "cycles per sample met (361" in text
    assert "BRAM NOT met (21)" in markdown([{**row, "BRAM": 21}], 40.0)
    assert "cycles per sample NOT met (417" in markdown([{**row, "cycles_per_sample": 417}], 40.0)
    assert "| min 39.6, median 40.8 (seed 1: 41.2, seed 2: 39.6, seed 3: 40.8) |" in text
    assert "Fmax NOT met (39.6, the lowest over seeds 1, 2, 3)" in text
    row["fmax_seeds"]["2"] = 40.1
    assert "Fmax met (40.1, the lowest over seeds 1, 2, 3)" in markdown([row], 40.0)
    row["fmax_seeds"]["3"] = None
    assert "Fmax NOT met (-" in markdown([row], 40.0)
    assert hwplan.seeds_of("chain_paper002 (ARCH=1)") == hwplan.SEED_SWEEP
    assert hwplan.seeds_of("chain_user (ARCH=1)") == hwplan.SEED_SWEEP and len(hwplan.SEED_SWEEP) >= 10
    assert hwplan.seeds_of("demod (ARCH=1)") == (1,) and hwplan.seeds_of("chain_paper002") == (1,)


def test_adding_an_instance_reruns_no_other_row():
    """A new block table and a chain of it (their headers and top are new generated files) leave every
    other row's hash as it was: a row reads only the generated files of its own instances, also when
    the new chain's name begins with another's (chain_paper002_extra.v is not chain_paper002's)."""
    import copy

    from conftest import default_data
    from fxdsp.chains import build
    from fxdsp.config import Config
    from fxdsp.hdl.hwplan import expected_row_hashes

    before = expected_row_hashes(build(), 40.0)
    data = copy.deepcopy(default_data())
    data["iir2"] = {**data["iir"], "cutoff_hz": 20.0}
    data["chain"]["paper002_extra"] = {"instances": ["iir2"], "inputs": ["x -> iir2.x"], "wires": [],
                                       "outputs": ["iir2.y -> y"]}
    data["iir2"]["data_format"] = "s24.22"
    after = expected_row_hashes(build(Config(data, source="<test>")), 40.0)
    assert {r for r in after if r not in before} == {"iir2", "iir2 (ARCH=1)", "chain_paper002_extra",
                                                     "chain_paper002_extra (ARCH=1)"}
    assert all(after[r] == h for r, h in before.items())
    data["iir"]["cutoff_hz"] = 40.0    # and a change to one table re-runs the rows that read it
    changed = {r for r, h in expected_row_hashes(build(Config(data, source="<test>")), 40.0).items()
               if before.get(r, h) != h}
    assert changed == {"iir", "iir (ARCH=1)", "chain_paper002", "chain_paper002 (ARCH=1)"}, changed


def test_a_comment_or_whitespace_edit_of_the_rtl_needs_no_new_synthesis(tmp_path, monkeypatch):
    """The staleness key is the logic: rewording every comment of sf_divide.v and re-indenting it leaves
    every row's hash as it was (no re-synthesis), while a one-character change of its code makes
    exactly the rows that read it stale."""
    from fxdsp.chains import build
    from fxdsp.hdl.hwplan import expected_row_hashes

    design = build()
    before = expected_row_hashes(design, 40.0)
    rtl = _copy_rtl(tmp_path, monkeypatch)
    source_before = hwreport.source_hash(design)
    text = (rtl / "sf_divide.v").read_text()
    reworded = re.sub(r"//[^\n]*", "// reworded", text).replace("\n    ", "\n        ")
    assert reworded != text
    (rtl / "sf_divide.v").write_text(reworded)
    assert expected_row_hashes(design, 40.0) == before
    assert hwreport.source_hash(design) == source_before   # the report's own key likewise
    assert reworded.count("assign in_ready = ~busy & ~fin;") == 1
    (rtl / "sf_divide.v").write_text(reworded.replace("assign in_ready = ~busy & ~fin;", "assign in_ready = ~busy;"))
    after = expected_row_hashes(design, 40.0)
    changed = {row for row in before if before[row] != after[row]}
    assert hwreport.source_hash(design) != source_before
    assert hwreport.source_hash(design) != source_before
    assert {"sf_divide", "sf_divide (ARCH=1)", "sf_divide000", "chain_paper002 (ARCH=1)", "chain_paper000"} <= changed
    assert not changed & {"rtd", "iir", "demod", "chain_paper001", "chain_paper001 (ARCH=1)"}


def test_a_generated_tops_comments_are_not_its_logic():
    """The row hash of a generated top ignores its comments (the schedule it states in words) and
    sees any change of its code."""
    from fxdsp.chains import build
    from fxdsp.hdl.chain_top import chain_top
    from fxdsp.hdl.hwreport import row_hash

    text = chain_top(build(), "chain_paper000")
    h = row_hash("chain_paper000", None, {"chain_paper000.v": text})
    reworded = text.replace("// ARCH = 1 schedule", "// ARCH = 1: the schedule")
    assert reworded != text and row_hash("chain_paper000", None, {"chain_paper000.v": reworded}) == h
    broken = text.replace(" & done_piecewise_k0", "", 1)
    assert broken != text and row_hash("chain_paper000", None, {"chain_paper000.v": broken}) != h


def test_checks_synthesis_never_reads_are_not_logic():
    """A formal property (`ifdef FORMAL) or a simulation-only check (`ifndef SYNTHESIS) of a generated
    top is not what synthesis reads: editing it leaves the row current; the synthesised code beside
    it still counts, and a branch synthesis does take (`else of `ifdef FORMAL) counts too."""
    from fxdsp.chains import build
    from fxdsp.hdl.chain_top import chain_top
    from fxdsp.hdl.hwreport import row_hash, synthesised

    text = chain_top(build(), "chain_paper000")
    h = row_hash("chain_paper000", None, {"chain_paper000.v": text})
    assert text.count("one_request: assert(") == 1 and text.count("$finish;") == 1
    for edited in (text.replace("one_request: assert(", "one_request: assume("),
                   text.replace("$finish;", "$stop;")):
        assert edited != text and row_hash("chain_paper000", None, {"chain_paper000.v": edited}) == h
    # the directives as synthesis (SYNTHESIS defined, FORMAL not) resolves them, nested, with `else
    src = "a\n`ifdef FORMAL\nf\n`else\nx\n`ifndef SYNTHESIS\ns\n`else\ny\n`endif\n`endif\nb\n`ifdef SYNTHESIS\nz\n`endif"
    assert synthesised(src).split() == ["a", "x", "y", "b", "z"]
    assert synthesised(src, {"FORMAL"}).split() == ["a", "f", "b"]
    with pytest.raises(ValueError):
        synthesised("`ifdef FORMAL\nf\n")


# the parts of a nextpnr-ice40 0.4 log that hw-report reads (its own words and layout)
NEXTPNR_LOG = """Info: Device utilisation:
Info: 	         ICESTORM_LC:  3850/ 5280    72%
Info: 	        ICESTORM_RAM:    19/   30    63%
Info: 	               SB_GB:     8/    8   100%
Info: Max frequency for clock 'clk$SB_IO_IN_$glb_clk': 43.15 MHz (PASS at 40.00 MHz)
Info: Critical path report for clock 'clk$SB_IO_IN_$glb_clk' (posedge -> posedge):
Info: curr total
Info:  1.4  1.4  Source dut.done_demod_SB_DFFESR_Q_DFFLC.O
Info:  3.0  4.3    Net dut.done_demod budget 2.965000 ns (9,27) -> (5,25)
Info:                Sink dut.done_iir_SB_LUT4_I2_LC.I0
Info:  1.2  5.5  Source dut.done_iir_SB_LUT4_I2_LC.O
Info:  2.1  7.6    Net dut.x budget 2.9 ns (5,25) -> (6,25)
Info:                Sink dut.g_mac.u_mac.ia_SB_DFFESR_Q_D_SB_LUT4_O_LC.SR
Info: 5.8 ns logic, 17.4 ns routing

Info: Critical path report for cross-domain path '<async>' -> 'posedge clk$SB_IO_IN_$glb_clk':
Info:  0.0  0.0  Source sin$sb_io.D_IN_0
Info:                Sink dut.other.I0
Info: 1.2 ns logic, 3.8 ns routing
"""


def test_the_placement_is_read_from_nextpnrs_log():
    """Logic cells and global buffers of the placed design and the clock's critical path (not a
    cross-domain one): its first source, its last sink, logic and routing."""
    got = synthesis._placement(NEXTPNR_LOG)
    assert got == {"LC": 3850, "GB": 8, "critical_path": "dut.done_demod_SB_DFFESR_Q_DFFLC.O -> "
                   "dut.g_mac.u_mac.ia_SB_DFFESR_Q_D_SB_LUT4_O_LC.SR: 5.8 ns logic, 17.4 ns routing"}
    assert synthesis._placement("Info: nothing placed") == {"LC": None, "GB": None, "critical_path": None}


def test_tool_warnings_are_kept_but_the_two_every_placement_gives():
    """A yosys or nextpnr warning reaches the row (each once) and the report lists it; nextpnr's
    missing-PCF note and a seed's Fmax below target (the Fmax column) are left out."""
    text = ("Warning: No PCF file specified; IO pins will be placed automatically\n"
            "Warning: Literal has a width of 28 bit, but value requires 35 bit. (iir.v:1)\n"
            "Info: something\nWarning: Literal has a width of 28 bit, but value requires 35 bit. (iir.v:1)\n"
            "Warning: Max frequency for clock 'clk': 39.1 MHz (FAIL at 40.00 MHz)\n")
    assert synthesis.tool_warnings(text) == ["Warning: Literal has a width of 28 bit, but value requires 35 bit. "
                                              "(iir.v:1)"]
    row = {"name": "iir", "module": "iir", "LUT": 1, "MAC16": 0, "FF": 1, "BRAM": 0, "fmax": 50.0, "note": "",
           "warnings": synthesis.tool_warnings(text)}
    text = markdown([row], 40.0)
    assert "1:" in text and "* iir (iCE40): Warning: Literal has a width" in text
    # a warning nobody has explained says so; an explained one carries its reason
    assert "(harmless: NOT EXPLAINED)" in text
    resize = "Warning: Resizing cell port iir.g_ser.ram_e.0.0.ADDRARDADDR from 17 bits to 16 bits."
    text = markdown([{**row, "warnings": [resize]}], 40.0)
    assert f"{resize} (harmless: yosys's 7-series memory mapping" in text and "NOT EXPLAINED" not in text
    assert "none." in markdown([{**row, "warnings": []}], 40.0)


def test_a_chains_targets_come_from_its_config_table():
    """A chain's hardware targets are its table's ``hardware`` (a user's chain declares its own), carried
    in its report rows; a misspelt or non-positive target is an error naming the field."""
    import copy

    from conftest import edited_data
    from fxdsp.config import Config
    from fxdsp.hdl.hwreport_md import schedule_fields

    data = edited_data()
    data["chain"]["paper001"]["hardware"] = {"lut4": 100, "mhz": 45.0}
    d = build(Config(copy.deepcopy(data), source="<targets>"))
    assert d.chains["chain_paper001"].netlist.hardware == {"lut4": 100.0, "mhz": 45.0}
    fields = schedule_fields(d, "chain_paper001", {"ARCH": 1})
    row = {"name": "chain_paper001 (ARCH=1)", "module": "chain_paper001", "LUT": 870, "MAC16": 2, "FF": 1000,
           "BRAM": 0, "fmax": 46.0, "fmax_seeds": {"1": 46.0, "2": 44.0}, "note": "", **fields}
    text = markdown([row], 40.0)
    assert "LUT NOT met (870)" in text and "Fmax NOT met (44" in text and "MAC16" not in text.split("Target for")[1]
    assert "Targets missed: chain_paper001" in text
    for bad, words in (({"lut": 1}, "did you mean 'lut4'"), ({"mhz": -1}, "positive number"), ({"bram": "x"}, "positive")):
        data["chain"]["paper001"]["hardware"] = bad
        with pytest.raises(ValueError, match=r"chain\.paper001\.hardware"):
            try:
                build(Config(copy.deepcopy(data), source="<targets>"))
            except ValueError as e:
                assert words in str(e), str(e)
                raise


@pytest.mark.parametrize("args", [["--freq", "-1"], ["--freq", "nan"], ["--freq", "inf"], ["--timeout", "0"],
                                  ["--xc7-timeout", "-5"]])
def test_a_bad_number_is_refused_before_any_synthesis(tmp_path, capsys, args):
    from fxdsp.cli import main

    out = tmp_path / "R.md"
    assert main(["hw-report", "--only", "lag", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and args[0] in err and not out.exists(), err


def test_every_serial_row_states_its_cycles_per_sample_against_the_period():
    """The committed report's serial rows carry their schedule (the datapath's for a block, the top's for a
    chain) and the period at 40 MHz; the Markdown lists them, a row over the period with the clock it needs."""
    from fxdsp.hdl.schedule import chain_schedule, member_cycles

    d = build()
    d.with_rtl()
    rows = {r["name"]: r for r in load_hw_report()["rows"]}
    serial = {n: r for n, r in rows.items() if n.endswith(" (ARCH=1)")}
    assert {n.split(" (")[0] for n in serial} == {n for n in d.hardware if d.instances[n].rtl.variant()}
    period = int(40e6 // d.fs_hz)
    for n, r in serial.items():
        name = n.split(" (")[0]
        want = chain_schedule(d, name)[0] if d.instances[name].members else member_cycles(d, name, 1)
        assert (r["cycles_per_sample"], r["cycle_budget"]) == (want, period), n
    text = (ROOT / "hdl" / "HW_REPORT.md").read_text()
    over = [n for n, r in serial.items() if r["cycles_per_sample"] > period]
    assert over, "paper 001's whole design (the loop and the thermometer on one multiplier) is over the period"
    for n in over:
        assert f"* {n}: {serial[n]['cycles_per_sample']} of {period} (needs " in text


def test_the_ecp5_placement_is_read_from_its_tools_logs():
    """nextpnr-ecp5's Fmax line (the last of a run: the routed one) and yosys's ECP5 cell counts."""
    log = ("Info: Max frequency for clock '$glbnet$clk$TRELLIS_IO_IN': 61.20 MHz (PASS at 40.00 MHz)\n"
           "Info: Routing..\n"
           "Info: Max frequency for clock '$glbnet$clk$TRELLIS_IO_IN': 66.64 MHz (PASS at 40.00 MHz)\n")
    assert synthesis.ecp5_fmax(log) == 66.64 and synthesis.ecp5_fmax("ERROR: no BELs") is None
    stat = "   Number of cells: 9\n     CCU2C   1026\n     DP16KD   7\n     LUT4   2822\n     MULT18X18D   1\n" \
           "     TRELLIS_FF   3250\n"
    assert synthesis._ecp5_stat(stat) == {"LUT": 2822, "FF": 3250, "CARRY": 1026, "MULT18": 1, "EBR": 7}


def test_a_serial_row_that_does_not_place_is_shown_on_the_ecp5_against_the_clock_it_needs():
    row = {"name": "chain_x (ARCH=1)", "module": "chain_x", "LUT": 4280, "FF": 3803, "MAC16": 2, "fmax": None,
           "note": "does not place: 4280 LUT4 and 3803 FF need 6765 logic cells (packed), the device has 5280",
           "cycles_per_sample": 475, "cycle_budget": 416,
           "ecp5": {"device": "LFE5U-12F", "LUT": 3277, "FF": 4060, "CARRY": 1177, "MULT18": 2, "EBR": 7,
                    "fmax": 66.8, "fmax_seeds": {"1": 72.3, "2": 67.0, "3": 66.8}, "tool": "nextpnr-0.11.1"}}
    text = markdown([row], 40.0)
    line = next(l for l in text.splitlines() if l.startswith("| chain_x (ARCH=1) | LFE5U-12F"))
    assert "min 66.8, median 67.0" in line and "| 45.7 |" in line   # 475 of 416 cycles at 40 MHz
    assert json.loads(report_json([row], 40.0, UP5K))["rows"][0]["ecp5"]["fmax_seeds"] == {"1": 72.3, "2": 67.0,
                                                                                            "3": 66.8}


def test_every_serial_row_the_up5k_cannot_hold_meets_its_clock_on_the_ecp5():
    """The committed report: a serial row that does not place on the UP5K has an ECP5 placement whose
    slowest seed runs at least as fast as its cycles per sample need at the design's rate."""
    rows = [r for r in load_hw_report()["rows"] if r["name"].endswith(" (ARCH=1)")
            and str(r.get("note", "")).startswith("does not place")]
    assert {r["name"] for r in rows} >= {"drive (ARCH=1)", "chain_paper001_loop (ARCH=1)", "chain_paper002_loop (ARCH=1)"}
    for r in rows:
        e = r.get("ecp5") or {}
        need = 40.0 * max(1.0, r["cycles_per_sample"] / r["cycle_budget"])
        assert e.get("fmax") is not None and e["fmax"] >= need, (r["name"], e, need)
        # a carry cell (CCU2C) takes two LUT4 sites of the part's count
        assert e["LUT"] + 2 * e["CARRY"] <= synthesis.ECP5["LUT"] and e["MULT18"] <= synthesis.ECP5["MULT18"]
        assert e["EBR"] <= synthesis.ECP5["EBR"]
