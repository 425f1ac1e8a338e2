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
    limbs = (max(p["ACOEF_W"], p["OUT_SHIFT"] + 2) + 15) // 16 * ((p["DATA_W"] + 15) // 16)
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


def _demod_cycles_per_sample(p: dict) -> int:
    """The demod's edges from its accepting edge to its successor's (hdl/rtl/demod.v; for a serial
    block with one sample in flight, its cycles per sample). ARCH = 1 (serial): 6 N + 30 + 3 ITERATIONS
    + F, N the limb products of its shared MAC (a: max(DW, XW) bits, DW = INTERP_BITS + TWO_PI_W + 3,
    XW = max(IN_W, DATA_W + 3); b: max(TWO_PI_W + 1, NCO_W, INV_K_W + max(0, MIX_SHIFT - AMP_SHIFT))
    bits), F = 2 LPF_SECTIONS (7 M + 10) the two-channel serial iir's cycles (M its limb products);
    206 at the default config (the pre-rotation and every CORDIC step take three cycles: one shifter)."""
    dw = p["INTERP_BITS"] + 2 + p["TWO_PI_W"] + 1
    xw = max(p["IN_W"], p["DATA_W"] + 3)
    ikw = p["INV_K_W"] + max(0, p["MIX_SHIFT"] - p["AMP_SHIFT"])
    n = _limbs(max(dw, xw), max(p["TWO_PI_W"] + 1, p["NCO_W"], ikw))
    m = _limbs(max(p["LPF_ACOEF_W"], p["LPF_OUT_SHIFT"] + 2), p["DATA_W"])
    return 6 * n + 30 + 3 * p["ITERATIONS"] + 2 * p["LPF_SECTIONS"] * (7 * m + 10)


def _sf_divide_cycles_per_sample(p: dict) -> int:
    """The pipelined divider (ARCH = 1, hdl/rtl/sf_divide.v) at UNROLL = 1, from its accepting edge to
    its successor's: its latency IN_W + NUM_SHIFT + 6."""
    return p["IN_W"] + p["NUM_SHIFT"] + 6


def _chain_paper002_cycles_per_sample(_p: dict) -> int:
    """hdl/rtl/chain_paper002.v, ARCH = 1 (LAG_EN = 0, the default config): rtd's cycles + piecewise_sf's
    + max(the divider's, piecewise_bias's) (the bias engine runs during the division; demod starts after
    both: the two share the multiplier) + demod's + 3 (the join into registers, the subtraction, the
    output register) + the iir's."""
    d = default_design()
    par = lambda n: hp.instance(d, n).params  # noqa: E731
    return (_rtd_cycles_per_sample(par("rtd")) + _piecewise_cycles_per_sample(par("piecewise_sf"))
            + max(_sf_divide_cycles_per_sample(par("sf_divide")), _piecewise_cycles_per_sample(par("piecewise_bias")))
            + _demod_cycles_per_sample(par("demod")) + 3 + _iir_cycles_per_sample(par("iir")))


# per module: a member's edges from its accepting edge to the cycle its result is taken (serial variants)
MODULE_CYCLES = {"iir": _iir_cycles_per_sample, "rtd": _rtd_cycles_per_sample, "lag": _lag_cycles_per_sample,
                 "piecewise": _piecewise_cycles_per_sample, "freq2temp": _freq2temp_cycles_per_sample,
                 "demod": _demod_cycles_per_sample, "sf_divide": _sf_divide_cycles_per_sample,
                 "bias_subtract": lambda _p: 1}


def _generated_chain_cycles(name: str) -> int:
    """A generated top (fxdsp/hdl/chain_top.py), one sample in flight: the accepting edge, then along
    the netlist's longest path each member's cycles + 1 (its result is captured in a done flag that
    starts its successors the cycle after), then the out_valid register (busy clears with it, and the
    next sample enters as it leaves)."""
    d = default_design()
    net = d.chains[name].netlist
    finish: dict[str, int] = {}
    for m in net.order:   # a member starts when its latest driver is done
        v = m.replace(".", "_")
        start = max([finish[s.instance] for dst, s in net.drivers.items()
                     if dst.instance == m and not isinstance(s, str)], default=0)
        finish[m] = start + MODULE_CYCLES[d.instances[v].module](hp.instance(d, v).params) + 1
    return 2 + max(finish.values())


SCHEDULES = {"iir": _iir_cycles_per_sample, "rtd": _rtd_cycles_per_sample, "lag": _lag_cycles_per_sample,
             "piecewise_sf": _piecewise_cycles_per_sample, "piecewise_k0": _piecewise_cycles_per_sample,
             "freq2temp": _freq2temp_cycles_per_sample, "chain_paper001": _chain_paper001_cycles_per_sample,
             "demod": _demod_cycles_per_sample, "sf_divide": _sf_divide_cycles_per_sample,
             "chain_paper002": _chain_paper002_cycles_per_sample}


@pytest.mark.hdl
@pytest.mark.parametrize("name", sorted(SERIAL))
def test_long_stream_serial(name):
    """Bit for bit, and back to back at exactly the documented cycles per sample (+1: the first
    sample is taken one cycle after the reset is released)."""
    cycles, _, n = long_stream(name, sim="verilator", extra=SERIAL[name])
    design = default_design()
    if name in SCHEDULES:
        per = SCHEDULES[name]({} if design.instances[name].members else hp.instance(design, name).params)
    else:
        per = _generated_chain_cycles(name)
    assert cycles == n * per + 1, f"{name}: {cycles} cycles for {n} samples, the schedule says {per} each"
