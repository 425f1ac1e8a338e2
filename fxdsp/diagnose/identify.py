"""Whether a log determines a fitted parameter. A number the data cannot pin down is reported as
unidentified (with the reason), never as a plain value, and a cause is not named on it.

Rules (each in the report's words):
* the value must be finite;
* its uncertainty (the diagnosis's: jackknife or the log's own noise, the larger) must be finite and
  smaller than the value itself;
* a time constant must leave at least TAU_LENGTHS of itself in the log: a lag or settling whose
  tau is a quarter of the log or longer shows as a near-straight drift that an aging slope, a
  random walk or a polynomial explains as well;
* a grid-searched parameter must not sit at either end of its search range (a fit at its bound
  is the edge of the search, not a measurement).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TAU_LENGTHS = 4.0  # a time constant needs the log to last this many of it (98 % of its settling seen)
TIME_CONSTANTS = ("tau_s",)


@dataclass(frozen=True)
class Verdict:
    identified: bool
    why: str = ""


def judge(name: str, value: float, sd: float | None, duration_s: float, at_bound: bool = False) -> Verdict:
    """Verdict on one parameter of a fit; ``sd`` None means no uncertainty could be computed."""
    if not np.isfinite(value):
        return Verdict(False, f"{name} is not a finite number")
    if at_bound:
        return Verdict(False, f"{name} = {value:.4g} sits at the end of its search range (a fit at its bound)")
    if name in TIME_CONSTANTS and value * TAU_LENGTHS > duration_s:
        return Verdict(False, f"{name} = {value:.4g} s is longer than 1/{TAU_LENGTHS:g} of the log "
                              f"({duration_s:.4g} s): the log cannot tell it from a slow drift")
    if sd is None or not np.isfinite(sd):
        return Verdict(False, f"{name} has no finite uncertainty")
    if sd >= abs(value):
        return Verdict(False, f"{name} = {value:.4g} has an uncertainty ({sd:.3g}) as large as its value")
    return Verdict(True)


def described(value: float, sd: float | None, verdict: Verdict) -> dict:
    """A parameter as the report writes it: value and uncertainty with its identified flag."""
    out = {"value": float(value) if np.isfinite(value) else None,
           "uncertainty": float(sd) if sd is not None and np.isfinite(sd) else None,
           "identified": verdict.identified}
    if not verdict.identified:
        out["why"] = verdict.why
    return out


def reasons(described_params: dict) -> str:
    """Why a cause's described parameters are not determined, in words (for notes and reports)."""
    return "; ".join(p["why"] for p in described_params.values() if not p["identified"])
