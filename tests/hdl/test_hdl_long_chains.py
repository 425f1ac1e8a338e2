"""(d) Long file-driven streams, >= 100k samples, for the demodulator and both tops; and the
committed chain_paper002 vectors with the hardware divider setting (one quotient bit per cycle),
timed against a latency computed here from the config, not copied from the RTL.
On Verilator; the 64-sample latency checks on Icarus (the long streams take 14-115 s each on
Icarus: chain_paper001's generated top, one sample in flight, 11 cycles per sample). Those checks on
Verilator too are the slow tier: each is a C++ build of the top for 64 samples, and the cycle count of
the same top on Verilator is checked over the whole golden set at the hardware setting (below)."""

import math

import numpy as np
import pytest

from fxdsp.fixed import Format
from fxdsp.vectors import load
from conftest import tiered
from hdl_util import SIMULATORS, VECTORS, default_data, mutated_top, run_harness
from long_common import default_design, long_stream, on_simulators

# Per-block latencies of the spec (hdl/README.md, "latency (cycles)"), along chain_paper002's longest
# path rtd -> piecewise_sf -> sf_divide -> demod -> bias_subtract -> iir (piecewise_bias beside it).
BLOCK_LATENCY = {"rtd": 1, "piecewise": 1, "demod": 2, "bias_subtract": 2, "iir": 1}


def chain002_period(unroll: int) -> int:
    """Cycles per sample of the generated top (ARCH = 0), from the config: the divider runs one
    restoring step per numerator bit, numerator = vsa << (SF fraction + guard bits)
    (blocks/sf_divide.py), so it takes ceil((vsa wl + SF fl + guard_bits) / UNROLL) steps plus its
    output register; the other blocks take their spec latencies. One sample in flight: each block's
    start is decided the cycle after its driver's result is captured and registered into its in_valid
    (+2 each), out_valid comes a cycle after the last capture and the next sample is taken as it
    leaves (+2)."""
    cfg = default_data()
    vsa = Format.parse(cfg["sf_divide"]["in_format"])
    sf = Format.parse(cfg["piecewise"]["sf"]["out_format"])
    numerator_bits = vsa.wl + sf.fl + cfg["sf_divide"]["guard_bits"]
    divider = math.ceil(numerator_bits / unroll) + 1
    return sum(lat + 2 for lat in [*BLOCK_LATENCY.values(), divider]) + 2


def assert_chain002_cycles(cycles: int, n: int, unroll: int) -> None:
    """n samples take n periods (+ at most one period of start-up / drain in the harness). Slower or
    faster both fail."""
    period = chain002_period(unroll)
    assert n * period <= cycles <= n * period + period, (
        f"chain_paper002 at DIV_UNROLL={unroll}: {cycles} cycles for {n} samples = {cycles / n:.3f} per sample, "
        f"expected {period} from the config")


@pytest.mark.hdl
@pytest.mark.parametrize("name, sim", on_simulators(["demod", "chain_paper001"]))
def test_long_stream(name, sim):
    long_stream(name, sim=sim)


@pytest.mark.hdl
def test_long_stream_chain_paper002():
    long_stream("chain_paper002", unroll=2, sim="verilator")


@pytest.mark.hdl
def test_golden_chain_paper002_hardware_divider():
    ins, outs, _ = load(VECTORS, "chain_paper002")
    got, _, cycles, _ = run_harness(default_design(), "chain_paper002", ins, "golden_file_chain_paper002", unroll=1,
                                    sim="verilator")
    for port, want in outs.items():
        assert np.array_equal(got[port], want), port
    assert_chain002_cycles(cycles, len(ins["vsa"]), unroll=1)


def _prefix(n: int):
    ins, outs, _ = load(VECTORS, "chain_paper002")
    return {k: v[:n] for k, v in ins.items()}, {k: v[:n] for k, v in outs.items()}


@pytest.mark.hdl
@pytest.mark.parametrize("sim", tiered(SIMULATORS, lambda sim: sim == "icarus"))
@pytest.mark.parametrize("unroll", [7, 48])
def test_chain_paper002_latency_follows_the_divider_unroll(unroll, sim):
    """Other divider settings on a short prefix: the latency formula holds for each UNROLL."""
    ins, outs = _prefix(64)
    got, _, cycles, _ = run_harness(default_design(), "chain_paper002", ins, f"latency_chain002_u{unroll}",
                                    unroll=unroll, sim=sim)
    for port, want in outs.items():
        assert np.array_equal(got[port], want), port
    assert_chain002_cycles(cycles, 64, unroll)


@pytest.mark.hdl
@pytest.mark.parametrize("sim", tiered(SIMULATORS, lambda sim: sim == "icarus"))
def test_latency_check_catches_one_extra_cycle_per_sample(sim):
    """An RTL latency regression (the chain stays busy one more cycle after out_valid): outputs still
    bit-exact, only the cycle count shows it, and the check must fail."""
    ins, outs = _prefix(64)
    with mutated_top("chain_paper002", [(old, old.replace("~busy", "~busy & ~out_valid"))
                                        for old in ("assign in_ready = ~busy;", "wire accept = in_valid & ~busy;")]):
        got, _, cycles, _ = run_harness(default_design(), "chain_paper002", ins, "latency_chain002_slow", unroll=7,
                                        sim=sim)
    for port, want in outs.items():
        assert np.array_equal(got[port], want), port
    with pytest.raises(AssertionError, match="per sample"):
        assert_chain002_cycles(cycles, 64, unroll=7)
