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

from ..chains import Chain
from ..fixed import Format, Rules, quantize
from ..fixed.kernels import FLOOR, TOWARD_ZERO, round_float
from ..blocks.lag import held

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


def lag_hybrid(block, temp: np.ndarray, sw: Switch) -> np.ndarray:
    """The lag block; sources lag.alpha (alpha as mantissa x 2**-shift) and lag.round (the state
    step at state_format's LSB and the output at temp_format's; in the loop: the state keeps its
    own rounding errors). A decimating lag updates on every decim-th input and holds between."""
    dp = block.datapath
    tf = dp.temp_format
    full = np.asarray(temp, dtype=float)
    if "lag.alpha" in sw and "lag.round" in sw and (codes := _grid_codes(full / tf.lsb)) is not None:
        # all of this block on and its input on the temperature grid: the block's own kernel
        return block.run(temp=codes).outputs["te"].astype(float) * tf.lsb
    x = full[::dp.decim]
    alpha = dp.alpha_m * 2.0**-dp.alpha_s if "lag.alpha" in sw else block.alpha
    mode = 1 if "lag.round" in sw else 2 if "lag.round" in sw.inject else 0
    noise = sw.rng.uniform(0.0, 1.0, (2, x.size)) if mode == 2 else np.zeros((2, x.size))
    resid = np.zeros((2, x.size))
    q_state = tf.lsb * 2.0**-dp.guard   # the state's LSB: guard bits below the temperature code
    y = _lag_float(x, alpha, q_state, tf.lsb, mode, dp.rules.rounding_code, tf.min_value, tf.max_value, noise,
                   resid)
    if mode == 1:
        sw.record("lag.round", "state", resid[0])
        sw.record("lag.round", "out", resid[1])
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


def rtd_hybrid(block, frac: np.ndarray, sw: Switch) -> np.ndarray:
    """ADC fraction -> temperature; sources rtd.lut_resolution (linear interpolation over 2**k
    segments instead of the exact inverse), rtd.lut_coef (LUT entries quantised), rtd.round."""
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

    if "rtd.lut_resolution" in sw:
        temp = interp(lut_q if "rtd.lut_coef" in sw else block.lut_real)
    elif "rtd.lut_coef" in sw:
        temp = exact + interp(lut_q - block.lut_real)
    else:
        temp = exact
    if dp.shift > 0:
        temp = sw.round("rtd.round", temp, block.temp_format, block.rules)
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


def nco_hybrid(block, n: int, sw: Switch) -> np.ndarray:
    """2 cos of the NCO phase (the I mixer's factor); sources demod.nco_phase (tuning word, bin
    address and interpolation offset: the phase the NCO evaluates, with an exact table and an exact
    first-order correction) and demod.nco_amp (table values and correction quantised)."""
    nco = block.nco
    phases = nco.phases(n)
    if "demod.nco_phase" in sw:
        if "demod.nco_amp" in sw:
            return nco.wave(phases)[0].astype(float) * nco.nco_format.lsb
        centre, delta = nco.bin_phase(phases)
        return np.cos(centre) - np.sin(centre) * delta
    angle = nco.reference_phase(n, 0)
    if "demod.nco_amp" in sw:
        return nco.lut_quantize(np.cos(angle)).astype(float) * nco.lut_format.lsb
    return np.cos(angle)


def demod_hybrid(block, x: np.ndarray, sw: Switch) -> tuple[np.ndarray, np.ndarray]:
    """The rate (I) channel: mixer 2 x cos, rounding demod.mix_round, low-pass demod.lpf_*."""
    mix = 2.0 * np.asarray(x, dtype=float) * nco_hybrid(block, len(x), sw)
    if block.datapath.mix_shift > 0:
        mix = sw.round("demod.mix_round", mix, block.data_format, block.rules)
    i = iir_hybrid(block.lpf_i, mix, "demod.lpf_coef", "demod.lpf_round", sw)
    return mix, i


def subtract_hybrid(block, x, bias, name: str, sw: Switch) -> np.ndarray:
    r = np.asarray(x, dtype=float) - np.asarray(bias, dtype=float)
    if block.datapath.shift > 0:
        r = sw.round(name, r, block.out_format, block.rules)
    return r


