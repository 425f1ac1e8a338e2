"""The property checks can fail: inject broken kernels and watch them get caught.

``fxdsp.fixed.ops`` calls ``kernels.convert_array`` (looked up on the module at call time) for
every resize / shift_round / quantize fit, so replacing that one attribute swaps the arithmetic
underneath the public API. (The numba scalar kernels are inlined into compiled callers, so patching
them would not reach ops.) ``make_convert_array`` is an independent pure-Python (exact int)
reimplementation with switchable bugs:

* ``None``                  - no bug: the control; it must pass every check.
* ``half_even_ties_up``     - half_even rounds ties up, like half_up.
* ``half_up_no_half``       - half_up forgets the +half-LSB constant (becomes floor).
* ``toward_zero_floors``    - toward_zero floors negatives.
* ``wrap_drops_msb``        - wrap keeps one bit too few (modulo 2**(wl-1)).
* ``saturate_uncounted``    - saturation clamps but does not count the overflow.
* ``shift_mod_64``          - shift counts taken modulo 64 (what x86 does with an int64 shift of
                              >= 64 bits; the bug the original numba kernels had).

Each mutant must fail (a) a fixed, hand-picked sweep through the plain check functions of
tests/fixed_oracles.py and (b) the hypothesis property test of tests/test_fixed_properties.py
that exercises it. Demonstration from the command line (runs the whole property file on a mutant):

    .venv/bin/python tests/test_fixed_mutation.py half_even_ties_up
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import fxdsp.fixed.kernels as kernels
from fixed_oracles import ALL_RULES, check_quantize, check_resize, check_shift_round

_CODES_R = ("floor", "half_up", "half_even", "toward_zero")  # rules.py order (Verilog parameters)
_CODES_O = ("wrap", "saturate")

MUTANTS = ("half_even_ties_up", "half_up_no_half", "toward_zero_floors", "wrap_drops_msb",
           "saturate_uncounted", "shift_mod_64")


def make_convert_array(bug: str | None = None):
    """Pure-Python stand-in for kernels.convert_array(x, shift, rounding, lo, hi, overflow)."""
    assert bug is None or bug in MUTANTS, bug

    def round_right(v: int, n: int, rounding: str) -> int:
        if n == 0:
            return v
        half = 1 << (n - 1)
        if rounding == "floor":
            return v >> n
        if rounding == "half_up":
            return v >> n if bug == "half_up_no_half" else (v + half) >> n
        if rounding == "half_even":
            q = v >> n
            rem = v - (q << n)
            if bug == "half_even_ties_up":
                return q + 1 if rem >= half else q
            return q + 1 if rem > half or (rem == half and q % 2 == 1) else q
        # toward_zero
        if v < 0 and bug != "toward_zero_floors":
            return -((-v) >> n)
        return v >> n

    def convert_array(x, shift, rounding, lo, hi, overflow):
        rounding, overflow = _CODES_R[int(rounding)], _CODES_O[int(overflow)]
        shift, lo, hi = int(shift), int(lo), int(hi)
        if bug == "shift_mod_64":
            shift = shift % 64 if shift >= 0 else -((-shift) % 64)
        out, count = [], 0
        for v in np.asarray(x).tolist():
            r = round_right(v, shift, rounding) if shift >= 0 else v << -shift  # exact, unbounded
            if lo <= r <= hi:
                out.append(r)
                continue
            if overflow == "saturate":
                out.append(hi if r > hi else lo)
                count += bug != "saturate_uncounted"
            else:
                span = hi - lo + 1
                if bug == "wrap_drops_msb":
                    span //= 2
                out.append((r - lo) % span + lo)
                count += 1
        return np.asarray(out, dtype=np.int64), count

    return convert_array


def sweep() -> None:
    """Fixed cases through the plain property checks (raises AssertionError on a mismatch)."""
    s8_2 = list(range(-128, 128))
    for rounding, overflow in ALL_RULES:
        # ties and carries: s8.2 -> s8.0 / s6.0 / u5.1 (every quarter, both signs, overflow edges)
        for dst in ((True, 8, 0), (True, 6, 0), (False, 5, 1)):
            check_resize(s8_2, (True, 8, 2), dst, rounding, overflow)
        # left shifts that overflow, and shifts of >= 64 bits both ways
        for dst in ((True, 8, 3), (False, 6, 1), (True, 8, 64), (True, 8, 70), (True, 8, -64), (True, 8, -70)):
            check_resize([-128, -5, -1, 0, 1, 5, 127], (True, 8, 0), dst, rounding, overflow)
        check_quantize([-2.5, -1.5, -0.5, 0.5, 1.5, 2.5, 40.0, -40.0], (True, 6, 0), rounding, overflow)
    for rounding in _CODES_R:
        for n in (1, 2, 3, 64, 70):
            check_shift_round([-7, -6, -5, -4, -3, -2, -1, 0, 1, 2, 3, 4, 5, 6, 7, -(1 << 62), (1 << 62) - 1],
                              n, rounding)


# which hypothesis property of test_fixed_properties.py (and parameters) must catch each mutant
PROPERTY_FOR = {
    "half_even_ties_up": ("test_resize_matches_oracles", dict(rounding="half_even", overflow="wrap")),
    "half_up_no_half": ("test_shift_round_matches_oracles", dict(rounding="half_up")),
    "toward_zero_floors": ("test_resize_matches_oracles", dict(rounding="toward_zero", overflow="saturate")),
    "wrap_drops_msb": ("test_quantize_matches_oracles", dict(rounding="floor", overflow="wrap")),
    "saturate_uncounted": ("test_resize_matches_oracles", dict(rounding="half_up", overflow="saturate")),
    "shift_mod_64": ("test_resize_matches_oracles", dict(rounding="floor", overflow="saturate")),
}


def _props():
    # imported lazily so that the command-line demo below imports it only under pytest
    import test_fixed_properties

    return test_fixed_properties


def test_control_reimplementation_passes(monkeypatch):
    """Without a bug the stand-in passes everything: detection below is due to the bug alone."""
    monkeypatch.setattr(kernels, "convert_array", make_convert_array(None))
    sweep()
    _props().test_resize_matches_oracles(rounding="half_even", overflow="wrap")
    _props().test_shift_round_matches_oracles(rounding="toward_zero")


@pytest.mark.parametrize("bug", MUTANTS)
def test_sweep_catches_mutant(bug, monkeypatch):
    monkeypatch.setattr(kernels, "convert_array", make_convert_array(bug))
    with pytest.raises(AssertionError):
        sweep()


@pytest.mark.parametrize("bug", MUTANTS)
def test_property_catches_mutant(bug, monkeypatch):
    monkeypatch.setattr(kernels, "convert_array", make_convert_array(bug))
    name, kwargs = PROPERTY_FOR[bug]
    with pytest.raises((AssertionError, ExceptionGroup)):
        getattr(_props(), name)(**kwargs)


# --- command-line demonstration ------------------------------------------------------------------
class _Inject:
    """pytest plugin: run a whole test session on a mutant kernel."""

    def __init__(self, bug: str):
        self.bug = bug

    def pytest_sessionstart(self, session):
        kernels.convert_array = make_convert_array(self.bug)
        print(f"\n*** kernels.convert_array replaced by mutant {self.bug!r} ***")


if __name__ == "__main__":
    if len(sys.argv) < 2 or sys.argv[1] not in MUTANTS:
        sys.exit(f"usage: {sys.argv[0]} {{{','.join(MUTANTS)}}} [pytest args]")
    here = Path(__file__).resolve().parent
    sys.exit(pytest.main(["-q", "-p", "no:cacheprovider", "--rootdir", str(here.parent),
                          str(here / "test_fixed_properties.py"), *sys.argv[2:]],
                         plugins=[_Inject(sys.argv[1])]))
