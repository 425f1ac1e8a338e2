"""Independent oracles for the fixed-point core (tests only; nothing here imports fxdsp's helpers).

Two oracles, written without looking at the implementation's arithmetic tricks:

* ``exact_*`` - Python ints and :class:`fractions.Fraction` (unbounded, exact).
* ``apy_*``   - apytypes 0.5.1 (``APyFixed``), an independent C++ arbitrary-precision library.
  apytypes has only two's-complement (signed) formats given as (int_bits incl. sign, frac_bits),
  so an unsigned format u(wl, fl) is held in the signed format of wl + 1 bits, wrap is read back
  from the low wl bits of the bit pattern, and unsigned saturation is signed saturation to wl + 1
  bits followed by clamping negatives to 0 (the one step the oracle does itself).

Formats are passed around as plain tuples ``(signed, wl, fl)`` so the oracles do not depend on
``fxdsp.fixed.Format`` either; ``fmt_tuple`` converts.
"""

from __future__ import annotations

import math
from fractions import Fraction

import apytypes as apy
import numpy as np
import pytest

MODES_ROUNDING = ("floor", "half_up", "half_even", "toward_zero")
MODES_OVERFLOW = ("wrap", "saturate")
ALL_RULES = [(r, o) for r in MODES_ROUNDING for o in MODES_OVERFLOW]


def fmt_tuple(fmt) -> tuple[bool, int, int]:
    return (bool(fmt.signed), int(fmt.wl), int(fmt.fl))


def int_range(signed: bool, wl: int) -> tuple[int, int]:
    if signed:
        return -(2 ** (wl - 1)), 2 ** (wl - 1) - 1
    return 0, 2**wl - 1


# ============================================================================================
# Oracle 1: exact arithmetic with Fraction / int
# ============================================================================================
def exact_round(value: Fraction, rounding: str) -> int:
    """Round an exact rational to an integer."""
    value = Fraction(value)
    n, d = value.numerator, value.denominator  # d > 0
    fl = n // d  # floor, Python ints are exact
    rem = value - fl  # in [0, 1)
    if rounding == "floor":
        return fl
    if rounding == "half_up":  # nearest, ties toward +inf
        return fl + 1 if rem >= Fraction(1, 2) else fl
    if rounding == "half_even":
        if rem > Fraction(1, 2):
            return fl + 1
        if rem < Fraction(1, 2):
            return fl
        return fl if fl % 2 == 0 else fl + 1
    if rounding == "toward_zero":
        return math.trunc(value)
    raise AssertionError(rounding)


def exact_fit(r: int, signed: bool, wl: int, overflow: str) -> tuple[int, bool]:
    """Fit an integer into the stored range; returns (stored, overflowed)."""
    lo, hi = int_range(signed, wl)
    if lo <= r <= hi:
        return r, False
    if overflow == "saturate":
        return (hi if r > hi else lo), True
    if overflow == "wrap":
        m = r % (2**wl)  # Python % is non-negative for a positive modulus
        if signed and m >= 2 ** (wl - 1):
            m -= 2**wl
        return m, True
    raise AssertionError(overflow)


def exact_requantize(value: Fraction, dst, rounding: str, overflow: str) -> tuple[int, bool]:
    """Real value -> stored integer of dst=(signed, wl, fl)."""
    signed, wl, fl = dst
    return exact_fit(exact_round(Fraction(value) * Fraction(2) ** fl, rounding), signed, wl, overflow)


def exact_value(q: int, fmt) -> Fraction:
    return Fraction(q) * Fraction(2) ** (-fmt[2])


def exact_resize(qs, src, dst, rounding, overflow) -> tuple[list[int], int]:
    out, count = [], 0
    for q in qs:
        v, o = exact_requantize(exact_value(int(q), src), dst, rounding, overflow)
        out.append(v)
        count += o
    return out, count


def exact_quantize(xs, dst, rounding, overflow) -> tuple[list[int], int]:
    out, count = [], 0
    for x in xs:
        v, o = exact_requantize(Fraction(float(x)), dst, rounding, overflow)
        out.append(v)
        count += o
    return out, count


