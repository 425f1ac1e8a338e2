"""fxdsp budget: attribution adds up, theory check, optimiser, CLI errors."""

from __future__ import annotations

import re
import tomllib

import numpy as np
import pytest

from conftest import OLD_NCO, coarse_subtract, design_with, edited_data
from fxdsp.budget.attribution import attribute, check_rounding
from fxdsp.budget.static import static_error
from fxdsp.chains import build
from fxdsp.cli import main
from fxdsp.config import load_config
from fxdsp.float_vs_fixed import block_errors


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


# the requirement of the floor issue (not a reading of the code): the rate output within 3 dB of the
# sense and RTD ADCs' quantisation carried to it, and no bias beyond 0.05 deg/h
FLOOR_DB = 3.0
MAX_BIAS_DPH = 0.05


def _floor_violations(a) -> list[str]:
    floor = np.sqrt(sum(np.mean(s.error**2) for s in a.sources if s.source.category == "ADC quantisation"))
    floor_phys = floor * a.scale
    out = []
    if a.total_rms > floor_phys * 10 ** (FLOOR_DB / 20):
        out.append(f"rms {a.total_rms:.3g} more than {FLOOR_DB} dB above the ADC floor {floor_phys:.3g}")
    if abs(a.total_mean) > MAX_BIAS_DPH:
        out.append(f"mean {a.total_mean:+.3g} beyond {MAX_BIAS_DPH}")
    return out


def test_paper002_rate_within_3_db_of_its_adc_floor(design):
    a = attribute(design, "chain_paper002", "rate", n=8192)
    assert a.hybrid_max_diff == 0
    assert _floor_violations(a) == []
    e_sum = np.sum([s.error for s in a.sources], axis=0)
    # linear superposition of the one-source errors reproduces the total within 0.1 dB
    assert abs(_db(np.mean(e_sum**2), np.mean(a.total_error**2))) < 0.1


@pytest.mark.parametrize("f_hz", [8000.0, 7987.3, 8011.55])   # the nominal f/fs = 1/12 and two in the band
def test_old_truncating_nco_bias_is_caught_and_named(design, f_hz):
    """Inject the old phase-truncating NCO: its deterministic phase error is a bias the floor check
    catches, the attribution names as the biggest source and explains as correlated."""
    old = design_with(chains=True, **OLD_NCO, **{"demod.f_hz": f_hz})
    a = attribute(old, "chain_paper002", "rate", n=8192)
    assert _floor_violations(a) != []
    top = max(a.sources, key=lambda s: np.mean(s.error**2))
    assert top.source.name == "demod.nco_phase"
    if f_hz == 8000.0:   # f/fs = 1/12: the same 12 truncated phases again and again, a pure bias
        assert abs(np.mean(top.error)) > 0.9 * np.sqrt(np.mean(top.error**2))
    new = attribute(design_with(chains=True, **{"demod.f_hz": f_hz}), "chain_paper002", "rate", n=8192)
    assert _floor_violations(new) == []
    nco = next(s for s in new.sources if s.source.name == "demod.nco_phase")
    assert abs(np.mean(nco.error)) * new.scale < MAX_BIAS_DPH / 10



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


@pytest.mark.parametrize("rounding", ["half_up", "floor"])
def test_theory_check_on_a_stage(rounding):
    d = build(coarse_subtract(rounding))
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
    """On paper 000's chain: its knobs come from its members' kinds (it had none of its own), its
    target is in mg (the port found by its unit), and a chain with a sensor is also held to its
    quasi-static chamber points. (Paper 002's 23-knob search takes ~50 s; its evaluator is tested
    below and its knobs are the same kinds'.)"""
    out = tmp_path / "opt.toml"
    argv = ["budget", "--optimise", "--chain", "chain_paper000", "--target", "0.01mg", "--config-out", str(out)]
    assert main(argv) == 0
    data = tomllib.loads(out.read_text())
    default = load_config().data
    assert _format_bits(data) < _format_bits(default)
    d = build(str(out))
    stats = {s.port: s for s in block_errors(d, "chain_paper000")}
    assert stats["accel"].rms * 1e3 <= 0.01           # g -> mg
    assert static_error(d, "chain_paper000", "accel")["rms"] * 1e3 <= 0.01
    capsys.readouterr()
    assert main(["budget", "--config", str(out), "--chain", "chain_paper000", "--target", "0.01mg"]) == 0
    assert "MET" in capsys.readouterr().out


