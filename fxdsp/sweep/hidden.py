"""The hidden-effect confusion matrix as a sweep: one task per simulated case.

Why: ``fxdsp diagnose-hidden`` diagnoses its cases one after the other (about half a second each);
500 logs are minutes on one core. Here every case is a task; the cases, their seeds (first seed +
k for the k-th case of each cause, as :func:`fxdsp.diagnose.hidden.confusion` draws them) and the
tally are those of :mod:`fxdsp.diagnose.hidden`, whose ``make_case``, ``diagnose_case`` and
``parameters_within`` the task calls, so the matrix is the one ``diagnose-hidden`` prints.
"""

from __future__ import annotations

from functools import partial
from fxdsp.errors import InputError


def settings(per_cause: int, first_seed: int, causes, snr_range, outside: str | None = None) -> dict:
    from fxdsp.diagnose.hidden import ALL_CAUSES, OUTSIDE, check_snr_range

    causes = tuple(causes)
    unknown = [c for c in causes if c not in ALL_CAUSES]
    if unknown:
        raise InputError(f"--causes: unknown cause {unknown[0]!r}; expected some of {', '.join(ALL_CAUSES)}")
    if not causes:
        raise InputError("--causes: no cause given")
    if per_cause < 1:
        raise InputError(f"--per-cause: need at least 1 case per cause, got {per_cause}")
    if first_seed < 0:
        raise InputError(f"--first-seed: must be >= 0, got {first_seed}")
    lo, hi = check_snr_range(snr_range)
    if outside is not None and outside not in OUTSIDE:
        raise InputError(f"--outside: unknown effect {outside!r}; expected one of {', '.join(OUTSIDE)}")
    out = {"per_cause": int(per_cause), "first_seed": int(first_seed), "causes": list(causes), "snr": [lo, hi]}
    return {**out, "outside": outside} if outside else out


def task_params(settings: dict) -> list[dict]:
    return [{"cause": c, "case_seed": settings["first_seed"] + k}
            for c in settings["causes"] for k in range(settings["per_cause"])]


def task_function(settings: dict):
    return partial(_task, tuple(settings["snr"]), settings.get("outside"))


def _task(snr_range: tuple, outside: str | None, params: dict, seed: int) -> dict:
    """Simulate and diagnose one case (``seed``, the engine's, is unused: the case seed is the
    one ``diagnose-hidden`` would use, so both give the same case)."""
    from fxdsp.diagnose.hidden import case_outcome, diagnose_case, make_case

    case = make_case(params["cause"], params["case_seed"], snr_range=snr_range, outside=outside)
    return case_outcome(case, diagnose_case(case))


def confusion_of(settings: dict, records: list[dict], seconds: float = 0.0):
    """The :class:`fxdsp.diagnose.hidden.Confusion` of the finished cases (failed ones left out)."""
    from fxdsp.diagnose.hidden import tally

    done = [(r["params"]["cause"], r["params"]["case_seed"], r["result"]) for r in records if "result" in r]
    return tally(settings["per_cause"], settings["causes"], done, seconds)


def summarise(settings: dict, records: list[dict]) -> dict:
    from fxdsp.diagnose.hidden import ALL_CAUSES
    from fxdsp.sweep.engine import failed_records

    c = confusion_of(settings, records)
    return {"per_cause": settings["per_cause"], "first_seed": settings["first_seed"], "snr": settings["snr"],
            "causes": list(c.causes), "matrix_labels": list(ALL_CAUSES),
            "matrix": [[int(v) for v in row] for row in c.matrix],
            "params_ok": c.params_ok, "gain_ok": c.gain_ok, "extra_causes": c.extra, "remaining_significant": c.flagged,
            **({"outside": settings["outside"]} if settings.get("outside") else {}),
            "misses": [{"cause": f[0], "case_seed": f[1], "scenario": f[2], "found": f[5]} for f in c.failures],
            "failed": failed_records(records)}


def format_report(settings: dict, records: list[dict], seconds: float | None = None) -> str:
    """``diagnose-hidden``'s table; without ``seconds`` its timing line is left out (for files)."""
    from fxdsp.diagnose.hidden import format_confusion

    c = confusion_of(settings, records, seconds or 0.0)
    lines = format_confusion(c, timing=seconds is not None).splitlines()
    failed = [r for r in records if "error" in r]
    if failed:
        lines.append(f"{len(failed)} cases failed (left out; see results.jsonl)")
    return "\n".join(lines)