def exact_shift_round(q: int, n: int, rounding: str) -> int:
    return exact_round(Fraction(int(q), 2**n), rounding)


def corner_values(fmt) -> list[Fraction]:
    lo, hi = int_range(fmt[0], fmt[1])
    return [exact_value(lo, fmt), exact_value(hi, fmt)]


def minimal_signed_wl(values, fl: int) -> int:
    """Smallest signed word length holding every value (all multiples of 2**-fl) at fraction fl."""
    ints = [v * Fraction(2) ** fl for v in values]
    assert all(i.denominator == 1 for i in ints)
    wl = 1
    while not all(-(2 ** (wl - 1)) <= i <= 2 ** (wl - 1) - 1 for i in ints):
        wl += 1
    return wl


# ============================================================================================
# Oracle 2: apytypes
# ============================================================================================
_QM = {
    "floor": apy.QuantizationMode.TRN,
    "half_up": apy.QuantizationMode.RND,
    "half_even": apy.QuantizationMode.RND_CONV,
    "toward_zero": apy.QuantizationMode.TRN_ZERO,
}
_OM = {"wrap": apy.OverflowMode.WRAP, "saturate": apy.OverflowMode.SAT}


def apy_from_stored(q: int, fmt) -> apy.APyFixed:
    """Stored integer of fmt=(signed, wl, fl) -> APyFixed holding the same real value."""
    signed, wl, fl = fmt
    bits = wl if signed else wl + 1
    return apy.APyFixed(int(q) % (2**bits), bits=bits, frac_bits=fl)


def apy_from_float(x: float) -> apy.APyFixed:
    """A finite float, exactly (from_float is exact when the format holds every bit of x)."""
    n, d = float(x).as_integer_ratio()
    frac_bits = d.bit_length() - 1  # d is a power of two
    int_bits = max(abs(n).bit_length() - frac_bits, 0) + 2
    a = apy.APyFixed.from_float(float(x), int_bits=int_bits, frac_bits=frac_bits)
    assert _apy_fraction(a) == Fraction(float(x)), (x, a)
    return a


def _apy_stored(a: apy.APyFixed) -> int:
    """Signed stored integer (the value in units of its LSB), read from the two's-complement bit
    pattern. (Not via ``to_fraction()``: in apytypes 0.5.1 it can return a stale value after a
    narrowing cast, e.g. a 71-bit value wrapped to 2 bits reprs as 0 but to_fraction() gives the
    old value.)"""
    bits, n = int(a.to_bits()), a.bits
    return bits - (1 << n) if bits >> (n - 1) else bits


def _apy_fraction(a: apy.APyFixed) -> Fraction:
    return Fraction(_apy_stored(a)) * Fraction(2) ** (-a.frac_bits)


def apy_requantize(a: apy.APyFixed, dst, rounding: str, overflow: str) -> tuple[int, bool]:
    """apytypes casts of ``a`` into dst=(signed, wl, fl): first quantize into a format too wide to
    overflow, then apply the overflow mode with a second cast at the same fraction length.

    (Two casts, because apytypes 0.5.1's single ``cast(quantization=..., overflow=SAT)`` returns the
    wrong end of the range when the fraction length grows by a lot, e.g. an 18-bit source saturated
    into a format with 50 more fraction bits. Quantization is exact either way, so the two-step
    form has the same semantics.)"""
    signed, wl, fl = dst
    qm, om = _QM[rounding], _OM[overflow]
    # wide: enough integer bits for the rounded value (one more for a rounding carry, one for sign)
    wide_ib = max(a.int_bits + 2, 3, 3 - fl)  # and at least 3 bits in total
    unbounded = a.cast(int_bits=wide_ib, frac_bits=fl, quantization=qm, overflow=apy.OverflowMode.WRAP)
    assert _apy_fraction(unbounded.cast(int_bits=wide_ib + 8, frac_bits=fl)) == _apy_fraction(unbounded)
    if signed:
        res = unbounded.cast(int_bits=wl - fl, frac_bits=fl, overflow=om)
        out = _apy_stored(res)
    elif overflow == "wrap":
        res = unbounded.cast(int_bits=wl - fl, frac_bits=fl, overflow=om)
        out = int(res.to_bits())  # low wl bits, read as unsigned
    else:  # unsigned saturate: signed saturation to wl + 1 bits, then negatives -> 0
        res = unbounded.cast(int_bits=wl + 1 - fl, frac_bits=fl, overflow=om)
        out = max(_apy_stored(res), 0)
    overflowed = _apy_stored(unbounded) != out
    return out, overflowed


