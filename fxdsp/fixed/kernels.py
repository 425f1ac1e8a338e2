"""The one implementation of every rounding and overflow mode, on stored int64 integers.

Scalar ``@njit`` functions are called from recursive kernels (IIR, NCO, divider loops); the array
versions below are compiled loops over the same scalars, so array code and recursive code cannot
disagree. Only these few-line scalars are inlined at Numba's IR level (``inline="always"``); the
composites built on them (a biquad step, a CORDIC, the drive loop's detector and PIs) are plain
``@njit`` calls that LLVM is free to inline: IR-inlining them too made every cold process compile
12 s longer (``fxdsp budget``: 29 -> 41 s) and the chains run slower (``fxdsp bench``, chain_paper002:
18.7 -> 12.4 MS/s). Codes: rounding floor=0, half_up=1, half_even=2, toward_zero=3; overflow wrap=0,
saturate=1 (see :mod:`fxdsp.fixed.rules`).

Range argument: every stored value is |q| < 2**62 (see format.py), so adding a rounding constant
2**(n-1) (n <= 62) to it cannot leave int64, and neither can |q| itself be negated.
"""

from __future__ import annotations

import numpy as np
from numba import njit

FLOOR, HALF_UP, HALF_EVEN, TOWARD_ZERO = 0, 1, 2, 3
WRAP, SATURATE = 0, 1


@njit(cache=True, inline="always")
def shift_right_round(x, n, rounding):
    """x * 2**-n rounded to an integer by ``rounding``; n >= 0."""
    if n <= 0:
        return x
    # int64 shifts by >= 64 are undefined (x86 uses the count mod 64). For |x| <= 2**62 every
    # n >= 63 gives the same result as n = 63 (|x| * 2**-n <= 1/2, with the tie only at n = 63
    # for x = -2**62, where every mode already agrees with larger n), so clamp.
    if n > 63:
        n = 63
    if rounding == FLOOR:
        return x >> n
    if rounding == HALF_UP:
        return (x + (np.int64(1) << (n - 1))) >> n
    if rounding == HALF_EVEN:
        # add half - 1, plus 1 more when the kept part is odd: a tie carries only from odd to even
        return (x + ((np.int64(1) << (n - 1)) - 1 + ((x >> n) & 1))) >> n
    # TOWARD_ZERO: a negative value gets 2**n - 1 added first, turning floor into ceiling
    return (x + ((x >> 63) & ((np.int64(1) << n) - 1))) >> n


@njit(cache=True, inline="always")
def round_float(v, rounding):
    """A float to the integer chosen by ``rounding`` (returned as a float): the decision is made
    on the exact fraction v - floor(v), never by np.round. Used to quantise real values (configs,
    ADC models) and by the budget's hybrid models whose accumulators are not integers."""
    f = np.floor(v)
    if rounding == FLOOR:
        return f
    frac = v - f  # exact, in [0, 1)
    if rounding == HALF_UP:
        return f + 1.0 if frac >= 0.5 else f
    if rounding == HALF_EVEN:
        return f + 1.0 if (frac > 0.5 or (frac == 0.5 and np.fmod(f, 2.0) != 0.0)) else f
    return np.trunc(v)


@njit(cache=True)
def round_float_array(v, rounding):
    out = np.empty_like(v)
    for i in range(v.shape[0]):
        out[i] = round_float(v[i], rounding)
    return out


@njit(cache=True, inline="always")
def fit(x, lo, hi, overflow):
    """Bring x into [lo, hi] (a format of hi - lo + 1 = 2**wl codes). Returns (value, overflowed)."""
    if lo <= x <= hi:
        return x, False
    if overflow == SATURATE:
        return (hi if x > hi else lo), True
    span_mask = hi - lo  # 2**wl - 1
    return ((x - lo) & span_mask) + lo, True


@njit(cache=True, inline="always")
def convert(x, shift, rounding, lo, hi, overflow):
    """Scale a stored integer by 2**-shift (round if shift > 0, exact if shift <= 0), then fit.

    For a left shift the overflow test is done before shifting, on the true value, so neither
    saturation nor the overflow count can be fooled by int64 wrap-around; ``wrap`` may shift first
    because int64 arithmetic is already modulo 2**64, a multiple of the format's 2**wl.
    """
    if shift >= 0:
        return fit(shift_right_round(x, shift, rounding), lo, hi, overflow)
    # shifts by >= 64 are undefined in int64 (x86 uses the count mod 64); k = 63 is equivalent
    # for every larger k: hi >> 63 == 0 == (-lo) >> 63, so any x != 0 overflows, and x << 63 is
    # 0 modulo 2**wl (wl <= 63), exactly what x * 2**k wraps to.
    k = min(-shift, 63)
    # true x * 2**k > hi  <=>  x > floor(hi / 2**k);   < lo  <=>  x < ceil(lo / 2**k)
    if x > (hi >> k):
        if overflow == SATURATE:
            return hi, True
        return fit(x << k, lo, hi, overflow)[0], True
    if x < -((-lo) >> k):
        if overflow == SATURATE:
            return lo, True
        return fit(x << k, lo, hi, overflow)[0], True
    return x << k, False


@njit(cache=True)
def convert_array(x, shift, rounding, lo, hi, overflow):
    """Array version of :func:`convert`; returns (values, overflow count)."""
    out = np.empty(x.shape[0], dtype=np.int64)
    count = 0
    for i in range(x.shape[0]):
        v, o = convert(x[i], shift, rounding, lo, hi, overflow)
        out[i] = v
        if o:
            count += 1
    return out, count
