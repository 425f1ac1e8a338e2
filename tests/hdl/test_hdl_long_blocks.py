"""(d) Long file-driven streams, >= 100k samples, for the blocks (the lag filter among them) and the
divider: on Verilator; the blocks that take a few seconds on Icarus there too (iir, piecewise_k1
and the divider at one quotient bit per cycle, 7-32 s each on Icarus, on Verilator only); the serial
variants (tens of cycles per sample) on Verilator."""

import pytest

from fxdsp.hdl import params as hp
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



def _iir_cycles_per_sample(p: dict) -> int:
    """The serial iir's documented schedule (hdl/rtl/iir.v): SECTIONS * (7 N + 10) + 1 cycles, N the
    16 x 16 limb products of one coefficient-or-error x data product."""
    limbs = (max(p["COEF_W"], p["OUT_SHIFT"] + 2) + 15) // 16 * ((p["DATA_W"] + 15) // 16)
    return p["SECTIONS"] * (7 * limbs + 10) + 1


SCHEDULES = {"iir": _iir_cycles_per_sample}


@pytest.mark.hdl
@pytest.mark.parametrize("name", sorted(SERIAL))
def test_long_stream_serial(name):
    """Bit for bit, and back to back at exactly the documented cycles per sample (+1: the first
    sample is taken one cycle after the reset is released)."""
    cycles, _, n = long_stream(name, sim="verilator", extra=SERIAL[name])
    per = SCHEDULES[name](hp.instance(default_design(), name).params)
    assert cycles == n * per + 1, f"{name}: {cycles} cycles for {n} samples, the schedule says {per} each"