def apy_resize(qs, src, dst, rounding, overflow) -> tuple[list[int], int]:
    out, count = [], 0
    for q in qs:
        v, o = apy_requantize(apy_from_stored(int(q), src), dst, rounding, overflow)
        out.append(v)
        count += o
    return out, count


def apy_quantize(xs, dst, rounding, overflow) -> tuple[list[int], int]:
    out, count = [], 0
    for x in xs:
        v, o = apy_requantize(apy_from_float(float(x)), dst, rounding, overflow)
        out.append(v)
        count += o
    return out, count


def apy_shift_round(q: int, n: int, rounding: str) -> int:
    a = apy.APyFixed(int(q) % 2**64, bits=64, frac_bits=n)  # value q * 2**-n
    r = a.cast(int_bits=66, frac_bits=0, quantization=_QM[rounding], overflow=apy.OverflowMode.WRAP)
    return _apy_stored(r)


def apy_binary(op: str, qa: int, fa, qb: int, fb) -> Fraction:
    """Exact a op b by apytypes' own full-precision arithmetic, as a Fraction."""
    a, b = apy_from_stored(qa, fa), apy_from_stored(qb, fb)
    r = {"mul": a * b, "add": a + b, "sub": a - b}[op]
    return _apy_fraction(r)


# ============================================================================================
# Property checks: call an implementation, compare with BOTH oracles (which must also agree).
# Plain functions so that tests/test_fixed_mutation.py can run them against a broken kernel.
# Only these functions touch fxdsp, and only to call the code under test.
# ============================================================================================
def _fx():
    import fxdsp.fixed as fx

    return fx


def _show(src, dst, rules, qs, got, want):
    bad = [(q, g, w) for q, g, w in zip(qs, got, want) if g != w][:5]
    return f"{src} -> {dst} {rules}: first mismatches (input, got, expected): {bad}"


def check_resize(qs, src, dst, rounding, overflow):
    """resize() of stored ints ``qs`` from src to dst (tuples) equals both oracles, values and
    overflow count (via OverflowLog)."""
    fx = _fx()
    want1, n1 = exact_resize(qs, src, dst, rounding, overflow)
    want2, n2 = apy_resize(qs, src, dst, rounding, overflow)
    assert (want1, n1) == (want2, n2), f"oracles disagree: {src} {dst} {rounding}/{overflow} {qs}"
    log = fx.OverflowLog()
    got = fx.resize(np.asarray(qs, dtype=np.int64), fx.Format(*src), fx.Format(*dst),
                    fx.Rules(rounding, overflow), log=log, where="p")
    assert got.dtype == np.int64 and got.shape == (len(qs),)
    got = [int(v) for v in got]
    assert got == want1, _show(src, dst, f"{rounding}/{overflow}", qs, got, want1)
    assert log["p"] == n1, f"overflow count {log['p']} != {n1}: {src} -> {dst} {rounding}/{overflow} {qs}"


def check_quantize(xs, dst, rounding, overflow):
    """quantize() of floats equals both oracles. Documented limit: under ``wrap`` a value whose
    rounded stored integer has magnitude >= 2**62 raises ValueError ("too large to wrap")."""
    fx = _fx()
    rounded = [exact_round(Fraction(float(x)) * Fraction(2) ** dst[2], rounding) for x in xs]
    if overflow == "wrap" and any(abs(r) >= 2**62 for r in rounded):
        with pytest.raises(ValueError, match="too large to wrap"):
            fx.quantize(np.asarray(xs, dtype=float), fx.Format(*dst), fx.Rules(rounding, overflow))
        return
    want1, n1 = exact_quantize(xs, dst, rounding, overflow)
    want2, n2 = apy_quantize(xs, dst, rounding, overflow)
    assert (want1, n1) == (want2, n2), f"oracles disagree: {dst} {rounding}/{overflow} {xs}"
    log = fx.OverflowLog()
    got = fx.quantize(np.asarray(xs, dtype=float), fx.Format(*dst), fx.Rules(rounding, overflow),
                      log=log, where="p")
    got = [int(v) for v in got]
    assert got == want1, _show("float", dst, f"{rounding}/{overflow}", xs, got, want1)
    assert log["p"] == n1, f"overflow count {log['p']} != {n1}: {dst} {rounding}/{overflow} {xs}"


