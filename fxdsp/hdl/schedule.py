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
    """The serial piecewise's documented schedule (hdl/rtl/piecewise.v): ORDER (N + 11) + 7, N the
    limb products of acc (ACC_W bits) x t (T_W + 1 bits)."""
    return p["ORDER"] * (limbs(p["ACC_W"], p["T_W"] + 1) + 11) + 7


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


def divider_steps(p: dict, unroll: int = 1) -> int:
    """The restoring divider's steps (hdl/rtl/sf_divide.v): ceil((IN_W + NUM_SHIFT) / UNROLL)."""
    return -(-(p["IN_W"] + p["NUM_SHIFT"]) // unroll)


def sf_divide_cycles_per_sample(p: dict, unroll: int = 1) -> int:
    """The pipelined divider (ARCH = 1, hdl/rtl/sf_divide.v), from its accepting edge to its
    successor's: its latency, its steps + 6."""
    return divider_steps(p, unroll) + 6


# per module: edges from a serial member's accepting edge to its successor's (its cycles per sample)
SERIAL_CYCLES = {"iir": iir_cycles_per_sample, "rtd": rtd_cycles_per_sample, "lag": lag_cycles_per_sample,
                 "piecewise": piecewise_cycles_per_sample, "freq2temp": freq2temp_cycles_per_sample,
                 "demod": demod_cycles_per_sample, "sf_divide": sf_divide_cycles_per_sample,
                 "bias_subtract": lambda _p: 2}   # two registered stages (difference, then round and fit)

# per module: the one-sample-per-clock variant's latency (ARCH = 0, each header's "Latency"), edges
# from the accepting edge to out_valid; the divider's is its steps + 1
PER_CLOCK_LATENCY = {"iir": 1, "rtd": 1, "lag": 1, "piecewise": 1, "freq2temp": 1, "demod": 2, "bias_subtract": 2}


def whole_limbs(w: int) -> int:
    """A multiplier bundle's operand width for ``w`` bits: whole 16-bit limbs, at least one."""
    return max(16, -(-w // 16) * 16)


def mac_operands(module: str, p: dict) -> tuple[int, int]:
    """The widest (a, b) operands a serial block issues on its multiplier bundle (each header's
    fx_mac_port A_W / B_W): what a multiplier shared by several blocks must take."""
    if module == "rtd":
        return p["LUT_W"] + 1, p["ADC_W"] - p["LUT_INDEX_BITS"] + 1
    if module == "piecewise":
        return p["ACC_W"], p["T_W"] + 1
    if module == "iir":
        return max(p["ACOEF_W"], p["OUT_SHIFT"] + 2), p["DATA_W"]
    if module == "demod":
        dw = p["INTERP_BITS"] + 2 + p["TWO_PI_W"] + 1
        xw = max(p["IN_W"], p["DATA_W"] + 3)
        ikw = p["INV_K_W"] + max(0, p["MIX_SHIFT"] - p["AMP_SHIFT"])
        lpf_a = max(p["LPF_ACOEF_W"], p["LPF_OUT_SHIFT"] + 2)
        return max(dw, xw, lpf_a), max(p["TWO_PI_W"] + 1, p["NCO_W"], ikw, p["DATA_W"])
    raise ValueError(f"{module} has no multiplier bundle")


def member_cycles(design, name: str, arch: int = 1, unroll: int = 1) -> int:
    """A block instance's cycles from its accepting edge to its successor's at the design's parameters:
    ARCH = 1 its serial cycles per sample, ARCH = 0 its latency (``unroll``: the divider's UNROLL)."""
    from .params import instance

    module, p = design.instances[name].module, instance(design, name).params
    if module == "sf_divide":
        return sf_divide_cycles_per_sample(p, unroll) if arch else divider_steps(p, unroll) + 1
    return SERIAL_CYCLES[module](p) if arch else PER_CLOCK_LATENCY[module]


def cycles_per_sample(design, name: str, arch: int = 1, unroll: int = 1) -> int:
    """An instance's cycles per sample (a chain's from its top's schedule, a block's from its module's);
    for a schedule that varies from sample to sample (a decimating lag) the bound every schedule
    must meet: the sample period at 40 MHz."""
    try:
        if design.instances[name].members:
            return chain_schedule(design, name, arch, unroll)[0]
        return member_cycles(design, name, arch, unroll)
    except ValueError:   # the period of the chain's own rate (a block: the system's)
        return int(40e6 // getattr(design.chains.get(name), "fs_hz", design.fs_hz))


def chain_schedule(design, name: str, arch: int = 1, unroll: int = 1) -> tuple[int, dict[str, tuple[int, int]]]:
    """A generated top's schedule, one sample in flight, as the top runs it (:mod:`fxdsp.hdl.chain_top`):
    (cycles per sample, {member: (in_valid cycle, cycles)}), counted from the cycle after the chain's
    accepting edge (cycle 0). A member's start is decided in the cycle after its drivers' results are
    all captured (their in_valid cycle + cycles + 1) and registered: its in_valid comes a cycle later.
    In the serial variant the members on the one multiplier (and the engines they share,
    :mod:`fxdsp.hdl.sharing`) are also started only when no other one is working on it (from its
    in_valid to its result's capture), the earlier in the netlist's order first; a shared set's guest
    pass runs as its host's result leaves. Then the out_valid register (busy clears with it and the
    next sample enters as it leaves): cycles per sample = 3 + the last member's in_valid + cycles."""
    net = design.chains[name].netlist
    from .sharing import engine_sharing

    shares = engine_sharing(design, name) if arch else {}
    cycles = {m: member_cycles(design, m.replace(".", "_"), arch, unroll) for m in net.order}
    on_mac = {m for m in net.order if arch and design.instances[m.replace(".", "_")].rtl.mac_bundle}
    deps = {m: net.upstream(m) for m in net.order}
    guest_of = {s.host: s.guest for s in shares.values() if s.kind == "set"}
    valid: dict[str, int] = {}   # each member's in_valid cycle
    t = 0
    while len(valid) < len(net.order):
        if t > 1_000_000:
            raise RuntimeError(f"{name}: the schedule does not finish")
        # started (from in_valid) and its result not yet captured (through its out_valid cycle)
        mac_busy = any(valid[u] <= t <= valid[u] + cycles[u] for u in on_mac if u in valid)
        for m in net.order:
            if m in valid or m in guest_of.values():
                continue
            if not all(d in valid and valid[d] + cycles[d] + 1 <= t for d in deps[m]):
                continue
            if m in on_mac:
                if mac_busy:
                    continue
                mac_busy = True     # granted: lower-priority members wait
            valid[m] = t + 1
            if m in guest_of:
                valid[guest_of[m]] = t + 1 + cycles[m]
        t += 1
    return 3 + max(valid[m] + cycles[m] for m in valid), {m: (valid[m], cycles[m]) for m in net.order}
