"""Generic cocotb stream driver for every fxdsp RTL block and top (cocotb 2.x API): the test module
the simulator imports (``fxdsp.hdl.cocotb_stream``) for :func:`fxdsp.hdl.harness.run_cocotb`.

The harness writes ``spec.json`` (path in ``FXDSP_SPEC``): input words, expected output
words (unsigned, masked to the port width) and the model's overflow count, per *segment*; a
synchronous reset is applied before every segment, so a segment after another one is a reset in
mid-stream. ``abort_after`` cuts a segment after that many accepted samples and resets while
samples are still in flight: the outputs seen until then must be a prefix of the expected ones.
``gap`` is the probability of an idle cycle between samples (gapped valid; a segment may set its
own ``gap``); 0 is back to back. A segment's ``label`` names it in the errors (default ``segment
<i>``); the summary gives each segment's cycles and each error's segment (``segment_cycles``,
``error_segments``), so that several streams can share one run (``fxdsp rtl``: one simulator start
per DUT for its golden, random and corner streams). While in_valid is low the data inputs carry random words (a DUT
must not read them), while a valid sample waits for in_ready they hold. An aborted segment's reset
lands a random 0..``abort_cycles`` cycles after its last accepted sample: anywhere in a schedule.
Outputs are sampled on out_valid at each rising edge; for valid/ready DUTs a sample counts as
accepted only when in_ready was high at the edge.
A busy valid/ready DUT (a serial one spends hundreds of cycles per sample) is not stepped edge by
edge from Python: after an edge with in_ready low, if neither in_ready nor out_valid is high
after it, the driver holds its inputs (valid or, in a gapped segment by the same draw as any
cycle, idle) and sleeps until one of them rises, resuming at the following edge, the first at
which the DUT can take or give a sample. Nothing the DUT does at the skipped edges is observable
at its ports, so the comparison is the same. Cycles are counted from simulation time.
"""

from __future__ import annotations

import json
import os
import random
import time

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import First, ReadOnly, RisingEdge, Timer
from cocotb.utils import get_sim_time

PERIOD_NS = 10
IDLE_LIMIT = 500   # cycles without an output beyond the DUT's stated cycles per sample: a hung DUT


def _u(handle) -> int:
    v = handle.value
    return int(v.to_unsigned()) if hasattr(v, "to_unsigned") else int(v)


def _popcount(v: int) -> int:
    return bin(v).count("1")


def _drive(dut, ins, in_h, seg, idx, drive: bool, noise: random.Random, widths: dict) -> None:
    """The next cycle's inputs: the sample at idx with in_valid high, or in_valid low with random
    words on the data inputs (what a DUT reads while in_valid is low is garbage)."""
    for p in ins:
        in_h[p].value = seg["inputs"][p][idx] if drive else noise.getrandbits(widths[p])
    dut.in_valid.value = int(drive)


