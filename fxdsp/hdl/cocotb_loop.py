"""cocotb test module of the closed-loop co-simulation (:mod:`fxdsp.hdl.cosim`): a drive loop's RTL
closed on the simulated resonator (cocotb 2.x API).

``spec.json`` (path in ``FXDSP_SPEC``) names the pickled :class:`fxdsp.sim.driveloop.ModeTwin` (the
mode and its pick-off ADC, the model's own coefficients and noise) and the expected words (``.npz``:
the model's closed loop, every ADC code it read and every output word, unsigned at the port's
width). Per sample: the twin's ADC code goes in with in_valid (one cycle, once in_ready is high), the
DUT's outputs are read at its out_valid, and the DAC word drives the twin for the next sample. A
serial variant's out_valid comes its schedule's cycles after the sample (``quiet``: the cycles the
driver sleeps through before it watches each edge; ``output_limit``: the most it waits in all). The RTL's words are
compared with the model's sample by sample; the first sample where any differs ends the run (the
loop has left the model's trajectory: later words differ because the earlier did). Summary: the
samples run, cycles, seconds, the first mismatch and whether every ADC code was the model's.
"""

from __future__ import annotations

import json
import os
import pickle
import time

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import RisingEdge, Timer
from cocotb.utils import get_sim_time

PERIOD_NS = 10


def _u(handle) -> int:
    v = handle.value
    return int(v.to_unsigned()) if hasattr(v, "to_unsigned") else int(v)


@cocotb.test()
async def closed_loop(dut):
    with open(os.environ["FXDSP_SPEC"]) as f:
        spec = json.load(f)
    with open(spec["twin"], "rb") as f:
        twin = pickle.load(f)
    exp = np.load(spec["expected"])
    outs, dac_w, in_w = spec["outputs"], int(spec["dac_w"]), int(spec["in_w"])
    limit, quiet = int(spec["output_limit"]), int(spec["quiet"])
    n = min(int(spec["samples"]), twin.n)
    want = {p: exp[p] for p in outs}
    codes_want = exp["codes"]
    out_h = {p: getattr(dut, p) for p in outs}
    cocotb.start_soon(Clock(dut.clk, PERIOD_NS, unit="ns", impl="gpi").start())   # as cocotb_stream's
    dut.in_valid.value = 0
    dut.x.value = 0
    dut.rst.value = 1
    for _ in range(2):
        await RisingEdge(dut.clk)
    dut.rst.value = 0
    t0 = time.perf_counter()
    sim0 = get_sim_time(unit="ns")
    errors: list[str] = []
    mismatch = None
    codes_ok = True
    ovf_seen = 0
    in_mask = (1 << in_w) - 1
    i = 0
    while i < n:
        code = twin.code()
        if code != int(codes_want[i]):
            codes_ok = False
        dut.x.value = code & in_mask
        dut.in_valid.value = 1
        await RisingEdge(dut.clk)
        while int(dut.in_ready.value) != 1:   # taken at an edge with in_ready
            await RisingEdge(dut.clk)
        dut.in_valid.value = 0
        if quiet:   # to mid-cycle (never on an edge), then edge by edge
            await Timer(quiet * PERIOD_NS - PERIOD_NS // 2, unit="ns")
        for _ in range(limit - quiet):
            await RisingEdge(dut.clk)
            if int(dut.out_valid.value) == 1:
                break
        else:
            errors.append(f"sample {i}: no out_valid within {limit} cycles")
            break
        words = {p: _u(out_h[p]) for p in outs}
        ovf_seen += bin(_u(dut.ovf)).count("1")
        bad = [p for p in outs if words[p] != int(want[p][i])]
        if bad:
            p = bad[0]
            mismatch = {"sample": i, "port": p, "got": words[p], "expected": int(want[p][i]), "ports": bad}
            errors.append(f"sample {i} ({i / spec['fs_hz']:.6f} s): port {p} got {words[p]:#x}, expected "
                          f"{int(want[p][i]):#x} (wrong: {', '.join(bad)})")
            break
        dac = words["dac"]
        twin.drive(dac - (1 << dac_w) if dac >> (dac_w - 1) else dac)
        i += 1
    if not codes_ok and not errors:
        errors.append("the ADC codes left the model's although every output word matched (the twin)")
    seconds = time.perf_counter() - t0
    cycles = round((get_sim_time(unit="ns") - sim0) / PERIOD_NS)
    with open(spec["summary"], "w") as f:
        json.dump({"samples": i, "cycles": cycles, "seconds": seconds, "errors": errors, "mismatch": mismatch,
                   "codes_match": codes_ok, "overflow_flags": ovf_seen, "adc_saturations": twin.saturations}, f)
    for e in errors[:5]:
        dut._log.error(e)
    assert not errors, errors[0]
