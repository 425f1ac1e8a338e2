"""Monte-Carlo error budget of a chain's output over seeds x chamber temperatures x drive
frequencies, with percentiles and their confidence intervals.

Why: ``fxdsp budget`` measures one stimulus per question; a user's question is "what error will 99 %
of my parts see?", which needs the distribution over many noise realisations and operating points.

Any chain with a ``sensor`` (default ``chain_paper002``; ``--chain``), any of its outputs (default:
its one output that is not a temperature; ``--port``). One task is one seed (a Monte-Carlo sample):
for every drive frequency f (only for a chain with a demodulator: the design rebuilt with its f_hz =
f, as the budget's drive-frequency sweep does: the band the -40..85 C silicon resonator covers, and
f0) and every held chamber temperature T, a record of ``settle + samples`` samples at T under the
sensor's physical input drawn uniformly in +-``Sensor.LEVEL_SPAN`` (a rate, an acceleration) with the
sensor's own noise (:meth:`fxdsp.sensors.Sensor.held_inputs`); the error is bit-exact minus float on
the same input words (the design's own error, as in ``fxdsp budget``), in the port's physical unit
(:mod:`fxdsp.units`), measured after the filters have settled (floor.settling_samples). The level
and noise of (seed, T) are drawn from the task's seed and T's index only, so every drive frequency
sees the same realisation (the frequencies differ by the design alone). The grid of frequencies is
crossed with the temperatures: a superset of the physical pairing f(T), so the figures bound it.

Percentiles are order statistics (the ceil(p n)-th smallest value) with a distribution-free
confidence interval from the binomial law of the count below the true quantile (Conover); an upper
end beyond the largest sample is None (too few seeds for that confidence). Pooled figures treat the
grid points as draws from the grid's mixture.
"""

from __future__ import annotations

import copy
import json
import math
from functools import lru_cache, partial

import numpy as np
from scipy.stats import binom

from fxdsp.errors import InputError
from fxdsp.sweep.engine import failed_records
from fxdsp.plots import save_figure

CHAIN = "chain_paper002"
PERCENTILES = (0.5, 0.9, 0.99)
LEVEL = 0.95


# ----------------------------------------------------------------------------------------------
# Settings and the grid
# ----------------------------------------------------------------------------------------------
def _chain(config_data: dict, chain: str):
    from fxdsp.chains import build
    from fxdsp.config import Config

    design = build(Config(copy.deepcopy(config_data), source="<sweep montecarlo>"))
    c = design.chain(chain, "fxdsp sweep montecarlo")
    if c.sensor is None:
        raise InputError(f"--chain: {chain} has no sensor to stimulate it ([{c.netlist.name}].sensor)")
    return design, c


def _demod(chain) -> str | None:
    """The config table of the chain's demodulator (whose f_hz a drive frequency sets), None without."""
    found = [m for m, k in chain.kinds.items() if k == "demod"]
    if len(found) > 1:
        raise InputError(f"--freqs: {chain.name} has {len(found)} demodulators ({', '.join(found)}); "
                         f"a drive frequency would be ambiguous: use --freqs 1")
    return found[0] if found else None


def grid(config_data: dict, temps: int = 16, freqs: int | None = None, temp_range=None,
         chain: str = CHAIN) -> tuple[list, list]:
    """(temperatures C, drive frequencies Hz): ``temps`` evenly over ``temp_range`` (ends included;
    default the chain's sensor's chamber range); ``freqs`` = 1: the demodulator's f_hz alone (None
    for a chain without one), else ``freqs`` evenly across the drive band and f0 (default 2 with a
    demodulator, 1 without)."""
    from fxdsp.budget.floor import drive_frequencies

    if temps < 1:
        raise InputError(f"--temps: need at least 1 temperature, got {temps}")
    if freqs is not None and freqs < 1:
        raise InputError(f"--freqs: need at least 1 drive frequency, got {freqs}")
    design, c = _chain(config_data, chain)
    lo, hi = (float(x) for x in (temp_range if temp_range is not None else c.sensor.CHAMBER_C))
    if not lo <= hi:
        raise InputError(f"--temp-range: LO must not exceed HI, got {lo} {hi}")
    t = [lo] if temps == 1 else [float(x) for x in np.linspace(lo, hi, temps)]
    demod = _demod(c)
    if demod is None:
        if freqs not in (None, 1):
            raise InputError(f"--freqs: {chain} has no demodulator, so no drive frequency to sweep; use 1")
        return t, [None]
    f0 = float(c.members[demod].nco.f_hz)
    freqs = 2 if freqs is None else freqs
    f = [f0] if freqs == 1 else [float(x) for x in drive_frequencies(f0, freqs)]
    return t, f


