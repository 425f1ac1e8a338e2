"""Arithmetic rules (MATLAB's fimath): how to round, what to do on overflow.

Rounding names (the same words appear in configs, model docstrings and RTL headers):

* ``floor``       - drop the low bits (two's-complement truncation, toward -inf); mean error -q/2.
* ``half_up``     - round to nearest, ties toward +inf (add half an LSB, then floor).
* ``half_even``   - round to nearest, ties to the even neighbour (convergent rounding).
* ``toward_zero`` - truncate the magnitude (sign-magnitude truncation).

Overflow names: ``wrap`` (keep the low wl bits, two's complement) and ``saturate`` (clamp to the
format's min/max). Either way every overflowing sample is counted.
"""

from __future__ import annotations

from dataclasses import dataclass
from fxdsp.errors import InputError

ROUNDING_MODES: tuple[str, ...] = ("floor", "half_up", "half_even", "toward_zero")
OVERFLOW_MODES: tuple[str, ...] = ("wrap", "saturate")

# integer codes used inside numba kernels and as Verilog parameter values
ROUNDING_CODE = {name: i for i, name in enumerate(ROUNDING_MODES)}
OVERFLOW_CODE = {name: i for i, name in enumerate(OVERFLOW_MODES)}


def check_rounding(name: str, field: str = "rounding") -> str:
    if name not in ROUNDING_CODE:
        raise InputError(f"{field}: unknown rounding {name!r}; expected one of {', '.join(ROUNDING_MODES)}")
    return name


def check_overflow(name: str, field: str = "overflow") -> str:
    if name not in OVERFLOW_CODE:
        raise InputError(f"{field}: unknown overflow {name!r}; expected one of {', '.join(OVERFLOW_MODES)}")
    return name


@dataclass(frozen=True, slots=True)
class Rules:
    """How a result is brought into a format (MATLAB's fimath): ``rounding`` (floor, half_up,
    half_even, toward_zero) drops fraction bits, ``overflow`` (wrap, saturate) fits the range. The
    names are the config's; an unknown one is a ValueError listing the valid ones."""

    rounding: str = "half_up"
    overflow: str = "saturate"

    def __post_init__(self):
        check_rounding(self.rounding)
        check_overflow(self.overflow)

    @property
    def rounding_code(self) -> int:
        return ROUNDING_CODE[self.rounding]

    @property
    def overflow_code(self) -> int:
        return OVERFLOW_CODE[self.overflow]

    def __str__(self) -> str:
        return f"{self.rounding}/{self.overflow}"
