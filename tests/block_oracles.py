"""Independent oracles of the blocks: plain Python integers and Fractions, written from the block
docstrings (the specification), sample by sample, sharing no code with fxdsp's kernels.

Slow on purpose: clarity over speed. Used on a few hundred samples per test.
"""

from __future__ import annotations

import math
from fractions import Fraction


def round_to_int(v: Fraction, rounding: str) -> int:
    if rounding == "floor":
        return math.floor(v)
    if rounding == "half_up":
        return math.floor(v + Fraction(1, 2))
    if rounding == "half_even":
        f = math.floor(v)
        r = v - f
        if r > Fraction(1, 2) or (r == Fraction(1, 2) and f % 2 == 1):
            return f + 1
        return f
    if rounding == "toward_zero":
        return math.trunc(v)
    raise AssertionError(rounding)


def fit(v: int, fmt, overflow: str) -> tuple[int, bool]:
    lo, hi = fmt.min_int, fmt.max_int
    if lo <= v <= hi:
        return v, False
    if overflow == "saturate":
        return (hi if v > hi else lo), True
    return (v - lo) % (1 << fmt.wl) + lo, True


def requantize(stored: int, fl_from: int, fmt, rules) -> tuple[int, bool]:
    """A stored integer with fraction length fl_from -> fmt: exact value, one rounding, one fit."""
    value = Fraction(stored, 1) / Fraction(2) ** fl_from
    return fit(round_to_int(value * Fraction(2) ** fmt.fl, rules.rounding), fmt, rules.overflow)


# --- blocks ----------------------------------------------------------------------------------------

def rtd(block, codes) -> list[int]:
    """Offset-binary code: top k bits index the LUT, the rest interpolate linearly."""
    out = []
    wl = block.adc_format.wl
    s = wl - block.k
    for c in codes:
        u = int(c) + (1 << (wl - 1))
        i, frac = u >> s, u % (1 << s)
        lo_t, hi_t = int(block.lut[i]), int(block.lut[i + 1])
        # value in LUT units: L[i] + (L[i+1] - L[i]) * frac / 2**s, exactly
        exact = Fraction(lo_t) + Fraction((hi_t - lo_t) * frac, 1 << s)
        out.append(requantize_fraction(exact, block.lut_format.fl, block.temp_format, block.rules))
    return out


def requantize_fraction(v_stored: Fraction, fl_from: int, fmt, rules) -> int:
    value = v_stored / Fraction(2) ** fl_from
    return fit(round_to_int(value * Fraction(2) ** fmt.fl, rules.rounding), fmt, rules.overflow)[0]


def iir(block, xs) -> list[int]:
    """DF-I sections in cascade; per section the exact real-valued accumulator
    b.x - a.y + c1 e1 + c2 e2 (e = exact acc minus the rounded output, 0 after an overflow)."""
    nf, df, d = block.num_format.fl, block.den_format.fl, block.data_format
    seq = [int(v) for v in xs]
    for s in range(block.b.shape[0]):
        b = [Fraction(int(v), 1 << nf) for v in block.b[s]]
        a = [Fraction(int(v), 1 << df) for v in block.a[s]]
        c = [int(v) for v in block.c[s]]
        x1 = x2 = y1 = y2 = Fraction(0)
        e1 = e2 = Fraction(0)
        out = []
        for v in seq:
            xv = Fraction(v, 1 << d.fl)
            acc = b[0] * xv + b[1] * x1 + b[2] * x2 - a[0] * y1 - a[1] * y2 + c[0] * e1 + c[1] * e2
            r = round_to_int(acc * (1 << d.fl), block.rules.rounding)
            y, o = fit(r, d, block.rules.overflow)
            e = Fraction(0) if o else acc - Fraction(r, 1 << d.fl)
            x2, x1, y2, y1, e2, e1 = x1, xv, y1, Fraction(y, 1 << d.fl), e1, e
            out.append(y)
        seq = out
    return seq