def settings(config_data: dict, seeds: int, temps: list, freqs: list, samples: int, chain: str = CHAIN,
             port: str | None = None) -> dict:
    if seeds < 1:
        raise InputError(f"--seeds: need at least 1 seed, got {seeds}")
    if samples < 16:
        raise InputError(f"--samples: need at least 16 measured samples per point, got {samples}")
    design, c = _chain(config_data, chain)
    quantities = {p.name: p for p in design.instances[chain].outputs}
    if port is None:
        rest = [p for p, q in quantities.items() if q.quantity != "C"]
        if len(rest) != 1:
            raise InputError(f"--port: {chain} has outputs {', '.join(quantities)}: name the one to budget")
        port = rest[0]
    elif port not in quantities:
        raise InputError(f"--port: {chain} has no output {port!r} (outputs: {', '.join(quantities)})")
    unit, scale = quantities[port].unit, quantities[port].scale
    demod = _demod(c)
    if demod is None and list(freqs) != [None]:
        raise InputError(f"--freqs: {chain} has no demodulator, so no drive frequency to sweep")
    return {"config": copy.deepcopy(config_data), "chain": chain, "port": port, "unit": unit, "scale": scale,
            "demod": demod, "seeds": int(seeds), "temps_c": list(temps), "freqs_hz": list(freqs),
            "samples": int(samples), "level_span": float(c.sensor.LEVEL_SPAN), "level_unit": c.sensor.LEVEL_UNIT}


# ----------------------------------------------------------------------------------------------
# One task (runs on a worker)
# ----------------------------------------------------------------------------------------------
@lru_cache(maxsize=32)
def _design(config_json: str, chain: str, demod: str | None, f_hz: float | None):
    """The chain at one drive frequency and its settling length, kept per worker process."""
    from fxdsp.budget.floor import settling_samples
    from fxdsp.chains import build
    from fxdsp.config import Config

    data = json.loads(config_json)
    if demod is not None:
        node = data
        for key in demod.split("."):
            node = node[key]
        node["f_hz"] = float(f_hz)
    c = build(Config(data, source="<sweep montecarlo>")).chains[chain]
    return c, settling_samples(c)


def point_errors(settings: dict, seed: int) -> dict:
    """One seed: rms and mean error (the port's unit) at every (frequency, temperature), and the overflows."""
    config_json = json.dumps(settings["config"], sort_keys=True)
    temps, freqs, m = settings["temps_c"], settings["freqs_hz"], settings["samples"]
    span, port, scale = settings["level_span"], settings["port"], settings["scale"]
    levels = [float(np.random.default_rng([seed, k]).uniform(-span, span)) for k in range(len(temps))]
    rms = [[0.0] * len(temps) for _ in freqs]
    mean = [[0.0] * len(temps) for _ in freqs]
    overflows = 0
    for j, f in enumerate(freqs):
        chain, settle = _design(config_json, settings["chain"], settings["demod"], f)
        n = settle + m
        for k, t in enumerate(temps):
            # the operating point of (seed, T), the same at every frequency: level first, then the noise
            rng = np.random.default_rng([seed, k])
            level = float(rng.uniform(-span, span))
            stim = chain.sensor.held_inputs(np.full(n, float(t)), np.full(n, level), rng)
            res = chain.run(**stim)
            e = (chain.real_outputs(res)[port] - chain.run_float(**stim)[port])[settle:] * scale
            rms[j][k] = float(np.sqrt(np.mean(e ** 2)))
            mean[j][k] = float(e.mean())
            overflows += int(res.overflows.total)
    return {"level": levels, "rms": rms, "mean": mean, "overflows": overflows}


