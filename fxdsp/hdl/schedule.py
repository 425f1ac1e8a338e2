"""Cycles per sample of the serial variants (ARCH = 1), stated once from each module's documented
schedule (the headers of hdl/rtl/*.v), as functions of the module's parameters (the generated
headers' values), and of a generated chain top (:mod:`fxdsp.hdl.chain_top`) from its netlist. The
long-stream tests measure the RTL against them, back to back."""

from __future__ import annotations


def iir_cycles_per_sample(p: dict) -> int:
    """The serial iir's documented schedule (hdl/rtl/iir.v): SECTIONS * (7 N + 10) + 1 cycles, N the
    16 x 16 limb products of one coefficient-or-error x data product."""
    limbs = (max(p["ACOEF_W"], p["OUT_SHIFT"] + 2) + 15) // 16 * ((p["DATA_W"] + 15) // 16)
    return p["SECTIONS"] * (7 * limbs + 10) + 1


def rtd_cycles_per_sample(p: dict) -> int:
    """The serial rtd's documented schedule (hdl/rtl/rtd.v): N + 10 cycles, N the 16 x 16 limb
    products of the diff (LUT_W + 1 bits) x frac (S + 1 bits) product."""
    s = p["ADC_W"] - p["LUT_INDEX_BITS"]
    return (p["LUT_W"] + 1 + 15) // 16 * ((s + 1 + 15) // 16) + 10


def lag_cycles_per_sample(p: dict) -> int:
    """The serial lag's documented schedule (hdl/rtl/lag.v): N + 11 cycles per update sample, N the
    16 x 16 limb products of d (STATE_W + 1 bits) x alpha (ALPHA_W + 1 bits); at DECIM = 1 (the
    default config) every sample updates (a held sample takes 1 cycle)."""
    if p["DECIM"] != 1:
        raise ValueError("lag: DECIM > 1: the samples between updates take 1 cycle, the updates this many")
    return (p["STATE_W"] + 1 + 15) // 16 * ((p["ALPHA_W"] + 1 + 15) // 16) + 11


def limbs(a_w: int, b_w: int) -> int:
    """16 x 16 limb products of an a_w x b_w-bit product on fx_mac_serial."""
    return (a_w + 15) // 16 * ((b_w + 15) // 16)


def piecewise_cycles_per_sample(p: dict) -> int:
    """The serial piecewise's documented schedule (hdl/rtl/piecewise.v): ORDER (N + 10) + 7, N the
    limb products of acc (ACC_W bits) x t (T_W + 1 bits)."""
    return p["ORDER"] * (limbs(p["ACC_W"], p["T_W"] + 1) + 10) + 7


def freq2temp_cycles_per_sample(p: dict) -> int:
    """The serial freq2temp's documented schedule (hdl/rtl/freq2temp.v): N + 7, N the limb products
    of d (FREQ_W + 1 bits) x KINV (KINV_W bits)."""
    return limbs(p["FREQ_W"] + 1, p["KINV_W"]) + 7


def demod_cycles_per_sample(p: dict) -> int:
    """The demod's edges from its accepting edge to its successor's (hdl/rtl/demod.v; for a serial
    block with one sample in flight, its cycles per sample). ARCH = 1 (serial): 6 N + 30 + 3 ITERATIONS
    + F, N the limb products of its shared MAC (a: max(DW, XW) bits, DW = INTERP_BITS + TWO_PI_W + 3,
    XW = max(IN_W, DATA_W + 3); b: max(TWO_PI_W + 1, NCO_W, INV_K_W + max(0, MIX_SHIFT - AMP_SHIFT))
    bits), F = 2 LPF_SECTIONS (7 M + 10) the two-channel serial iir's cycles (M its limb products);
    206 at the default config (the pre-rotation and every CORDIC step take three cycles: one shifter)."""
    dw = p["INTERP_BITS"] + 2 + p["TWO_PI_W"] + 1
    xw = max(p["IN_W"], p["DATA_W"] + 3)
    ikw = p["INV_K_W"] + max(0, p["MIX_SHIFT"] - p["AMP_SHIFT"])
    n = limbs(max(dw, xw), max(p["TWO_PI_W"] + 1, p["NCO_W"], ikw))
    m = limbs(max(p["LPF_ACOEF_W"], p["LPF_OUT_SHIFT"] + 2), p["DATA_W"])
    return 6 * n + 30 + 3 * p["ITERATIONS"] + 2 * p["LPF_SECTIONS"] * (7 * m + 10)


def sf_divide_cycles_per_sample(p: dict) -> int:
    """The pipelined divider (ARCH = 1, hdl/rtl/sf_divide.v) at UNROLL = 1, from its accepting edge to
    its successor's: its latency IN_W + NUM_SHIFT + 6."""
    return p["IN_W"] + p["NUM_SHIFT"] + 6


# per module: edges from a serial member's accepting edge to its successor's (its cycles per sample)
SERIAL_CYCLES = {"iir": iir_cycles_per_sample, "rtd": rtd_cycles_per_sample, "lag": lag_cycles_per_sample,
                 "piecewise": piecewise_cycles_per_sample, "freq2temp": freq2temp_cycles_per_sample,
                 "demod": demod_cycles_per_sample, "sf_divide": sf_divide_cycles_per_sample,
                 "bias_subtract": lambda _p: 1}   # one registered stage


def member_cycles(design, name: str) -> int:
    """A block instance's serial cycles per sample at the design's parameters."""
    from .params import instance

    return SERIAL_CYCLES[design.instances[name].module](instance(design, name).params)


def chain_schedule(design, name: str) -> tuple[int, dict[str, tuple[int, int]]]:
    """A generated top's serial schedule, one sample in flight: (cycles per sample, {member: (start,
    cycles)}). The accepting edge, then each member starts the cycle after its latest driver's result
    is captured (its cycles + 1 after that driver's start), then the out_valid register (busy clears
    with it and the next sample enters as it leaves): 2 + the longest path of (cycles + 1)."""
    net = design.chains[name].netlist
    start: dict[str, tuple[int, int]] = {}
    for m in net.order:
        begin = max([sum(start[s.instance]) + 1 for d, s in net.drivers.items()
                     if d.instance == m and not isinstance(s, str)], default=0)
        start[m] = (begin, member_cycles(design, m.replace(".", "_")))
    return 2 + max(b + c + 1 for b, c in start.values()), start
