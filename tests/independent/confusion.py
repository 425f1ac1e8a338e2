"""Scoring `fxdsp diagnose` on independently generated logs (chamber_logs) and the confusion matrix.

This module runs the diagnosis (it imports fxdsp); the generator it scores, chamber_logs, does not.
A log is *named exactly* when the diagnosis lists exactly its causes (in any order; none for
'none'); its parameters are *within 25 %* when every true parameter of every true cause is; the
*gain* is the held-out rms ratio of the first named cause's channel."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

import numpy as np

from fxdsp.diagnose.api import diagnose_columns
from fxdsp.diagnose.report import report_dict

try:  # run as part of the tests package, or from scripts/ with tests/ on sys.path
    from independent.chamber_logs import CAUSES, PAIRS, IndependentLog, generate
except ImportError:  # pragma: no cover
    from tests.independent.chamber_logs import CAUSES, PAIRS, IndependentLog, generate

TOLERANCE = 0.25
MIN_RATIO = 1.3


@dataclass
class Outcome:
    truth: tuple[str, ...]
    seed: int
    found: list[str]
    named_exactly: bool
    params_ok: bool
    gain_ratio: float
    seconds: float
    rows: int
    report: dict = field(repr=False)
    brief: str = ""
    misses: list[str] = field(default_factory=list)
    plain_unidentified: list[str] = field(default_factory=list)  # must stay empty

    @property
    def gain_ok(self) -> bool:
        return not self.truth or self.gain_ratio > MIN_RATIO


def plain_numbers_of_unidentified(report: dict) -> list[str]:
    """Paths in a report where a parameter flagged unidentified (or lacking a flag where the
    report gives flags) is written as a plain number."""
    bad = []
    for name, value in report["parameters"].items():
        flags = report["parameters_by_cause"][report["cause"]][name]
        if not flags["identified"]:
            bad.append(f"parameters.{name}")
    for cause, params in report["parameters_by_cause"].items():
        for name, p in params.items():
            if not isinstance(p, dict) or "identified" not in p:
                bad.append(f"parameters_by_cause.{cause}.{name}")
            elif not p["identified"]:
                bad.append(f"parameters_by_cause.{cause}.{name} (named cause with an unidentified parameter)")
    for cause, params in report["not_identified"].items():
        if cause in report["causes"]:
            bad.append(f"not_identified.{cause} is named")
        for name, p in params.items():
            if not isinstance(p, dict) or "identified" not in p:
                bad.append(f"not_identified.{cause}.{name}")
    for c in report["candidates"]:
        for name, p in c.get("parameters", {}).items():
            if not isinstance(p, dict) or "identified" not in p:
                bad.append(f"candidates.{c['cause']}.{name}")
        if c.get("fit") == "failed" and any(k in c for k in ("parameters", "rms_after", "ratio", "score")):
            bad.append(f"candidates.{c['cause']}: a failed fit carries numbers")
    return bad


def diagnose_independent(log: IndependentLog):
    return diagnose_columns(log.columns, source="independent")


class ProjectLog:
    """A log of the project's own simulator (fxdsp.diagnose.hidden, a round trip: it shares
    fxdsp.mechanisms with the diagnosis) in the independent generator's shape."""

    def __init__(self, causes: tuple[str, ...], seed: int):
        from fxdsp.diagnose.hidden import make_case

        first = causes[0] if causes else "none"
        case = make_case(first, seed, second=causes[1] if len(causes) > 1 else None)
        self.columns = case.log
        self.truth = {c: dict(case.effects[c]) for c in causes}
        self._brief = f"project seed={seed} causes={list(causes) or ['none']} scenario={case.scenario} " \
                      f"columns={list(case.columns)} snr={case.snr:.1f}"

    def brief(self) -> str:
        return self._brief


GENERATORS = {"independent": generate, "project": ProjectLog}


def score(causes: tuple[str, ...], seed: int, generator: str = "independent", **kw) -> Outcome:
    causes = tuple(c for c in causes if c != "none")
    log = GENERATORS[generator](causes, seed, **kw)
    start = time.perf_counter()
    diag = diagnose_independent(log)
    seconds = time.perf_counter() - start
    report = report_dict(diag)
    found = list(diag.causes)
    misses = []
    for cause, params in log.truth.items():
        got = diag.parameters.get(cause, {})
        for name, value in params.items():
            if not abs(got.get(name, np.nan) - value) <= TOLERANCE * abs(value):
                misses.append(f"{cause}.{name} {got.get(name)} vs {value:.4g}")
    return Outcome(truth=causes, seed=seed, found=found, named_exactly=sorted(found) == sorted(causes),
                   params_ok=not misses, gain_ratio=float(diag.gain["ratio"]), seconds=seconds,
                   rows=len(log.columns["time_s"]), report=report, brief=log.brief(), misses=misses,
                   plain_unidentified=plain_numbers_of_unidentified(json.loads(json.dumps(report))))


def labels(pairs: bool = True) -> list[tuple[str, ...]]:
    single = [() if c == "none" else (c,) for c in CAUSES]
    return single + (list(PAIRS) if pairs else [])


def run(per_label: int, first_seed: int = 5000, pairs: bool = True, generator: str = "independent",
        progress=None) -> list[Outcome]:
    out = []
    for lab in labels(pairs):
        for k in range(per_label):
            out.append(score(lab, first_seed + k, generator))
            if progress:
                progress(out[-1])
    return out


def table(outcomes: list[Outcome]) -> str:
    """Per truth label: named exactly, false alarms ('none' only), parameters, gain; the misses."""
    rows = {}
    for o in outcomes:
        rows.setdefault(o.truth, []).append(o)
    lines = ["| truth | logs | named exactly | params within 25 % (of those named) | held-out gain > 1.3 | "
             "most common other answer |", "|---|---|---|---|---|---|"]
    for lab, items in rows.items():
        wrong = [",".join(o.found) or "none" for o in items if not o.named_exactly]
        common = max(set(wrong), key=wrong.count) if wrong else ""
        name = " + ".join(lab) or "none"
        lines.append(f"| {name} | {len(items)} | {sum(o.named_exactly for o in items)} | "
                     f"{sum(o.params_ok for o in items if o.named_exactly)} | {sum(o.gain_ok for o in items)} | {common} |")
    n = len(outcomes)
    exact = sum(o.named_exactly for o in outcomes)
    secs = np.median([o.seconds for o in outcomes])
    rows6k = np.median([o.rows for o in outcomes])
    lines.append("")
    none = [o for o in outcomes if not o.truth]
    alarms = sum(bool(o.found) for o in none)
    gains = [o.gain_ratio for o in outcomes if o.truth and o.named_exactly]
    lines.append(f"{exact}/{n} named exactly ({100 * exact / n:.1f} %); false alarms on none: {alarms}/{len(none)}; "
                 f"parameters within 25 %: {sum(o.params_ok for o in outcomes if o.truth and o.named_exactly)}/"
                 f"{len(gains)} of the logs named exactly; held-out gain min {min(gains, default=float('nan')):.2f}, "
                 f"median {np.median(gains) if gains else float('nan'):.2f}; median {secs:.2f} s per log "
                 f"(median {rows6k:.0f} rows); reports with an unidentified parameter as a plain number: "
                 f"{sum(bool(o.plain_unidentified) for o in outcomes)}")
    return "\n".join(lines)