# --------------------------------------------------------------------------------------------
# chains: analog stimulus, sources, hybrid run
# --------------------------------------------------------------------------------------------
def sources_paper002(chain: Chain) -> list[Source]:
    rtd, sf, div, dem, bias, sub, lpf = (chain.sensor.rtd, chain.sensor.sf, chain.sensor.divide, chain.sensor.demod, chain.sensor.bias,
                                        chain.sensor.subtract, chain.sensor.lpf)
    s = [Source("adc.sense", ADC, "sf_divide", "vsa", div.in_format.lsb, "half_up", "sense ADC"),
         Source("adc.rtd", ADC, "rtd", "rtd_frac", rtd.adc_format.lsb, "half_up", "RTD bridge ADC"),
         Source("rtd.lut_resolution", LUTNCO, "rtd", "temp", note=f"{2**rtd.datapath.lut_index_bits} linear segments"),
         Source("rtd.lut_coef", COEF, "rtd", "temp", note=f"LUT entries in {rtd.lut_format}")]
    if rtd.datapath.shift > 0:
        s.append(Source("rtd.round", ROUND, "rtd", "temp", rtd.temp_format.lsb, rtd.rules.rounding))
    if chain.sensor.lag is not None:
        lag = chain.sensor.lag
        s += [Source("lag.alpha", COEF, "lag", "te", note=f"alpha = {lag.m} x 2**-{lag.s}"),
              Source("lag.round", ROUND, "lag", "te", lag.temp_format.lsb, lag.rules.rounding,
                     f"state step at {lag.state_format}, output")]
    s += [Source("piecewise_sf.coef", COEF, "piecewise_sf", "sf"),
          Source("piecewise_sf.round", ROUND, "piecewise_sf", "sf", sf.out_format.lsb, sf.rules.rounding),
          Source("sf_divide.trunc", DIVIDER, "sf_divide", "v", div.out_format.lsb, div.rules.rounding,
                 "quotient toward zero, then the rescale"),
          Source("demod.nco_phase", LUTNCO, "demod", "mix", note=f"{dem.nco.lut_bits}-bit address, {dem.nco.interp_bits}-bit interpolation"),
          Source("demod.nco_amp", LUTNCO, "demod", "mix", note=f"LUT values in {dem.nco.lut_format}")]
    if dem.datapath.mix_shift > 0:
        s.append(Source("demod.mix_round", ROUND, "demod", "mix", dem.data_format.lsb, dem.rules.rounding))
    s += [Source("demod.lpf_coef", COEF, "demod", "i"),
          Source("demod.lpf_round", ROUND, "demod", "i", dem.data_format.lsb, dem.lpf_i.rules.rounding),
          Source("piecewise_bias.coef", COEF, "piecewise_bias", "bias"),
          Source("piecewise_bias.round", ROUND, "piecewise_bias", "bias", bias.out_format.lsb, bias.rules.rounding)]
    if sub.datapath.shift > 0:
        s.append(Source("bias_subtract.round", ROUND, "bias_subtract", "r", sub.out_format.lsb, sub.rules.rounding))
    s += [Source("iir.coef", COEF, "iir", "rate"),
          Source("iir.round", ROUND, "iir", "rate", lpf.data_format.lsb, lpf.rules.rounding)]
    return s


def sources_paper001(chain: Chain) -> list[Source]:
    f2t, bias, sub = chain.sensor.f2t, chain.sensor.bias, chain.sensor.subtract
    s = [Source("adc.freq", ADC, "freq2temp", "f", f2t.freq_format.lsb, "half_up", "frequency word"),
         Source("adc.rate", ADC, "bias_subtract001", "rate_in", sub.in_format.lsb, "half_up", "rate input word"),
         Source("freq2temp.coef", COEF, "freq2temp", "temp", note="f0 and 1/k"),
         Source("freq2temp.round", ROUND, "freq2temp", "temp", f2t.temp_format.lsb, f2t.rules.rounding),
         Source("piecewise_bias001.coef", COEF, "piecewise_bias001", "bias"),
         Source("piecewise_bias001.round", ROUND, "piecewise_bias001", "bias", bias.out_format.lsb,
                bias.rules.rounding)]
    if sub.datapath.shift > 0:
        s.append(Source("bias_subtract001.round", ROUND, "bias_subtract001", "rate", sub.out_format.lsb,
                        sub.rules.rounding))
    return s


def run_paper002(chain: Chain, analog: dict, sw: Switch) -> dict[str, np.ndarray]:
    """Every node of the hybrid paper 002 chain."""
    dem = chain.sensor.demod
    x = analog["vsa"]
    x = sw.round("adc.sense", x, chain.sensor.divide.in_format, Rules("half_up", "saturate"))
    frac = analog["rtd_frac"]
    af = chain.sensor.rtd.adc_format
    frac = sw.round("adc.rtd", frac, af, Rules("half_up", "saturate"))
    temp = rtd_hybrid(chain.sensor.rtd, frac, sw)
    te = lag_hybrid(chain.sensor.lag, temp, sw) if chain.sensor.lag is not None else temp   # what the engines see
    sf = piecewise_hybrid(chain.sensor.sf, te, "piecewise_sf", sw)
    v = divide_hybrid(chain.sensor.divide, x, sf, sw)
    mix, i = demod_hybrid(dem, v, sw)
    b = piecewise_hybrid(chain.sensor.bias, te, "piecewise_bias", sw)
    r = subtract_hybrid(chain.sensor.subtract, i, b, "bias_subtract.round", sw)
    rate = iir_hybrid(chain.sensor.lpf, r, "iir.coef", "iir.round", sw)
    return {"vsa": x, "rtd_frac": frac, "temp": temp, "te": te, "sf": sf, "v": v, "mix": mix, "i": i, "bias": b,
            "r": r, "rate": rate}


