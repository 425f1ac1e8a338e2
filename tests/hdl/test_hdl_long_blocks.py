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


def _rtd_cycles_per_sample(p: dict) -> int:
    """The serial rtd's documented schedule (hdl/rtl/rtd.v): N + 10 cycles, N the 16 x 16 limb
    products of the diff (LUT_W + 1 bits) x frac (S + 1 bits) product."""
    s = p["ADC_W"] - p["LUT_INDEX_BITS"]
    return (p["LUT_W"] + 1 + 15) // 16 * ((s + 1 + 15) // 16) + 10


def _lag_cycles_per_sample(p: dict) -> int:
    """The serial lag's documented schedule (hdl/rtl/lag.v): N + 11 cycles per update sample, N the
    16 x 16 limb products of d (STATE_W + 1 bits) x alpha (ALPHA_W + 1 bits); at DECIM = 1 (the
    default config) every sample updates (a held sample takes 1 cycle)."""
    assert p["DECIM"] == 1, "the formula counts update samples only"
    return (p["STATE_W"] + 1 + 15) // 16 * ((p["ALPHA_W"] + 1 + 15) // 16) + 11


def _limbs(a_w: int, b_w: int) -> int:
    """16 x 16 limb products of an a_w x b_w-bit product on fx_mac_serial."""
    return (a_w + 15) // 16 * ((b_w + 15) // 16)


def _piecewise_cycles_per_sample(p: dict) -> int:
    """The serial piecewise's documented schedule (hdl/rtl/piecewise.v): ORDER (N + 10) + 7, N the
    limb products of acc (ACC_W bits) x t (T_W + 1 bits)."""
    return p["ORDER"] * (_limbs(p["ACC_W"], p["T_W"] + 1) + 10) + 7


def _freq2temp_cycles_per_sample(p: dict) -> int:
    """The serial freq2temp's documented schedule (hdl/rtl/freq2temp.v): N + 7, N the limb products
    of d (FREQ_W + 1 bits) x KINV (KINV_W bits)."""
    return _limbs(p["FREQ_W"] + 1, p["KINV_W"]) + 7


def _chain_paper001_cycles_per_sample(_p: dict) -> int:
    """hdl/rtl/chain_paper001.v: freq2temp's cycles + piecewise_bias001's + 1 (the subtraction)."""
    d = default_design()
    return (_freq2temp_cycles_per_sample(hp.instance(d, "freq2temp").params)
            + _piecewise_cycles_per_sample(hp.instance(d, "piecewise_bias001").params) + 1)


SCHEDULES = {"iir": _iir_cycles_per_sample, "rtd": _rtd_cycles_per_sample, "lag": _lag_cycles_per_sample,
             "piecewise_sf": _piecewise_cycles_per_sample, "piecewise_k0": _piecewise_cycles_per_sample,
             "freq2temp": _freq2temp_cycles_per_sample, "chain_paper001": _chain_paper001_cycles_per_sample}


@pytest.mark.hdl
@pytest.mark.parametrize("name", sorted(SERIAL))
def test_long_stream_serial(name):
    """Bit for bit, and back to back at exactly the documented cycles per sample (+1: the first
    sample is taken one cycle after the reset is released)."""
    cycles, _, n = long_stream(name, sim="verilator", extra=SERIAL[name])
    design = default_design()
    per = SCHEDULES[name]({} if design.instances[name].members else hp.instance(design, name).params)
    assert cycles == n * per + 1, f"{name}: {cycles} cycles for {n} samples, the schedule says {per} each"
