"""(d) Long file-driven streams, >= 100k samples, for the blocks (the lag filter among them) and the
divider: on Verilator; the blocks that take a few seconds on Icarus there too (iir, piecewise_k1
and the divider at one quotient bit per cycle, 7-32 s each on Icarus, on Verilator only); the serial
variants (tens of cycles per sample) on Verilator."""

import pytest

from fxdsp.hdl import params as hp
from fxdsp.hdl.schedule import (chain_schedule, demod_cycles_per_sample, freq2temp_cycles_per_sample,
                                 iir_cycles_per_sample, member_cycles, piecewise_cycles_per_sample,
                                 rtd_cycles_per_sample, sf_divide_cycles_per_sample)
from hdl_util import SERIAL
from long_common import default_design, long_stream, on_simulators

BLOCKS = ["rtd", "iir", "piecewise_sf", "piecewise_k1", "bias_subtract", "freq2temp", "lag"]
ICARUS_TOO = ["rtd", "piecewise_sf", "bias_subtract", "freq2temp", "lag"]


@pytest.mark.hdl
@pytest.mark.parametrize("name, sim", on_simulators(BLOCKS, ICARUS_TOO))
def test_long_stream(name, sim):
    long_stream(name, sim=sim)


@pytest.mark.hdl
def test_long_stream_sf_divide_one_bit_per_cycle():
    long_stream("sf_divide", unroll=1, sim="verilator")



def _chain_paper001_cycles_per_sample(d) -> int:
    """hdl/rtl/chain_paper001.v: freq2temp's cycles + piecewise_bias001's + 1 (the subtraction)."""
    return (freq2temp_cycles_per_sample(hp.instance(d, "freq2temp").params)
            + piecewise_cycles_per_sample(hp.instance(d, "piecewise_bias001").params) + 1)


def _chain_paper002_cycles_per_sample(d) -> int:
    """hdl/rtl/chain_paper002.v, ARCH = 1 (LAG_EN = 0, the default config): rtd's cycles + piecewise_sf's
    + max(the divider's, piecewise_bias's) (the bias engine runs during the division; demod starts after
    both: the two share the multiplier) + demod's + 3 (the join into registers, the subtraction, the
    output register) + the iir's."""
    par = lambda n: hp.instance(d, n).params  # noqa: E731
    return (rtd_cycles_per_sample(par("rtd")) + piecewise_cycles_per_sample(par("piecewise_sf"))
            + max(sf_divide_cycles_per_sample(par("sf_divide")), piecewise_cycles_per_sample(par("piecewise_bias")))
            + demod_cycles_per_sample(par("demod")) + 3 + iir_cycles_per_sample(par("iir")))


# the hand-written tops' schedules (their headers); a block's is its module's (fxdsp.hdl.schedule), a
# generated top's its netlist's (fxdsp.hdl.schedule.chain_schedule)
HAND_TOPS = {"chain_paper001": _chain_paper001_cycles_per_sample, "chain_paper002": _chain_paper002_cycles_per_sample}


@pytest.mark.hdl
@pytest.mark.parametrize("name", sorted(SERIAL))
def test_long_stream_serial(name):
    """Bit for bit, and back to back at exactly the documented cycles per sample (+1: the first
    sample is taken one cycle after the reset is released)."""
    cycles, _, n = long_stream(name, sim="verilator", extra=SERIAL[name])
    design = default_design()
    if name in HAND_TOPS:
        per = HAND_TOPS[name](design)
    elif design.instances[name].members:
        per = chain_schedule(design, name)[0]
    else:
        per = member_cycles(design, name)
    assert cycles == n * per + 1, f"{name}: {cycles} cycles for {n} samples, the schedule says {per} each"
