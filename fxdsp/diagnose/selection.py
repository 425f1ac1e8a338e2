"""Which causes to name: greedy forward selection on held-out evidence, a re-test of time-like
causes against a wandering (random-walk) bias, and a backward check of the final model."""

from __future__ import annotations

import numpy as np

from fxdsp import mechanisms as mech
from fxdsp.diagnose.candidates import affected_channels, available, evaluate, refit_nonlinear
from fxdsp.diagnose.context import (MAX_CAUSES, MIN_EVIDENCE, MIN_GAIN, Candidate, Context, innovations,
                                    residual, set_noise_weights, white_noise_variance)

# causes whose regressor is slow in time, so a bias random walk can imitate them: a drift, a
# settling, a level that changes a few times, a quadrature level wandering over hours
TIME_TIED = ("aging_drift", "warmup", "hysteresis", "quadrature_leak")


def greedy_search(ctx: Context) -> tuple[dict, list[Candidate], list[Candidate]]:
    """Forward selection on held-out evidence: (state, accepted candidates, first-round candidates)."""
    series = ctx.series
    state: dict = {}
    accepted: list[Candidate] = []
    first_round: list[Candidate] = []
    causes = [c for c in mech.CAUSES if available(ctx, c)]
    for _ in range(MAX_CAUSES):
        set_noise_weights(ctx, state)
        base_held = {ch: ctx.normals(ch, state)[0].folds()[1] for ch in series.channels()}
        results = [evaluate(ctx, state, c, base_held) for c in causes if c not in state]
        if not first_round:
            first_round = sorted(results, key=lambda c: -c.evidence)
        good = [c for c in results if c.accepted_by_rule]
        if not good:
            break
        best = max(good, key=lambda c: c.evidence)
        accepted.append(best)
        state[best.cause] = dict(best.nonlinear)
        if len(accepted) > 1:
            refit_nonlinear(ctx, state, accepted)
    return state, accepted, first_round


def variogram(residual: np.ndarray, lag: int) -> float:
    """Robust variogram: median of squared lag differences, scaled to a variance for Gaussian noise
    (a few samples of model mismatch at a ramp corner must not look like a wandering bias)."""
    d = residual[lag:] - residual[:-lag]
    return float(np.median(d * d)) / 0.4549


def wander(residual: np.ndarray) -> tuple[float, float, float]:
    """(variogram ratio gamma(M)/gamma(1), the ratio white noise stays below, Kalman gain).

    White noise has a flat variogram; a random walk's grows linearly with the lag. M is a fifth of
    the log; the threshold is 1 + 4 standard deviations of the ratio for white noise, which is
    3.2 / sqrt(n) (simulated for n = 1e3 .. 1e5)."""
    n = residual.size
    m = max(2, n // 5)
    if n < 50:
        return 1.0, np.inf, 0.0
    g1, gm = variogram(residual, 1), variogram(residual, m)
    ratio = gm / g1 if g1 > 0 else 1.0
    threshold = 1.0 + 4.0 * 3.2 / np.sqrt(n)
    q = max((gm - g1) / (m - 1), 0.0)
    white = max((g1 - q) / 2.0, 1e-300)
    lam = q / white
    p = 0.5 * (lam + np.sqrt(lam * lam + 4.0 * lam))
    return float(ratio), float(threshold), float(p / (p + 1.0))


def check_against_wander(ctx: Context, state: dict, accepted: list[Candidate]):
    """Re-test the accepted time-like causes when the final residual still wanders.

    A bias random walk drifts; over one run it can look like an aging slope, a warm-up or a
    hysteresis step (a level that changes a few times), and the white-noise held-out test cannot
    tell. Causes tied to the temperature ramps themselves (lag, ramp rate) or to other channels
    are not time-like: a random walk does not repeat with the programme. If the residual of the
    final model is not white, each time-like cause is tested again (dropped from the final model,
    held-out folds) on innovations of the white-plus-random-walk noise that the residual shows,
    and the weakest cause that no longer passes is removed, until all pass or the residual is
    white.
    """
    ch = "output"
    while True:
        out_causes = [c for c in accepted if c.cause in TIME_TIED]
        if not out_causes:
            return state, accepted
        ratio, threshold, gain = wander(residual(ctx, state, ch))
        if ratio <= threshold:
            return state, accepted
        ctx.innovation_gain[ch] = gain
        e = innovations(residual(ctx, state, ch), gain)
        saved_weight = ctx.weights[ch]
        ctx.weights[ch] = 1.0 / white_noise_variance(e)
        try:
            full = ctx.normals(ch, state)[0].folds()[1].sum()
            verdicts = []
            for cand in out_causes:
                without = {k: v for k, v in state.items() if k != cand.cause}
                held = ctx.normals(ch, without)[0].folds()[1].sum()
                evidence = held - full
                rms_ratio = float(np.sqrt(held / full)) if full > 0 else np.inf
                verdicts.append((evidence, rms_ratio, cand))
        finally:
            ctx.innovation_gain.pop(ch, None)
            ctx.weights[ch] = saved_weight
        failing = [v for v in verdicts if v[1] < MIN_GAIN or v[0] < MIN_EVIDENCE]
        if not failing:
            return state, accepted
        weakest = min(failing, key=lambda v: v[0])[2]
        accepted = [c for c in accepted if c is not weakest]
        state = {k: v for k, v in state.items() if k != weakest.cause}


def prune(ctx: Context, state: dict, accepted: list[Candidate]):
    """Backward check of the final model: every cause must still pass the acceptance rule when it
    is the last one added (a cause accepted early can become redundant after a later one, or after
    a time-like cause was removed by the wander check). The weakest failure goes first."""
    while accepted:
        verdicts = []
        for cand in accepted:
            without = {k: v for k, v in state.items() if k != cand.cause}
            evidence, ratio = 0.0, 0.0
            for ch in affected_channels(ctx, cand.cause):
                full = ctx.normals(ch, state)[0].folds()[1].sum()
                held = ctx.normals(ch, without)[0].folds()[1].sum()
                evidence += held - full
                ratio = max(ratio, float(np.sqrt(held / full)) if full > 0 else np.inf)
            verdicts.append((evidence, ratio, cand))
        failing = [v for v in verdicts if v[1] < MIN_GAIN or v[0] < MIN_EVIDENCE]
        if not failing:
            break
        weakest = min(failing, key=lambda v: v[0])[2]
        accepted = [c for c in accepted if c is not weakest]
        state = {k: v for k, v in state.items() if k != weakest.cause}
    return state, accepted