async def _sleep_while_busy(dut, ins, in_h, seg, idx, drive: bool, noise: random.Random, widths: dict,
                            idle: int) -> bool:
    """Set the next cycle's inputs, then sleep until the edge before which in_ready or out_valid is high.

    Called right after an edge (before the DUT's registers update). The next cycle's inputs (the
    sample at idx if ``drive``, else in_valid low; a gapped segment draws ``drive`` as for any
    cycle) are held over the whole busy stretch, so the caller must not set them again; ReadOnly
    then shows the ports the next edge will sample. If neither handshake signal is high, wait for
    one to rise (or ``idle`` cycles: the caller's timeout) and return before the edge that
    samples it, where the caller resumes. Returns whether in_valid is driven.
    """
    _drive(dut, ins, in_h, seg, idx, drive, noise, widths)
    await ReadOnly()
    if int(dut.in_ready.value) == 0 and int(dut.out_valid.value) == 0:
        await First(RisingEdge(dut.in_ready), RisingEdge(dut.out_valid),
                    Timer(idle * PERIOD_NS + PERIOD_NS // 2, unit="ns"))
    return drive


@cocotb.test()
async def stream(dut):
    with open(os.environ["FXDSP_SPEC"]) as f:
        spec = json.load(f)
    rng = random.Random(spec["seed"])
    noise = random.Random(spec["seed"] + 1)   # its own stream: the gap draws stay as they were
    widths = spec["widths"]
    abort_cycles = int(spec.get("abort_cycles", 0))
    idle = IDLE_LIMIT + abort_cycles   # a sample may take its stated cycles; then it has hung
    ins, outs, ready, gap = spec["inputs"], spec["outputs"], spec["ready"], spec["gap"]
    ignore = int(spec.get("ovf_ignore", 0))
    names = spec.get("rtl_names", {})   # the model's port -> the RTL's, where they differ
    in_h = {p: getattr(dut, names.get(p, p)) for p in ins}
    out_h = {p: getattr(dut, names.get(p, p)) for p in outs}
    out_valid, ovf = dut.out_valid, dut.ovf
    edge = RisingEdge(dut.clk)
    # the simulator's own clock (cocotb's C++ one) rather than a Python coroutine toggling the pin:
    # the same edges, and the Python side wakes once per cycle instead of three times (half of a
    # cheap DUT's run on Icarus). Only the clock is written by the simulator's inertial write; the
    # inputs are still written in the ReadWrite phase after the edge, so the DUT samples them at the
    # next one (the golden, random and corner streams and the driver's own mutants hold either way:
    # bit for bit)
    cocotb.start_soon(Clock(dut.clk, PERIOD_NS, unit="ns", impl="gpi").start())
    t0 = time.perf_counter()
    sim0 = get_sim_time(unit="ns")
    errors: list[str] = []
    error_segments: list[int] = []   # the segment of each error (a caller's streams share one run)
    mismatches: list[dict] = []   # per (segment, port): the first wrong word, for the report
    segment_cycles: list[int] = []

    def error(s_i: int, text: str) -> None:
        errors.append(f"{spec['segments'][s_i].get('label', f'segment {s_i}')}{text}")
        error_segments.append(s_i)

    for s_i, seg in enumerate(spec["segments"]):
        seg_sim0 = get_sim_time(unit="ns")
        dut.in_valid.value = 0
        for p in ins:
            in_h[p].value = 0
        dut.rst.value = 1
        for _ in range(2):
            await edge
        dut.rst.value = 0
        seg_gap = seg.get("gap", gap)
        n = len(seg["inputs"][ins[0]])
        n_feed = min(n, seg.get("abort_after", n))
        exp = seg["outputs"]
        got = {p: [] for p in outs}
        ovf_seen = 0
        idx = 0
        driving = False
        last_progress = get_sim_time(unit="ns")  # the last take or output: a hung DUT times out
        resume = False  # the inputs of this cycle were set while sleeping through a busy stretch
        while True:
            # drive this cycle
            if resume:
                resume = False
            else:
                driving = idx < n_feed and rng.random() >= seg_gap
                _drive(dut, ins, in_h, seg, idx, driving, noise, widths)
            await edge
            # what happened at this edge
            taken = driving and (not ready or int(dut.in_ready.value) == 1)
            now = get_sim_time(unit="ns")
            if taken:
                idx += 1
                last_progress = now
            if int(out_valid.value) == 1:
                for p in outs:
                    got[p].append(_u(out_h[p]))
                ovf_seen += _popcount(_u(ovf) & ~ignore)
                last_progress = now
            if "abort_after" in seg:
                if idx >= n_feed:
                    # reset with samples in flight, a random number of cycles into the schedule
                    for _ in range(noise.randrange(abort_cycles + 1)):
                        _drive(dut, ins, in_h, seg, idx, False, noise, widths)
                        await edge
                        if int(out_valid.value) == 1:
                            for p in outs:
                                got[p].append(_u(out_h[p]))
                    break
            elif len(got[outs[0]]) >= n:
                break
            if now - last_progress > idle * PERIOD_NS:
                error(s_i, f": timeout, {len(got[outs[0]])} of {n} outputs")
                break
            # busy before this edge (in_ready low): most likely busy for many more
            if ready and int(dut.in_ready.value) == 0:
                drive = idx < n_feed and rng.random() >= seg_gap
                driving = await _sleep_while_busy(dut, ins, in_h, seg, idx, drive, noise, widths, idle)
                resume = True
        for p in outs:
            want = exp[p][: len(got[p])] if "abort_after" in seg else exp[p]
            if len(got[p]) != len(want):
                error(s_i, f" port {p}: {len(got[p])} outputs, expected {len(want)}")
            bad = [k for k, (a, b) in enumerate(zip(got[p], want)) if a != b]
            if bad:
                k = bad[0]
                mismatches.append({"segment": s_i, "port": p, "sample": k, "got": got[p][k],
                                   "expected": want[k], "count": len(bad), "of": len(want)})
                error(s_i, f" port {p}: {len(bad)} mismatch(es), first at sample {k}: "
                           f"got {got[p][k]:#x}, expected {want[k]:#x}")
        if seg.get("ovf_total") is not None and "abort_after" not in seg and ovf_seen != seg["ovf_total"]:
            error(s_i, f": {ovf_seen} overflow flags, model counted {seg['ovf_total']}")
        segment_cycles.append(round((get_sim_time(unit="ns") - seg_sim0) / PERIOD_NS))
    seconds = time.perf_counter() - t0
    cycles = round((get_sim_time(unit="ns") - sim0) / PERIOD_NS)
    with open(spec["summary"], "w") as f:
        json.dump({"cycles": cycles, "seconds": seconds, "errors": errors, "mismatches": mismatches,
                   "error_segments": error_segments, "segment_cycles": segment_cycles}, f)
    for e in errors[:20]:
        dut._log.error(e)
    assert not errors, f"{len(errors)} error(s): {errors[0]}"
