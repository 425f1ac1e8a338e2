"""Property tests of fxdsp.fixed against two independent oracles (tests/fixed_oracles.py):
exact Fraction/int arithmetic and apytypes. Every rounding x overflow combination, widths 2..48
signed and unsigned (plus a wide-format set up to the 62/63-bit budget), fraction lengths negative
and beyond the word length, ties on exactly half an LSB, format min/max and values just outside.

Deterministic: ``derandomize=True`` and no example database.
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fixed_oracles import (ALL_RULES, MODES_ROUNDING, check_binary, check_quantize, check_resize,
                           check_shift_round, int_range)


def fast(n):
    return settings(max_examples=n, derandomize=True, database=None, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


rules_params = pytest.mark.parametrize("rounding,overflow", ALL_RULES, ids=[f"{r}-{o}" for r, o in ALL_RULES])


# --- strategies --------------------------------------------------------------------------------
@st.composite
def formats(draw, min_wl=2, max_wl=48, fl_lo=-40, fl_hi=90):
    signed = draw(st.booleans())
    wl = draw(st.integers(min_wl, min(max_wl, 63 if signed else 62)))
    fl = draw(st.one_of(st.integers(fl_lo, fl_hi),
                        st.sampled_from([0, wl, wl - 1, wl + 1, -1, -wl, 2 * wl])))
    return (signed, wl, fl)


@st.composite
def resize_case(draw, min_wl=2, max_wl=48):
    src = draw(formats(min_wl, max_wl))
    dst_signed = draw(st.booleans())
    dst_wl = draw(st.integers(min_wl, min(max_wl, 63 if dst_signed else 62)))
    # small shifts (ties, carries) and huge ones (>= 64 bits either way)
    shift = draw(st.one_of(st.integers(-6, 6), st.integers(-140, 140), st.sampled_from([-64, -63, 63, 64])))
    dst = (dst_signed, dst_wl, max(-256, min(256, src[2] - shift)))
    shift = src[2] - dst[2]
    lo, hi = int_range(src[0], src[1])
    dlo, dhi = int_range(dst[0], dst[1])

    def in_src(v):
        return lo <= v <= hi

    special = {lo, hi, lo + 1, hi - 1, 0, 1, -1}
    # dst min/max and their neighbours (just outside), expressed in src units
    for b in (dlo, dhi):
        for off in (-1, 0, 1):
            t = b + off
            if shift >= 0:
                special.add(t << shift)
                if shift >= 1:  # half an LSB either side: ties right at the edge of the range
                    special.add((t << shift) + (1 << (shift - 1)))
                    special.add((t << shift) - (1 << (shift - 1)))
            else:
                special.add(t >> -shift)
                special.add(-((-t) >> -shift))
    special = sorted(v for v in special if in_src(v))

    @st.composite
    def tie(draw2):  # exactly half a dst LSB above a multiple of the dst LSB
        q = draw2(st.integers(lo, hi))
        if shift < 1:
            return q
        t = ((q >> shift) << shift) + (1 << (shift - 1))
        for cand in (t, t - (1 << shift), t + (1 << shift)):
            if in_src(cand):
                return cand
        return q

    value = st.one_of(st.integers(lo, hi), st.sampled_from(special), tie())
    qs = draw(st.lists(value, min_size=1, max_size=16))
    return src, dst, qs


@st.composite
def quantize_case(draw, min_wl=2, max_wl=48):
    dst = draw(formats(min_wl, max_wl))
    lo, hi = int_range(dst[0], dst[1])
    e = draw(st.integers(0, 4))  # extra fraction bits below the LSB (x stays an exact float)
    scale = 2.0 ** -(dst[2] + e)
    m_lo, m_hi = (lo - 3) << e, (hi + 3) << e
    half = (1 << (e - 1)) if e else 0
    specials = [lo << e, hi << e, (lo - 1) << e, (hi + 1) << e, 0]
    if e:
        specials += [(hi << e) + half, (lo << e) - half, (hi << e) - half, (lo << e) + half, half, -half]

    @st.composite
    def tie(draw2):
        m = draw2(st.integers(m_lo, m_hi))
        return ((m >> e) << e) + half

    m = st.one_of(st.integers(m_lo, m_hi), st.sampled_from(specials), tie())
    ms = draw(st.lists(m, min_size=1, max_size=16))
    return dst, [mm * scale for mm in ms]


@st.composite
def shift_case(draw):
    n = draw(st.one_of(st.integers(0, 8), st.integers(0, 140), st.sampled_from([62, 63, 64, 65])))
    lo, hi = -(1 << 62), (1 << 62) - 1

    def tie(q):
        if n == 0:
            return q
        t = ((q >> n) << n) + (1 << (n - 1))
        return t if lo <= t <= hi else q

    q = st.one_of(st.integers(lo, hi), st.integers(-1000, 1000), st.sampled_from([lo, hi, 0, -1, 1]),
                  st.integers(lo, hi).map(tie), st.integers(-1000, 1000).map(tie))
    return n, draw(st.lists(q, min_size=1, max_size=16))


@st.composite
def binary_case(draw, max_wl=40):
    fa = draw(formats(1, max_wl, -30, 60))
    fb = draw(formats(1, max_wl, -30, 60))
    la, ha = int_range(fa[0], fa[1])
    lb, hb = int_range(fb[0], fb[1])
    n = draw(st.integers(1, 8))
    va = st.one_of(st.integers(la, ha), st.sampled_from([la, ha, 0]))
    vb = st.one_of(st.integers(lb, hb), st.sampled_from([lb, hb, 0]))
    return fa, draw(st.lists(va, min_size=n, max_size=n)), fb, draw(st.lists(vb, min_size=n, max_size=n))


# --- properties --------------------------------------------------------------------------------
@rules_params
@fast(110)
@given(case=resize_case())
def test_resize_matches_oracles(rounding, overflow, case):
    src, dst, qs = case
    check_resize(qs, src, dst, rounding, overflow)


@rules_params
@fast(40)
@given(case=resize_case(min_wl=40, max_wl=63))
def test_resize_wide_formats_match_oracles(rounding, overflow, case):
    """The int64 edge: 62-bit unsigned and 63-bit signed formats, huge shifts both ways."""
    src, dst, qs = case
    check_resize(qs, src, dst, rounding, overflow)


@rules_params
@fast(80)
@given(case=quantize_case())
def test_quantize_matches_oracles(rounding, overflow, case):
    dst, xs = case
    check_quantize(xs, dst, rounding, overflow)


@rules_params
@fast(30)
@given(case=quantize_case(min_wl=40, max_wl=63))
def test_quantize_wide_formats_match_oracles(rounding, overflow, case):
    """Floats carry 53 bits, so most of these values are far from the LSB grid; ties and
    boundaries still come from the strategy's specials."""
    dst, xs = case
    check_quantize(xs, dst, rounding, overflow)


@pytest.mark.parametrize("rounding", MODES_ROUNDING)
@fast(120)
@given(case=shift_case())
def test_shift_round_matches_oracles(rounding, case):
    n, qs = case
    check_shift_round(qs, n, rounding)


@pytest.mark.parametrize("op", ["mul", "add", "sub"])
@fast(150)
@given(case=binary_case())
def test_binary_ops_exact(op, case):
    fa, qa, fb, qb = case
    check_binary(op, qa, fa, qb, fb)


@pytest.mark.parametrize("op", ["mul", "add", "sub"])
@fast(60)
@given(case=binary_case(max_wl=63))
def test_binary_ops_near_budget(op, case):
    """Formats up to the 63-bit budget: either exact or a ValueError naming both formats."""
    fa, qa, fb, qb = case
    check_binary(op, qa, fa, qb, fb)