def run_paper001(chain: Chain, analog: dict, sw: Switch) -> dict[str, np.ndarray]:
    f2t = chain.sensor.f2t
    f = analog["f"]
    f = sw.round("adc.freq", f, f2t.freq_format, Rules("half_up", "saturate"))
    rate_in = analog["rate_in"]
    fi = chain.sensor.subtract.in_format
    rate_in = sw.round("adc.rate", rate_in, fi, Rules("half_up", "saturate"))
    if "freq2temp.coef" in sw:
        temp = (f - f2t.datapath.f0 * f2t.freq_format.lsb) * (f2t.datapath.kinv * f2t.kinv_format.lsb)
    else:
        temp = (f - f2t.f0_hz) / f2t.k_hz_per_c
    temp = sw.round("freq2temp.round", temp, f2t.temp_format, f2t.rules)
    b = piecewise_hybrid(chain.sensor.bias, temp, "piecewise_bias001", sw)
    rate = subtract_hybrid(chain.sensor.subtract, rate_in, b, "bias_subtract001.round", sw)
    return {"f": f, "rate_in": rate_in, "temp": temp, "bias": b, "rate": rate}


def sources_paper000(chain: Chain) -> list[Source]:
    s = chain.sensor
    k0, k1, sub, div = s.k0, s.k1, s.subtract, s.divide
    out = [Source("adc.df", ADC, s.subtract.name.replace(".", "_"), "df", sub.in_format.lsb, "half_up",
                  "difference-frequency word"),
           Source("adc.temp", ADC, k0.name.replace(".", "_"), "temp", k0.temp_format.lsb, "half_up", "temperature word")]
    for engine, node in ((k0, "k0"), (k1, "k1")):
        inst = engine.name.replace(".", "_")
        out += [Source(f"{inst}.coef", COEF, inst, node),
                Source(f"{inst}.round", ROUND, inst, node, engine.out_format.lsb, engine.rules.rounding)]
    if sub.datapath.shift > 0:
        out.append(Source(f"{sub.name}.round", ROUND, sub.name, "diff", sub.out_format.lsb, sub.rules.rounding))
    out.append(Source(f"{div.name}.trunc", DIVIDER, div.name, "accel", div.out_format.lsb, div.rules.rounding,
                      "quotient toward zero, then the rescale"))
    return out


def run_paper000(chain: Chain, analog: dict, sw: Switch) -> dict[str, np.ndarray]:
    """Every node of the hybrid paper 000 chain: a = (Df - K0(t)) / K1(t)."""
    s = chain.sensor
    df = sw.round("adc.df", analog["df"], s.subtract.in_format, Rules("half_up", "saturate"))
    temp = sw.round("adc.temp", analog["temp"], s.k0.temp_format, Rules("half_up", "saturate"))
    k0 = piecewise_hybrid(s.k0, temp, s.k0.name.replace(".", "_"), sw)
    k1 = piecewise_hybrid(s.k1, temp, s.k1.name.replace(".", "_"), sw)
    diff = subtract_hybrid(s.subtract, df, k0, f"{s.subtract.name}.round", sw)
    accel = divide_hybrid(s.divide, diff, k1, sw, f"{s.divide.name}.trunc")
    (port, _), = chain.outputs.items()
    return {"df": df, "temp": temp, "k0": k0, "k1": k1, "diff": diff, "accel": accel, port: accel}


# per chain: its analog stimulus (the chain's own ``nominal_analog``: the same draws as
# ``nominal_stimulus``, before the ADCs), its sources and its hybrid run
CHAIN_MODELS = {
    "chain_paper002": (lambda chain, rng, n: chain.sensor.nominal_analog(rng, n), sources_paper002, run_paper002),
    "chain_paper001": (lambda chain, rng, n: chain.sensor.nominal_analog(rng, n), sources_paper001, run_paper001),
    "chain_paper000": (lambda chain, rng, n: chain.sensor.nominal_analog(rng, n), sources_paper000, run_paper000),
}
