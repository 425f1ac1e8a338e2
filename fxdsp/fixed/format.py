"""Fixed-point format (MATLAB's numerictype): signedness, word length, fraction length.

A value v with stored integer q in format (signed, wl, fl) is v = q * 2**-fl with
q in [-2**(wl-1), 2**(wl-1) - 1] (signed) or [0, 2**wl - 1] (unsigned).

Arithmetic rules (rounding, overflow) live apart in :mod:`fxdsp.fixed.rules`, as MATLAB keeps
fimath apart from numerictype.

Every stored integer must fit int64 with room for one rounding constant, so a format holds at most
63 bits signed or 62 bits unsigned: |q| < 2**62. Any operation whose exact result would need a
wider format raises ValueError naming the formats (see :mod:`fxdsp.fixed.ops`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fxdsp.errors import InputError, InputTypeError

MAX_SIGNED_WL = 63
MAX_UNSIGNED_WL = 62
# fraction lengths beyond this are surely a typo (and 2.0**fl must stay exact in float64)
MAX_ABS_FL = 256

_FORMAT_RE = re.compile(r"^\s*([su])\s*(\d+)\s*\.\s*(-?\d+)\s*$")


@dataclass(frozen=True, slots=True)
class Format:
    """Fixed-point format. ``str(fmt)`` is the short form used in configs: ``s16.15``, ``u12.0``."""

    signed: bool
    wl: int
    fl: int

    def __post_init__(self):
        if not isinstance(self.signed, bool):
            raise TypeError(f"signed: expected bool, got {type(self.signed).__name__}")
        for name in ("wl", "fl"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int):
                raise TypeError(f"{name}: expected int, got {type(value).__name__}")
        limit = MAX_SIGNED_WL if self.signed else MAX_UNSIGNED_WL
        if not 1 <= self.wl <= limit:
            kind = "signed" if self.signed else "unsigned"
            raise InputError(f"wl: {kind} word length must be 1..{limit}, got {self.wl}")
        if abs(self.fl) > MAX_ABS_FL:
            raise InputError(f"fl: fraction length must be within +-{MAX_ABS_FL}, got {self.fl}")

    # --- construction -------------------------------------------------------------------------
    @classmethod
    def parse(cls, text: str, field: str = "format") -> "Format":
        """``'s16.15'`` -> Format(True, 16, 15). ValueError naming ``field`` on anything else."""
        if isinstance(text, Format):
            return text
        if not isinstance(text, str):
            raise InputTypeError(f"{field}: expected a format string like 's16.15', got {type(text).__name__}")
        m = _FORMAT_RE.match(text)
        if not m:
            raise InputError(f"{field}: {text!r} is not a format like 's16.15' or 'u12.0'")
        try:
            return cls(m.group(1) == "s", int(m.group(2)), int(m.group(3)))
        except (ValueError, TypeError) as exc:
            raise InputError(f"{field}: {text!r}: {exc}") from None

    # --- ranges -------------------------------------------------------------------------------
    @property
    def min_int(self) -> int:
        return -(1 << (self.wl - 1)) if self.signed else 0

    @property
    def max_int(self) -> int:
        return (1 << (self.wl - 1)) - 1 if self.signed else (1 << self.wl) - 1

    @property
    def int_bits(self) -> int:
        """Integer bits, sign excluded (may be negative when fl > wl)."""
        return self.wl - self.fl - (1 if self.signed else 0)

    @property
    def lsb(self) -> float:
        return 2.0 ** -self.fl

    @property
    def min_value(self) -> float:
        return self.min_int * self.lsb

    @property
    def max_value(self) -> float:
        return self.max_int * self.lsb

    def __str__(self) -> str:
        return f"{'s' if self.signed else 'u'}{self.wl}.{self.fl}"

    def with_fl(self, fl: int) -> "Format":
        return Format(self.signed, self.wl, fl)