def check_shift_round(qs, n, rounding):
    fx = _fx()
    want1 = [exact_shift_round(q, n, rounding) for q in qs]
    want2 = [apy_shift_round(q, n, rounding) for q in qs]
    assert want1 == want2, f"oracles disagree: n={n} {rounding} {qs}"
    got = [int(v) for v in fx.shift_round(np.asarray(qs, dtype=np.int64), n, rounding)]
    assert got == want1, _show("q", f">>{n}", rounding, qs, got, want1)


def check_binary(op: str, qa, fa, qb, fb):
    """mul/add/sub: exact (both oracles), result inside its own format, format as documented,
    or ValueError naming both formats when the exact result cannot fit the 63-bit budget."""
    fx = _fx()
    Fa, Fb = fx.Format(*fa), fx.Format(*fb)
    signed = fa[0] or fb[0]
    if op == "mul":
        # independent: the exact product of two's-complement/unsigned words needs wa + wb bits
        corners = [x * y for x in corner_values(fa) for y in corner_values(fb)]
        want_fl = fa[2] + fb[2]
        need = fa[1] + fb[1]
        limit = 63 if signed else 62
        must_raise, may_raise = need > limit, need > limit
    else:
        corners = [x + y for x in corner_values(fa) for y in corner_values(fb)]
        corners += [x - y for x in corner_values(fa) for y in corner_values(fb)]
        want_fl = max(fa[2], fb[2])
        need = minimal_signed_wl(corners, want_fl)
        must_raise, may_raise = need > 63, need + 1 > 63
    func = {"mul": fx.mul, "add": fx.add, "sub": fx.sub}[op]
    a = np.asarray(qa, dtype=np.int64)
    b = np.asarray(qb, dtype=np.int64)
    if must_raise:
        with pytest.raises(ValueError) as info:
            func(a, Fa, b, Fb)
        assert str(Fa) in str(info.value) and str(Fb) in str(info.value), str(info.value)
        return
    try:
        got, fmt = func(a, Fa, b, Fb)
    except ValueError as exc:
        assert may_raise, f"{op} {fa} {fb} raised although {need} bits suffice: {exc}"
        assert str(Fa) in str(exc) and str(Fb) in str(exc), str(exc)
        return
    fmt_t = fmt_tuple(fmt)
    assert fmt_t[2] == want_fl, f"{op} {Fa} {Fb} -> {fmt}: fraction length should be {want_fl}"
    if op == "mul":
        assert fmt_t == (signed, fa[1] + fb[1], want_fl), f"product {Fa} x {Fb} -> {fmt}"
    else:
        assert fmt_t[0] is True, f"sum format {fmt} must be signed (differences can be negative)"
        assert need <= fmt_t[1] <= need + 1, f"{op} {Fa} {Fb} -> {fmt}: needs {need} bits"
    # every possible result (the corners) is representable: the format really is exact
    lo, hi = int_range(fmt_t[0], fmt_t[1])
    for c in corners:
        s = c * Fraction(2) ** fmt_t[2]
        assert s.denominator == 1 and lo <= s <= hi, f"{op} {Fa} {Fb} -> {fmt} cannot hold {c}"
    got = [int(v) for v in got]
    for x, y, r in zip(qa, qb, got):
        va, vb = exact_value(int(x), fa), exact_value(int(y), fb)
        want = {"mul": va * vb, "add": va + vb, "sub": va - vb}[op]
        assert want == apy_binary(op, int(x), fa, int(y), fb)
        assert exact_value(r, fmt_t) == want, f"{op} {Fa}:{x} {Fb}:{y} -> {fmt}:{r}, want {want}"
        assert lo <= r <= hi, f"{op} result {r} outside {fmt}"
