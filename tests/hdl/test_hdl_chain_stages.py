"""The optional stages of chain_paper002 on the RTL: the lag between the RTD
readout and the coefficient engines (the lag inserted into ``[chain.paper002]``, a member of its generated top) and the
phase trim of the NCO reference (``[demod] phase_trim_rad`` -> demod's PHASE_TRIM), each alone and
together. Golden vectors of each extended config are made here from the model (not committed) and
streamed through the chain with cocotb on Icarus: every output word and the overflow-flag count
must match the model. The checks must be able to fail: the same run on a mutated RTL copy (the lag
bypassed, the trim's sign inverted, the trim not passed to the NCO) fails. The chain with the lag is
also linted (the default chain's lint is test_hdl_lint.py's).
"""

from __future__ import annotations

import contextlib
import json

import numpy as np
import pytest

from conftest import lag_chain
from hdl_util import SIM_BUILD, build_dir, default_data, design_of, generate_into, lint_iverilog, lint_verilator, \
    mutated_rtl, mutated_top, require_iverilog, run_cocotb, segment

CHAIN = "chain_paper002"
FS = default_data()["system"]["fs_hz"]
# rate_hz = fs: the lag updates on every chain sample. tau of a few ms makes Te trail the swept
# temperature by ~1 C within the streamed prefix (a large, visible effect)
LAG = {**lag_chain(), "lag": {"rate_hz": FS, "tau_s": 0.002}}
TRIM = {"demod": {"phase_trim_rad": 0.3}}
# both, with the lag updated on every 5th sample (DECIM = 5: holds between), another lag rounding
# and few guard bits (the state rounding shows), a trim across a quadrant boundary (negative: the
# word wraps modulo 2**phase_bits)
BOTH = {**lag_chain(), "demod": {"phase_trim_rad": -2.2},
        "lag": {"rate_hz": FS / 5, "tau_s": 0.005, "state_guard_bits": 6, "rounding": "floor"}}
CONFIGS = {"lag": LAG, "trim": TRIM, "both": BOTH}
EXTRA = {"DIV_UNROLL": 7}   # 7 quotient bits per cycle: the Python-driven run stays fast
HEAD, TAIL = 1000, 300      # samples of the nominal sweep and of the saturating hot tail
# a mutant's run: a fifth of it (each mutant changes most rate words from the first samples on; the
# lag of tau = 2-5 ms, 190-480 samples, trails the sweep within the first 400)
MUTANT_HEAD, MUTANT_TAIL = 400, 60


def stimulus(design, head: int = HEAD, tail: int = TAIL) -> dict[str, np.ndarray]:
    """The chain's own vector stimulus, shortened: the start of the temperature sweep with rate steps
    and quadrature, and the end of the full-scale (saturating) segment at 60 C, which the lag reaches
    by slewing from -18 C."""
    full = design.chains[CHAIN].stimulus(np.random.default_rng([design.seed, 14]), design.samples)
    return {k: np.concatenate([v[:head], v[-tail:]]) for k, v in full.items()}


@pytest.fixture(scope="module")
def designs():
    return {k: design_of(v) for k, v in CONFIGS.items()}


@pytest.fixture(scope="module")
def baseline():
    return design_of()


def test_configs_have_the_stages_and_change_the_outputs(designs, baseline):
    """Each config really enables its stage (and nothing else), and on this stimulus the model's rate
    differs from the chain without it: a matching RTL run below is evidence about the stage."""
    ins = stimulus(baseline)
    plain = baseline.chains[CHAIN].run(**ins).outputs
    for key, d in designs.items():
        chain = d.chains[CHAIN]
        assert chain.stages == (() if key == "trim" else ("lag",)), key
        assert (chain.sensor.demod.nco.trim != 0) == (key != "lag"), key
        out = chain.run(**ins).outputs
        assert np.array_equal(out["temp"], plain["temp"]), f"{key}: the temp port stays the thermometer's"
        changed = np.count_nonzero(out["rate"] != plain["rate"])
        assert changed > 0.9 * len(plain["rate"]), f"{key}: only {changed} rate words changed"


