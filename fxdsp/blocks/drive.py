"""The drive loop (paper 002's figure 4): a PLL and an amplitude controller that keep the drive mode
oscillating at its resonance with a set amplitude. Its frequency word is paper 001's thermometer and
its NCO the demodulator's reference.

Per sample n, on the drive ADC's code ``x``:

* **Phase detector**: the demodulator's NCO (``demod.Nco``: accumulator, quarter-wave table,
  first-order interpolation) read at the accumulator ``phase`` gives (cos, -sin); the demodulator's
  mixers ``i = 2 x cos``, ``q = -2 x sin`` (read one fraction bit coarser, rounded by ``rounding``,
  fitted by ``overflow`` into ``data_format``), one ``iir`` low-pass per channel (``[drive.lpf]``,
  each sample, the iir's own section arithmetic).
* **Every ``update_every`` samples** the control update: the demodulator's CORDIC turns the filtered
  (I, Q) into amplitude and angle;
  - PLL: phase error ``e = angle - phase_setpoint`` wrapped into (-pi, pi]; ``df = R(kp_f e +
    integ_f) >> pi_shift_f`` with ``integ_f += ki_f e``; the frequency word ``ftw = ftw_center + df``,
    and in Hz on ``freq_format`` ``f = hz_center + R(df * hz_coef >> hz_shift)`` (``hz_words``: the
    centre's Hz word and fs / 2**phase_bits as a coefficient, for any sample rate: within 1.25 LSB of
    ``ftw * fs / 2**phase_bits``, half from each rounding and a quarter from the coefficient's);
  - amplitude: ``ea = amp_setpoint - amp``; ``g = R(kp_a ea + integ_a) >> pi_shift_a`` with
    ``integ_a += ki_a ea``.
  The PLL holds while the amplitude is below ``pll_min_amp`` (at rest the angle is the noise's).
  Integrators and outputs are limited (anti-windup, always saturating whatever ``overflow`` says,
  each limit counted): ``df`` and ``integ_f`` to +- ``lock_range_hz``, ``g`` and ``integ_a`` to
  0..``gain_max``. ``R`` is ``rounding``.
* **Drive**: the carrier is the NCO's -sin read ``advance_samples`` ahead (``phase + (ftw * adv)
  >> advance_bits``: the DAC's latency and hold, 1.5 samples in the simulated front end, would
  otherwise add ``2 pi f 1.5 / fs`` of lag that the PLL would turn into a frequency offset of
  ``lag / (2 pi tau)`` moving with Q); ``dac = R(g * carrier)`` fitted by ``overflow`` into
  ``dac_format``.
* ``phase += ftw`` (mod ``2**phase_bits``).

Why the signs: with the drive ``cos(phi + pi/2)`` the displacement at resonance lags it by 90 deg,
``x = A cos(phi)``, so I = A and Q = 0 (angle 0). Driven above resonance it lags more, the angle
goes negative, and ``df = +kp e`` lowers the frequency: the gains are positive.

Loop design (``design_gains``): with the detector's angle against the NCO frequency the resonator
is a lag ``-2 pi tau / (1 + s tau)`` rad/Hz (tau = 2Q/w), and the amplitude against the gain is
``G / (1 + s tau)``. Each PI places both closed-loop poles at its natural frequency
(``pll_bandwidth_hz``, ``agc_bandwidth_hz``) with ``damping``; a Q away from the design's ``tau_s``
moves them a little, not the loop's type.

The float reference runs the same structure in float64: the exact NCO phase and sin/cos, the
unquantised low-pass design and gains, atan2 and hypot, no rounding and no limits but the same
anti-windup clamps.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from numba import njit

from fxdsp.config import Section
from fxdsp.fixed import Format, OverflowLog, Rules, product_format, quantize
from fxdsp.fixed.kernels import convert, shift_right_round
from fxdsp.blocks.base import Block, corner_codes
from fxdsp.blocks.datapath import Datapath, OvfField, Rom, RtlPorts, const, info, limbs, nested, whole_limbs
from fxdsp.blocks.demod import INV_K_FORMAT, TWO_PI_FORMAT, Nco, _nco_wave, cordic_one, cordic_words, mixer_format
from fxdsp.blocks.iir import Iir, IirDatapath, df1_cascade_step
from fxdsp.errors import InputError

# int64 parameter vector of the kernels (indices)
(P_ADDR_SHIFT, P_LUT_BITS, P_INTERP_BITS, P_TWO_PI, P_CORR_SHIFT, P_PHASE_MASK, P_MIX_SHIFT, P_RND, P_OVF,
 P_DLO, P_DHI, P_LPF_SB, P_LPF_SA, P_LPF_OS, P_ITER, P_HALF_PI, P_INV_K, P_AMP_SHIFT, P_UPDATE, P_SET, P_PI,
 P_TWO_PI_ANGLE, P_KP_F, P_KI_F, P_SH_F, P_RANGE, P_CENTER, P_AMP_SET, P_KP_A, P_KI_A, P_SH_A, P_GMAX, P_ADV,
 P_ADV_BITS, P_DAC_SHIFT, P_DAC_LO, P_DAC_HI, P_HZ_CENTER, P_HZ_COEF, P_HZ_SHIFT, P_FLO, P_FHI, P_MIN_AMP,
 P_LPF_RND, P_LPF_OVF, P_COUNT) = range(46)
# int64 state vector: accumulator, frequency word, integrators, gain, update counter, amplitude, phase
# error and the frequency word in Hz (the low-pass states are their own array)
S_PHASE, S_FTW, S_INTEG_F, S_INTEG_A, S_GAIN, S_COUNT, S_AMP, S_ERR, S_F, S_LEN = range(10)
# counters: the format overflows (the datapath's ovf fields after the low-pass sections), then the
# control limits (not overflows: the PIs' designed clamps; each output's counter follows its integrator's)
C_MIX_I, C_MIX_Q, C_AMP, C_DAC, C_F, C_PLL_INTEG, C_PLL_LIMIT, C_AGC_INTEG, C_AGC_LIMIT, C_LEN = range(10)
LIMITS = ("pll_integ", "pll_limit", "agc_integ", "agc_limit")
# the low-pass's order when [drive.lpf] states none: the mixers' 2 f ripple must fall below the
# amplitude loop's 100 ppm with the cut-off far enough above the PLL (4 at 200 Hz: 6e-9 at 16 kHz)
LPF_ORDER = 4


@njit(cache=True, inline="always")
def _clamp(v, lo, hi):
    if v > hi:
        return hi, 1
    if v < lo:
        return lo, 1
    return v, 0


@njit(cache=True)
def _pi_update(e, st, k, kp, ki, shift, lo, hi, rnd, counts, c):
    """A PI controller's output ``R((kp e + integ) >> shift)`` limited to lo..hi, with its
    integrator ``st[k] += ki e`` (in output LSBs x 2**shift) held while the output is limited
    in the direction the error pushes (conditional integration: no wind-up, so no overshoot after
    a long saturation such as the start-up) and kept within the limits. counts[c]: integrator
    at a limit, counts[c + 1]: output at a limit."""
    integ = st[k] + ki * e
    out = shift_right_round(kp * e + integ, shift, rnd)
    if (out > hi and e > 0) or (out < lo and e < 0):
        integ = st[k]
        out = shift_right_round(kp * e + integ, shift, rnd)
    integ, o = _clamp(integ, lo << shift, hi << shift)
    counts[c] += o
    st[k] = integ
    out, o = _clamp(out, lo, hi)
    counts[c + 1] += o
    return out


@njit(cache=True)
def _detect(x, ph, lpf_st, p, qsin, lb, la, lc, counts, lcounts):
    """The phase detector's per-sample part on ADC code ``x`` with the NCO at ``ph``: mixers and
    low-pass; returns the filtered (I, Q)."""
    rnd, ovf = p[P_RND], p[P_OVF]
    c, m = _nco_wave(ph, p[P_ADDR_SHIFT], p[P_LUT_BITS], p[P_INTERP_BITS], qsin, p[P_TWO_PI], p[P_CORR_SHIFT], rnd)
    i_mix, o = convert(x * c, p[P_MIX_SHIFT], rnd, p[P_DLO], p[P_DHI], ovf)
    counts[C_MIX_I] += o
    q_mix, o = convert(x * m, p[P_MIX_SHIFT], rnd, p[P_DLO], p[P_DHI], ovf)
    counts[C_MIX_Q] += o
    # the low-pass by its own rules (its table's rounding and overflow, as its RTL's LPF_ parameters)
    lrnd, lovf = p[P_LPF_RND], p[P_LPF_OVF]
    i_lp = df1_cascade_step(i_mix, lb, la, lc, p[P_LPF_SB], p[P_LPF_SA], p[P_LPF_OS], lrnd, p[P_DLO], p[P_DHI], lovf,
                            lpf_st[0], lcounts[0])
    q_lp = df1_cascade_step(q_mix, lb, la, lc, p[P_LPF_SB], p[P_LPF_SA], p[P_LPF_OS], lrnd, p[P_DLO], p[P_DHI], lovf,
                            lpf_st[1], lcounts[1])
    return i_lp, q_lp


@njit(cache=True)
def _polar(i_lp, q_lp, p, atans, counts):
    """The phase detector's update part: the CORDIC's amplitude and the angle's error against the
    set point, wrapped into (-pi, pi]."""
    xk, z = cordic_one(i_lp, q_lp, atans, p[P_HALF_PI], p[P_ITER])
    amp, o = convert(xk * p[P_INV_K], p[P_AMP_SHIFT], p[P_RND], p[P_DLO], p[P_DHI], p[P_OVF])
    counts[C_AMP] += o
    e = z - p[P_SET]
    while e > p[P_PI]:
        e -= p[P_TWO_PI_ANGLE]
    while e <= -p[P_PI]:
        e += p[P_TWO_PI_ANGLE]
    return amp, e


@njit(cache=True)
def _drive_step(x, st, lpf_st, p, qsin, atans, lb, la, lc, counts, lcounts):
    """One sample of the loop on ADC code ``x``: returns the DAC word; updates ``st`` (S_*),
    ``lpf_st`` (2 channels x sections x 6) and the overflow counts (module docstring)."""
    rnd, ovf = p[P_RND], p[P_OVF]
    ph = st[S_PHASE]
    i_lp, q_lp = _detect(x, ph, lpf_st, p, qsin, lb, la, lc, counts, lcounts)
    st[S_COUNT] += 1
    if st[S_COUNT] >= p[P_UPDATE]:
        st[S_COUNT] = 0
        # PLL: held (frequency and integrator) while the amplitude is below pll_min_amp, where the
        # angle is the noise's
        amp, e = _polar(i_lp, q_lp, p, atans, counts)
        if amp >= p[P_MIN_AMP]:
            rng = p[P_RANGE]
            df = _pi_update(e, st, S_INTEG_F, p[P_KP_F], p[P_KI_F], p[P_SH_F], -rng, rng, rnd, counts, C_PLL_INTEG)
            st[S_FTW] = p[P_CENTER] + df
            # the frequency in Hz: the centre's word plus df x (fs / 2**phase_bits) (module docstring)
            f, o = convert(df * p[P_HZ_COEF], p[P_HZ_SHIFT], rnd, p[P_FLO] - p[P_HZ_CENTER],
                           p[P_FHI] - p[P_HZ_CENTER], ovf)
            counts[C_F] += o
            st[S_F] = p[P_HZ_CENTER] + f
        # amplitude controller
        ea = p[P_AMP_SET] - amp
        st[S_GAIN] = _pi_update(ea, st, S_INTEG_A, p[P_KP_A], p[P_KI_A], p[P_SH_A], 0, p[P_GMAX], rnd, counts,
                                C_AGC_INTEG)
        st[S_AMP] = amp
        st[S_ERR] = e
    ftw = st[S_FTW]
    cph = (ph + ((ftw * p[P_ADV]) >> p[P_ADV_BITS])) & p[P_PHASE_MASK]
    c, m = _nco_wave(cph, p[P_ADDR_SHIFT], p[P_LUT_BITS], p[P_INTERP_BITS], qsin, p[P_TWO_PI], p[P_CORR_SHIFT], rnd)
    dac, o = convert(st[S_GAIN] * m, p[P_DAC_SHIFT], rnd, p[P_DAC_LO], p[P_DAC_HI], ovf)
    counts[C_DAC] += o
    st[S_PHASE] = (ph + ftw) & p[P_PHASE_MASK]
    return dac


@njit(cache=True)
def _drive_open(x, st, lpf_st, p, qsin, atans, lb, la, lc, counts, lcounts):
    """The loop on given ADC codes (open loop): dac, f (Hz), amp, phase error and the NCO's
    accumulator word (the one its mixers read at that sample) per sample."""
    n = x.shape[0]
    dac = np.empty(n, dtype=np.int64)
    f = np.empty(n, dtype=np.int64)
    amp = np.empty(n, dtype=np.int64)
    err = np.empty(n, dtype=np.int64)
    nco = np.empty(n, dtype=np.int64)
    for k in range(n):
        nco[k] = st[S_PHASE]
        dac[k] = _drive_step(x[k], st, lpf_st, p, qsin, atans, lb, la, lc, counts, lcounts)
        f[k] = st[S_F]
        amp[k] = st[S_AMP]
        err[k] = st[S_ERR]
    return dac, f, amp, err, nco


@njit(cache=True)
def _detector_open(x, lpf_st, p, qsin, atans, lb, la, lc, counts, lcounts):
    """The phase detector alone on ADC codes, its NCO free at the centre word (no PLL): the angle
    error at every control update (angle_format LSBs)."""
    m = x.shape[0] // p[P_UPDATE]
    err = np.empty(m, dtype=np.int64)
    ph = 0
    k = 0
    for n in range(m * p[P_UPDATE]):
        i_lp, q_lp = _detect(x[n], ph, lpf_st, p, qsin, lb, la, lc, counts, lcounts)
        if (n + 1) % p[P_UPDATE] == 0:
            err[k] = _polar(i_lp, q_lp, p, atans, counts)[1]
            k += 1
        ph = (ph + p[P_CENTER]) & p[P_PHASE_MASK]
    return err


# ---- float reference ---------------------------------------------------------------------------
# float parameter vector and state
(F_FS, F_CENTER, F_KP_F, F_KI_F, F_RANGE, F_SET, F_AMP_SET, F_KP_A, F_KI_A, F_GMAX, F_ADV, F_UPDATE, F_MIN_AMP,
 F_LEN) = range(14)
FS_PHASE, FS_F, FS_INTEG_F, FS_INTEG_A, FS_GAIN, FS_COUNT, FS_AMP, FS_ERR, FS_LEN = range(9)


@njit(cache=True)
def _pi_update_float(e, st, k, kp, ki, lo, hi):
    """:func:`_pi_update` in float, without rounding."""
    integ = st[k] + ki * e
    out = kp * e + integ
    if (out > hi and e > 0) or (out < lo and e < 0):
        integ = st[k]
        out = kp * e + integ
    st[k] = min(max(integ, lo), hi)
    return min(max(out, lo), hi)


@njit(cache=True)
def _detect_float(x, ph, lpf_st, sos):
    """:func:`_detect` in float: exact sin/cos at ``ph`` (turns), the unquantised low-pass
    (``lpf_st``: 2 x sections x 4, x1, x2, y1, y2)."""
    w = 2.0 * np.pi * ph
    v = np.empty(2)
    v[0] = 2.0 * x * np.cos(w)
    v[1] = -2.0 * x * np.sin(w)
    out = np.empty(2)
    for ch in range(2):
        y = v[ch]
        for s in range(sos.shape[0]):
            r = lpf_st[ch, s]
            acc = sos[s, 0] * y + sos[s, 1] * r[0] + sos[s, 2] * r[1] - sos[s, 4] * r[2] - sos[s, 5] * r[3]
            r[1] = r[0]
            r[0] = y
            r[3] = r[2]
            r[2] = acc
            y = acc
        out[ch] = y
    return out[0], out[1]


@njit(cache=True, inline="always")
def wrap_rad(e):
    """An angle wrapped into (-pi, pi], as :func:`_polar` wraps its words."""
    while e > np.pi:
        e -= 2 * np.pi
    while e <= -np.pi:
        e += 2 * np.pi
    return e


@njit(cache=True)
def _polar_float(i_lp, q_lp, p):
    """:func:`_polar` in float: hypot and atan2."""
    return np.hypot(i_lp, q_lp), wrap_rad(np.arctan2(q_lp, i_lp) - p[F_SET])


@njit(cache=True)
def _drive_step_float(x, st, lpf_st, p, sos):
    """The float loop on a real ADC value x (full-scale units): returns the real DAC value.
    ``st`` (FS_*), ``lpf_st`` (2 x sections x 4: x1, x2, y1, y2, transposed-free DF-I)."""
    ph = st[FS_PHASE]   # turns, in [0, 1)
    i_lp, q_lp = _detect_float(x, ph, lpf_st, sos)
    st[FS_COUNT] += 1.0
    if st[FS_COUNT] >= p[F_UPDATE]:
        st[FS_COUNT] = 0.0
        amp, e = _polar_float(i_lp, q_lp, p)
        if amp >= p[F_MIN_AMP]:
            rng = p[F_RANGE]
            st[FS_F] = p[F_CENTER] + _pi_update_float(e, st, FS_INTEG_F, p[F_KP_F], p[F_KI_F], -rng, rng)
        ea = p[F_AMP_SET] - amp
        st[FS_GAIN] = _pi_update_float(ea, st, FS_INTEG_A, p[F_KP_A], p[F_KI_A], 0.0, p[F_GMAX])
        st[FS_AMP] = amp
        st[FS_ERR] = e
    f = st[FS_F]
    dac = st[FS_GAIN] * -np.sin(2.0 * np.pi * (ph + f / p[F_FS] * p[F_ADV]))
    ph += f / p[F_FS]
    st[FS_PHASE] = ph - np.floor(ph)
    return dac


@njit(cache=True)
def _drive_open_float(x, st, lpf_st, p, sos):
    n = x.shape[0]
    dac = np.empty(n)
    f = np.empty(n)
    amp = np.empty(n)
    err = np.empty(n)
    nco = np.empty(n)
    for k in range(n):
        nco[k] = st[FS_PHASE]
        dac[k] = _drive_step_float(x[k], st, lpf_st, p, sos)
        f[k] = st[FS_F]
        amp[k] = st[FS_AMP]
        err[k] = st[FS_ERR]
    return dac, f, amp, err, nco


@njit(cache=True)
def _detector_open_float(x, lpf_st, p, sos, turns_per_sample):
    """:func:`_detector_open` in float (radians), the NCO at ``turns_per_sample``."""
    upd = int(p[F_UPDATE])
    m = x.shape[0] // upd
    err = np.empty(m)
    for n in range(m * upd):
        i_lp, q_lp = _detect_float(x[n], (n * turns_per_sample) % 1.0, lpf_st, sos)
        if (n + 1) % upd == 0:
            err[(n + 1) // upd - 1] = _polar_float(i_lp, q_lp, p)[1]
    return err


def design_gains(pll_hz: float, agc_hz: float, damping: float, tau_s: float, resonator_gain: float,
                 update_s: float, name: str = "drive") -> dict[str, float]:
    """The PI gains in physical units (module docstring): kp_f Hz/rad, ki_f Hz/rad per update,
    kp_a per FS of amplitude, ki_a per FS per update. Each loop is a PI on a first-order lag
    ``G / (1 + s tau)``; its closed-loop poles solve ``tau s^2 + (1 + G kp) s + G ki = 0``, placed at
    the natural frequency ``2 pi f`` with ``damping``: ``kp = (2 damping w tau - 1) / G``, ``ki = w^2
    tau / G``. (A PI whose zero cancels the pole instead leaves the pole in the response to the
    start-up's initial state: a tail with the resonator's own time constant.)"""
    out = {}
    for loop, f, g in (("f", pll_hz, 2 * np.pi * tau_s), ("a", agc_hz, resonator_gain)):
        w = 2 * np.pi * f
        if 2 * damping * w * tau_s <= 1:
            raise InputError(f"{name}.{'pll' if loop == 'f' else 'agc'}_bandwidth_hz: {f} Hz is below what the "
                             f"mode's own 1 / (2 pi tau_s) = {1 / (2 * np.pi * tau_s):.3g} Hz allows at damping {damping}")
        out[f"kp_{loop}"] = (2 * damping * w * tau_s - 1) / g
        out[f"ki_{loop}"] = w * w * tau_s / g * update_s
    return out


def _pi_words(kp: float, ki: float, coef_bits: int) -> tuple[int, int, int]:
    """(kp word, ki word, shift): both gains in output LSBs per input LSB times 2**shift, the shift
    chosen so that the smaller word keeps ``coef_bits`` significant bits."""
    small = min(kp, ki)
    shift = max(0, coef_bits - 1 - int(np.floor(np.log2(small))) - 1)
    fmt = Format(True, 63, shift)
    words = quantize([kp, ki], fmt, Rules("half_up", "saturate"))
    return int(words[0]), int(words[1]), shift


@dataclass(frozen=True, eq=False)
class DriveDatapath(Datapath):
    """The drive loop's arithmetic (fields in the order of its future RTL module's parameters)."""

    MODULE = "drive"
    RTL = RtlPorts(ready=True, serial=True, mac_bundle=True, signed=("x", "dac", "f", "amp", "phase"),
                   ahead=(("nco", "nco_next"),))   # hdl/rtl/drive.v
    LATENCY = 2

    @staticmethod
    def controller_operands(p: dict) -> tuple[tuple[int, int], ...]:
        """The serial variant's (ARCH = 1) own products, (a, b) bits each in the order drive.v issues
        them: KP_F e, KI_F e, KP_A ea, KI_A ea, ftw ADVANCE, df HZ_COEF, gain -sin' (e ANGLE_W + 3
        bits, ea DATA_W + 2, ftw and df within FTW_CENTER +- LOCK_RANGE, the constants at their own
        width, at least 2)."""
        ew, aw = p["ANGLE_W"] + 3, p["DATA_W"] + 2
        fw = max(_sbits(p["FTW_CENTER"] + p["LOCK_RANGE"]), _sbits(p["FTW_CENTER"] - p["LOCK_RANGE"]))
        c = lambda k: max(2, _sbits(p[k]))  # noqa: E731
        return ((ew, c("KP_F")), (ew, c("KI_F")), (aw, c("KP_A")), (aw, c("KI_A")), (fw, c("ADVANCE")),
                (_sbits(p["LOCK_RANGE"]), c("HZ_COEF")), (p["GAIN_W"] + 1, p["NCO_W"]))

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """hdl/rtl/drive.v, ARCH = 1, the same on every sample: the serial demodulator's pass (its
        cycles, demod.v, on the loop's parameters), its wave pass and the cycle after (3 N + 13), the
        controller's seven products on their own limb counts and 25 cycles of its own (5 of them the
        pipelined PIs')."""
        from fxdsp.blocks.demod import DemodDatapath

        n = limbs(*DemodDatapath._mixer_operands(p))
        products = sum(limbs(a, b) for a, b in DriveDatapath.controller_operands(p))
        return DemodDatapath.serial_cycles(p) + 3 * n + 13 + products + 25

    @staticmethod
    def mac_operands(p: dict) -> tuple[int, int]:
        """The serial variant's multiplier (ENG_A_W x ENG_B_W): its detector's and its own products."""
        return p["ENG_A_W"], p["ENG_B_W"]

    @staticmethod
    def engine_widths(p: dict) -> tuple[int, int]:
        """ENG_A_W, ENG_B_W: the widest a and b of the detector's products (the serial demodulator's
        bundle, :meth:`DemodDatapath.mac_operands`) and of the controller's, in whole 16-bit limbs."""
        from fxdsp.blocks.demod import DemodDatapath

        ops = (DemodDatapath.mac_operands(p), *DriveDatapath.controller_operands(p))
        return tuple(whole_limbs(max(o[k] for o in ops)) for k in (0, 1))

    in_w: int
    data_w: int
    phase_bits: int
    lut_bits: int
    lut_w: int
    interp_bits: int
    two_pi: int = const()
    two_pi_w: int
    corr_shift: int
    nco_w: int               # the NCO's cos / -sin: lut_w + 1 (the interpolated value cannot overflow it)
    mix_shift: int           # exact x * nco product, read as 2 x nco, -> data_format
    rules: Rules
    lpf: IirDatapath = nested("LPF_")   # both channels' low-pass (one design)
    iterations: int
    angle_w: int
    half_pi: int = const()
    inv_k: int = const()
    inv_k_w: int
    amp_shift: int           # CORDIC x * 1/K -> data_format
    update_every: int        # samples per control update
    phase_set: int = const()     # the PLL's set point on angle_format
    pi_word: int = const()       # pi on angle_format (the error's wrap)
    ftw_center: int = const()    # f_hz as a tuning word
    lock_range: int = const()    # +- ftw LSBs
    kp_f: int = const()          # ftw LSBs per angle LSB, x 2**pi_shift_f
    ki_f: int = const()
    pi_shift_f: int
    amp_set: int = const()       # on data_format
    kp_a: int = const()          # gain LSBs per data LSB, x 2**pi_shift_a
    ki_a: int = const()
    pi_shift_a: int
    gain_w: int
    gain_max: int = const()
    advance: int = const()       # carrier advance in samples x 2**advance_bits (signed)
    advance_bits: int
    dac_w: int
    dac_shift: int               # gain x carrier product -> dac_format
    hz_center: int = const()     # f_hz's tuning word in Hz on freq_format
    hz_coef: int = const()       # fs / 2**phase_bits in freq_format LSBs x 2**hz_shift
    hz_shift: int
    freq_w: int
    min_amp: int = const()       # the PLL holds below this amplitude (data_format)
    eng_a_w: int                 # the serial variant's multiplier: a and b operands, whole limbs
    eng_b_w: int
    qsin: Rom
    atan: Rom
    data_format: Format = info()
    dac_format: Format = info()
    freq_format: Format = info()
    ovf: tuple = info()


