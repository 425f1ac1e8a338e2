"""(d) Long file-driven streams, >= 100k samples, for the blocks (the lag filter among them) and the
divider: on Verilator, one block on Icarus too (the harness on both simulators); the serial variants
(12-350 cycles per sample) on Verilator, 20k samples each, their cycle count against the schedule."""

import pytest

from conftest import tiered

from fxdsp.hdl.schedule import chain_schedule, member_cycles
from hdl_util import SERIAL
from long_common import N_LONG, default_design, long_stream, on_simulators

BLOCKS = ["rtd", "iir", "piecewise_sf", "piecewise_k1", "bias_subtract", "freq2temp", "lag", "drive"]
# the file-driven harness on Icarus too, on one block (every block streams on Verilator: a second
# simulator over the same 100k samples of each would repeat it for ~15 s)
ICARUS_TOO = ["freq2temp"]
# the serial variants' streams: a fifth of the blocks' (the serial demodulator's 206 cycles per sample
# made 100k samples 20 M cycles, 12-16 s; paper 002's top 349); their datapaths stream 100k samples
# each above in the one-sample-per-clock variant
SERIAL_LONG = N_LONG // 5
SERIAL_CYCLES = 4_000_000   # the clock cycles a serial long stream may take


@pytest.mark.hdl
@pytest.mark.parametrize("name, sim", on_simulators(BLOCKS, ICARUS_TOO))
def test_long_stream(name, sim):
    long_stream(name, sim=sim)


@pytest.mark.hdl
def test_long_stream_sf_divide_one_bit_per_cycle():
    long_stream("sf_divide", unroll=1, sim="verilator")



def _chain_paper001_cycles_per_sample(d) -> int:
    """The generated chain_paper001 top, ARCH = 1, written out here from the top's rule: a member's start
    is decided the cycle after its driver's result is captured and registered into its in_valid (+2
    per member beyond its own cycles); out_valid a cycle after the last capture and the next sample
    taken as it leaves (+2): freq2temp, then piecewise_bias001, then the subtraction."""
    return member_cycles(d, "freq2temp") + 2 + member_cycles(d, "piecewise_bias001") + 2 + (2 + 2) + 2


def _chain_paper002_cycles_per_sample(d) -> int:
    """The generated chain_paper002 top, ARCH = 1 (the default config), likewise: rtd, then SF(T); then
    the divider and (SF's engine's second coefficient set, its pass as SF's result leaves) bias(T); the
    demodulator after the divider's result and the bias pass (they share the multiplier); then the
    subtraction and the output low-pass (on the demodulator's filter engine)."""
    c = lambda n: member_cycles(d, n)  # noqa: E731
    return (c("rtd") + 2 + c("piecewise_sf") + max(c("sf_divide") + 2, c("piecewise_bias")) + 2 + c("demod") + 2
            + (2 + 2) + c("iir") + 2 + 2)


# the paper chains' schedules written out here; a block's is its module's (fxdsp.hdl.schedule), any
# other chain's its netlist's (fxdsp.hdl.schedule.chain_schedule)
PAPER_TOPS = {"chain_paper001": _chain_paper001_cycles_per_sample, "chain_paper002": _chain_paper002_cycles_per_sample}


def _in_a_top(name: str) -> bool:
    """A serial block that a chain top holds as it stands, with a multiplier of its own (the
    netlist's own_multiplier: drive in paper 002's loop): that top's long stream runs the same RTL on
    Verilator, back to back at a schedule written from its members' cycles, so the block's own stream
    is the slow tier. A member that takes turns on the top's shared multiplier (EXT_MAC) runs another
    configuration of its RTL there, and iir runs on demod's filter engine: their own streams stay."""
    d = default_design()
    return any(name in c.netlist.own_multiplier for c in d.chains.values())


@pytest.mark.hdl
@pytest.mark.parametrize("name", tiered(sorted(SERIAL), lambda name: not _in_a_top(name)))
def test_long_stream_serial(name):
    """Bit for bit, and back to back at exactly the documented cycles per sample (+1: the first
    sample is taken one cycle after the reset is released)."""
    design = default_design()
    if name in PAPER_TOPS:
        per = PAPER_TOPS[name](design)
        assert per == chain_schedule(design, name)[0], "the schedule stated in the top's header"
    elif design.instances[name].members:
        per = chain_schedule(design, name)[0]
    else:
        per = member_cycles(design, name)
    # SERIAL_LONG samples, or as many as SERIAL_CYCLES clock cycles hold (a top with a drive loop
    # takes 400..625 cycles a sample: still thousands of samples back to back)
    cycles, _, n = long_stream(name, n=min(SERIAL_LONG, SERIAL_CYCLES // per), sim="verilator", extra=SERIAL[name])
    assert cycles == n * per + 1, f"{name}: {cycles} cycles for {n} samples, the schedule says {per} each"
