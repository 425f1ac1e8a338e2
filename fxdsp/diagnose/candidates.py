"""The candidate causes: which channels each one touches, when it can be tested at all, the grid
of its nonlinear parameter, and its fit and held-out score on top of the current model."""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from fxdsp.causes import CAUSES
from fxdsp.diagnose.blockfit import jackknife_sd
from fxdsp.numeric import parabolic_argmin
from fxdsp.diagnose.context import MIN_GAIN, Candidate, Context, gain_ratio
from fxdsp.diagnose.identify import judge
from fxdsp.ramps import sample_interval


def affected_channels(ctx: Context, cause: str) -> list[str]:
    """Channels whose fit a cause changes (and where its held-out evidence is counted)."""
    return CAUSES[cause].channels(ctx.series.freq is not None)


def available(ctx: Context, cause: str) -> bool:
    """Whether the log can show the cause at all (its record's ``shows``: the column it needs, a
    moving temperature, a rate table)."""
    return CAUSES[cause].shows(ctx)


def tried(ctx: Context) -> list[str]:
    """The causes the selection tries on a log: every one it can show (none never is)."""
    return [c for c in CAUSES if available(ctx, c)]


def nested_held(train: np.ndarray, held: np.ndarray) -> np.ndarray:
    """The held-out error of each fold at the grid value its own training data prefer (nested
    cross-validation of a searched parameter): ``train`` and ``held`` are [values, folds, ...]
    (more axes: several targets, e.g. the draws of a noise null); the result is [folds, ...]."""
    return np.take_along_axis(held, np.argmin(train, axis=0)[None], axis=0)[0]


def grid(ctx: Context, cause: str) -> np.ndarray:
    """Search grid of a nonlinear parameter: time constants from two samples to the log's length."""
    s = ctx.series
    dt = sample_interval(s.t) if np.ptp(s.t) > 0 else 1.0
    lo = max(2.0 * dt, 5.0)
    search = CAUSES[cause].search
    if search is None:
        raise KeyError(cause)
    return np.geomspace(lo, max(search.span * s.duration, 4 * lo), search.points)


def _log_axis(cause: str) -> bool:
    return CAUSES[cause].search is not None   # time constants: searched on a log axis


def searched_parameter(cause: str) -> str | None:
    """The parameter of ``cause`` searched on a grid (None: the cause is linear)."""
    search = CAUSES[cause].search
    return None if search is None else search.parameter


def _evaluate_state(ctx: Context, state: dict, channels: list[str]):
    """Per channel: (train SSE per fold, held SSE per fold, full SSE, jackknife SSE per group)."""
    out = {}
    for ch in channels:
        normals, _ = ctx.normals(ch, state)
        train, held = normals.folds()
        _, full = normals.fit_all()
        out[ch] = (train, held, full * normals.weight, normals.jackknife()[1])
    return out


def evaluate(ctx: Context, state: dict, cause: str, base_held: dict) -> Candidate:
    """Fit one candidate on top of ``state``; score it on held-out folds against ``state``."""
    channels = affected_channels(ctx, cause)
    if searched_parameter(cause) is None:
        res = _evaluate_state(ctx, {**state, cause: {}}, channels)
        held = {ch: res[ch][1] for ch in channels}
        nonlinear, nonlinear_sd = {}, {}
        at_bound = False
    else:
        pname = searched_parameter(cause)
        values = grid(ctx, cause)
        train = np.zeros((values.size, ctx.blocks.n_folds))
        full = np.zeros(values.size)
        jk = np.zeros((values.size, ctx.blocks.n_groups))
        held_g = {ch: np.zeros((values.size, ctx.blocks.n_folds)) for ch in channels}
        for i, v in enumerate(values):
            res = _evaluate_state(ctx, {**state, cause: {pname: float(v)}}, channels)
            for ch in channels:
                train[i] += res[ch][0]
                held_g[ch][i] = res[ch][1]
                full[i] += res[ch][2]
                jk[i] += res[ch][3]
        # nested: each fold's parameter is the one its own training data prefer
        held = {ch: nested_held(train, held_g[ch]) for ch in channels}
        axis = np.log(values) if _log_axis(cause) else values
        best = _refine(ctx, state, cause, channels, values, full, axis)
        nonlinear = {pname: best}
        nonlinear_sd = {pname: _jackknife_of_search(cause, axis, train, jk)}
        at_bound = int(np.argmin(full)) in (0, values.size - 1)
    evidence = 0.0
    ratios, before_after = {}, {}
    for ch in channels:
        w = ctx.weights[ch]
        b, a = float(base_held[ch].sum()), float(held[ch].sum())
        evidence += b - a
        sd = ctx.norm[ch][1]
        rms_b = np.sqrt(b / w / ctx.series.n) * sd
        rms_a = np.sqrt(a / w / ctx.series.n) * sd
        ratios[ch] = gain_ratio(rms_b, rms_a)
        before_after[ch] = (rms_b, rms_a)
    main = max(channels, key=lambda ch: ratios[ch])
    own = CAUSES[cause].channel
    if ratios[own] >= MIN_GAIN:
        main = own  # the contract's channel for the cause (a lag's: output), whenever it shows there
    return Candidate(cause=cause, channel=main, evidence=float(evidence), ratio=float(ratios[main]),
                     rms_before=float(before_after[main][0]), rms_after=float(before_after[main][1]),
                     nonlinear=nonlinear, nonlinear_sd=nonlinear_sd, ratios=ratios, at_bound=at_bound,
                     verdicts={k: judge(k, v, nonlinear_sd[k], ctx.series.duration, at_bound)
                               for k, v in nonlinear.items()})