def _sbits(v: int) -> int:
    """Bits of a 64-bit two's-complement constant, sign included (drive.v's sbits)."""
    v = v - (1 << 64) if v >= 1 << 63 else v
    return max(1, (v if v >= 0 else ~v).bit_length() + 1)


def hz_words(fs_hz: float, phase_bits: int, ftw_center: int, lock_range: int, freq_format: Format,
             name: str) -> tuple[int, int, int]:
    """(hz_center, hz_coef, hz_shift): the frequency word's conversion to Hz on ``freq_format``,
    ``f = hz_center + R(df * hz_coef >> hz_shift)`` with ``df = ftw - ftw_center``. The centre is
    exact to half an LSB; the coefficient's shift is the largest whose product with the lock range
    fits 62 bits, and its rounding may add at most a quarter of an LSB over the lock range (any
    sample rate: an exact ``ftw * fs`` would need fs to be a short binary fraction)."""
    exact = Rules("half_up", "saturate")
    center = Fraction(ftw_center) * Fraction(fs_hz) / (1 << phase_bits)
    hz_center = int(quantize([float(center)], freq_format, exact)[0])
    step = Fraction(fs_hz) * (1 << freq_format.fl) / (1 << phase_bits)   # freq LSBs per ftw LSB
    lock = max(lock_range, 1)
    shift = 62 - lock.bit_length() - (step.numerator.bit_length() - step.denominator.bit_length()) + 2
    while shift >= 0 and lock * int(step * (1 << shift) + Fraction(1, 2)) >= 1 << 62:
        shift -= 1
    coef = int(step * (1 << shift) + Fraction(1, 2)) if shift >= 0 else 0
    if shift < 0 or coef == 0 or 2 * lock_range > (1 << shift):
        raise InputError(f"{name}.freq_format: {freq_format} with phase_bits {phase_bits}: the frequency word's "
                         f"conversion to Hz would err by more than a quarter of an LSB over the lock range")
    return hz_center, coef, shift


