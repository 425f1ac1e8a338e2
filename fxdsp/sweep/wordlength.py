"""The word-length search of ``fxdsp budget --optimise`` with its candidate evaluations spread over
workers.

Why: the search evaluates a couple of thousand candidate configs (each a design build and two chain
runs, ~10 ms, many more with --drive-band); most of them come in batches that do not depend on each
other (every knob's +1 trial of a greedy step, every knob's binary-search midpoint, the rest of a
removal pass). :func:`fxdsp.budget.optimise.optimise` names each batch through its ``prefetch``
hook; here a batch becomes one map of the sweep engine and its errors are put into the evaluator's
cache, from which the (unchanged, sequential) search reads. The search is deterministic, so it asks
the same batches in the same order on every run: task numbers are stable and a resumed search finds
its evaluations in the journal. The result is the one ``fxdsp budget --optimise`` finds; the count
of evaluations can be larger (the removal stage's look-ahead is speculative).
"""

from __future__ import annotations

import copy
import math
from functools import partial


class TaskFailed(ValueError):
    """A candidate evaluation failed (not a config that does not build: that is an infinite error);
    names the task and its parameters."""


def settings(config_data: dict, target, metric: str, margin: float, cost_model: str, max_mean, frequencies) -> dict:
    return {"config": copy.deepcopy(config_data), "target": {"text": target.text, "value": target.value,
                                                             "chain": target.chain, "port": target.port},
            "metric": metric, "margin": float(margin), "cost": cost_model,
            "max_mean": None if max_mean is None else {"text": max_mean.text, "value": max_mean.value},
            "frequencies": [float(f) for f in frequencies]}


CHUNK = 4   # candidates per task: fewer, longer tasks (a fixed number, so task numbers do not depend on the workers)


def _evaluate(spec: dict, params: dict, seed: int) -> dict:
    """A few candidates: the evaluator's error of each (None: the config does not build or overflows)."""
    from fxdsp.budget.optimise import Evaluator

    ev = Evaluator(spec["base"], spec["chain"], spec["port"], spec["metric"], spec["samples"], spec["mean_weight"],
                   tuple(spec["frequencies"]))
    # an infinite error (None in JSON, as the engine makes every result) is a config that does not build
    return {"errors": [ev.error({k: int(v) for k, v in values.items()}, seed_offset=int(params["seed_offset"]))
                       for values in params["candidates"]]}


def prefetcher(sweep):
    """The ``prefetch`` hook of :func:`fxdsp.budget.optimise.optimise` that runs a batch on ``sweep``."""
    def prefetch(ev, candidates: list[dict], seed_offset: int) -> None:
        spec = {"base": ev.base, "chain": ev.chain, "port": ev.port, "metric": ev.metric, "samples": ev.samples,
                "mean_weight": ev.mean_weight, "frequencies": list(ev.frequencies)}
        new, seen = [], set()
        for values in candidates:
            key = ev.key(values, seed_offset)
            if key not in ev.cache and key not in seen:
                seen.add(key)
                new.append((key, values))
        if not new:
            return
        chunks = [new[i:i + CHUNK] for i in range(0, len(new), CHUNK)]
        records = sweep.map(partial(_evaluate, spec),
                            [{"candidates": [dict(sorted(v.items())) for _, v in chunk], "seed_offset": seed_offset}
                             for chunk in chunks], desc="word-length candidates")
        for chunk, rec in zip(chunks, records):
            if "error" in rec:
                from fxdsp.sweep.engine import failure_line

                raise TaskFailed(f"word-length {failure_line(rec)}")
            for (key, _), err in zip(chunk, rec["result"]["errors"]):
                ev.cache[key] = math.inf if err is None else float(err)
        ev.evaluations += len(new)
    return prefetch


def search(sweep, config, target, metric: str, margin: float, cost_model: str, max_mean, frequencies):
    """:func:`fxdsp.budget.optimise.optimise` with its batches on ``sweep``."""
    from fxdsp.budget import optimise as opt

    return opt.optimise(config, target, metric, margin, cost_model=cost_model, max_mean=max_mean,
                        frequencies=tuple(frequencies), prefetch=prefetcher(sweep))


def summary(result, settings: dict) -> dict:
    return {"chain": result.target.chain, "port": result.target.port, "target": settings["target"],
            "metric": result.metric, "margin": settings["margin"], "cost_model": settings["cost"],
            **result.as_dict()}


def format_summary(result) -> str:
    from fxdsp.budget.optimise import format_result

    t = result.target
    return (f"word-length search on {t.chain}.{t.port} ({result.metric}), target {t.value:.4g} {t.unit}: "
            f"{result.evaluations} evaluations\n" + format_result(result, brief=True))
