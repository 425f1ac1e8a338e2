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
from hdl_util import VERILATOR_MODELS, build_dir, design_of, mutated_rtl, record_throughput, require_simulator
from mutation import MUTATIONS

SHORT_S = 0.05   # 4800 samples at 96 kS/s: the PLL switches on after ~10 ms (pll_min_amp) and runs 40 ms
TEMP_C = 85.0    # the resonance 14 Hz off the NCO's centre: the PLL has somewhere to go


@pytest.mark.hdl
@pytest.mark.parametrize("name", loop_instances(design_of()))
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
@pytest.mark.parametrize("key", ["drive_pll_rounding_floor", "drive_detector_q_sign"])
def test_a_loop_mutant_leaves_the_models_trajectory(key, tmp_path):
    require_simulator("verilator")
    m = next(m for m in MUTATIONS if m.key == key)
    rtl = mutated_rtl(tmp_path / "rtl", m.file, [(m.old, m.new)])
    s = run_loop_cosim(design_of(), "drive", build_dir(f"cosim_mut_{key}"), VERILATOR_MODELS, temp_c=TEMP_C,
                       seconds=SHORT_S, rtl=rtl)
    assert s["mismatch"] is not None, f"{key}: not caught in {s['samples']} samples"
