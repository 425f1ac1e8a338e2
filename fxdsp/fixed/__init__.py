"""Fixed-point core: formats, arithmetic rules, and operations on stored int64 integers."""

from fxdsp.fixed.format import Format
from fxdsp.fixed.ops import (OverflowLog, add, check_in_format, from_fxp, mul, product_format, quantize, resize,
                  shift_round, stored, sub, sum_format, to_float, to_fxp)
from fxdsp.fixed.rules import OVERFLOW_MODES, ROUNDING_MODES, Rules

__all__ = [
    "Format", "Rules", "OverflowLog", "ROUNDING_MODES", "OVERFLOW_MODES",
    "quantize", "to_float", "resize", "shift_round", "mul", "add", "sub", "product_format",
    "sum_format", "stored", "check_in_format", "to_fxp", "from_fxp",
]