@pytest.mark.hdl
@pytest.mark.parametrize("key", sorted(CONFIGS))
def test_chain_with_stages_matches_the_model_on_the_rtl(designs, baseline, key):
    d = designs[key]
    assert d.ovf_width(CHAIN) == baseline.ovf_width(CHAIN) + (key != "trim"), \
        "the lag adds one ovf bit (lag.te), after rtd"
    run_cocotb(d, CHAIN, [segment(d, CHAIN, stimulus(d))], f"stages_{key}", extra_params=EXTRA)


@pytest.mark.hdl
def test_serial_chain_with_both_stages_matches_the_model_on_the_rtl(designs):
    """ARCH = 1 with the lag and the trim (the serial lag's update and held samples at DECIM 5, the
    serial demod's trimmed NCO): ~290 cycles per sample, so on Verilator (Icarus would take minutes)."""
    d = designs["both"]
    run_cocotb(d, CHAIN, [segment(d, CHAIN, stimulus(d))], "stages_both_serial", extra_params={**EXTRA, "ARCH": 1},
               sim="verilator")


# single-point RTL mutations of the stages, each with the config whose check must catch it
MUTATIONS = {
    # (the generated top: the lag's result captured as the thermometer's, so the engines read T, not Te)
    "lag_bypassed": ("chain_paper002.v", "lag_te_q <= lag_te;", "lag_te_q <= rtd_temp_q;", "lag"),
    "trim_sign_inverted": ("nco.v", "START_C  = PHASE0_C + TRIM_C;", "START_C  = PHASE0_C - TRIM_C;", "trim"),
    "trim_not_passed": ("demod.v", ".PHASE_TRIM(PHASE_TRIM), ", "", "trim"),
    "lag_not_decimated": ("lag.v", "wire                     update = in_valid & ((DECIM == 1) | (phase == {PH_W{1'b0}}));",
                          "wire                     update = in_valid;", "both"),
}


@pytest.mark.hdl
@pytest.mark.parametrize("key", sorted(MUTATIONS))
def test_a_stage_mutation_fails_the_check(designs, key, tmp_path):
    file, old, new, config = MUTATIONS[key]
    generated = file == f"{CHAIN}.v"   # the chain's top is generated: mutate what the generator writes
    rtl = None if generated else mutated_rtl(tmp_path / "rtl", file, [(old, new)])
    d = designs[config]
    seg = segment(d, CHAIN, stimulus(d, MUTANT_HEAD, MUTANT_TAIL))
    tag = f"stages_mut_{key}"
    # a failed cocotb test ends run_cocotb with pytest.fail, or with the runner's SystemExit
    with pytest.raises((pytest.fail.Exception, SystemExit)), \
            (mutated_top(CHAIN, [(old, new)]) if generated else contextlib.nullcontext()):
        run_cocotb(d, CHAIN, [seg], tag, extra_params=EXTRA, rtl=rtl)
    # ... and it failed on the outputs (the mutant compiled and ran): the driver's own summary
    errors = json.loads((SIM_BUILD / tag / "summary.json").read_text())["errors"]
    assert any("port rate" in e and "mismatch" in e for e in errors), errors


@pytest.mark.hdl
def test_chain_with_the_lag_lints_clean(designs):
    """The generated top of a lag config (the lag a member of it) with its headers: iverilog -Wall and
    verilator -Wall."""
    require_iverilog()
    d = build_dir("stages_lint")
    generate_into(designs["both"], d)
    top = d / f"{CHAIN}.v"
    assert " u_lag (" in top.read_text()
    assert ".DECIM(5)" in (d / "lag_params.vh").read_text()
    assert lint_iverilog(CHAIN, include=d, extra=(top,)) == ""
    assert lint_verilator(CHAIN, include=d, extra=(top,)) == ""
    assert lint_iverilog(CHAIN, {"ARCH": 1}, include=d, extra=(top,)) == ""   # the serial chain, the serial lag
    assert lint_verilator(CHAIN, {"ARCH": 1}, include=d, extra=(top,)) == ""
