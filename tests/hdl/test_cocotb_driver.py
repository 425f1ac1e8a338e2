"""The Python-driven (cocotb) stream driver sleeps through a serial DUT's busy stretches instead of
stepping every edge (cocotb_stream._sleep_while_busy). That must not blind it: a serial DUT's
scheduler bugs, including the handshake ones the sleep is built on (in_ready, out_valid), still
fail the golden comparison on both simulators, and the unmutated DUT passes on the same prefix."""

from __future__ import annotations

import pytest

from fxdsp.vectors import load
from hdl_util import SERIAL, SIMULATORS, VECTORS, build_dir, design_of, icarus_window, mutated_rtl, run_cocotb, segment
from mutation import MUTATIONS

# a missed stall (in_ready never low: the driver never sleeps, samples are lost mid-schedule), a
# stale accumulator read and a wrong operand slot (outputs wrong, handshake right: the driver sleeps
# through every sample)
KEYS = ["iir_serial_missed_stall", "iir_serial_stale_sum", "iir_serial_wrong_state_slot"]
N = 120  # golden samples (hdl_util.icarus_window: the set opens with 256 zeros): ~6,500 cycles


def _run(sim: str, tag: str, rtl=None):
    design = design_of()
    ins, _, _ = load(VECTORS, "iir")
    seg = segment(design, "iir", icarus_window(ins, N))  # model outputs from reset
    return run_cocotb(design, "iir", [seg], tag, extra_params=SERIAL["iir"], sim=sim, rtl=rtl)


@pytest.mark.hdl
@pytest.mark.parametrize("sim", SIMULATORS)
def test_driver_passes_the_unmutated_serial_dut(sim):
    summary = _run(sim, "driver_baseline")
    assert summary["errors"] == []
    # the cycles counted from simulation time cover every sample's schedule
    assert summary["cycles"] >= N * 7


# Verilator builds a model per mutant (~10 s of C++): there the one whose handshake is right, so the
# driver sleeps through every sample and only the outputs can tell
CASES = [(k, "icarus") for k in KEYS] + [("iir_serial_stale_sum", "verilator")]


@pytest.mark.hdl
@pytest.mark.parametrize("key, sim", CASES)
def test_driver_catches_serial_scheduler_bugs(key, sim):
    m = next(m for m in MUTATIONS if m.key == key)
    d = build_dir(f"driver_{key}_{sim}_src")
    rtl = mutated_rtl(d / "rtl", m.file, [(m.old, m.new)])
    with pytest.raises(pytest.fail.Exception):
        _run(sim, f"driver_{key}", rtl=rtl)
