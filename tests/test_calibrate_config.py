"""``fxdsp calibrate --config-out F --apply LOG2`` and ``fxdsp repro``."""

from __future__ import annotations

import json

import pytest

from fxdsp.chains import build
from fxdsp.cli import main
from fxdsp.sim import generate_log, write_log


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    paths = {}
    for scenario, seed in (("paper002", 1), ("paper002", 2), ("paper001", 1), ("paper001", 2), ("paper000", 1),
                           ("paper000", 2)):
        noise = {"output": 1e-3} if scenario == "paper000" else None  # about 20 ug: a quartz pair
        path = d / f"{scenario}_{seed}.csv"
        write_log(path, generate_log(scenario, effects={}, seed=seed, noise=noise))
        paths[scenario, seed] = str(path)
    return paths


def test_paper002_config_out_and_apply(logs, tmp_path, capsys):
    cfg, js = tmp_path / "cal.toml", tmp_path / "cal.json"
    rc = main(["calibrate", "--paper", "002", logs["paper002", 1], "--json", str(js), "--config-out", str(cfg),
               "--apply", logs["paper002", 2]])
    assert rc == 0
    build(str(cfg))  # the written config is a valid, complete config
    res = json.loads(js.read_text())["apply"]
    assert res["overflows"] == 0
    assert 250 < res["sf_tempco_ppm_before"] < 400 and 250 < res["bias_tempco_deg_h_before"] < 450
    assert res["sf_tempco_ppm_after"] < res["sf_tempco_ppm_before"] / 100
    assert res["bias_tempco_deg_h_after"] < res["bias_tempco_deg_h_before"] / 100
    assert "sf_tempco_ppm_after" in capsys.readouterr().out


def test_paper002_quadratic_segments_config(logs, tmp_path):
    cfg = tmp_path / "cal2.toml"
    assert main(["calibrate", "--paper", "002", logs["paper002", 1], "--json", str(tmp_path / "j.json"),
                 "--config-out", str(cfg), "--order", "2"]) == 0
    d = build(str(cfg))
    assert d.blocks["piecewise_sf"].order == 2 and d.blocks["piecewise_bias"].order == 2


def test_paper001_config_is_checked_and_applied(logs, tmp_path):
    cfg, js = tmp_path / "c1.toml", tmp_path / "c1.json"
    assert main(["calibrate", "--paper", "001", logs["paper001", 1], "--json", str(js), "--config-out", str(cfg),
                 "--apply", logs["paper001", 2]]) == 0
    out = json.loads(js.read_text())
    assert out["config"]["thermometer_check"]["ok"]
    assert abs(out["config"]["thermometer_check"]["mean_error_c"]) < 0.05
    app = out["apply"]
    assert app["output_std_after"] < app["output_std_before"] / 100
    assert app["temp_range_c"][0] == pytest.approx(-10.0, abs=0.5)
    assert app["temp_range_c"][1] == pytest.approx(50.0, abs=0.5)


def test_paper000_config_applied_to_a_second_run(logs, tmp_path):
    js = tmp_path / "c0.json"
    assert main(["calibrate", "--paper", "000", logs["paper000", 1], "--json", str(js),
                 "--apply", logs["paper000", 2]]) == 0
    app = json.loads(js.read_text())["apply"]
    assert app["k0_max_abs_mg"] < 1.0 and app["k1_max_abs_dev"] < 5e-5  # the paper's limits


def test_calibrate_bad_arguments_are_one_line_errors(logs, tmp_path, capsys):
    assert main(["calibrate", "--paper", "002", logs["paper002", 1], "--order", "5", "--apply",
                 logs["paper002", 2]]) == 2
    assert "--order" in capsys.readouterr().err
    assert main(["calibrate", "--paper", "001", logs["paper001", 1], "--order", "2", "--config-out",
                 str(tmp_path / "x.toml")]) == 2
    assert "--order" in capsys.readouterr().err
    assert main(["calibrate", "--paper", "001", logs["paper001", 1], "--config-out",
                 str(tmp_path / "no" / "dir" / "x.toml")]) == 2
    assert "--config-out" in capsys.readouterr().err
    assert main(["calibrate", "--paper", "001", logs["paper001", 1], "--apply", str(tmp_path / "missing.csv")]) == 2


def test_repro_command_writes_the_report(tmp_path, capsys):
    assert main(["repro", "--paper", "003", "--sweep-points", "7", "--quiet", "--report", str(tmp_path)]) == 0
    text = (tmp_path / "REPRODUCTIONS.md").read_text()
    assert "Paper 003" in text and "img/paper003.png" in text
    assert (tmp_path / "img" / "paper003.png").stat().st_size > 10_000
    assert "cxy" in capsys.readouterr().out
    assert main(["repro", "--paper", "004", "--quiet"]) == 2
    assert "--paper" in capsys.readouterr().err
    assert main(["repro", "--paper", "003", "--sweep-points", "2", "--quiet"]) == 2


def test_a_report_of_one_paper_keeps_the_other_papers_parts(tmp_path, capsys):
    """REPRODUCTIONS.md is made of one part per paper: a run of paper 000 into a report that holds
    paper 003 adds its part and keeps 003's (its section, its summary rows, its figure) byte for
    byte; a run of 003 again replaces only 003's."""
    from fxdsp.repro.report import PARTS

    def section(text, paper):
        start = text.index(f"## Paper {paper}")
        nxt = text.find("\n## Paper ", start + 1)
        return text[start: nxt if nxt > 0 else None]

    argv = ["repro", "--quiet", "--report", str(tmp_path)]
    assert main([*argv, "--paper", "003", "--sweep-points", "5"]) == 0
    first = (tmp_path / "REPRODUCTIONS.md").read_text()
    figure = (tmp_path / "img" / "paper003.png").read_bytes()
    assert main([*argv, "--paper", "000"]) == 0
    both = (tmp_path / "REPRODUCTIONS.md").read_text()
    assert section(both, "003") == section(first, "003") and "## Paper 000" in both
    assert [ln for ln in first.splitlines() if ln.startswith("| 003 |")] == \
        [ln for ln in both.splitlines() if ln.startswith("| 003 |")]
    assert (tmp_path / "img" / "paper003.png").read_bytes() == figure
    assert "--paper 003 --report" in both and "--paper 000 --report" in both
    assert main([*argv, "--paper", "003", "--sweep-points", "3"]) == 0   # 003's part replaced, 000's kept
    again = (tmp_path / "REPRODUCTIONS.md").read_text()
    assert section(again, "000") == section(both, "000") and section(again, "003") != section(both, "003")
    capsys.readouterr()
    (tmp_path / PARTS).write_text("not json")   # edited by hand: not fxdsp's any more, so not replaced
    assert main([*argv, "--paper", "000"]) == 2 and PARTS in capsys.readouterr().err
    (tmp_path / PARTS).unlink()                 # gone: the report holds this run's papers only
    assert main([*argv, "--paper", "000"]) == 0 and "## Paper 003" not in (tmp_path / "REPRODUCTIONS.md").read_text()
    capsys.readouterr()
