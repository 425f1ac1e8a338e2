"""Hybrid float/fixed models of the two chains: every quantisation source can be switched on
(exactly as the bit-exact datapath does it), off (float), or replaced by its textbook model
(additive white uniform noise of the same step and rounding mode: the "theory" of item 3).

Built only from the blocks' public attributes (quantised coefficient arrays, LUTs, formats, rules);
no block is modified. With every source on, the hybrid reproduces the bit-exact model (checked by
:func:`fxdsp.budget.attribution.attribute` and by the tests); with every source off it is the
float reference fed with the *analog* (unquantised) sensor signals.

Rounding points are the hardware's: a source is only modelled where the datapath really drops
bits (a resize to a coarser fraction length), so switching one source on in an otherwise float
chain adds exactly that one rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from fxdsp.chains import Chain
from fxdsp.fixed import Format, OverflowLog, Rules, quantize
from fxdsp.fixed.kernels import FLOOR, TOWARD_ZERO, round_float
from fxdsp.blocks.lag import held
from fxdsp.errors import InputError

# categories of the attribution (item 2)
ADC = "ADC quantisation"
COEF = "coefficient quantisation"
ROUND = "data-path rounding"
DIVIDER = "divider truncation"
LUTNCO = "LUT/NCO resolution"
CATEGORIES = (ADC, COEF, ROUND, DIVIDER, LUTNCO)


@dataclass(frozen=True)
class Source:
    """One quantisation source of a chain."""

    name: str            # e.g. "iir.round"
    category: str        # one of CATEGORIES
    stage: str           # block name of the design (for the table / report)
    node: str            # hybrid node where the source acts (its local error is measured there)
    q: float | None = None           # step of the rounding (None: not a rounding, no q^2/12 theory)
    rounding: str | None = None      # rounding mode of the step
    note: str = ""
    kind: str = ""       # kind of the block it belongs to ("adc" for a chain input's ADC)

    @property
    def is_rounding(self) -> bool:
        return self.q is not None


class Switch:
    """Which sources are on (bit-exact), injected (white-noise model) or off (float)."""

    def __init__(self, on=(), inject=(), rng: np.random.Generator | None = None):
        self.on = set(on)
        self.inject = set(inject)
        self.rng = rng if rng is not None else np.random.default_rng(12345)
        # rounding residue r - x of every rounding point switched on, by (source, point)
        self.residues: dict[tuple[str, str], np.ndarray] = {}

    def record(self, name: str, point: str, residue: np.ndarray) -> None:
        key = (name, point)
        self.residues[key] = residue if key not in self.residues else np.concatenate([self.residues[key], residue])

    def __contains__(self, name: str) -> bool:
        return name in self.on

    def noise(self, rounding: str, q: float, x: np.ndarray) -> np.ndarray:
        """Textbook rounding error r - x for ``rounding`` with step q, independent of x (except the
        sign for toward_zero). The same model as :func:`_rounded` mode 2 (the loops' copy, compiled);
        kept apart because the half modes are written differently there (``x + u q - q/2`` against
        ``x + q (u - 1/2)`` here) and merging them would change the float bits of the budget."""
        u = self.rng.uniform(0.0, 1.0, np.shape(x))
        if rounding == "floor":
            return -q * u
        if rounding == "toward_zero":
            return -np.sign(x) * q * u
        return q * (u - 0.5)

    def round(self, name: str, x, fmt: Format, rules: Rules, point: str = "out") -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if name in self.on:
            y = quantize(x, fmt, rules).astype(float) * fmt.lsb
            self.record(name, point, y - x)
            return y
        if name in self.inject:
            return x + self.noise(rules.rounding, fmt.lsb, x)
        return x


# --------------------------------------------------------------------------------------------
# IIR (direct form I, error feedback) in float, or the block's own integer kernel
# --------------------------------------------------------------------------------------------
@njit(cache=True)
def _rounded(x, q, rounding, mode, u):
    """x on a grid of step q: mode 0 unrounded, 1 rounded by ``rounding`` as the integer kernels do,
    2 by the textbook model (an independent uniform u in [0, 1) shaped by the rounding; the same
    model as :meth:`Switch.noise`, whose half modes are written as x + q (u - 1/2): not merged, the
    float bits of the budget would change)."""
    if mode == 1:
        return round_float(x / q, rounding) * q
    if mode == 2:
        if rounding == FLOOR:
            return x - u * q
        if rounding == TOWARD_ZERO:
            return x - np.sign(x) * u * q
        return x + u * q - 0.5 * q  # (as written, so q = 1 is bit for bit the unscaled model)
    return x


@njit(cache=True)
def _df1_float(x, b, a, c, mode, rounding, lo, hi, noise, resid):
    """DF-I cascade in units of the output LSB. mode 0: no rounding; 1: rounding by ``rounding``
    with error feedback c (as the integer kernel); 2: the rounding replaced by its textbook model,
    drawn from ``noise`` (uniform in [0, 1)), with the same error feedback. Saturation to [lo, hi]
    (error taken as 0 after an overflow)."""
    v = x.copy()
    for s in range(b.shape[0]):
        y = np.empty_like(v)
        x1 = 0.0
        x2 = 0.0
        y1 = 0.0
        y2 = 0.0
        e1 = 0.0
        e2 = 0.0
        for i in range(v.shape[0]):
            acc = b[s, 0] * v[i] + b[s, 1] * x1 + b[s, 2] * x2 - a[s, 0] * y1 - a[s, 1] * y2
            if mode == 0:
                r = acc
                e = 0.0
            else:
                acc += c[s, 0] * e1 + c[s, 1] * e2
                r = _rounded(acc, 1.0, rounding, mode, noise[s, i])
                e = acc - r
                resid[s, i] = -e
                if r > hi:
                    r = hi
                    e = 0.0
                elif r < lo:
                    r = lo
                    e = 0.0
            x2 = x1
            x1 = v[i]
            y2 = y1
            y1 = r
            e2 = e1
            e1 = e
            y[i] = r
        v = y
    return v


def _grid_codes(scaled: np.ndarray) -> np.ndarray | None:
    """The stored integers of values already divided by their LSB, or None when any is off the grid
    (then the block's own integer kernel cannot be used)."""
    codes = scaled.astype(np.int64)
    return codes if np.array_equal(codes, scaled) else None


def iir_hybrid(block, x: np.ndarray, coef: str, rnd: str, sw: Switch) -> np.ndarray:
    """The IIR block with its coefficient source ``coef`` and rounding source ``rnd`` switched."""
    lsb = block.data_format.lsb
    xs = np.asarray(x, dtype=float) / lsb
    coef_on = coef in sw
    dp = block.datapath
    if coef_on and rnd in sw and (codes := _grid_codes(xs)) is not None:
        # everything of this block is on and its input is on the data grid: the block's own kernel
        return block.run(x=codes).outputs["y"].astype(float) * lsb
    if coef_on:
        b = dp.b.astype(float) * block.num_format.lsb
        a = dp.a.astype(float) * block.den_format.lsb
    else:
        b = block.sos[:, :3].copy()
        a = block.sos[:, 4:].copy()
    c = dp.c.astype(float)
    if rnd in sw:
        mode = 1
    elif rnd in sw.inject:
        mode = 2
    else:
        mode = 0
    noise = sw.rng.uniform(0.0, 1.0, (b.shape[0], xs.size)) if mode == 2 else np.zeros((b.shape[0], xs.size))
    fmt = block.data_format
    resid = np.zeros((b.shape[0], xs.size))
    y = _df1_float(xs, b, a, c, mode, block.rules.rounding_code, float(fmt.min_int), float(fmt.max_int), noise,
                   resid)
    if mode == 1:
        for s in range(b.shape[0]):
            sw.record(rnd, f"section{s}", resid[s] * lsb)
    return y * lsb


# --------------------------------------------------------------------------------------------
# thermal lag (first order, the paper 002 chain's optional stage) in float, or its integer kernel
# --------------------------------------------------------------------------------------------
@njit(cache=True)
def _lag_float(x, alpha, q_state, q_out, mode, rounding, lo, hi, noise, resid):
    """Te += alpha (T - Te), started settled on x[0], in real units. mode 0: exact; 1: the state
    step rounded to q_state and the output to q_out by ``rounding`` (as the integer kernel), the
    output saturated to [lo, hi]; 2: both roundings replaced by their textbook model drawn from
    ``noise`` (uniform in [0, 1), rows: state, output). resid rows: state and output r - x."""
    n = x.shape[0]
    y = np.empty(n)
    te = x[0] if n else 0.0
    for i in range(n):
        step = alpha * (x[i] - te)
        r_step = _rounded(step, q_state, rounding, mode, noise[0, i])
        resid[0, i] = r_step - step
        te += r_step
        r = _rounded(te, q_out, rounding, mode, noise[1, i])
        resid[1, i] = r - te
        if mode != 0:
            r = min(max(r, lo), hi)
        y[i] = r
    return y


def lag_hybrid(block, temp: np.ndarray, sw: Switch, prefix: str = "lag") -> np.ndarray:
    """The lag block; sources <prefix>.alpha (alpha as mantissa x 2**-shift) and lag.round (the state
    step at state_format's LSB and the output at temp_format's; in the loop: the state keeps its
    own rounding errors). A decimating lag updates on every decim-th input and holds between."""
    dp = block.datapath
    tf = dp.temp_format
    full = np.asarray(temp, dtype=float)
    if f"{prefix}.alpha" in sw and f"{prefix}.round" in sw and (codes := _grid_codes(full / tf.lsb)) is not None:
        # all of this block on and its input on the temperature grid: the block's own kernel
        return block.run(temp=codes).outputs["te"].astype(float) * tf.lsb
    x = full[::dp.decim]
    alpha = dp.alpha_m * 2.0**-dp.alpha_s if f"{prefix}.alpha" in sw else block.alpha
    mode = 1 if f"{prefix}.round" in sw else 2 if f"{prefix}.round" in sw.inject else 0
    noise = sw.rng.uniform(0.0, 1.0, (2, x.size)) if mode == 2 else np.zeros((2, x.size))
    resid = np.zeros((2, x.size))
    q_state = tf.lsb * 2.0**-dp.guard   # the state's LSB: guard bits below the temperature code
    y = _lag_float(x, alpha, q_state, tf.lsb, mode, dp.rules.rounding_code, tf.min_value, tf.max_value, noise,
                   resid)
    if mode == 1:
        sw.record(f"{prefix}.round", "state", resid[0])
        sw.record(f"{prefix}.round", "out", resid[1])
    return held(y, dp.decim, full.size)


# --------------------------------------------------------------------------------------------
# blocks
# --------------------------------------------------------------------------------------------
def piecewise_hybrid(block, temp: np.ndarray, prefix: str, sw: Switch) -> np.ndarray:
    """Segment select + Horner; sources ``<prefix>.coef`` (coefficients, breakpoints, t0) and
    ``<prefix>.round`` (every rounding of the datapath: acc products and sums, output)."""
    temp = np.asarray(temp, dtype=float)
    tf = block.temp_format
    if f"{prefix}.coef" in sw:
        bp = block.breakpoints.astype(float) * tf.lsb
        t0 = float(block.t0[0]) * tf.lsb
        coef = np.column_stack([block.coef[:, k].astype(float) * f.lsb for k, f in enumerate(block.coef_formats)])
    else:
        bp = np.asarray(block.breakpoints_c, dtype=float)
        t0 = block.t0_c
        coef = block.coefficients_real
    seg = np.searchsorted(bp, temp, side="right")
    c = coef[seg]
    t = temp - t0
    name = f"{prefix}.round"
    acc_f, rules = block.acc_format, block.rules
    dp = block.datapath
    acc = c[:, block.order].copy()
    if dp.top_shift > 0:  # the top coefficient enters the accumulator: a constant rounding per segment
        acc = sw.round(name, acc, acc_f, rules, "coef_into_acc")
    for k in range(block.order - 1, -1, -1):
        acc = sw.round(name, acc * t, acc_f, rules, "acc")  # the product always drops t's fraction bits
        acc = acc + c[:, k]
        if dp.acc_align[k] > 0:  # the sum returns to acc_format by acc_align: c_k's extra bits rounded
            acc = sw.round(name, acc, acc_f, rules, "acc")
    if dp.out_shift > 0:
        acc = sw.round(name, acc, block.out_format, rules)
    return acc


def rtd_hybrid(block, frac: np.ndarray, sw: Switch, prefix: str = "rtd") -> np.ndarray:
    """ADC fraction -> temperature; sources <prefix>.lut_resolution (linear interpolation over 2**k
    segments instead of the exact inverse), <prefix>.lut_coef (LUT entries quantised), <prefix>.round."""
    frac = np.asarray(frac, dtype=float)
    adc, dp = block.adc_format, block.datapath
    exact = block.physics.temperature_from_fraction(frac)
    lut_q = block.lut.astype(float) * block.lut_format.lsb

    def interp(table):
        u = (frac - adc.min_value) / adc.lsb  # continuous offset-binary code
        seg = float(1 << dp.frac_bits)
        idx = np.clip(np.floor(u / seg), 0, (1 << dp.lut_index_bits) - 1).astype(np.int64)
        fr = u - idx * seg
        return (table[idx] * seg + (table[idx + 1] - table[idx]) * fr) / seg

    if f"{prefix}.lut_resolution" in sw:
        temp = interp(lut_q if f"{prefix}.lut_coef" in sw else block.lut_real)
    elif f"{prefix}.lut_coef" in sw:
        temp = exact + interp(lut_q - block.lut_real)
    else:
        temp = exact
    if dp.shift > 0:
        temp = sw.round(f"{prefix}.round", temp, block.temp_format, block.rules)
    return temp


def divide_hybrid(block, x: np.ndarray, sf: np.ndarray, sw: Switch, name: str = "sf_divide.trunc") -> np.ndarray:
    """x / SF; source ``name`` = quotient truncated toward zero at in.fl + guard_bits, then the
    rescale (``rounding``, floor by default) into out_format."""
    v = np.asarray(x, dtype=float) / np.asarray(sf, dtype=float)
    if name in sw:
        scale = 2.0 ** block.datapath.q_format.fl
        q = np.trunc(np.asarray(x, dtype=float) * scale / sf) / scale
        y = quantize(q, block.out_format, block.rules).astype(float) * block.out_format.lsb
        sw.record(name, "out", y - v)
        return y
    if name in sw.inject:
        return v + sw.noise(block.rules.rounding, block.out_format.lsb, v)
    return v


def nco_hybrid(block, n: int, sw: Switch, prefix: str = "demod", ref=None) -> tuple[np.ndarray, np.ndarray]:
    """(cos, -sin) of the NCO phase; sources <prefix>.nco_phase (tuning word, bin address and
    interpolation offset: the phase the NCO evaluates, with an exact table and an exact first-order
    correction) and <prefix>.nco_amp (table values and correction quantised). ``ref``: an external
    reference in turns (a drive loop's NCO) in place of the accumulator: on its word grid when
    nco_phase is on, exact when off."""
    nco = block.nco
    if ref is not None:
        turns = np.asarray(ref, dtype=float)
        phases = (quantize(turns, nco.phase_format, Rules("half_up", "wrap")) + nco.trim) & nco.phase_mask
    else:
        phases = nco.phases(n)
    if f"{prefix}.nco_phase" in sw:
        if f"{prefix}.nco_amp" in sw:
            c, m = nco.wave(phases)
            return c.astype(float) * nco.nco_format.lsb, m.astype(float) * nco.nco_format.lsb
        centre, delta = nco.bin_phase(phases)
        return np.cos(centre) - np.sin(centre) * delta, -np.sin(centre) - np.cos(centre) * delta
    angle = nco.reference_phase(n, 0) if ref is None else 2 * np.pi * turns + nco.phase_trim_rad
    if f"{prefix}.nco_amp" in sw:
        lsb = nco.lut_format.lsb
        return nco.lut_quantize(np.cos(angle)).astype(float) * lsb, nco.lut_quantize(-np.sin(angle)).astype(float) * lsb
    return np.cos(angle), -np.sin(angle)


def demod_hybrid(block, x: np.ndarray, sw: Switch, prefix: str = "demod", wanted=("i",),
                 ref=None) -> dict[str, np.ndarray]:
    """Mixers 2 x cos (I) and -2 x sin (Q), rounding <prefix>.mix_round, low-pass <prefix>.lpf_*
    (both channels share the filter's coefficients and rounding); amp and phase through
    <prefix>.cordic (the CORDIC on the channels' stored words, or hypot / atan2 when off). Returns
    ``mix`` (the I mixer) and the wanted outputs."""
    cos, msin = nco_hybrid(block, len(x), sw, prefix, ref)
    x = np.asarray(x, dtype=float)
    out = {}
    for port, lpf, wave in (("i", block.lpf_i, cos), ("q", block.lpf_q, msin)):
        if port == "q" and not set(wanted) & {"q", "amp", "phase"}:
            continue
        mix = 2.0 * x * wave
        if block.datapath.mix_shift > 0:
            mix = sw.round(f"{prefix}.mix_round", mix, block.data_format, block.rules, "out" if port == "i" else "mix_q")
        if port == "i":
            out["mix"] = mix
        out[port] = iir_hybrid(lpf, mix, f"{prefix}.lpf_coef", f"{prefix}.lpf_round", sw)
    if set(wanted) & {"amp", "phase"}:
        if f"{prefix}.cordic" in sw:
            df = block.data_format
            i, q = (quantize(out[p], df, block.rules) for p in ("i", "q"))
            amp, phase = block.polar(OverflowLog(), i, q)
            out["amp"] = amp.astype(float) * block.outputs["amp"].lsb
            out["phase"] = phase.astype(float) * block.outputs["phase"].lsb
        else:
            out["amp"], out["phase"] = np.hypot(out["i"], out["q"]), np.arctan2(out["q"], out["i"])
    return out


def subtract_hybrid(block, x, bias, name: str, sw: Switch) -> np.ndarray:
    r = np.asarray(x, dtype=float) - np.asarray(bias, dtype=float)
    if block.datapath.shift > 0:
        r = sw.round(name, r, block.out_format, block.rules)
    return r


def freq2temp_hybrid(block, f: np.ndarray, sw: Switch, prefix: str = "freq2temp") -> np.ndarray:
    """T = (f - f0) / k; sources <prefix>.coef (f0 and 1/k quantised) and <prefix>.round."""
    f = np.asarray(f, dtype=float)
    dp = block.datapath
    if f"{prefix}.coef" in sw:
        temp = (f - dp.f0 * block.freq_format.lsb) * (dp.kinv * block.kinv_format.lsb)
    else:
        temp = (f - block.f0_hz) / block.k_hz_per_c
    return sw.round(f"{prefix}.round", temp, block.temp_format, block.rules)


def drive_hybrid(block, x: np.ndarray, sw: Switch, prefix: str = "drive") -> dict[str, np.ndarray]:
    """The drive loop as one source, ``<prefix>.loop``: on, the bit-exact loop (on the ADC codes of
    ``x``); off (or injected: a feedback loop has no white-noise model here), its float reference.
    Its rounding points are not separated: they act inside the feedback, where switching one alone
    would need the loop's kernel written a second time in float."""
    x = np.asarray(x, dtype=float)
    if f"{prefix}.loop" in sw:
        codes = quantize(x, block.in_format, ADC_RULES)
        return block.real_outputs(block.run(x=codes))
    return block.reference(x=x)


# --------------------------------------------------------------------------------------------
# each kind of block: its quantisation sources and its hybrid run, by instance
# --------------------------------------------------------------------------------------------
def _rounding(iid: str, what: str, category: str, kind: str, node: str, fmt: Format, rules: Rules,
              note: str = "") -> Source:
    return Source(f"{iid}.{what}", category, iid, node, fmt.lsb, rules.rounding, note, kind)


def _sources_rtd(iid, b, wanted):
    node = f"{iid}.temp"
    s = [Source(f"{iid}.lut_resolution", LUTNCO, iid, node, note=f"{2**b.datapath.lut_index_bits} linear segments",
                kind="rtd"),
         Source(f"{iid}.lut_coef", COEF, iid, node, note=f"LUT entries in {b.lut_format}", kind="rtd")]
    if b.datapath.shift > 0:
        s.append(_rounding(iid, "round", ROUND, "rtd", node, b.temp_format, b.rules))
    return s


def _sources_lag(iid, b, wanted):
    node = f"{iid}.te"
    return [Source(f"{iid}.alpha", COEF, iid, node, note=f"alpha = {b.m} x 2**-{b.s}", kind="lag"),
            _rounding(iid, "round", ROUND, "lag", node, b.temp_format, b.rules, f"state step at {b.state_format}, output")]


def _sources_piecewise(iid, b, wanted):
    node = f"{iid}.y"
    return [Source(f"{iid}.coef", COEF, iid, node, kind="piecewise"),
            _rounding(iid, "round", ROUND, "piecewise", node, b.out_format, b.rules)]


def _sources_divide(iid, b, wanted):
    return [_rounding(iid, "trunc", DIVIDER, "sf_divide", f"{iid}.y", b.out_format, b.rules,
                      "quotient toward zero, then the rescale")]


def _sources_demod(iid, b, wanted):
    nco = b.nco
    s = [Source(f"{iid}.nco_phase", LUTNCO, iid, f"{iid}.mix", note=f"{nco.lut_bits}-bit address, "
                f"{nco.interp_bits}-bit interpolation", kind="demod"),
         Source(f"{iid}.nco_amp", LUTNCO, iid, f"{iid}.mix", note=f"LUT values in {nco.lut_format}", kind="demod")]
    if b.datapath.mix_shift > 0:
        s.append(_rounding(iid, "mix_round", ROUND, "demod", f"{iid}.mix", b.data_format, b.rules))
    s += [Source(f"{iid}.lpf_coef", COEF, iid, f"{iid}.i", kind="demod"),
          _rounding(iid, "lpf_round", ROUND, "demod", f"{iid}.i", b.data_format, b.lpf_i.rules)]
    if set(wanted) & {"amp", "phase"}:
        s.append(Source(f"{iid}.cordic", ROUND, iid, f"{iid}.amp", note="CORDIC on the stored I and Q words",
                        kind="demod"))
    return s


def _sources_subtract(iid, b, wanted):
    if b.datapath.shift > 0:
        return [_rounding(iid, "round", ROUND, "bias_subtract", f"{iid}.y", b.out_format, b.rules)]
    return []


def _sources_iir(iid, b, wanted):
    return [Source(f"{iid}.coef", COEF, iid, f"{iid}.y", kind="iir"),
            _rounding(iid, "round", ROUND, "iir", f"{iid}.y", b.data_format, b.rules)]


def _sources_freq2temp(iid, b, wanted):
    return [Source(f"{iid}.coef", COEF, iid, f"{iid}.temp", note="f0 and 1/k", kind="freq2temp"),
            _rounding(iid, "round", ROUND, "freq2temp", f"{iid}.temp", b.temp_format, b.rules)]


def _sources_drive(iid, b, wanted):
    return [Source(f"{iid}.loop", ROUND, iid, f"{iid}.f", note="the loop's arithmetic, all its rounding points",
                   kind="drive")]


@dataclass(frozen=True)
class KindHybrid:
    """One kind of block in the hybrid: ``sources(iid, block, wanted)`` lists its quantisation
    sources (named ``<iid>.<what>``, iid = the instance with dots as underscores), ``run(iid, block,
    inputs, sw, wanted)`` its outputs (real units) from real inputs, plus any internal node a source
    is measured at (``mix``)."""

    sources: object
    run: object


HYBRIDS: dict[str, KindHybrid] = {
    "rtd": KindHybrid(_sources_rtd, lambda iid, b, ins, sw, w: {"temp": rtd_hybrid(b, ins["code"], sw, iid)}),
    "lag": KindHybrid(_sources_lag, lambda iid, b, ins, sw, w: {"te": lag_hybrid(b, ins["temp"], sw, iid)}),
    "piecewise": KindHybrid(_sources_piecewise,
                            lambda iid, b, ins, sw, w: {"y": piecewise_hybrid(b, ins["temp"], iid, sw)}),
    "sf_divide": KindHybrid(_sources_divide,
                            lambda iid, b, ins, sw, w: {"y": divide_hybrid(b, ins["x"], ins["sf"], sw, f"{iid}.trunc")}),
    "demod": KindHybrid(_sources_demod, lambda iid, b, ins, sw, w: demod_hybrid(b, ins["x"], sw, iid, w,
                                                                               ins.get("ref"))),
    "bias_subtract": KindHybrid(_sources_subtract, lambda iid, b, ins, sw, w: {
        "y": subtract_hybrid(b, ins["x"], ins["bias"], f"{iid}.round", sw)}),
    "iir": KindHybrid(_sources_iir, lambda iid, b, ins, sw, w: {"y": iir_hybrid(b, ins["x"], f"{iid}.coef",
                                                                                  f"{iid}.round", sw)}),
    "drive": KindHybrid(_sources_drive, lambda iid, b, ins, sw, w: drive_hybrid(b, ins["x"], sw, iid)),
    "freq2temp": KindHybrid(_sources_freq2temp, lambda iid, b, ins, sw, w: {"temp": freq2temp_hybrid(b, ins["f"], sw,
                                                                                                   iid)}),
}


def lowpass_of(chain: Chain, inst: str):
    """The member's low-pass (an iir member itself, a demodulator's channel filter), or None."""
    block = chain.members[inst]
    return {"iir": block, "demod": getattr(block, "lpf_i", None)}.get(chain.kinds[inst])


def _hybrid_of(chain: Chain, inst: str) -> KindHybrid:
    kind = chain.kinds[inst]
    if kind not in HYBRIDS:
        raise InputError(f"{chain.name}: {inst} ({kind}) has no hybrid model in fxdsp.budget.hybrid.HYBRIDS")
    return HYBRIDS[kind]


# --------------------------------------------------------------------------------------------
# chains: analog stimulus, sources, hybrid run -- composed from the netlist, any chain
# --------------------------------------------------------------------------------------------
def chain_analog(chain: Chain, rng: np.random.Generator, n: int) -> dict:
    """The chain's stimulus before its ADCs, by chain input: ``analog`` (with the sensor's noise),
    ``clean`` (without) and ``codes`` (what the bit-exact chain reads). A chain with a sensor: the
    sensor's own draws (the same as ``nominal_stimulus``); without one, the stored words themselves
    (there is no ADC to attribute)."""
    if chain.sensor is not None:
        out = chain.sensor.nominal_analog(rng, n)
        return {"analog": chain.sensor.analog_inputs(out["analog"]), "clean": chain.sensor.analog_inputs(out["clean"]),
                "codes": out["codes"]}
    codes = chain.nominal_stimulus(rng, n)
    real = {k: np.asarray(v, dtype=float) * chain.inputs[k].lsb for k, v in codes.items()}
    return {"analog": real, "clean": real, "codes": codes}


def chain_sources(chain: Chain) -> list[Source]:
    """Every quantisation source of the chain: one ADC per chain input (when the chain has a sensor
    to read analog values from), then each member's, in execution order."""
    out = []
    if chain.sensor is not None:
        for name, dsts in chain.netlist.inputs.items():
            fmt = chain.inputs[name]
            out.append(Source(f"adc.{name}", ADC, dsts[0].instance.replace(".", "_"), name, fmt.lsb, "half_up",
                              f"{name} ADC ({fmt})", "adc"))
    wanted = chain.wanted()
    for inst in chain.netlist.order:
        out += _hybrid_of(chain, inst).sources(inst.replace(".", "_"), chain.members[inst], wanted[inst])
    return out


def run_chain(chain: Chain, analog: dict[str, np.ndarray], sw: Switch) -> dict[str, np.ndarray]:
    """Every node of the hybrid chain: the chain inputs after their ADCs (by input name), each
    member's outputs and internal nodes (``<iid>.<port>``) and the chain outputs (by name)."""
    nodes: dict[str, np.ndarray] = {}
    inputs = {}
    for name in chain.netlist.inputs:
        x = analog[name]
        if chain.sensor is not None:
            x = sw.round(f"adc.{name}", x, chain.inputs[name], ADC_RULES)
        nodes[name] = inputs[name] = x

    def step(inst, block, ins, wanted):
        iid = inst.replace(".", "_")
        outs = _hybrid_of(chain, inst).run(iid, block, ins, sw, wanted)
        nodes.update({f"{iid}.{k}": v for k, v in outs.items()})
        return outs

    nodes.update(chain.evaluate(step, inputs))
    return nodes


ADC_RULES = Rules("half_up", "saturate")   # an ADC: nearest code, clipped at full scale
