"""fxdsp budget: attribution adds up, theory check, optimiser, CLI errors."""

from __future__ import annotations

import copy
import tomllib

import numpy as np
import pytest

from fxdsp.budget.attribution import attribute, check_rounding
from fxdsp.chains import build
from fxdsp.cli import main
from fxdsp.config import Config, load_config
from fxdsp.errors_table import block_errors


@pytest.fixture(scope="module")
def design():
    return build()


def _db(a, b):
    return 10 * np.log10(a / b)


def test_paper001_attribution_adds_up_in_power(design):
    a = attribute(design, "chain_paper001", "rate", n=1024)
    assert a.hybrid_max_diff == 0  # every source on reproduces the bit-exact chain
    total = np.mean(a.total_error**2)
    powers = sum(np.mean(s.error**2) for s in a.sources)
    assert abs(_db(powers, total)) < 0.5


def test_paper002_attribution_superposes_and_names_the_correlated_sources(design):
    a = attribute(design, "chain_paper002", "rate", n=8192)
    assert a.hybrid_max_diff == 0
    e_sum = np.sum([s.error for s in a.sources], axis=0)
    total = np.mean(a.total_error**2)
    # linear superposition of the one-source errors reproduces the total within 0.1 dB
    assert abs(_db(np.mean(e_sum**2), total)) < 0.1
    # the biggest single source is the NCO's deterministic phase error, a bias (mean ~ rms)
    top = max(a.sources, key=lambda s: np.mean(s.error**2))
    assert top.source.name == "demod.nco_phase"
    assert abs(np.mean(top.error)) > 0.9 * np.sqrt(np.mean(top.error**2))
    # the plain power sum misses the coherent bias cross terms, and the report says so
    powers = sum(np.mean(s.error**2) for s in a.sources)
    assert _db(powers, total) < -0.5
    assert "demod.nco_phase" in a.explanation() and "correlated" in a.explanation()


def test_theory_check_on_synthetic_rounding():
    rng = np.random.default_rng(3)
    q = 2.0**-10
    x = rng.uniform(-1, 1, 50000)
    half = np.floor(x / q + 0.5) * q - x
    flo = np.floor(x / q) * q - x
    nums, reasons = check_rounding(half, q, "half_up", x)
    assert abs(nums["mean_q"]) < 0.02 and abs(10 * np.log10(np.mean(half**2) / (q * q / 12))) < 0.2
    assert reasons == []
    nums, reasons = check_rounding(flo, q, "floor", x)
    assert abs(nums["mean_q"] + 0.5) < 0.02
    assert reasons and "mean" in reasons[0]


def _coarse_subtract(rounding: str) -> Config:
    cfg = load_config()
    data = copy.deepcopy(cfg.data)
    data["bias_subtract"]["out_format"] = "s20.18"   # 4 fraction bits dropped after the subtraction
    data["bias_subtract"]["rounding"] = rounding
    data["iir"]["data_format"] = "s20.18"
    return Config(data)


@pytest.mark.parametrize("rounding", ["half_up", "floor"])
def test_theory_check_on_a_stage(rounding):
    d = build(_coarse_subtract(rounding))
    a = attribute(d, "chain_paper002", "rate", n=8192)
    t = next(t for t in a.theory if t.source == "bias_subtract.round")
    assert t.q == 2.0**-18
    if rounding == "half_up":
        assert abs(t.local_mean_q) < 0.05 and abs(t.local_mse_db) < 1.0
        assert not any("mean" in r for r in t.reasons)
    else:
        assert abs(t.local_mean_q + 0.5) < 0.05
        assert t.flagged and any("mean" in r for r in t.reasons)


def _format_bits(data) -> int:
    total = 0
    stack = [data]
    while stack:
        node = stack.pop()
        for v in node.values() if isinstance(node, dict) else node:
            if isinstance(v, (dict, list)):
                stack.append(v)
            elif isinstance(v, str) and v[:1] in "su" and "." in v and v[1:].split(".")[0].isdigit():
                total += int(v[1:].split(".")[0])
    return total


def test_optimiser_meets_target_with_fewer_bits(tmp_path, capsys):
    out = tmp_path / "opt.toml"
    assert main(["budget", "--optimise", "--target", "40deg/h", "--config-out", str(out)]) == 0
    data = tomllib.loads(out.read_text())
    default = load_config().data
    assert _format_bits(data) < _format_bits(default)
    d = build(str(out))
    stats = {s.port: s for s in block_errors(d, "chain_paper002")}
    assert stats["rate"].rms * d.rate_full_scale_dps * 3600 <= 40.0
    capsys.readouterr()
    assert main(["budget", "--config", str(out), "--target", "40deg/h"]) == 0
    assert "MET" in capsys.readouterr().out


@pytest.mark.parametrize("argv, word", [
    (["budget", "--target", "10furlong"], "--target"),
    (["budget", "--target", "abc"], "--target"),
    (["budget", "--optimise", "--target", "1e-9deg/h"], "unreachable"),
])
def test_bad_input_exits_2_with_one_line(argv, word, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and word in err[0]


def test_synth_estimate_sums_the_chain_members():
    from fxdsp.budget.optimise import synth_estimate

    rows = {"rtd": {"lut": 120.0, "mac16": 1.0}, "iir": {"lut": 300.0, "mac16": 4.0},
            "freq2temp": {"lut": 50.0, "mac16": 1.0}}
    est = synth_estimate(rows, build().instances["chain_paper002"].members, 100, 50)
    assert est["lut_default"] == 420 and est["mac16_default"] == 5 and est["lut_estimate"] == 210
