"""Unit tests of fxdsp.fixed: formats, rules, guards, hand-derived rounding tables, edge cases of
quantize/resize, OverflowLog, and fxpmath interop. Expected numbers are worked out by hand (see
the comments) or by the independent oracles in tests/fixed_oracles.py, never by fxdsp itself."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fxdsp.fixed as fx
from fxdsp.fixed import Format, OverflowLog, Rules
from fixed_oracles import ALL_RULES, check_quantize, exact_quantize, int_range


def fast(n):
    return settings(max_examples=n, derandomize=True, database=None, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


# --- Format ------------------------------------------------------------------------------------
@pytest.mark.parametrize("text,want", [
    ("s16.15", (True, 16, 15)),
    ("u12.0", (False, 12, 0)),
    ("s8.-3", (True, 8, -3)),
    ("  u4 . 10 ", (False, 4, 10)),
    ("s63.0", (True, 63, 0)),
    ("u62.62", (False, 62, 62)),
    ("s1.0", (True, 1, 0)),
    ("u1.-256", (False, 1, -256)),
])
def test_parse_good(text, want):
    f = Format.parse(text)
    assert (f.signed, f.wl, f.fl) == want
    assert Format.parse(str(f)) == f
    assert Format.parse(f) is f


@pytest.mark.parametrize("text,word", [
    ("x16.15", None), ("s16", None), ("16.15", None), ("s16.", None), ("s.15", None),
    ("s16.15.1", None), ("", None), ("s-3.0", None), ("s16,15", None), ("s1e1.0", None),
    ("s0.0", "wl"), ("u0.5", "wl"), ("s64.0", "wl"), ("u63.0", "wl"), ("s99999.0", "wl"),
    ("s8.257", "fl"), ("u8.-300", "fl"),
])
def test_parse_bad_names_field(text, word):
    with pytest.raises(ValueError) as info:
        Format.parse(text, field="coeff_format")
    msg = str(info.value)
    assert msg.startswith("coeff_format"), msg
    if word:
        assert word in msg, msg


def test_parse_non_string_names_field():
    with pytest.raises(TypeError, match="^acc_format"):
        Format.parse(16, field="acc_format")


@pytest.mark.parametrize("signed,wl", [(True, 0), (False, 0), (True, -1), (False, -5),
                                       (True, 64), (False, 63), (True, 1000)])
def test_bad_word_length_raises(signed, wl):
    with pytest.raises(ValueError, match="wl"):
        Format(signed, wl, 0)


@pytest.mark.parametrize("signed,wl", [(True, 1), (True, 63), (False, 1), (False, 62)])
def test_word_length_limits_accepted(signed, wl):
    f = Format(signed, wl, 3)
    lo, hi = int_range(signed, wl)  # independent
    assert (f.min_int, f.max_int) == (lo, hi)
    assert f.lsb == 2.0**-3


@pytest.mark.parametrize("fl", [257, -257])
def test_bad_fraction_length_raises(fl):
    with pytest.raises(ValueError, match="fl"):
        Format(True, 8, fl)


@pytest.mark.parametrize("args", [(1, 8, 0), (True, 8.0, 0), (True, 8, 1.5), (True, True, 0)])
def test_format_types(args):
    with pytest.raises(TypeError):
        Format(*args)


def test_format_ranges_by_hand():
    f = Format.parse("s8.4")  # [-128, 127] * 1/16
    assert (f.min_value, f.max_value, f.int_bits) == (-8.0, 127 / 16, 3)
    g = Format.parse("u8.10")  # [0, 255] * 2**-10, int_bits = 8 - 10 = -2
    assert (g.min_value, g.max_value, g.int_bits) == (0.0, 255 / 1024, -2)


# --- Rules -------------------------------------------------------------------------------------
@pytest.mark.parametrize("bad", ["round", "HALF_UP", "", "nearest", "ceil"])
def test_unknown_rounding_names_rounding(bad):
    with pytest.raises(ValueError, match="rounding"):
        Rules(bad, "wrap")
    with pytest.raises(ValueError, match="rounding"):
        fx.shift_round([1], 1, bad)


@pytest.mark.parametrize("bad", ["clip", "Saturate", "", "wraparound"])
def test_unknown_overflow_names_overflow(bad):
    with pytest.raises(ValueError, match="overflow"):
        Rules("floor", bad)


def test_all_eight_rules_construct():
    assert {str(Rules(r, o)) for r, o in ALL_RULES} == {f"{r}/{o}" for r, o in ALL_RULES}
    assert set(fx.ROUNDING_MODES) == {"floor", "half_up", "half_even", "toward_zero"}
    assert set(fx.OVERFLOW_MODES) == {"wrap", "saturate"}


# --- hand-derived rounding and overflow tables ---------------------------------------------------
# stored values in s8.1 = real -2.5 .. 2.5 in halves; resized to s8.0
HALVES = [-5, -4, -3, -2, -1, 0, 1, 2, 3, 4, 5]
ROUNDED = {
    #             -2.5 -2.0 -1.5 -1.0 -0.5  0.0  0.5  1.0  1.5  2.0  2.5
    "floor":       [-3, -2, -2, -1, -1, 0, 0, 1, 1, 2, 2],
    "half_up":     [-2, -2, -1, -1, 0, 0, 1, 1, 2, 2, 3],
    "half_even":   [-2, -2, -2, -1, 0, 0, 0, 1, 2, 2, 2],
    "toward_zero": [-2, -2, -1, -1, 0, 0, 0, 1, 1, 2, 2],
}


@pytest.mark.parametrize("rounding", list(ROUNDED))
def test_tie_table(rounding):
    got = fx.resize(HALVES, Format.parse("s8.1"), Format.parse("s8.0"), Rules(rounding, "saturate"))
    assert got.tolist() == ROUNDED[rounding]
    assert fx.shift_round(HALVES, 1, rounding).tolist() == ROUNDED[rounding]
    xs = [h / 2 for h in HALVES]
    assert fx.quantize(xs, Format.parse("s8.0"), Rules(rounding, "wrap")).tolist() == ROUNDED[rounding]


def test_overflow_table_by_hand():
    # s8.0 values into s4.0 ([-8, 7]): 8 -> -8 wrapped, 9 -> -7, -9 -> 7, 100 -> 100 - 96 = 4,
    # -128 -> 0, 127 -> -1 (low 4 bits); six of the eight are out of range
    src, dst = Format.parse("s8.0"), Format.parse("s4.0")
    q = [7, 8, 9, -8, -9, 100, -128, 127]
    log = OverflowLog()
    assert fx.resize(q, src, dst, Rules("floor", "wrap"), log, "w").tolist() == [7, -8, -7, -8, 7, 4, 0, -1]
    assert fx.resize(q, src, dst, Rules("floor", "saturate"), log, "s").tolist() == [7, 7, 7, -8, -8, 7, -8, 7]
    assert log == {"w": 6, "s": 6} and log.total == 12
    # unsigned: u4.0 is [0, 15]; -1 wraps to 15, 16 to 0, -1 saturates to 0
    u = fx.resize([-1, 16, 15, 0, -128], src, Format.parse("u4.0"), Rules("floor", "wrap"))
    assert u.tolist() == [15, 0, 15, 0, 0]
    u = fx.resize([-1, 16, 15, 0, -128], src, Format.parse("u4.0"), Rules("floor", "saturate"))
    assert u.tolist() == [0, 15, 15, 0, 0]


def test_rounding_carry_overflows():
    # s4.1 stored 15 = 7.5; to s4.0 half_up gives 8 -> out of [-8, 7]: saturate 7, wrap -8, counted
    for overflow, want in (("saturate", 7), ("wrap", -8)):
        log = OverflowLog()
        assert fx.resize([15], Format.parse("s4.1"), Format.parse("s4.0"), Rules("half_up", overflow),
                         log).tolist() == [want]
        assert log.total == 1
    # floor of the same value is 7: no overflow
    log = OverflowLog()
    assert fx.resize([15], Format.parse("s4.1"), Format.parse("s4.0"), Rules("floor", "wrap"), log).tolist() == [7]
    assert log == {"resize": 0}


@pytest.mark.parametrize("k", [62, 63, 64, 65, 100, 127, 128, 200])
def test_huge_left_shift(k):
    # 1 * 2**k can never fit s8 (k >= 7): wrap gives 0 (low 8 bits of 2**k), saturate 127; 0 stays 0
    src, dst = Format.parse("s8.0"), Format(True, 8, k)
    for overflow, want in (("wrap", [0, 0, 0]), ("saturate", [127, -128, 0])):
        log = OverflowLog()
        assert fx.resize([1, -3, 0], src, dst, Rules("floor", overflow), log).tolist() == want
        assert log.total == 2


@pytest.mark.parametrize("n", [62, 63, 64, 65, 100, 128, 200])
def test_huge_right_shift(n):
    # |x| * 2**-n < 1/2 for these x: floor gives -1 for negatives, everything else rounds to 0
    src, dst = Format.parse("s40.0"), Format(True, 40, -n)
    q = [5, -5, 1, -1, 0, (1 << 39) - 1, -(1 << 39)]
    for rounding in ROUNDED:
        got = fx.resize(q, src, dst, Rules(rounding, "wrap")).tolist()
        want = [-1 if (rounding == "floor" and v < 0) else 0 for v in q]
        assert got == want, rounding
        assert fx.shift_round(q, n, rounding).tolist() == want


def test_shift_round_negative_n_raises():
    with pytest.raises(ValueError, match="n"):
        fx.shift_round([1], -1, "floor")


# --- quantize edge cases -------------------------------------------------------------------------
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_quantize_nan_inf_raises(bad):
    for rounding, overflow in ALL_RULES:
        with pytest.raises(ValueError, match="NaN or infinity"):
            fx.quantize([0.5, bad], Format.parse("s16.8"), Rules(rounding, overflow))
        with pytest.raises(ValueError):
            fx.quantize(bad, Format.parse("u16.8"), Rules(rounding, overflow))


def test_quantize_scalar_and_shape():
    out = fx.quantize(0.75, Format.parse("s8.2"), Rules("floor", "wrap"))
    assert out.dtype == np.int64 and out.tolist() == [3]
    out = fx.quantize(np.zeros((2, 3)), Format.parse("s8.2"))
    assert out.shape == (6,)


@pytest.mark.parametrize("rounding,overflow", ALL_RULES)
def test_quantize_float_range_extremes(rounding, overflow):
    """Scaling by 2**fl leaves float64's range (|fl| up to 256): a tiny negative still floors to
    -1 and a huge finite value is out of range (saturated/counted), not NaN/inf."""
    cases = [
        ([-(2.0**-1000), 2.0**-1000, -5e-324, 5e-324, -0.0], (True, 8, -100)),
        ([-(2.0**-1070), 2.0**-1070], (False, 8, -10)),
        ([1e300, -1e300], (True, 16, 256)),
        ([1e300, -1e300, 3.0], (False, 16, 100)),
    ]
    for xs, dst in cases:
        check_quantize(xs, dst, rounding, overflow)  # (wrap of 1e300 raises "too large to wrap")


def test_quantize_wrap_limit_documented():
    # |round(x * 2**fl)| >= 2**62 cannot be wrapped exactly in int64: ValueError (documented);
    # saturate clamps and counts instead
    f = Format.parse("s63.0")
    with pytest.raises(ValueError, match="too large to wrap"):
        fx.quantize([2.0**62], f, Rules("floor", "wrap"))
    log = OverflowLog()
    assert fx.quantize([2.0**62, -(2.0**62), -(2.0**63)], f, Rules("floor", "saturate"), log).tolist() == \
        [2**62 - 1, -(2**62), -(2**62)]
    assert log.total == 2


@pytest.mark.parametrize("rounding,overflow", ALL_RULES)
@fast(60)
@given(x=st.floats(allow_nan=False, allow_infinity=False), fl=st.integers(-256, 256),
       signed=st.booleans(), wl=st.integers(2, 48))
def test_quantize_any_finite_float(rounding, overflow, x, fl, signed, wl):
    """Every finite float (an exact binary fraction) at every fraction length, vs both oracles."""
    check_quantize([x], (signed, wl, fl), rounding, overflow)


# --- 63-bit guard --------------------------------------------------------------------------------
def test_product_guard_names_both_formats():
    a, b = Format.parse("s40.0"), Format.parse("s30.0")
    with pytest.raises(ValueError) as info:
        fx.mul([1], a, [1], b)
    assert "s40.0" in str(info.value) and "s30.0" in str(info.value)
    with pytest.raises(ValueError, match="s40.0.*s30.0"):
        fx.product_format(a, b)


@pytest.mark.parametrize("fa,fb,ok", [
    ("s32.0", "s31.0", True),    # 63 bits signed: fits
    ("s32.0", "s32.0", False),   # 64
    ("u31.0", "u31.0", True),    # 62 bits unsigned: fits
    ("u32.0", "u31.0", False),   # 63 bits unsigned: over the 62-bit budget
    ("s32.10", "u31.-4", True),  # signed x unsigned: signed 63
])
def test_product_budget(fa, fb, ok):
    fa, fb = Format.parse(fa), Format.parse(fb)
    if ok:
        q, f = fx.mul([fa.max_int, fa.min_int], fa, [fb.max_int, fb.max_int], fb)
        assert f.wl == fa.wl + fb.wl and f.fl == fa.fl + fb.fl
        assert q.tolist() == [fa.max_int * fb.max_int, fa.min_int * fb.max_int]
    else:
        with pytest.raises(ValueError, match=f"{fa}.*{fb}"):
            fx.mul([1], fa, [1], fb)


@pytest.mark.parametrize("op", [fx.add, fx.sub])
def test_sum_guard_names_both_formats(op):
    with pytest.raises(ValueError, match="s62.0.*s62.-2"):
        op([1], Format.parse("s62.0"), [1], Format.parse("s62.-2"))
    with pytest.raises(ValueError, match="s8.60.*s8.0"):  # alignment alone needs ~69 bits
        op([1], Format.parse("s8.60"), [1], Format.parse("s8.0"))


def test_unsigned_sum_by_hand():
    u8 = Format.parse("u8.0")
    q, f = fx.add([255, 0], u8, [255, 0], u8)
    assert q.tolist() == [510, 0] and f.min_int <= 510 <= f.max_int
    q, f = fx.sub([0, 255], u8, [255, 0], u8)
    assert q.tolist() == [-255, 255] and f.min_int <= -255 and 255 <= f.max_int


# --- stored / check_in_format / OverflowLog ------------------------------------------------------
def test_check_in_format():
    f = Format.parse("s4.0")
    assert fx.check_in_format([-8, 7], f).tolist() == [-8, 7]
    with pytest.raises(ValueError, match="8.*s4.0"):
        fx.check_in_format([0, 8], f, "x")
    with pytest.raises(TypeError):
        fx.stored([0.5])


def test_overflow_log():
    log = OverflowLog()
    log.add("a", 0)
    log.add("b", 2)
    log.add("b", 3)
    assert log == {"a": 0, "b": 5} and log.total == 5


# --- fxpmath interop -----------------------------------------------------------------------------
@st.composite
def fxp_case(draw):
    signed = draw(st.booleans())
    wl = draw(st.integers(2, 52))
    fl = draw(st.one_of(st.integers(-20, 70), st.sampled_from([0, wl, wl + 3, -3])))
    lo, hi = int_range(signed, wl)
    qs = draw(st.lists(st.one_of(st.integers(lo, hi), st.sampled_from([lo, hi, 0])), min_size=1, max_size=12))
    return (signed, wl, fl), qs


@fast(150)
@given(case=fxp_case(), rules=st.sampled_from(ALL_RULES))
def test_fxp_round_trip(case, rules):
    (signed, wl, fl), qs = case
    fmt = Format(signed, wl, fl)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        x = fx.to_fxp(np.asarray(qs, dtype=np.int64), fmt, Rules(*rules))
        assert (bool(x.signed), int(x.n_word), int(x.n_frac)) == (signed, wl, fl)
        assert [int(v) for v in np.atleast_1d(x.val)] == qs
        real = [float(v) for v in np.atleast_1d(x.get_val())]
        q2, f2 = fx.from_fxp(x)
    assert real == [q * 2.0**-fl for q in qs]  # exact: wl <= 52 bits
    assert fx.to_float(qs, fmt).tolist() == real
    assert f2 == fmt and q2.dtype == np.int64 and q2.tolist() == qs


def test_to_fxp_width_limit():
    with pytest.raises(ValueError, match="wl"):
        fx.to_fxp([0], Format.parse("s53.0"))


@pytest.mark.parametrize("rounding,fxp_rounding", [("floor", "floor"), ("toward_zero", "fix")])
@fast(100)
@given(signed=st.booleans(), wl=st.integers(2, 46), fl=st.integers(-20, 70), e=st.integers(0, 3),
       data=st.data())
def test_quantize_agrees_with_fxp_saturate(rounding, fxp_rounding, signed, wl, fl, e, data):
    """Fxp's own float quantisation, where its semantics match ours (floor and fix, saturate).
    (fxpmath 0.4.10 disagrees with exact arithmetic for some wider/unsigned wrap and 'around'
    cases, so those are checked against the exact oracles only.)"""
    from fxpmath import Fxp

    lo, hi = int_range(signed, wl)
    half = (1 << e) >> 1
    m = st.one_of(st.integers((lo - 3) << e, (hi + 3) << e),
                  st.sampled_from([(hi << e) + half, (lo << e) - half, (hi + 1) << e, (lo - 1) << e, 0]))
    xs = [v * 2.0 ** -(fl + e) for v in data.draw(st.lists(m, min_size=1, max_size=12))]
    ours = fx.quantize(xs, Format(signed, wl, fl), Rules(rounding, "saturate")).tolist()
    want, _ = exact_quantize(xs, (signed, wl, fl), rounding, "saturate")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        theirs = Fxp(np.asarray(xs), signed=signed, n_word=wl, n_frac=fl, rounding=fxp_rounding,
                     overflow="saturate").val
    assert ours == [int(v) for v in np.atleast_1d(theirs)] == want
