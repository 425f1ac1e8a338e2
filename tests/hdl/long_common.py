"""(d) Long streams (>= 100k samples per block) through the file-driven Verilog harness: inputs by
$readmemh, outputs by $writememh, Python out of the per-cycle loop; compared with the model.
Verilator runs them all (~1-6 M cycles/s against Icarus's 3-200 k)."""

from __future__ import annotations

import numpy as np
import pytest

from hdl_util import design_of, model_run, record_throughput, run_harness

N_LONG = 100_000


def on_simulators(names, icarus_too=()):
    """(name, simulator) cases of the long streams: every one on Verilator, the cheap ones (a few
    seconds of Icarus) on Icarus as well."""
    return [pytest.param(n, s, id=f"{n}-{s}") for n in names for s in ("icarus", "verilator")
            if s == "verilator" or n in icarus_too]


_design = None


def default_design():
    global _design
    if _design is None:
        _design = design_of()
    return _design


def long_stream(name: str, n: int = N_LONG, unroll: int | None = None, seed: int = 2026, sim: str = "icarus",
                extra: dict | None = None):
    d = default_design()
    block = d.all[name]
    stim = block.stimulus(np.random.default_rng(seed), n)
    assert len(next(iter(stim.values()))) >= n
    expected, ovf_model = model_run(d, name, stim)
    tag = f"long_{name}" + ("_serial" if extra else "")
    cycles, seconds = file_stream(d, name, stim, expected, ovf_model, tag, sim, unroll, extra)
    record_throughput("file", name + (" (serial)" if extra else ""), cycles, seconds, sim=sim)
    return cycles, seconds, len(next(iter(stim.values())))


def file_stream(d, name: str, stim: dict, expected: dict, ovf_model: int, tag: str, sim: str,
                unroll: int | None = None, extra: dict | None = None) -> tuple[int, float]:
    """``stim`` through the file-driven harness of instance ``name``: every output word equal to
    ``expected`` and the overflow flags to ``ovf_model``; (cycles, seconds of simulation)."""
    got, ovf_rtl, cycles, seconds = run_harness(d, name, stim, tag, unroll, sim=sim, extra=extra)
    for port, want in expected.items():
        bad = np.flatnonzero(got[port] != want)
        assert bad.size == 0, (f"{name}.{port}: {bad.size} mismatches of {want.size}, first at {bad[0]}: "
                               f"got {got[port][bad[0]]}, expected {want[bad[0]]}")
    assert ovf_rtl == ovf_model, f"{name}: RTL flagged {ovf_rtl} overflows, model counted {ovf_model}"
    return cycles, seconds