class Drive(Block):
    """The drive loop: ``x`` (drive ADC) -> ``dac`` (drive DAC word), ``f`` (the NCO's frequency
    word in Hz), ``amp`` (measured amplitude) and ``phase`` (the PLL's phase error), these three
    held between control updates, and ``nco`` (the accumulator word its mixers read, turns: a
    demodulator's reference). ``closed_loop`` runs it on a resonator."""

    name = "drive"

    def __init__(self, fs_hz: float, f_hz: float, lock_range_hz: float, nco: Nco, in_format: Format,
                 data_format: Format, angle_format: Format, dac_format: Format, gain_format: Format,
                 freq_format: Format, lpf: Iir,
                 cordic_iterations: int, update_every: int, advance_samples: float, advance_bits: int,
                 phase_setpoint_rad: float, amp_setpoint: float, gain_max: float, pll_bandwidth_hz: float,
                 agc_bandwidth_hz: float, damping: float, tau_s: float, resonator_gain: float, coef_bits: int,
                 rules: Rules, pll_min_amp: float, name: str = "drive"):
        self.name = name
        if not 0 < lock_range_hz < min(f_hz, fs_hz / 2 - f_hz):
            raise InputError(f"{name}.lock_range_hz: must be within (0, {min(f_hz, fs_hz / 2 - f_hz)}), got "
                             f"{lock_range_hz}")
        if not 0 < amp_setpoint < data_format.max_value:
            raise InputError(f"{name}.amp_setpoint: must be within (0, {data_format.max_value}), got {amp_setpoint}")
        if not 0 <= pll_min_amp < amp_setpoint:
            raise InputError(f"{name}.pll_min_amp: must be within [0, amp_setpoint = {amp_setpoint}), got {pll_min_amp}")
        if not 0 < gain_max <= gain_format.max_value:
            raise InputError(f"{name}.gain_max: must be within (0, {gain_format.max_value}] ({gain_format}), "
                             f"got {gain_max}")
        if lpf.data_format != data_format:
            raise InputError(f"{name}.lpf.data_format: must equal {name}.data_format {data_format}")
        self.fs_hz, self.f_hz, self.lock_range_hz = fs_hz, f_hz, lock_range_hz
        self.nco, self.lpf, self.rules = nco, lpf, rules
        self.in_format, self.data_format, self.angle_format = in_format, data_format, angle_format
        self.dac_format, self.gain_format = dac_format, gain_format
        self.update_every, self.iterations, self.pll_min_amp = update_every, cordic_iterations, pll_min_amp
        self.advance_samples, self.phase_setpoint_rad = advance_samples, phase_setpoint_rad
        self.amp_setpoint, self.gain_max = amp_setpoint, gain_max
        self.tau_s, self.resonator_gain = tau_s, resonator_gain
        self.gains = design_gains(pll_bandwidth_hz, agc_bandwidth_hz, damping, tau_s, resonator_gain,
                                  update_every / fs_hz, name)
        exact = Rules("half_up", "saturate")
        mix = mixer_format(in_format, nco)
        cordic = cordic_words(name, data_format, angle_format, cordic_iterations)
        ftw_hz = fs_hz / 2.0**nco.phase_bits
        angle_lsb = 2.0**-angle_format.fl
        kp_f, ki_f, sh_f = _pi_words(self.gains["kp_f"] * angle_lsb / ftw_hz, self.gains["ki_f"] * angle_lsb / ftw_hz,
                                     coef_bits)
        scale_a = 2.0**-data_format.fl / 2.0**-gain_format.fl
        kp_a, ki_a, sh_a = _pi_words(self.gains["kp_a"] * scale_a, self.gains["ki_a"] * scale_a, coef_bits)
        q = lambda v, fmt: int(quantize([v], fmt, exact)[0])  # noqa: E731
        lock = q(lock_range_hz / fs_hz, nco.phase_format)
        advance = q(advance_samples, Format(True, 16, advance_bits))
        # 63-bit proofs: the PI sums and the carrier advance
        e_max = 2 * q(np.pi, angle_format) + 1
        for what, bound in (("pll", kp_f * e_max + (lock << sh_f) + ki_f * e_max),
                            ("agc", kp_a * (1 << data_format.wl) + (q(gain_max, gain_format) << sh_a)
                             + ki_a * (1 << data_format.wl)),
                            ("advance", (nco.ftw + lock) * abs(advance))):
            if bound >= 2**62:
                raise InputError(f"{name}: the {what} arithmetic needs more than 63 bits; lower coef_bits")
        gain_prod = product_format(gain_format, nco.nco_format)
        hz_center, hz_coef, hz_shift = hz_words(fs_hz, nco.phase_bits, nco.ftw, lock, freq_format, name)
        if hz_center + ((lock * hz_coef) >> hz_shift) + 1 > freq_format.max_int:
            raise InputError(f"{name}.freq_format: {freq_format} cannot hold f_hz + lock_range_hz = "
                             f"{f_hz + lock_range_hz} Hz")
        lpf_dp = lpf.datapath
        lpf_ovf = lambda ch: tuple(OvfField(f"lpf_{ch}.{f.counter}", f.width) for f in lpf_dp.ovf)  # noqa: E731
        self.datapath = DriveDatapath(
            in_w=in_format.wl, data_w=data_format.wl, phase_bits=nco.phase_bits, lut_bits=nco.lut_bits,
            lut_w=nco.lut_format.wl, interp_bits=nco.interp_bits, two_pi=nco.two_pi, two_pi_w=TWO_PI_FORMAT.wl,
            corr_shift=nco.corr_shift, nco_w=nco.nco_format.wl, mix_shift=mix.fl - data_format.fl, rules=rules, lpf=lpf_dp,
            iterations=cordic_iterations, angle_w=angle_format.wl, half_pi=cordic.half_pi,
            inv_k=cordic.inv_k, inv_k_w=INV_K_FORMAT.wl, amp_shift=cordic.amp_format.fl - data_format.fl, update_every=update_every,
            phase_set=q(phase_setpoint_rad, angle_format), pi_word=q(np.pi, angle_format), ftw_center=nco.ftw,
            lock_range=lock, kp_f=kp_f, ki_f=ki_f, pi_shift_f=sh_f, amp_set=q(amp_setpoint, data_format),
            kp_a=kp_a, ki_a=ki_a, pi_shift_a=sh_a, gain_w=gain_format.wl, gain_max=q(gain_max, gain_format),
            advance=advance, advance_bits=advance_bits, dac_w=dac_format.wl, dac_shift=gain_prod.fl - dac_format.fl,
            hz_center=hz_center, hz_coef=hz_coef, hz_shift=hz_shift, freq_w=freq_format.wl, min_amp=q(pll_min_amp, data_format),
            eng_a_w=0, eng_b_w=0, qsin=Rom(nco.qsin, nco.lut_format.wl), atan=cordic.atan,
            data_format=data_format, dac_format=dac_format, freq_format=freq_format,
            ovf=(OvfField("mix_i", 1), OvfField("mix_q", 1), *lpf_ovf("i"), *lpf_ovf("q"), OvfField("amp", 1),
                 OvfField("dac", 1), OvfField("f", 1)))
        # the serial variant's multiplier, from the module's own parameters (the widest of its products)
        eng_a_w, eng_b_w = DriveDatapath.engine_widths(self.datapath.verilog(name)[0])
        self.datapath = dataclasses.replace(self.datapath, eng_a_w=eng_a_w, eng_b_w=eng_b_w)
        dp = self.datapath
        prm = np.zeros(P_COUNT, dtype=np.int64)
        for idx, v in ((P_ADDR_SHIFT, nco.addr_shift), (P_LUT_BITS, dp.lut_bits), (P_INTERP_BITS, dp.interp_bits),
                       (P_TWO_PI, dp.two_pi), (P_CORR_SHIFT, dp.corr_shift), (P_PHASE_MASK, nco.phase_mask),
                       (P_MIX_SHIFT, dp.mix_shift), (P_RND, rules.rounding_code), (P_OVF, rules.overflow_code),
                       (P_DLO, data_format.min_int), (P_DHI, data_format.max_int), (P_LPF_SB, lpf_dp.shift_b),
                       (P_LPF_SA, lpf_dp.shift_a), (P_LPF_OS, lpf_dp.out_shift), (P_ITER, dp.iterations),
                       (P_HALF_PI, dp.half_pi), (P_INV_K, dp.inv_k), (P_AMP_SHIFT, dp.amp_shift),
                       (P_UPDATE, dp.update_every), (P_SET, dp.phase_set), (P_PI, dp.pi_word),
                       (P_TWO_PI_ANGLE, 2 * dp.pi_word), (P_KP_F, kp_f), (P_KI_F, ki_f), (P_SH_F, sh_f),
                       (P_RANGE, lock), (P_CENTER, dp.ftw_center), (P_AMP_SET, dp.amp_set), (P_KP_A, kp_a),
                       (P_KI_A, ki_a), (P_SH_A, sh_a), (P_GMAX, dp.gain_max), (P_ADV, dp.advance),
                       (P_ADV_BITS, advance_bits), (P_DAC_SHIFT, dp.dac_shift), (P_DAC_LO, dac_format.min_int),
                       (P_DAC_HI, dac_format.max_int), (P_HZ_CENTER, hz_center), (P_HZ_COEF, hz_coef),
                       (P_HZ_SHIFT, hz_shift),
                       (P_FLO, freq_format.min_int), (P_FHI, freq_format.max_int), (P_MIN_AMP, dp.min_amp),
                       (P_LPF_RND, lpf_dp.rules.rounding_code), (P_LPF_OVF, lpf_dp.rules.overflow_code)):
            prm[idx] = v
        prm.setflags(write=False)
        self._prm = prm
        fp = np.zeros(F_LEN)
        fp[F_FS], fp[F_CENTER], fp[F_RANGE] = fs_hz, f_hz, lock_range_hz
        fp[F_KP_F], fp[F_KI_F], fp[F_KP_A], fp[F_KI_A] = (self.gains[k] for k in ("kp_f", "ki_f", "kp_a", "ki_a"))
        fp[F_SET], fp[F_AMP_SET], fp[F_GMAX] = phase_setpoint_rad, amp_setpoint, gain_max
        fp[F_ADV], fp[F_UPDATE], fp[F_MIN_AMP] = advance_samples, update_every, pll_min_amp
        self._fprm = fp
        self.freq_format = freq_format
        self.inputs = {"x": in_format}
        # nco: the accumulator word the mixers read (turns): the demodulator's reference in a chain
        self.outputs = {"dac": dac_format, "f": freq_format, "amp": data_format, "phase": angle_format,
                        "nco": nco.phase_format}
        self.reset()

    @classmethod
    def from_config(cls, sec: Section, fs_hz: float, in_format: Format) -> "Drive":
        f_hz = sec.number("f_hz", low=0, low_open=True)
        nco = Nco(fs_hz, f_hz, sec.integer("phase_bits", low=4, high=48), sec.integer("lut_bits", low=4, high=20),
                  sec.format("lut_format"), 0.0, sec.integer("interp_bits", low=0, high=24), sec.rules(), 0.0, sec.path)
        data_format = sec.format("data_format")
        lpf_sec = sec.sub("lpf")
        lpf = Iir.from_config(lpf_sec, fs_hz, lpf_sec.wired_format("data_format", data_format,
                                                                   sec.field("data_format"), True),
                              name=f"{sec.path}.lpf", default_order=LPF_ORDER)
        return cls(fs_hz, f_hz, sec.number("lock_range_hz", low=0, low_open=True), nco, in_format, data_format,
                   sec.format("angle_format"), sec.format("dac_format"), sec.format("gain_format"),
                   sec.format("freq_format"), lpf,
                   sec.integer("cordic_iterations", low=4, high=40), sec.integer("update_every", low=1, high=4096),
                   sec.number("advance_samples", low=-8, high=8), sec.integer("advance_bits", low=0, high=8),
                   sec.number("phase_setpoint_rad", 0.0, low=-np.pi, high=np.pi),
                   sec.number("amp_setpoint", low=0, low_open=True), sec.number("gain_max", low=0, low_open=True),
                   sec.number("pll_bandwidth_hz", low=0, low_open=True),
                   sec.number("agc_bandwidth_hz", low=0, low_open=True),
                   sec.number("damping", 1.0, low=0.3, high=3.0), sec.number("tau_s", low=0, low_open=True),
                   sec.number("resonator_gain", low=0, low_open=True), sec.integer("coef_bits", 18, low=8, high=40),
                   sec.rules(), sec.number("pll_min_amp", low=0), name=sec.path)

    # ---- state (scipy's zi / zf) ----------------------------------------------------------------
    def reset(self) -> None:
        self.state = np.zeros(S_LEN, dtype=np.int64)
        self.state[S_PHASE] = 0
        self.state[S_FTW] = self.datapath.ftw_center
        self.state[S_F] = self.datapath.hz_center
        self.lpf_state = np.zeros((2, self.datapath.lpf.sections, 6), dtype=np.int64)
        # samples at which a PI's integrator or output sat at its limit (start-up, loss of lock):
        # the control law's designed clamps, not format overflows
        self.limits = dict.fromkeys(LIMITS, 0)

    def get_state(self) -> dict:
        """The loop's registers, the low-pass states and the limit events so far."""
        return {"loop": self.state.copy(), "lpf": self.lpf_state.copy(), "limits": dict(self.limits)}

    def set_state(self, state) -> None:
        if not isinstance(state, dict) or set(state) != {"loop", "lpf", "limits"}:
            raise InputError(f"{self.name}: state: expected a previous result's state {{'loop', 'lpf', 'limits'}}")
        loop, lpf = np.asarray(state["loop"]), np.asarray(state["lpf"])
        if loop.shape != self.state.shape or lpf.shape != self.lpf_state.shape:
            raise InputError(f"{self.name}: state: expected loop {self.state.shape} and lpf {self.lpf_state.shape}, "
                             f"got {loop.shape} and {lpf.shape}")
        self.state = loop.astype(np.int64).copy()
        self.lpf_state = lpf.astype(np.int64).copy()
        self.limits = {k: int(state["limits"][k]) for k in LIMITS}

    def float_state(self) -> tuple[np.ndarray, np.ndarray]:
        st = np.zeros(FS_LEN)
        st[FS_F] = self.f_hz
        return st, np.zeros((2, self.datapath.lpf.sections, 4))

    # ---- bit-exact ------------------------------------------------------------------------------
    def _counts(self):
        return np.zeros(C_LEN, dtype=np.int64), np.zeros((2, self.datapath.lpf.sections), dtype=np.int64)

    def _log(self, log: OverflowLog, counts, lcounts) -> None:
        """Format overflows into ``log``; the PIs' limit events added to ``self.limits``."""
        names = [f.counter for f in self.datapath.ovf]
        values = [counts[C_MIX_I], counts[C_MIX_Q], *lcounts[0], *lcounts[1], *counts[C_AMP:C_PLL_INTEG]]
        for name, v in zip(names, values, strict=True):
            log.add(f"{self.name}.{name}", int(v))
        for name, v in zip(LIMITS, counts[C_PLL_INTEG:], strict=True):
            self.limits[name] += int(v)

    def kernel_args(self):
        dp = self.datapath
        return (self._prm, dp.qsin.words, dp.atan.words, dp.lpf.b, dp.lpf.a, dp.lpf.c)

    def stream(self, log: OverflowLog, x: np.ndarray) -> dict[str, np.ndarray]:
        counts, lcounts = self._counts()
        prm, qsin, atans, lb, la, lc = self.kernel_args()
        dac, f, amp, err, nco = _drive_open(np.asarray(x, dtype=np.int64), self.state, self.lpf_state, prm, qsin,
                                            atans, lb, la, lc, counts, lcounts)
        self._log(log, counts, lcounts)
        return {"dac": dac, "f": f, "amp": amp, "phase": err, "nco": nco}

    def detector_errors(self, x) -> tuple[np.ndarray, np.ndarray]:
        """The phase detector alone (mixers, low-pass, CORDIC) on ADC codes ``x``, its NCO free at
        the centre word (no PLL, no drive): the angle error at each control update, bit-exact and
        float (the same NCO frequency), in rad. Their mean difference is the detector's bias."""
        codes = np.asarray(x, dtype=np.int64)
        counts, lcounts = self._counts()
        prm, qsin, atans, lb, la, lc = self.kernel_args()
        fixed = _detector_open(codes, np.zeros_like(self.lpf_state), prm, qsin, atans, lb, la, lc, counts, lcounts)
        flt = _detector_open_float(codes * 2.0**-self.in_format.fl, self.float_state()[1], self._fprm, self.lpf.sos,
                                   self.nco.ftw / 2.0**self.nco.phase_bits)
        return fixed * 2.0**-self.angle_format.fl, flt

    # ---- float reference ------------------------------------------------------------------------
    def reference(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """The float loop on real ADC values from the reset state (pure)."""
        st, lpf_st = self.float_state()
        dac, f, amp, err, nco = _drive_open_float(np.asarray(x, dtype=float), st, lpf_st, self._fprm, self.lpf.sos)
        return {"dac": dac, "f": f, "amp": amp, "phase": err, "nco": nco}

    def frequency_hz(self, ftw) -> np.ndarray:
        """Frequency words in Hz: ftw * fs / 2**phase_bits."""
        return np.asarray(ftw, dtype=float) * (self.fs_hz / 2.0**self.nco.phase_bits)

    # ---- stimulus: open-loop ADC codes ----------------------------------------------------------
    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """A pick-off at the set amplitude in lock with the reset NCO (I = A, Q = 0), whose frequency
        steps 0.5 Hz up halfway: the PLL tracks it (a start far off frequency compares two
        acquisitions, whose paths part on the first different rounding), plus noise."""
        n = max(n, 4096)
        f = np.where(np.arange(n) < n // 2, self.f_hz, self.f_hz + 0.5)
        phase = 2 * np.pi * np.concatenate([[0.0], np.cumsum(f[:-1])]) / self.fs_hz
        x = self.amp_setpoint * np.cos(phase)
        x = x + rng.normal(0, 1e-4, n)
        return {"x": quantize(x, self.in_format, Rules("half_up", "saturate"))}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        fi = self.in_format
        t = np.arange(2048) / self.fs_hz
        full = 1.05 * fi.max_value * np.cos(2 * np.pi * self.f_hz * t)   # clipped: saturating pick-off
        parts = [np.tile(corner_codes(fi), 16), quantize(full, fi, Rules("half_up", "saturate")),
                 np.full(512, fi.min_int, np.int64), self.nominal_stimulus(rng, n)["x"]]
        return {"x": np.concatenate(parts)}

    def parameters(self) -> dict:
        dp = self.datapath
        return {"fs_hz": self.fs_hz, "f_hz": self.f_hz, "lock_range_hz": self.lock_range_hz,
                "ftw_center": dp.ftw_center, "phase_bits": dp.phase_bits, "in_format": str(self.in_format),
                "data_format": str(self.data_format), "angle_format": str(self.angle_format),
                "dac_format": str(self.dac_format), "gain_format": str(self.gain_format),
                "update_every": dp.update_every, "advance": dp.advance, "advance_bits": dp.advance_bits,
                "kp_f": dp.kp_f, "ki_f": dp.ki_f, "pi_shift_f": dp.pi_shift_f, "kp_a": dp.kp_a, "ki_a": dp.ki_a,
                "pi_shift_a": dp.pi_shift_a, "gains": self.gains, "rounding": self.rules.rounding,
                "overflow": self.rules.overflow, "lpf": self.lpf.parameters()}
