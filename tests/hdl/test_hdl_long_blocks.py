"""(d) Long file-driven streams, >= 100k samples, for the blocks (the lag filter among them) and the divider."""

import pytest

from long_common import long_stream


@pytest.mark.hdl
@pytest.mark.parametrize("name", ["rtd", "iir", "piecewise_sf", "piecewise_k1", "bias_subtract", "freq2temp", "lag"])
def test_long_stream(name):
    long_stream(name)


@pytest.mark.hdl
def test_long_stream_sf_divide_one_bit_per_cycle():
    long_stream("sf_divide", unroll=1)
