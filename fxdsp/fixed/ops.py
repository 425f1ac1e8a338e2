"""Vectorised fixed-point operations on stored integers (numpy int64 in, int64 out).

Each function takes and returns *stored integers* plus their :class:`Format`. Full-precision
``mul``/``add``/``sub`` grow the format exactly (no rounding, no overflow possible) and raise
ValueError if the exact result would not fit the 63-bit budget of :mod:`fxdsp.fixed.format`.
``resize`` is the only place where precision or range is lost: it rounds by ``rules.rounding``,
fits by ``rules.overflow`` and counts overflowing samples in an :class:`OverflowLog`.
"""

from __future__ import annotations

import numpy as np

from fxdsp.fixed import kernels
from fxdsp.fixed.format import MAX_SIGNED_WL, MAX_UNSIGNED_WL, Format
from fxdsp.fixed.rules import Rules
from fxdsp.errors import InputError

_TWO62 = float(2**62)


class OverflowLog(dict):
    """Overflow counts by place (``{"iir.section0": 3, ...}``); every fitting step adds to it."""

    def add(self, where: str, count: int) -> None:
        if count:
            self[where] = self.get(where, 0) + int(count)
        else:
            self.setdefault(where, 0)

    @property
    def total(self) -> int:
        return int(sum(self.values()))


def stored(x, name: str = "x") -> np.ndarray:
    """Validate stored integers: an integer array (or int), returned as a 1-D int64 array."""
    arr = np.asarray(x)
    if arr.dtype == object:
        try:
            arr = arr.astype(np.int64)
        except (OverflowError, TypeError, ValueError):
            raise TypeError(f"{name}: stored values must be integers that fit int64") from None
    if not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"{name}: stored values must be integers, got dtype {arr.dtype}")
    if arr.dtype == np.uint64 and arr.size and arr.max() > np.iinfo(np.int64).max:
        raise InputError(f"{name}: stored value exceeds int64")
    return np.ascontiguousarray(np.atleast_1d(arr).astype(np.int64, copy=False).ravel())


def check_in_format(q: np.ndarray, fmt: Format, name: str = "x") -> np.ndarray:
    """Raise ValueError if any stored integer lies outside ``fmt`` (an input contract, not an overflow)."""
    q = stored(q, name)
    if q.size and (q.min() < fmt.min_int or q.max() > fmt.max_int):
        bad = q[(q < fmt.min_int) | (q > fmt.max_int)][0]
        raise InputError(f"{name}: stored value {int(bad)} is outside {fmt} [{fmt.min_int}, {fmt.max_int}]")
    return q


def _count(log: OverflowLog | None, where: str, n: int) -> None:
    if log is not None:
        log.add(where, n)


def quantize(x, fmt: Format, rules: Rules = Rules(), log: OverflowLog | None = None,
             where: str = "quantize") -> np.ndarray:
    """Float values -> stored integers of ``fmt``, rounded by ``rules.rounding``, fitted by
    ``rules.overflow``. Exact: x * 2**fl is exact in binary floating point and the rounding
    decision is made on the exact fraction, not by ``np.round``."""
    xs = np.atleast_1d(np.asarray(x, dtype=float)).ravel()
    if not np.all(np.isfinite(xs)):
        raise InputError(f"{where}: cannot quantize NaN or infinity into {fmt}")
    with np.errstate(over="ignore", under="ignore"):
        v = xs * (2.0 ** fmt.fl)
    # a finite x scaled past float64's range (|fl| up to 256) is still a finite value outside
    # every format: clamp it to 2**63 (beyond any format, handled by the "big" test below) ...
    v = np.clip(v, -2.0**63, 2.0**63)
    # ... and a nonzero x scaled below float64's range keeps its sign (floor(-tiny) is -1, not 0);
    # every mode's decision for |v| < 1/2 depends on the sign alone
    v = np.where((v == 0) & (xs != 0), np.copysign(5e-324, xs), v)
    r = kernels.round_float_array(v, rules.rounding_code)
    big = np.abs(r) >= _TWO62
    if big.any():
        if rules.overflow == "wrap":
            raise InputError(f"{where}: value {x if np.ndim(x) == 0 else np.asarray(x).ravel()[big][0]!r} "
                             f"is too large to wrap exactly into {fmt}")
        # still outside every format (max_int <= 2**62 - 1, min_int >= -2**62, so -2**62 itself
        # would fit s63 and go uncounted): saturates and is counted below
        r = np.clip(r, -2.0 * _TWO62, _TWO62)
    q = r.astype(np.int64)
    out, n = kernels.convert_array(q, 0, rules.rounding_code, fmt.min_int, fmt.max_int, rules.overflow_code)
    _count(log, where, n)
    return out


def round_unfitted(x, fl: int, rounding: str = "half_up", where: str = "round_unfitted") -> tuple[np.ndarray, np.ndarray]:
    """Real values rounded (by ``rounding``, as :func:`quantize` rounds) to integers of ``2**-fl``
    with no format's range applied: (stored integers of the widest signed format ``s63.fl``, a mask
    of the values beyond even that one, left saturated there). For asking what range values need
    before choosing or checking a format, without rounding them a second way."""
    wide = Format(True, MAX_SIGNED_WL, fl)
    xs = np.atleast_1d(np.asarray(x, dtype=float)).ravel()
    if not np.all(np.isfinite(xs)):     # named here: the wide format is no format of the caller's
        raise InputError(f"{where}: cannot quantize NaN or infinity")
    q = quantize(xs, wide, Rules(rounding, "saturate"), where=where)
    with np.errstate(over="ignore"):
        v = xs * 2.0 ** fl      # exact; near 2**62 floats are 1024 apart: no rounding decides the ends
    return q, (v >= wide.max_int + 1.0) | (v < float(wide.min_int))


