"""Closed-loop co-simulation: a drive loop's RTL closed on the simulated resonator, its DAC word
driving the mode and the mode's pick-off feeding its ADC input, against the model's own closed
loop (:func:`fxdsp.sim.driveloop.closed_loop`) sample for sample.

A loop that is bit-exact on canned vectors can still fail closed: acquire a different way, lock
elsewhere, drift, because its outputs move the input it reads. Here the input is the mode's answer
to the RTL's own DAC words (:class:`fxdsp.sim.driveloop.ModeTwin`: the model's coefficients, noise
and arithmetic), so the RTL reads the model's ADC codes only while every DAC word it gave was the
model's; every output word is compared at every sample (:mod:`fxdsp.hdl.cocotb_loop`).

Nothing here prints or exits; a build failure is :class:`fxdsp.hdl.harness.BuildFailed`.
"""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np

from fxdsp.blocks.drive import Drive
from fxdsp.sim.driveloop import ModeTwin, closed_loop, lock_time
from fxdsp.sim.resonator import DriveResonator, resonator_for
from fxdsp.hdl.harness import is_serial, run_cocotb_test, to_unsigned
from fxdsp.hdl.schedule import member_cycles
from fxdsp.errors import InputError

LOOP_DRIVER = "fxdsp.hdl.cocotb_loop"
# the co-simulation's temperature: the end of the papers' range, where both papers' modes are
# furthest from their loops' centre words (paper 002's 14 Hz, paper 001's 3.2 Hz): the PLL travels
COSIM_TEMP_C = 85.0


def loop_instances(design) -> list[str]:
    """The design's drive loops with RTL (the instances a co-simulation closes)."""
    return [n for n, inst in design.hardware.items() if not inst.members and isinstance(inst.block, Drive)]


def acquisition_s(drive: Drive, resonator: DriveResonator | None = None, temp_c: float = COSIM_TEMP_C,
                  seed: int = 1) -> float | None:
    """The model's lock time from power-on on the mode (default :func:`resonator_for`), in s (None:
    it never locks within six time constants)."""
    res = resonator or resonator_for(drive)
    seconds = max(3.0, 6 * float(res.tau_s(temp_c)))
    return lock_time(closed_loop(drive, res, temp_c, seconds, seed=seed), drive)


def expected_words(design, name: str, resonator: DriveResonator, temp_c: float, seconds: float,
                   seed: int) -> dict[str, np.ndarray]:
    """The model's closed loop: every ADC code it read (``codes``) and every output word it gave,
    unsigned at the port's width (the block run open loop on those codes gives the closed loop's
    words again, bit for bit)."""
    drive = design.all[name]
    run = closed_loop(drive, resonator, temp_c, seconds, seed=seed, keep_codes=True)
    res = drive.run(x=run.adc_codes)
    words = {p: np.array(to_unsigned(res.outputs[p], drive.outputs[p].wl), dtype=np.uint64) for p in drive.outputs}
    return {"codes": run.adc_codes, **words}


def _waits(design, name: str, extra: dict | None) -> dict:
    """How long the driver waits for a sample's out_valid: ``quiet`` cycles it need not watch (a
    serial variant's schedule, less 3), ``output_limit`` cycles in all."""
    serial = is_serial(extra)
    cycles = member_cycles(design, name, 1 if serial else 0)
    return {"quiet": max(0, cycles - 3) if serial else 0, "output_limit": cycles + 64}


def run_loop_cosim(design, name: str, d: Path, models: Path | None, temp_c: float = COSIM_TEMP_C, seconds: float = 0.05,
                   seed: int = 1, sim: str = "verilator", rtl: Path | None = None,
                   resonator: DriveResonator | None = None, extra: dict | None = None) -> dict:
    """Close the RTL of drive loop ``name`` on its mode (default :func:`resonator_for`: the mode its
    table was designed for) at ``temp_c`` from power-on for ``seconds``, in the empty folder ``d``.
    Returns the co-simulation's summary (samples, cycles, seconds, errors, the first mismatch,
    codes_match) with ``samples_per_s`` and ``build_seconds``. ``extra``: the parameters selecting a
    variant (the serial one's ARCH), its schedule from its datapath."""
    drive = design.all[name]
    if not isinstance(drive, Drive):
        raise InputError(f"{name}: not a drive loop")
    res = resonator or resonator_for(drive)
    d = Path(d)
    d.mkdir(parents=True, exist_ok=True)
    exp = expected_words(design, name, res, temp_c, seconds, seed)
    np.savez(d / "expected.npz", **exp)
    twin = ModeTwin(drive, res, temp_c, seconds, seed=seed)
    with open(d / "twin.pkl", "wb") as f:
        pickle.dump(twin, f)
    spec = {"twin": str(d / "twin.pkl"), "expected": str(d / "expected.npz"), "samples": twin.n,
            "outputs": list(drive.outputs), "dac_w": drive.dac_format.wl, "in_w": drive.in_format.wl,
            "fs_hz": drive.fs_hz, **_waits(design, name, extra)}
    summary = run_cocotb_test(design, name, LOOP_DRIVER, spec, d, models, extra, sim, rtl)
    # a simulation that ended without its summary (a crash) ran no sample that was compared
    for key, empty in (("samples", 0), ("mismatch", None), ("codes_match", False)):
        summary.setdefault(key, empty)
    summary["samples_per_s"] = (summary["samples"] / summary["seconds"]) if summary.get("seconds") else None
    summary["expected_samples"] = twin.n
    return summary
