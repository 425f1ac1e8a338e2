"""Physical units of every port, propagated through the chains' netlists from what is stated once.

A port's *quantity* is what its real value (stored integer x LSB) measures: ``C``, ``Hz``, ``Hz/g``,
``g``, ``1`` (a ratio), ``FS`` (a fraction of the rate full scale ``[system].rate_full_scale_dps``),
``deg/h``, ``rad``, ``turn`` (an NCO's accumulator word), or ``sensor`` (the unit of a measured log's ``output``, which the log does not
state: ../shared/spec/measured-data.md). Engineers read errors in a display unit: ``g`` in mg, a ratio in ppm, ``FS`` in
deg/h, ``rad`` in mrad, ``turn`` in urad (:func:`display`).

Where a quantity comes from, each stated in one place:

* a kind's physical ports (:data:`INTRINSIC`): an RTD or frequency thermometer reads out ``C``, a
  frequency word is ``Hz``, a CORDIC phase ``rad``;
* a piecewise table's ``unit`` key: the quantity of its coefficients, hence of its output;
* a chain's ``input_units`` table, for inputs whose quantity nothing else fixes (the sense ADC);
* each kind's rule (:data:`RULES`): a filter, lag or demodulator passes its input's quantity on, a
  subtraction needs one quantity on both operands, a divide's quotient is x / sf (Hz over Hz/g is g).

Propagation runs each chain in its order; a subtraction whose operands carry different quantities is
an error naming the chain and both wires, like a format mismatch.
"""

from __future__ import annotations

import math
from typing import Callable

from fxdsp.errors import InputError

QUANTITIES = ("C", "Hz", "Hz/g", "g", "1", "FS", "deg/h", "rad", "turn", "sensor")

# kind -> port -> quantity, whatever the wiring (physical by construction)
INTRINSIC: dict[str, dict[str, str]] = {
    "rtd": {"temp": "C"}, "freq2temp": {"f": "Hz", "temp": "C"}, "lag": {"temp": "C", "te": "C"},
    "piecewise": {"temp": "C"}, "demod": {"phase": "rad", "ref": "turn"},
    "drive": {"x": "1", "dac": "1", "amp": "1", "f": "Hz", "phase": "rad", "nco": "turn"},
}

Units = dict[str, "str | None"]


def _same(*ports: str) -> Callable[[Units], Units]:
    """Every named port carries one quantity (the first known one)."""
    def rule(u: Units) -> Units:
        q = next((u[p] for p in ports if u.get(p)), None)
        return {p: q for p in ports}
    return rule


def _quotient(u: Units) -> Units:
    """y = x / sf: a ratio divisor keeps x's quantity; ``A`` over ``A/B`` is ``B``; otherwise unknown."""
    x, sf = u.get("x"), u.get("sf")
    y = None
    if x and sf == "1":
        y = x
    elif x and sf and sf.startswith(x + "/"):
        y = sf[len(x) + 1:]
    return {"y": y}


# kind -> the quantities of its ports from those known so far (inputs from the wiring)
RULES: dict[str, Callable[[Units], Units]] = {
    "iir": _same("x", "y"), "demod": _same("x", "i", "q", "amp"), "bias_subtract": _same("x", "bias", "y"),
    "sf_divide": _quotient,
}


def quantity(value, field: str) -> str:
    """A stated quantity, checked: InputError naming ``field`` for anything else."""
    if value not in QUANTITIES:
        raise InputError(f"{field}: {value!r} is not a unit fxdsp knows; one of {', '.join(QUANTITIES)}")
    return value


def display(q: str | None, rate_full_scale_dps: float) -> tuple[str, float]:
    """(display unit, real-value-to-display factor) of a quantity; ("", 1.0) when none is known."""
    return {None: ("", 1.0), "g": ("mg", 1e3), "1": ("ppm", 1e6), "FS": ("deg/h", rate_full_scale_dps * 3600.0),
            "rad": ("mrad", 1e3), "turn": ("urad", 2e6 * math.pi), "sensor": ("sensor unit", 1.0)}.get(q, (q, 1.0))


def instance_units(kind: str, known: Units, declared: Units, where: Callable[[str], str] = str) -> Units:
    """The quantity of every port of one instance of ``kind``, from its wired inputs (``known``) and
    its table's own statement (``declared``: a piecewise output). A wire bringing another quantity
    than the port's, or operands of a rule in different quantities, is an InputError; ``where(port)``
    names the wire or field a port's quantity came from."""
    u = {**known, **INTRINSIC.get(kind, {}), **declared}
    for p, got in known.items():
        if got and u[p] != got:
            raise InputError(f"{where(p)}: brings a value in {got}, but {p} is in {u[p]}")
    rule = RULES.get(kind)
    if rule is not None:
        ruled = rule(u)
        for p, q in ruled.items():
            if u.get(p) and q and u[p] != q:
                other = next((o for o in ruled if o != p and u.get(o) == q), None)
                if other is None:
                    raise InputError(f"{where(p)}: {p} is in {u[p]}, but the {kind}'s inputs make it {q}")
                raise InputError(f"{where(p)}: {p} is in {u[p]}, but {where(other)}: {other} is in {q}; "
                                 f"a {kind} needs one unit on both")
            u[p] = u.get(p) or q
    return u
