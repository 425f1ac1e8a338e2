"""Real values <-> stored integers for the library API (``fxdsp.quantize``, ``fxdsp.to_real``).

A real value v and its stored integer q in format ``s<wl>.<fl>``/``u<wl>.<fl>`` are related by
v = q * 2**-fl. The blocks' bit-exact ``run`` takes and returns stored integers, their float
``reference`` takes and returns real values; these two functions are the crossing, and each refuses
the other kind, so that a stored code is never read as a real value or the other way round. Both
use the project's one implementation of every rounding and overflow mode
(:mod:`fxdsp.fixed.kernels`), with the names the config uses.
"""

from __future__ import annotations

import numpy as np

from fxdsp.fixed import ops
from fxdsp.fixed.format import Format
from fxdsp.fixed.ops import OverflowLog
from fxdsp.fixed.rules import Rules, check_overflow, check_rounding
from fxdsp.errors import InputError


def _shaped(out: np.ndarray, shape: tuple):
    """``out`` in the caller's shape; a scalar in, a numpy scalar out."""
    return out.reshape(shape)[()]


def quantize(values, fmt: Format | str, rounding: str = "half_up", overflow: str | None = None, *,
             log: OverflowLog | None = None, where: str = "quantize"):
    """Real values -> stored integers (int64) of ``fmt`` (a :class:`Format` or ``"s16.15"``).

    ``rounding``: ``floor``, ``half_up`` (ties toward +inf, the default), ``half_even`` or
    ``toward_zero``, decided on the exact binary fraction (never ``np.round``). ``overflow``:
    None (the default) raises ValueError naming the first value that lands outside ``fmt``;
    ``saturate`` clamps it to the format's ends and ``wrap`` keeps its low ``wl`` bits, each
    overflowing value counted in ``log`` (an :class:`OverflowLog`, under ``where``) when one is given.
    The result has the shape of ``values`` (a scalar gives a numpy int64 scalar); NaN and infinity
    are refused. Back to real values: :func:`to_real`."""
    fmt = Format.parse(fmt, "fmt")
    check_rounding(rounding, "rounding")
    if overflow is not None:
        check_overflow(overflow, "overflow")
    arr = np.asarray(values)
    if arr.dtype.kind not in "iufO":
        raise TypeError(f"{where}: real values expected (numbers), got {arr.dtype}")
    shape = arr.shape
    if overflow is not None:
        return _shaped(ops.quantize(arr, fmt, Rules(rounding, overflow), log, where), shape)
    # rounded once, unfitted: the first value outside ``fmt`` is named, else those are the stored integers
    q, beyond = ops.round_unfitted(arr, fmt.fl, rounding, f"{where} into {fmt}")
    outside = np.flatnonzero(beyond | (q < fmt.min_int) | (q > fmt.max_int))
    if outside.size:
        i = int(outside[0])
        flat = np.atleast_1d(arr.astype(float)).ravel()
        at = f" (index {i})" if flat.size > 1 else ""
        raise InputError(f"{where}: {float(flat[i])!r}{at} is outside {fmt} [{fmt.min_value!r}, {fmt.max_value!r}] "
                         f"after {rounding} rounding; pass overflow='saturate' or 'wrap' to fit it (counted in log)")
    if log is not None:
        log.add(where, 0)
    return _shaped(q, shape)


def to_real(stored, fmt: Format | str):
    """Stored integers of ``fmt`` (a :class:`Format` or ``"s16.15"``) -> real values (float64,
    exact for wl <= 53): stored x 2**-fl. Floats are refused (they are real values already, or
    codes that lost their integer type), and so is an integer outside ``fmt``: a code of another
    format. The result has the shape of ``stored``. The other way: :func:`quantize`."""
    fmt = Format.parse(fmt, "fmt")
    arr = np.asarray(stored)
    if arr.dtype.kind not in "iuO":
        raise TypeError(f"to_real: stored integers expected, got {arr.dtype} values (real values need no "
                        f"conversion; quantize(values, {str(fmt)!r}) makes stored integers)")
    q = ops.check_in_format(arr, fmt, "to_real")
    return _shaped(ops.to_float(q, fmt), arr.shape)