def _jackknife_of_search(cause: str, axis: np.ndarray, train: np.ndarray, jk: np.ndarray) -> float:
    """Jackknife sd of a searched parameter from its SSE curves on ``axis`` [values, folds] (the
    training SSE of each fold) and [values, groups] (the SSE without each group)."""
    if CAUSES[cause].transient:
        # a settling lives in the first few time constants of the log: deleting one of the 20
        # contiguous groups can delete most of it and throw the estimate to the grid's end.
        # Its uncertainty comes from the interleaved cross-validation folds instead, each of
        # which keeps 80 % of every part of the log (a delete-a-fold jackknife)
        per_group = np.array([parabolic_argmin(axis, train[:, f]) for f in range(train.shape[1])])
    else:
        per_group = np.array([parabolic_argmin(axis, jk[:, k]) for k in range(jk.shape[1])])
    return jackknife_sd(np.exp(per_group) if _log_axis(cause) else per_group)


LOCAL_AXIS = np.linspace(-1.2, 1.2, 17)   # a local grid around a searched time constant, log axis


def local_axis(ctx: Context, cause: str, value: float) -> np.ndarray:
    """``LOCAL_AXIS`` around ``value`` (log axis), within the cause's search range."""
    lo, hi = np.log(grid(ctx, cause)[[0, -1]])
    return np.unique(np.clip(np.log(value) + LOCAL_AXIS, lo, hi))


def final_jackknife_sd(ctx: Context, state: dict, cause: str) -> float:
    """Jackknife sd of ``cause``'s searched parameter in the final model ``state`` (the other causes
    at their final values), on a local grid around its value. The candidate stage's sd was taken
    before later causes joined and before refit_nonlinear moved the value: a lag tried before the
    quadrature leak that shares its channel kept a 24 % sd on a noise-free log."""
    pname = searched_parameter(cause)
    axis = local_axis(ctx, cause, state[cause][pname])
    channels = affected_channels(ctx, cause)
    train = np.zeros((axis.size, ctx.blocks.n_folds))
    jk = np.zeros((axis.size, ctx.blocks.n_groups))
    for i, a in enumerate(axis):
        res = _evaluate_state(ctx, {**state, cause: {**state[cause], pname: float(np.exp(a))}}, channels)
        for ch in channels:
            train[i] += res[ch][0]
            jk[i] += res[ch][3]
    return _jackknife_of_search(cause, axis, train, jk)


def _refine(ctx, state, cause, channels, values, full, axis) -> float:
    """Full-data minimum of the weighted SSE between the grid neighbours of the grid minimum."""
    if values.size == 1:
        return float(values[0])
    a, _ = _brent_near_best(_full_sse(ctx, state, cause, channels), axis, full)
    return _from_axis(cause, a)


def _from_axis(cause: str, a: float) -> float:
    return float(np.exp(a)) if _log_axis(cause) else float(a)


def _full_sse(ctx: Context, others: dict, cause: str, channels: list[str]):
    """The weighted full-data SSE of ``others`` plus ``cause`` at its searched parameter's value on
    the search axis (log for a time constant), summed over ``channels``."""
    pname = searched_parameter(cause)

    def sse(a: float) -> float:
        total = 0.0
        for ch in channels:
            normals, _ = ctx.normals(ch, {**others, cause: {pname: _from_axis(cause, a)}})
            total += normals.fit_all()[1] * normals.weight
        return total
    return sse


def _brent_near_best(sse, axis, values) -> tuple[float, float]:
    """(point, SSE) of Brent's minimum between the grid neighbours of the grid's best, or the grid's
    best when Brent's point is not below it (its tolerance can leave it a hair above a minimum at the
    grid's edge). A lag 1000 x above the noise needs tau to 1e-4 or its misfit looks like another cause."""
    i = int(np.argmin(values))
    lo, hi = axis[max(i - 1, 0)], axis[min(i + 1, len(axis) - 1)]
    res = minimize_scalar(sse, bounds=(lo, hi), method="bounded", options={"xatol": 1e-7, "maxiter": 200})
    return (res.x, res.fun) if res.fun <= values[i] else (axis[i], values[i])


RECENTRE_STEPS = 8   # moves of refit_nonlinear's local grid (0.4 in log each): up to a factor of ~25


def refit_nonlinear(ctx: Context, state: dict, accepted: list[Candidate]) -> None:
    """Re-estimate the nonlinear parameters of earlier causes with the later ones in the model:
    a lag time constant fitted while a quadrature leak was still unexplained is biased."""
    for cand in accepted:
        pname = searched_parameter(cand.cause)
        if pname is None:
            continue
        others = {k: v for k, v in state.items() if k != cand.cause}
        sse = _full_sse(ctx, others, cand.cause, affected_channels(ctx, cand.cause))
        # a local grid first (real logs can have shallow secondary minima), then Brent; a minimum at
        # the grid's edge moves the grid there (a warm-up's time constant fitted before an aging
        # drift joined is often off by more than the grid's factor of 1.5 either way), within the
        # search range
        a0 = np.log(state[cand.cause][pname])
        bounds = np.log(grid(ctx, cand.cause)[[0, -1]])
        centre = a0
        for _ in range(RECENTRE_STEPS):
            local = centre + np.linspace(-0.4, 0.4, 17)
            values = [sse(a) for a in local]
            i = int(np.argmin(values))
            edge = local[i] if i in (0, local.size - 1) else None
            if edge is None or not bounds[0] < edge < bounds[1]:
                break
            centre = edge
        a, fa = _brent_near_best(sse, local, values)
        if fa <= sse(a0):   # unless the value it started from is better still
            state[cand.cause][pname] = float(np.exp(a))
            cand.nonlinear = dict(state[cand.cause])
