"""The drive loop's RTL closed on the simulated resonator (fxdsp.hdl.cosim), on Verilator: its DAC
word drives the mode, the mode's pick-off its ADC input, and every output word at every sample is
the model's closed loop's from power-on (the ADC codes it reads are the model's only while every
DAC word it gave was). A short run here, through the PLL's first updates (the full acquisition and
a second of lock: `fxdsp rtl`); a mutant in the loop filter and one in the phase detector each leave
the model's trajectory."""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.hdl.cosim import loop_instances, run_loop_cosim
from conftest import tiered
from hdl_util import VERILATOR_MODELS, build_dir, design_of, mutated_rtl, record_throughput, require_simulator
from mutation import MUTATIONS

SHORT_S = 0.05   # 4800 samples at 96 kS/s: the PLL switches on after ~10 ms (pll_min_amp) and runs 40 ms
TEMP_C = 85.0    # the resonance 14 Hz off the NCO's centre: the PLL has somewhere to go


@pytest.mark.hdl
# the first drive table in make test; the others (drive001: the same module at another resonance) are
# the slow tier, beside the user's own table below
@pytest.mark.parametrize("name", tiered(loop_instances(design_of()), lambda name: name == loop_instances(design_of())[0]))
def test_the_rtl_loop_closed_on_its_mode_is_the_models_closed_loop(name):
    require_simulator("verilator")
    d = build_dir(f"cosim_{name}")
    s = run_loop_cosim(design_of(), name, d, VERILATOR_MODELS, temp_c=TEMP_C, seconds=SHORT_S)
    assert s["errors"] == [], s["errors"]
    assert s["samples"] == s["expected_samples"] and s["codes_match"]
    f = np.load(d / "expected.npz")["f"]
    assert len(np.unique(f)) > 10, "the PLL must act within the compared window"
    record_throughput("cosim", name, s["cycles"], s["seconds"], sim="verilator")


@pytest.mark.hdl
def test_the_serial_rtl_loop_closed_on_its_mode_is_the_models_closed_loop():
    """The serial variant (ARCH = 1) in the same closed loop: the same words at every sample, one
    sample per its schedule's cycles (the handshake's cycle added)."""
    require_simulator("verilator")
    from fxdsp.hdl.schedule import member_cycles

    design, d = design_of(), build_dir("cosim_drive_serial")
    s = run_loop_cosim(design, "drive", d, VERILATOR_MODELS, temp_c=TEMP_C, seconds=SHORT_S, extra={"ARCH": 1})
    assert s["errors"] == [], s["errors"]
    assert s["samples"] == s["expected_samples"] and s["codes_match"]
    assert len(np.unique(np.load(d / "expected.npz")["f"])) > 10, "the PLL must act within the compared window"
    assert s["cycles"] == s["samples"] * (member_cycles(design, "drive") + 1)
    record_throughput("cosim", "drive (serial)", s["cycles"], s["seconds"], sim="verilator")


@pytest.mark.hdl
# (the loop filter's rounding mutant, drive_pll_rounding_floor, is the regression test's below: caught
# there in both variants, with its sample, port and waveform; the detector's, here, is the slow tier:
# a closed loop that leaves the model's trajectory is make test's there, and the golden vectors catch
# this mutant in test_mutation)
@pytest.mark.slow
@pytest.mark.parametrize("key", ["drive_detector_q_sign"])
def test_a_loop_mutant_leaves_the_models_trajectory(key, tmp_path):
    require_simulator("verilator")
    m = next(m for m in MUTATIONS if m.key == key)
    rtl = mutated_rtl(tmp_path / "rtl", m.file, [(m.old, m.new)])
    s = run_loop_cosim(design_of(), "drive", build_dir(f"cosim_mut_{key}"), VERILATOR_MODELS, temp_c=TEMP_C,
                       seconds=SHORT_S, rtl=rtl)
    assert s["mismatch"] is not None, f"{key}: not caught in {s['samples']} samples"


@pytest.mark.hdl
def test_a_users_loop_closes_on_the_mode_its_table_was_designed_for(tmp_path):
    """A drive table the project never saw (another name, resonance, lock range and bandwidth): the
    co-simulation closes it on the mode it was designed for (fxdsp.sim.resonator.resonator_for)."""
    require_simulator("verilator")
    from fxdsp.chains import build
    from fxdsp.config import Config
    from hdl_util import default_data

    data = {k: v for k, v in default_data().items() if k in ("system", "stimulus")}
    mine = dict(default_data()["drive"], f_hz=5123.4, lock_range_hz=8.0, pll_bandwidth_hz=15.0)
    mine["lpf"] = dict(default_data()["drive"]["lpf"])
    data["drive7"] = mine
    design = build(Config(data, source="pickoff.toml"))
    assert loop_instances(design) == ["drive7"]
    d = build_dir("cosim_user")
    s = run_loop_cosim(design, "drive7", d, VERILATOR_MODELS, seconds=SHORT_S)
    assert s["errors"] == [] and s["samples"] == s["expected_samples"] and s["codes_match"]
    assert len(np.unique(np.load(d / "expected.npz")["f"])) > 10


@pytest.mark.hdl
def test_the_regression_names_a_loop_that_leaves_the_models_trajectory(tmp_path):
    """`fxdsp rtl`'s closed_loop stream (fxdsp.hdl.regression, that stream alone: the others are the
    block tests') fails on the loop-filter mutant, with the sample, the port and a waveform of the
    RTL fed the model's ADC codes up to there (open loop, the same words)."""
    from fxdsp.hdl.regression import markdown, regression
    from fxdsp.vectors import generate

    require_simulator("verilator")
    m = next(m for m in MUTATIONS if m.key == "drive_pll_rounding_floor")
    rtl = mutated_rtl(tmp_path / "rtl", m.file, [(m.old, m.new)])
    design = design_of()
    out = tmp_path / "out"
    out.mkdir()
    report = regression(design, generate(design), out, sim="verilator", only=["drive"], rtl=rtl,
                        models=VERILATOR_MODELS, streams=("closed_loop",), show_progress=False)
    assert not report["passed"]
    assert [r["dut"] for r in report["duts"]] == ["drive", "drive (serial)"]   # the mutant is in both variants
    for row in report["duts"]:
        loop = row["streams"]["closed_loop"]
        assert not loop["ok"] and loop["samples"] < 2000 and "port" in loop["errors"][0]
        assert row["first_mismatch"]["stream"] == "closed_loop" and row["first_mismatch"]["sample"] == loop["samples"]
        waves = [w for w in row["waves"] if w["stream"] == "closed_loop"]
        assert waves and (out / waves[0]["file"]).stat().st_size > 1000
    assert "closed loop on its mode: sample" in markdown(report)