def task_function(settings: dict):
    """The picklable function a worker runs for task params ``{"seed_index": i}``."""
    return partial(_task, settings)


def _task(settings: dict, params: dict, seed: int) -> dict:
    return point_errors(settings, seed)


def task_params(settings: dict) -> list[dict]:
    return [{"seed_index": i} for i in range(settings["seeds"])]


# ----------------------------------------------------------------------------------------------
# Statistics
# ----------------------------------------------------------------------------------------------
def quantile_ci(values, p: float, level: float = LEVEL) -> dict:
    """p-quantile of ``values`` as the ceil(p n)-th order statistic, and a distribution-free
    ``level`` confidence interval [x_(l), x_(u)] (1-based ranks) with B ~ Binomial(n, p) the count
    below the true quantile: l the largest rank with P(B <= l - 1) <= (1 - level) / 2, u the
    smallest with P(B <= u - 1) >= (1 + level) / 2. An end outside 1..n is None."""
    x = np.sort(np.asarray(values, dtype=float))
    n = x.size
    if n == 0:
        raise InputError("values: empty")
    if not 0 < p < 1:
        raise InputError(f"p: must be within (0, 1), got {p}")
    if not 0 < level < 1:
        raise InputError(f"level: must be within (0, 1), got {level}")
    k = max(1, math.ceil(p * n - 1e-9))
    a = (1 - level) / 2
    cdf = binom.cdf(np.arange(n + 1), n, p)          # cdf[r] = P(B <= r)
    below = np.nonzero(cdf <= a)[0]
    lo_rank = int(below[-1]) + 1 if below.size else 0       # l - 1 = the largest r with P(B <= r) <= a
    above = np.nonzero(cdf >= 1 - a)[0]
    hi_rank = int(above[0]) + 1 if above.size else n + 1
    return {"p": p, "n": int(n), "value": float(x[k - 1]),
            "ci": [float(x[lo_rank - 1]) if lo_rank >= 1 else None,
                   float(x[hi_rank - 1]) if hi_rank <= n else None],
            "ci_ranks": [lo_rank if lo_rank >= 1 else None, hi_rank if hi_rank <= n else None],
            "level": level}


def _figures(rms: np.ndarray, mean: np.ndarray) -> dict:
    return {"n": int(rms.size),
            "rms": {f"p{round(p * 100, 1):g}": quantile_ci(rms.ravel(), p) for p in PERCENTILES},
            "rms_max": float(rms.max()), "rms_mean": float(rms.mean()),
            "abs_mean_p99": quantile_ci(np.abs(mean).ravel(), 0.99)}


def summarise(settings: dict, records: list[dict]) -> dict:
    """Percentile figures per (frequency, temperature) cell, per temperature, per frequency, pooled;
    the failed tasks (by index and params) are left out and listed."""
    good = [r for r in records if "result" in r]
    failed = failed_records(records)
    temps, freqs = settings["temps_c"], settings["freqs_hz"]
    out = {"chain": settings["chain"], "port": settings["port"], "unit": settings["unit"],
           "measure": "bit-exact minus float on the same input words, after settling", "seeds": settings["seeds"], "seeds_ok": len(good),
           "temps_c": temps, "freqs_hz": freqs, "samples_per_point": settings["samples"],
           "level_range": [-settings["level_span"], settings["level_span"]], "level_unit": settings["level_unit"],
           "failed": failed}
    if not good:
        return out
    rms = np.array([r["result"]["rms"] for r in good], dtype=float)      # seeds x freqs x temps
    mean = np.array([r["result"]["mean"] for r in good], dtype=float)
    out["overflows"] = int(sum(r["result"]["overflows"] for r in good))
    out["pooled"] = _figures(rms, mean)
    out["by_temp"] = [{"temp_c": t, **_figures(rms[:, :, k], mean[:, :, k])} for k, t in enumerate(temps)]
    out["by_freq"] = [{"f_hz": f, **_figures(rms[:, j, :], mean[:, j, :])} for j, f in enumerate(freqs)]
    cells = [{"f_hz": f, "temp_c": t, **_figures(rms[:, j, k], mean[:, j, k])}
             for j, f in enumerate(freqs) for k, t in enumerate(temps)]
    out["cells"] = cells
    worst = max(cells, key=lambda c: c["rms"]["p99"]["value"])
    out["worst_cell_p99"] = {"f_hz": worst["f_hz"], "temp_c": worst["temp_c"], **worst["rms"]["p99"]}
    return out


