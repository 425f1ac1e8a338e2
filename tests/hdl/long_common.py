"""(d) Long streams (>= 100k samples per block) through the file-driven Verilog harness: inputs by
$readmemh, outputs by $writememh, Python out of the per-cycle loop; compared with the model."""

from __future__ import annotations

import numpy as np

from hdl_util import design_of, model_run, record_throughput, run_harness

N_LONG = 100_000
_design = None


def default_design():
    global _design
    if _design is None:
        _design = design_of()
    return _design


def long_stream(name: str, n: int = N_LONG, unroll: int | None = None, seed: int = 2026):
    d = default_design()
    block = d.all[name]
    stim = block.stimulus(np.random.default_rng(seed), n)
    assert len(next(iter(stim.values()))) >= n
    expected, ovf_model = model_run(d, name, stim)
    got, ovf_rtl, cycles, seconds = run_harness(d, name, stim, f"long_{name}", unroll)
    for port, want in expected.items():
        bad = np.flatnonzero(got[port] != want)
        assert bad.size == 0, (f"{name}.{port}: {bad.size} mismatches of {want.size}, first at {bad[0]}: "
                               f"got {got[port][bad[0]]}, expected {want[bad[0]]}")
    assert ovf_rtl == ovf_model, f"{name}: RTL flagged {ovf_rtl} overflows, model counted {ovf_model}"
    record_throughput("file", name, cycles, seconds)
    return cycles, seconds