def piecewise(block, temps) -> list[int]:
    """Count breakpoints <= T, then Horner: acc = c_N; acc = fit(round(acc * t)) + c_k, fitted."""
    acc_f, out_f, rules = block.acc_format, block.out_format, block.rules
    t0 = int(block.t0[0])
    out = []
    for T in temps:
        T = int(T)
        seg = sum(1 for b in block.breakpoints if int(b) <= T)
        t = Fraction(T - t0, 1 << block.temp_format.fl)
        coefs = [Fraction(int(block.coef[seg, k]), 1 << block.coef_formats[k].fl) for k in range(block.order + 1)]

        def to_acc(v: Fraction) -> Fraction:
            q, _ = fit(round_to_int(v * Fraction(2) ** acc_f.fl, rules.rounding), acc_f, rules.overflow)
            return Fraction(q, 1) / Fraction(2) ** acc_f.fl

        acc = to_acc(coefs[block.order])
        for k in range(block.order - 1, -1, -1):
            acc = to_acc(acc * t)
            acc = to_acc(acc + coefs[k])
        out.append(fit(round_to_int(acc * Fraction(2) ** out_f.fl, rules.rounding), out_f, rules.overflow)[0])
    return out


def sf_divide(block, xs, sfs) -> list[int]:
    out = []
    g = block.guard_bits
    for x, d in zip(xs, sfs):
        x, d = int(x), int(d)
        if d == 0:
            out.append(block.out_format.max_int if x > 0 else block.out_format.min_int if x < 0 else 0)
            continue
        num = x * (1 << (block.sf_format.fl + g))
        q = abs(num) // abs(d)
        q = -q if (num < 0) != (d < 0) else q
        out.append(requantize(q, block.in_format.fl + g, block.out_format, block.rules)[0])
    return out


def bias_subtract(block, xs, biases) -> list[int]:
    out = []
    for x, b in zip(xs, biases):
        v = Fraction(int(x), 1) / Fraction(2) ** block.in_format.fl - Fraction(int(b), 1) / Fraction(2) ** block.bias_format.fl
        out.append(fit(round_to_int(v * Fraction(2) ** block.out_format.fl, block.rules.rounding),
                       block.out_format, block.rules.overflow)[0])
    return out


def freq2temp(block, fs) -> list[int]:
    out = []
    for f in fs:
        v = Fraction(int(f) - block.f0, 1 << block.freq_format.fl) * Fraction(block.kinv, 1 << block.kinv_format.fl)
        out.append(fit(round_to_int(v * Fraction(2) ** block.temp_format.fl, block.rules.rounding),
                       block.temp_format, block.rules.overflow)[0])
    return out


def nco_table(lut_bits: int, lut_format) -> list[int]:
    """Quarter-wave sine at the bin centres of a 2**lut_bits-bin turn, nearest (half_up), saturated."""
    quarter = 1 << (lut_bits - 2)
    out = []
    for k in range(quarter):
        v = Fraction(math.sin(math.pi / 2 * (k + 0.5) / quarter)) * (1 << lut_format.fl)
        out.append(fit(round_to_int(v, "half_up"), lut_format, "saturate")[0])
    return out


def nco_wave(nco, phase: int, table: list[int]) -> tuple[int, int]:
    """(cos, -sin) of one phase word: the bin centre by quadrant symmetry of the quarter table, then
    the first-order correction cos - sin * delta, -sin - cos * delta, delta the sub-bin centre in
    radians with 2 pi taken on s16.12, each correction rounded by the demodulator's rounding."""
    P, L, D = nco.phase_bits, nco.lut_bits, nco.interp_bits
    a = phase >> (P - L)
    quad, k = a >> (L - 2), a % (1 << (L - 2))
    sin_c = [table[k], table[-1 - k], -table[k], -table[-1 - k]][quad]          # sin of the bin centre
    cos_c = [table[-1 - k], -table[k], -table[-1 - k], table[k]][quad]
    r = (phase >> (P - L - D)) % (1 << D)
    two_pi = round_to_int(Fraction(2 * math.pi) * (1 << 12), "half_up")
    delta = Fraction((2 * r + 1 - (1 << D)) * two_pi, 1 << (D + 1 + 12 + L))     # radians
    rule = nco.rules.rounding
    return cos_c + round_to_int(-sin_c * delta, rule), -sin_c + round_to_int(-cos_c * delta, rule)


