"""The numbers of the command-line options, each with its domain, checked by the parser.

A numeric option is declared with one of these types instead of ``int`` or ``float``: a value outside
its domain (nan, inf, 1e400, a count below one, a negative seed, text) is then one line naming the
option, exit 2, before the command runs, whichever command it is. A bare ``float`` would take
``nan`` and ``inf`` and hand them on; ``tests/test_cli_walk.py`` walks every option of every
command and refuses one typed that way. Checks that relate two options (LO <= HI, a prefix within
--samples) or that need the config stay with the command or the library it calls.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

from fxdsp.errors import InputError


@dataclass(frozen=True)
class Number:
    """A number of ``kind`` (int or float) within ``lo`` .. ``hi`` (None: unbounded; ``lo_open``: lo
    itself excluded). Floats are always finite."""
    kind: type
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False

    def describe(self) -> str:
        what = "an integer" if self.kind is int else "a finite number"
        if self.lo is not None and self.hi is not None:
            return f"{what} in {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"
        if self.lo is not None:
            return f"{what} {'>' if self.lo_open else '>='} {self.lo:g}"
        return what

    def contains(self, value) -> bool:
        if not isinstance(value, self.kind) or (self.kind is float and not math.isfinite(value)):
            return False
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        return self.hi is None or value <= self.hi

    def __call__(self, text: str):
        try:
            value = int(text.strip(), 10) if self.kind is int else float(text)
        except (ValueError, OverflowError):
            raise argparse.ArgumentTypeError(f"need {self.describe()}, got {text!r}") from None
        if not self.contains(value):
            raise argparse.ArgumentTypeError(f"need {self.describe()}, got {text!r}")
        return value


def count(lo: int = 1) -> Number:
    """How many of something: an integer >= lo."""
    return Number(int, lo)


SEED = Number(int, 0)                      # numpy's generators take no negative seed
NATURAL = Number(int, 0)                   # a number of workers or retries (0: none)
FINITE = Number(float)
POSITIVE = Number(float, 0.0, lo_open=True)


def _dest(option: str) -> str:
    return option.lstrip("-").replace("-", "_")


def _holds(args, condition: str) -> bool:
    """``--opt`` given (not None, not False), ``--opt=value`` set to that value, ``not --opt`` not
    given (``--xc7-timeout`` means nothing beside ``--no-xc7``)."""
    if condition.startswith("not "):
        return not _holds(args, condition[len("not "):])
    option, _, value = condition.partition("=")
    have = getattr(args, _dest(option), None)
    return have == value if value else have not in (None, False)


def _said(condition: str) -> str:
    return f"without {condition[len('not '):]}" if condition.startswith("not ") else f"with {condition}"


def check_only_with(args, parser, only_with: dict[str, tuple[str, ...]]) -> None:
    """InputError naming the option when an option of ``only_with`` is given (its value is not the
    parser's default) on a run where none of its conditions holds (``--optimise``; ``--sim=verilator``;
    ``not --no-xc7``):
    the run would accept it and do nothing with it (a margin without a search, a model cache for a
    simulator that builds no model). Read by the command line for every command (a module's
    ``ONLY_WITH``), before the command runs, as its ``PATHS`` are."""
    for option, conditions in only_with.items():
        if getattr(args, _dest(option)) == parser.get_default(_dest(option)):
            continue
        if not any(_holds(args, c) for c in conditions):
            raise InputError(f"{option}: only {' or '.join(_said(c) for c in conditions)}")