def _q(q: dict) -> str:
    lo, hi = q["ci"]
    return f"{q['value']:.4g} [{'-' if lo is None else f'{lo:.4g}'}, {'-' if hi is None else f'{hi:.4g}'}]"


def format_summary(s: dict) -> str:
    """The budget table: per temperature (pooled over the drive frequencies), per frequency, pooled."""
    head = (f"{s['chain']}.{s['port']} error ({s['unit']} rms per point; {s['measure']}), {s['seeds_ok']} of "
            f"{s['seeds']} seeds x {len(s['temps_c'])} temperatures"
            + (f" x {len(s['freqs_hz'])} drive frequencies" if s["freqs_hz"] != [None] else "") + ", "
            f"{s['samples_per_point']} samples per point; percentile [95 % CI]")
    lines = [head]
    if "pooled" not in s:
        return "\n".join(lines + ["  no results"])
    cols = f"{'p50':>10s} {'p90':>10s} {'p99 [95 % CI]':>28s} {'max':>10s} {'p99 |mean|':>11s}"

    def row(label, fig):
        r = fig["rms"]
        return (f"  {label:>14s} {r['p50']['value']:10.4g} {r['p90']['value']:10.4g} {_q(r['p99']):>28s} "
                f"{fig['rms_max']:10.4g} {fig['abs_mean_p99']['value']:11.4g}")

    lines.append(f"  {'T C':>14s} " + cols)
    lines += [row(f"{b['temp_c']:.1f}", b) for b in s["by_temp"]]
    if s["freqs_hz"] != [None]:   # a chain with a demodulator: the drive frequencies
        lines.append(f"  {'f Hz':>14s} " + cols)
        lines += [row(f"{b['f_hz']:.2f}", b) for b in s["by_freq"]]
    lines.append(row("all", s["pooled"]))
    w = s["worst_cell_p99"]
    at_f = f", {w['f_hz']:.2f} Hz" if w["f_hz"] is not None else ""
    lines.append(f"  worst cell: p99 {_q(w)} at {w['temp_c']:.1f} C{at_f}; overflows "
                 f"{s['overflows']}")
    if s["failed"]:
        lines.append(f"  {len(s['failed'])} failed seeds left out (see results.jsonl)")
    return "\n".join(lines)


def plot(s: dict, path) -> None:
    """p50 and p99 (with its CI) of the rms error vs temperature, one colour per drive frequency."""
    from fxdsp.plots import pyplot

    plt = pyplot()

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    if "cells" in s:
        for j, f in enumerate(s["freqs_hz"]):
            cells = [c for c in s["cells"] if c["f_hz"] == f]
            t = [c["temp_c"] for c in cells]
            p99 = [c["rms"]["p99"] for c in cells]
            at = f", {f:.2f} Hz" if f is not None else ""
            line, = ax.plot(t, [q["value"] for q in p99], marker="o", ms=3, label=f"p99{at}")
            lo = [q["ci"][0] if q["ci"][0] is not None else q["value"] for q in p99]
            hi = [q["ci"][1] if q["ci"][1] is not None else q["value"] for q in p99]
            ax.fill_between(t, lo, hi, color=line.get_color(), alpha=0.15, lw=0)
            ax.plot(t, [c["rms"]["p50"]["value"] for c in cells], ls="--", color=line.get_color(), lw=1,
                    label=f"p50{at}")
    ax.set_xlabel("chamber temperature (C)")
    ax.set_ylabel(f"{s['port']} error rms ({s['unit']})")
    ax.set_title(f"{s['chain']}.{s['port']}: {s['seeds_ok']} seeds per point (band: 95 % CI of p99)", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    save_figure(fig, path, metadata={"Software": None})