def test_a_search_builds_its_chain_alone_and_gets_the_whole_configs_error_and_refusals():
    """The optimiser's evaluations build the chain and the chains that share a table with it
    (optimise.chain_only); at any knob values the error, and whether the config builds at all, are
    the whole config's. Drawn over every chain port of the default config: among the draws, paper
    001's input format, which its loop's drive table also wires to freq2temp, makes configs that
    only the whole build refuses."""
    import copy
    import math
    import random

    from fxdsp.budget import optimise as opt
    from fxdsp.config import Config

    def whole_error(ev, values):   # the whole config built, as before chain_only
        try:
            return ev._error_of(build(Config(ev.data(values), source="<test>")), 1000)
        except opt.NOT_BUILT:
            return math.inf

    cfg, rng = load_config(), random.Random(5)
    refused = 0
    for chain, c in sorted(build(cfg).chains.items()):
        for port in sorted(c.outputs):
            ev = opt.Evaluator(copy.deepcopy(cfg.data), chain, port)
            for _ in range(3 if ev.knobs else 0):
                values = {k.name: opt.knob_value(ev.base, k) + rng.choice([-3, -1, 0, 2]) for k in ev.knobs}
                whole = whole_error(ev, values)
                assert ev.error(values) == whole, (chain, port, values)
                refused += math.isinf(whole)
            assert set(ev.built["chain"]) <= set(cfg.data["chain"])
    assert refused, "no draw the whole config refuses: the shared-table case is not exercised"
    # a config that does not build whole (a typo in a table of another chain) is searched whole: no
    # candidate builds, as before, where the chain alone would
    data = copy.deepcopy(cfg.data)
    data["iir"]["cutof_hz"] = 1.0
    ev = opt.Evaluator(data, "chain_paper000", "accel")
    assert ev.built == data and math.isinf(ev.error({k.name: opt.knob_value(data, k) for k in ev.knobs}))


@pytest.mark.parametrize("argv, word", [
    (["budget", "--target", "10furlong"], "--target"),
    (["budget", "--target", "abc"], "--target"),
    (["budget", "--optimise", "--target", "1e-9deg/h"], "--target: 1e-9deg/h is unreachable"),
    # the target alone is met at every knob's maximum, the bias limit is not: the refusal names it
    (["budget", "--optimise", "--target", "1deg/h", "--max-mean", "1e-15deg/h"], "--max-mean: 1e-15deg/h is unreachable"),
    (["budget", "--max-mean", "0.05deg/h"], "--max-mean"),
    (["budget", "--drive-band"], "--drive-band"),
    (["budget", "--optimise", "--target", "1deg/h", "--max-mean", "5mC"], "--max-mean"),
    (["budget", "--optimise", "--chain", "chain_paper001", "--target", "1deg/h", "--drive-band"], "--drive-band"),
])
def test_bad_input_exits_2_with_one_line(argv, word, capsys):
    """Refused before the budget is computed: nothing on stdout (an unreachable target is the search's
    first finding, not a line after every section of the budget)."""
    assert main(argv) == 2
    out, err = capsys.readouterr()
    err = err.strip().splitlines()
    assert len(err) == 1 and word in err[0]
    assert out == ""


def test_an_unreachable_target_beside_a_bias_limit_quotes_the_targets_own_error(capsys):
    """With --max-mean the search's error is max(rms, |mean| x target / limit); a target that is not met
    even alone is refused with its own rms error, the same number as without the limit (not the
    bias term, which a limit of 1e-15 deg/h makes a thousand times larger)."""
    quoted = []
    for extra in ([], ["--max-mean", "1e-15deg/h"]):
        assert main(["budget", "--optimise", "--target", "1e-9deg/h", *extra]) == 2
        err = capsys.readouterr().err
        assert err.startswith("fxdsp budget: error: --target: 1e-9deg/h is unreachable"), err
        quoted.append(re.search(r"rms error is (\S+) deg/h", err).group(1))
    assert quoted[0] == quoted[1]


def test_synth_estimate_sums_the_chain_members():
    from fxdsp.budget.optimise import synth_estimate

    rows = {"rtd": {"lut": 120.0, "mac16": 1.0}, "iir": {"lut": 300.0, "mac16": 4.0},
            "freq2temp": {"lut": 50.0, "mac16": 1.0}}
    est = synth_estimate(rows, build().instances["chain_paper002"].members, 100, 50)
    assert est["lut_default"] == 420 and est["mac16_default"] == 5 and est["lut_estimate"] == 210


def _evaluator(edits=(), **kw):
    from fxdsp.budget.optimise import Evaluator

    return Evaluator(edited_data(**dict(edits)), "chain_paper002", "rate", **kw)


def test_optimiser_bias_limit_sees_a_bias_the_rms_target_weighs_lightly():
    """With --max-mean the search error is max(rms, target / limit x |mean|): the old truncating NCO,
    whose error is nearly all bias, scores the weight times worse; a design without bias does not."""
    weight = 0.33 / 0.05
    plain, weighted = _evaluator(OLD_NCO), _evaluator(OLD_NCO, mean_weight=weight)
    assert weighted.error({}) > 0.8 * weight * plain.error({})
    assert _evaluator(mean_weight=weight).error({}) < 2 * _evaluator().error({})


def test_optimiser_drive_band_takes_the_worst_frequency():
    f = (7987.3, 8011.55)
    singles = [_evaluator({"demod.f_hz": x}).error({}) for x in (8000.0, *f)]
    assert _evaluator(frequencies=f).error({}) == max(singles)
