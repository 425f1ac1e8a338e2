"""(d) Long file-driven streams, >= 100k samples, for the blocks (the lag filter among them) and the
divider: on Verilator; the blocks that take a few seconds on Icarus there too (iir, piecewise_k1
and the divider at one quotient bit per cycle, 7-32 s each on Icarus, on Verilator only)."""

import pytest

from long_common import long_stream, on_simulators

BLOCKS = ["rtd", "iir", "piecewise_sf", "piecewise_k1", "bias_subtract", "freq2temp", "lag"]
ICARUS_TOO = ["rtd", "piecewise_sf", "bias_subtract", "freq2temp", "lag"]


@pytest.mark.hdl
@pytest.mark.parametrize("name, sim", on_simulators(BLOCKS, ICARUS_TOO))
def test_long_stream(name, sim):
    long_stream(name, sim=sim)


@pytest.mark.hdl
def test_long_stream_sf_divide_one_bit_per_cycle():
    long_stream("sf_divide", unroll=1, sim="verilator")