def demod_mix(block, xs) -> tuple[list[int], list[int]]:
    """NCO phase n*ftw + phase0 modulo 2**P, the interpolated quarter-wave NCO, products read as
    2*x*nco."""
    nco = block.nco
    P = nco.phase_bits
    d, rules = block.data_format, block.rules
    in_fl, lut_fl = block.in_format.fl, nco.lut_format.fl
    table = nco_table(nco.lut_bits, nco.lut_format)
    i_out, q_out = [], []
    for n, x in enumerate(xs):
        for wave, out in zip(nco_wave(nco, (nco.phase0 + n * nco.ftw) % (1 << P), table), (i_out, q_out)):
            v = 2 * Fraction(int(x), 1 << in_fl) * Fraction(wave, 1 << lut_fl)
            out.append(fit(round_to_int(v * (1 << d.fl), rules.rounding), d, rules.overflow)[0])
    return i_out, q_out


def cordic(block, i_vals, q_vals) -> tuple[list[int], list[int]]:
    """Vectoring CORDIC with pre-rotation and floor shifts; returns (K*|v|, angle) stored."""
    import numpy as np

    ang = block.angle_format
    half_pi = round_to_int(Fraction(np.pi / 2) * (1 << ang.fl), "half_up")
    atans = [round_to_int(Fraction(float(np.arctan(2.0 ** -k))) * (1 << ang.fl), "half_up")
             for k in range(block.iterations)]
    xs, zs = [], []
    for x, y in zip(i_vals, q_vals):
        x, y, z = int(x), int(y), 0
        if x < 0:
            x, y, z = (y, -x, half_pi) if y >= 0 else (-y, x, -half_pi)
        for k in range(block.iterations):
            if y >= 0:
                x, y, z = x + (y >> k), y - (x >> k), z + atans[k]
            else:
                x, y, z = x - (y >> k), y + (x >> k), z - atans[k]
        xs.append(x)
        zs.append(z)
    return xs, zs


def lag(block, temps) -> list[int]:
    """Te += round((T - Te) * m / 2**s) on a state with g extra fraction bits, started on the first T;
    with decimation N the state moves on inputs 0, N, 2N, ... and the output holds in between."""
    g = block.g
    alpha = Fraction(block.m, 1 << block.s)
    te = None
    out = []
    for k, T in enumerate(temps):
        if k % block.decimation == 0:
            T = int(T) << g
            if te is None:
                te = T
            te += round_to_int((T - te) * alpha, block.rules.rounding)
            held = fit(round_to_int(Fraction(te, 1 << g), block.rules.rounding), block.temp_format,
                       block.rules.overflow)[0]
        out.append(held)
    return out


class _Cascade:
    """DF-I sections with error feedback, one sample at a time (:func:`iir`'s arithmetic, streaming)."""

    def __init__(self, block):
        self.block = block
        self.state = [[Fraction(0)] * 6 for _ in range(block.b.shape[0])]

    def step(self, v: int) -> int:
        blk = self.block
        nf, df, d = blk.num_format.fl, blk.den_format.fl, blk.data_format
        for s, st in enumerate(self.state):
            b = [Fraction(int(c), 1 << nf) for c in blk.b[s]]
            a = [Fraction(int(c), 1 << df) for c in blk.a[s]]
            c = [int(w) for w in blk.c[s]]
            x1, x2, y1, y2, e1, e2 = st
            xv = Fraction(v, 1 << d.fl)
            acc = b[0] * xv + b[1] * x1 + b[2] * x2 - a[0] * y1 - a[1] * y2 + c[0] * e1 + c[1] * e2
            r = round_to_int(acc * (1 << d.fl), blk.rules.rounding)
            y, o = fit(r, d, blk.rules.overflow)
            e = Fraction(0) if o else acc - Fraction(r, 1 << d.fl)
            self.state[s] = [xv, x1, Fraction(y, 1 << d.fl), y1, e, e1]
            v = y
        return v


def _pi(e: int, integ: int, kp: int, ki: int, shift: int, lo: int, hi: int, rounding: str) -> tuple[int, int]:
    """(output, integrator): integrate unless the output is limited in the direction e pushes it;
    both kept within the limits."""
    new = integ + ki * e
    out = round_to_int(Fraction(kp * e + new, 1 << shift), rounding)
    if (out > hi and e > 0) or (out < lo and e < 0):
        new = integ
        out = round_to_int(Fraction(kp * e + new, 1 << shift), rounding)
    return min(max(out, lo), hi), min(max(new, lo << shift), hi << shift)


