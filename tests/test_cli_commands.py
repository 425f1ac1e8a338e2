"""The demo and bench commands run end to end (functional checks; speed is not asserted)."""

from __future__ import annotations

import json
from pathlib import Path

from fxdsp.cli import main
from fxdsp.chains import build


def test_demo_prints_every_block(tmp_path: Path, capsys):
    assert main(["demo", "--out", str(tmp_path / "v")]) == 0
    out = capsys.readouterr().out
    for name in build().all:
        assert f"\n{name}." in out
    assert (tmp_path / "v" / "manifest.json").exists()
    assert "RTD readout vs true temperature" in out


def test_bench_reports_ratios_and_agreement(tmp_path: Path, capsys):
    out = tmp_path / "bench.json"
    assert main(["bench", "--samples", "200000", "--repeat", "1", "--prefix-apytypes", "400",
                 "--prefix-fxpmath", "40", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    for lib in ("apytypes", "fxpmath"):
        assert res[lib]["bit_identical_samples"] == res[lib]["prefix_samples"]
        assert res[lib]["ratio_fxdsp_over_lib"] > 0
    assert res["biquad"]["samples_per_s"] > 0 and res["chain_paper002"]["samples_per_s"] > 0


def test_bench_rejects_small_sample_counts(capsys):
    assert main(["bench", "--samples", "1000"]) == 2
    assert "200000" in capsys.readouterr().err