def to_float(q, fmt: Format) -> np.ndarray:
    """Stored integers -> real values (float64; exact for wl <= 53)."""
    return stored(q).astype(float) * fmt.lsb


def resize(q, src: Format, dst: Format, rules: Rules = Rules(), log: OverflowLog | None = None,
           where: str = "resize") -> np.ndarray:
    """Re-express stored integers of ``src`` in ``dst``: round away extra fraction bits by
    ``rules.rounding``, then fit the range by ``rules.overflow`` (overflows counted under ``where``)."""
    out, n = kernels.convert_array(stored(q), src.fl - dst.fl, rules.rounding_code,
                                   dst.min_int, dst.max_int, rules.overflow_code)
    _count(log, where, n)
    return out


def shift_round(q, n: int, rounding: str) -> np.ndarray:
    """q * 2**-n rounded by ``rounding`` (n >= 0), no range change: the rounding primitive alone."""
    if n < 0:
        raise InputError(f"n: shift must be >= 0, got {n}")
    r = Rules(rounding, "wrap")
    out, _ = kernels.convert_array(stored(q), n, r.rounding_code, -(1 << 62), (1 << 62) - 1, r.overflow_code)
    return out


def _grown(signed: bool, wl: int, fl: int, what: str) -> Format:
    limit = MAX_SIGNED_WL if signed else MAX_UNSIGNED_WL
    if wl > limit:
        raise InputError(f"{what} needs {wl} bits, more than the {limit}-bit int64 budget; "
                         f"resize an operand first")
    return Format(signed, wl, fl)


def product_format(fa: Format, fb: Format) -> Format:
    """Exact product format: word lengths add, fraction lengths add."""
    return _grown(fa.signed or fb.signed, fa.wl + fb.wl, fa.fl + fb.fl, f"product {fa} x {fb}")


def sum_format(fa: Format, fb: Format) -> Format:
    """Exact sum/difference format: aligned fraction, one carry bit above the wider integer part."""
    fl = max(fa.fl, fb.fl)
    # magnitude bits above the binary point, with unsigned operands counted as signed ones of one more bit
    ib = max(f.wl - f.fl - (1 if f.signed else 0) for f in (fa, fb))
    # the result is always signed (a - b may be negative), so: magnitude + carry + sign bit,
    # also for two unsigned operands (u8 + u8 reaches 510, which needs s10)
    wl = ib + fl + 2
    return _grown(True, max(wl, 2), fl, f"sum {fa} + {fb}")


def mul(a, fa: Format, b, fb: Format) -> tuple[np.ndarray, Format]:
    """Exact product of stored integers; returns (stored, product_format)."""
    fmt = product_format(fa, fb)
    return stored(a, "a") * stored(b, "b"), fmt


def _aligned(a, fa: Format, b, fb: Format, fmt: Format):
    a = stored(a, "a") << (fmt.fl - fa.fl)
    b = stored(b, "b") << (fmt.fl - fb.fl)
    return a, b


def add(a, fa: Format, b, fb: Format) -> tuple[np.ndarray, Format]:
    """Exact sum; returns (stored, sum_format)."""
    fmt = sum_format(fa, fb)
    a, b = _aligned(a, fa, b, fb, fmt)
    return a + b, fmt


def sub(a, fa: Format, b, fb: Format) -> tuple[np.ndarray, Format]:
    """Exact difference a - b; returns (stored, sum_format)."""
    fmt = sum_format(fa, fb)
    a, b = _aligned(a, fa, b, fb, fmt)
    return a - b, fmt


# --- fxpmath interop --------------------------------------------------------------------------
_FXP_MAX_WL = 52


def to_fxp(q, fmt: Format, rules: Rules = Rules()):
    """Stored integers -> fxpmath ``Fxp`` holding exactly the same values (wl <= 52)."""
    from fxpmath import Fxp

    if fmt.wl > _FXP_MAX_WL:
        raise InputError(f"fmt: fxpmath interop needs wl <= {_FXP_MAX_WL}, got {fmt}")
    fxp_round = {"floor": "floor", "half_up": "around", "half_even": "around", "toward_zero": "fix"}
    x = Fxp(None, signed=fmt.signed, n_word=fmt.wl, n_frac=fmt.fl, overflow=rules.overflow,
            rounding=fxp_round[rules.rounding])
    x.set_val(stored(q), raw=True)
    return x


def from_fxp(x) -> tuple[np.ndarray, Format]:
    """fxpmath ``Fxp`` -> (stored integers, Format)."""
    fmt = Format(bool(x.signed), int(x.n_word), int(x.n_frac))
    raw = np.asarray(x.val)
    return stored(raw.astype(np.int64) if raw.dtype != object else raw, "fxp"), fmt