def drive(block, xs) -> dict[str, list[int]]:
    """The drive loop, sample by sample, from its docstring: mixers on the NCO, the low-pass per
    channel, every update_every samples the CORDIC and the two PIs, the advanced carrier times the
    gain into the DAC, the accumulator stepped by the frequency word."""
    import numpy as np

    nco, dp, rules = block.nco, block.datapath, block.rules
    P, d, ang = nco.phase_bits, block.data_format, block.angle_format
    table = nco_table(nco.lut_bits, nco.lut_format)
    lpf = [_Cascade(block.lpf), _Cascade(block.lpf)]
    gain_k = float(np.prod(np.sqrt(1.0 + 2.0 ** (-2.0 * np.arange(block.iterations)))))
    inv_k = round_to_int(Fraction(1.0 / gain_k) * (1 << 17), "half_up")   # 1/K on s18.17
    pi_word = round_to_int(Fraction(math.pi) * (1 << ang.fl), "half_up")
    set_word = round_to_int(Fraction(block.phase_setpoint_rad) * (1 << ang.fl), "half_up")
    word = lambda v, fl: round_to_int(Fraction(v) * (1 << fl), "half_up")  # noqa: E731  (design constants)
    min_amp, amp_set = word(block.pll_min_amp, d.fl), word(block.amp_setpoint, d.fl)
    gain_max = word(block.gain_max, block.gain_format.fl)
    adv = word(block.advance_samples, dp.advance_bits)
    center = word(Fraction(block.f_hz) / Fraction(block.fs_hz), P)
    rng_f = word(Fraction(block.lock_range_hz) / Fraction(block.fs_hz), P)

    fl = block.freq_format.fl
    hz_center = word(Fraction(center) * Fraction(block.fs_hz) / (1 << P), fl)
    hz_coef = word(Fraction(block.fs_hz) * (1 << fl) / (1 << P), dp.hz_shift)

    def hz(ftw: int) -> int:   # the centre's word plus the deviation's, rounded by the rules
        dev = round_to_int(Fraction((ftw - center) * hz_coef, 1 << dp.hz_shift), rules.rounding)
        return fit(hz_center + dev, block.freq_format, rules.overflow)[0]

    phase, ftw, integ_f, integ_a, gain, count = 0, center, 0, 0, 0, 0
    f_word, amp, err = hz(center), 0, 0
    out = {"dac": [], "f": [], "amp": [], "phase": [], "nco": []}
    for x in xs:
        out["nco"].append(phase)
        cos_w, msin_w = nco_wave(nco, phase, table)
        ch = []
        for wave, filt in zip((cos_w, msin_w), lpf):
            v = 2 * Fraction(int(x), 1 << block.in_format.fl) * Fraction(wave, 1 << nco.lut_format.fl)
            ch.append(filt.step(fit(round_to_int(v * (1 << d.fl), rules.rounding), d, rules.overflow)[0]))
        count += 1
        if count >= dp.update_every:
            count = 0
            (xk,), (z,) = cordic(block, [ch[0]], [ch[1]])
            amp = fit(round_to_int(Fraction(xk * inv_k, 1 << 17), rules.rounding), d, rules.overflow)[0]
            e = z - set_word
            while e > pi_word:
                e -= 2 * pi_word
            while e <= -pi_word:
                e += 2 * pi_word
            err = e
            if amp >= min_amp:
                df, integ_f = _pi(e, integ_f, dp.kp_f, dp.ki_f, dp.pi_shift_f, -rng_f, rng_f, rules.rounding)
                ftw = center + df
                f_word = hz(ftw)
            gain, integ_a = _pi(amp_set - amp, integ_a, dp.kp_a, dp.ki_a, dp.pi_shift_a, 0, gain_max,
                                rules.rounding)
        carrier = nco_wave(nco, (phase + ((ftw * adv) >> dp.advance_bits)) % (1 << P), table)[1]
        v = Fraction(gain, 1 << block.gain_format.fl) * Fraction(carrier, 1 << nco.lut_format.fl)
        out["dac"].append(fit(round_to_int(v * (1 << block.dac_format.fl), rules.rounding), block.dac_format,
                              rules.overflow)[0])
        out["f"].append(f_word)
        out["amp"].append(amp)
        out["phase"].append(err)
        phase = (phase + ftw) % (1 << P)
    return out
