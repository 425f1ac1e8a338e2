"""Which causes to name: greedy forward selection on held-out evidence, a re-test of time-like
causes against a wandering (random-walk) bias, and a backward check of the final model."""

from __future__ import annotations

import numpy as np

from fxdsp.causes import CAUSES
from fxdsp.diagnose.blockfit import FoldTargets, SegmentNormals
from fxdsp.diagnose.candidates import (affected_channels, evaluate, grid, nested_held, refit_nonlinear, searched_parameter,
                                       tried)
from fxdsp.diagnose.context import (MAX_CAUSES, MIN_EVIDENCE, MIN_GAIN, PAIR_ON_TOP_OF, Candidate, Context, innovations,
                                    level_gain, residual, set_noise_weights, white_noise_variance)
from fxdsp.diagnose.noise import band_levels, noise_draws, readout_draws
from fxdsp.ramps import quantisation_step

# causes whose regressor is slow in time, so a bias random walk can imitate them: a drift, a
# settling, a level that changes a few times, a quadrature level wandering over hours
TIME_TIED = tuple(c.name for c in CAUSES.values() if c.time_tied)
# the re-test of a time-like cause in a wandering log: it must pass on innovations, or have a held-out
# rms ratio of at least WANDER_GAIN and evidence, relative to the wander left after it, beyond the
# NULL_QUANTILE of NULL_DRAWS random walks (beats_walks; fixed seed: reproducible); as the last cause added
# it needs WANDER_GAIN in every log (prune, _min_gain)
WANDER_GAIN = 1.3
# The draws come in sets of NULL_DRAWS, as many sets as NULL_ROWS simulated rows buy (at most
# MAX_NULL_SETS), and a cause must beat the 1 - (1 - NULL_QUANTILE)/sets quantile of them: always a
# point between the two largest draws. A new draw of the same null exceeds it about 1.4/(draws + 1)
# of the time (order statistics): one set of 40, on logs of more than 2,500 rows, tests at about
# 3.4 %, not 1 %; a log of 500 rows buys 10 sets and a test at about 0.35 %. A short log needs it:
# over a few hundred rows a random walk's excursion imitates a warm-up or a drift (500-row logs of
# noise alone named a cause in 2 of 200 sweep seeds at one set, p = 1.7 % for a held-out one), and
# its true causes stand at twice the largest of 240 draws or more. One set on long logs, where more
# would cost a draw per row, and where under flicker-dominated noise true causes stand at p = 0.4 to
# 1.7 %: a true 1 % would drop 10 of 145 of them. The issue 32 notes of 2026-11-28 and -29 give the
# numbers
NULL_DRAWS = 40
NULL_QUANTILE = 0.99
NULL_ROWS = 200_000
MAX_NULL_SETS = 10
NULL_SEED = 20261123


def greedy_search(ctx: Context) -> tuple[dict, list[Candidate], list[Candidate]]:
    """Forward selection on held-out evidence, also started from the best pair of causes:
    (state, accepted candidates, first-round candidates).

    Two causes can hide each other (a hysteresis step and an aging drift of opposite sign: each
    alone explains little, together nearly everything), which one-at-a-time selection never
    finds. So every pair of candidates is also scored together, and the forward selection is run
    again from the best pair that passes; the model with the lower held-out error wins."""
    causes = tried(ctx)
    state, accepted, first_round = forward(ctx, causes, {}, [])
    pair = _best_pair(ctx, causes, first_round)
    if pair is not None and {c.cause for c in pair} != set(state):
        start = {c.cause: dict(c.nonlinear) for c in pair}
        refit_nonlinear(ctx, start, list(pair))
        p_state, p_accepted, _ = forward(ctx, causes, start, list(pair))
        if _total_held(ctx, p_state) < _total_held(ctx, state) - MIN_EVIDENCE:
            state, accepted = p_state, p_accepted
    return state, accepted, first_round


def forward(ctx: Context, causes: list[str], state: dict, accepted: list[Candidate]):
    """Forward selection from ``state``: the best of ``causes`` that passes the acceptance rule joins,
    until none does or MAX_CAUSES are in (state, accepted, the first round's candidates)."""
    state, accepted = dict(state), list(accepted)
    first_round: list[Candidate] = []
    while len(accepted) < MAX_CAUSES:
        set_noise_weights(ctx, state)
        base_held = {ch: ctx.normals(ch, state)[0].folds()[1] for ch in ctx.series.channels()}
        results = [evaluate(ctx, state, c, base_held) for c in causes if c not in state]
        if not first_round:
            first_round = sorted(results, key=lambda c: -c.evidence)
        good = [c for c in results if c.accepted_by_rule]
        if not good:
            # two causes can hide each other on top of others too (a warm-up and a drift beside a
            # scale-factor cubic: each alone fits the other's part); the best pair that passes joins
            pair = _best_pair(ctx, [c.cause for c in results], results, state) \
                if state and len(accepted) <= PAIR_ON_TOP_OF else None
            if pair is None:
                break
            accepted.extend(pair)
            state.update({c.cause: dict(c.nonlinear) for c in pair})
            refit_nonlinear(ctx, state, accepted)
            continue
        best = max(good, key=lambda c: c.evidence)
        accepted.append(best)
        state[best.cause] = dict(best.nonlinear)
        if len(accepted) > 1:
            refit_nonlinear(ctx, state, accepted)
    return state, accepted, first_round


def _total_held(ctx: Context, state: dict) -> float:
    """Held-out SSE over every channel, in units of the baseline's white-noise variances (one
    yardstick for models with different causes)."""
    set_noise_weights(ctx, {})
    return float(sum(ctx.normals(ch, state)[0].folds()[1].sum() for ch in ctx.series.channels()))


def _best_pair(ctx: Context, causes: list[str], first_round: list[Candidate], state: dict | None = None):
    """The pair of ``causes`` with the lowest held-out error together on top of ``state`` (nonlinear
    parameters from ``first_round``, each cause fitted alone on top of ``state``), as two candidates
    each scored on top of ``state`` and the other; None unless both pass."""
    state = state or {}
    first = {c.cause: c for c in first_round}

    def unusable(c: Candidate) -> bool:
        # a linear cause that fails alone may succeed beside another; a grid-searched one carries a
        # usable parameter only when its own fit worked (on top of others, also when its value was
        # not determined: the cause it hides with took part of it; the pair's own fits, below,
        # search it again)
        return bool(c.nonlinear) and (c.failed or not (c.identified or state))

    best, best_sse = None, np.inf
    for i, a in enumerate(causes):
        for b in causes[i + 1:]:
            if unusable(first[a]) or unusable(first[b]):
                continue
            sse = _total_held(ctx, {**state, a: dict(first[a].nonlinear), b: dict(first[b].nonlinear)})
            if sse < best_sse:
                best, best_sse = (a, b), sse
    if best is None:
        return None
    pair = []
    for cause, other in (best, best[::-1]):
        on_top = {**state, other: dict(first[other].nonlinear)}
        set_noise_weights(ctx, on_top)
        base_held = {ch: ctx.normals(ch, on_top)[0].folds()[1] for ch in ctx.series.channels()}
        cand = evaluate(ctx, on_top, cause, base_held)
        if not cand.accepted_by_rule:
            return None
        pair.append(cand)
    return sorted(pair, key=lambda c: -c.evidence)


def variogram(residual: np.ndarray, lag: int):
    """Robust variogram: median of squared lag differences, scaled to a variance for Gaussian noise
    (a few samples of model mismatch at a ramp corner must not look like a wandering bias); of each
    column of a 2-D ``residual`` (rows down), one per column."""
    d = residual[lag:] - residual[:-lag]
    v = np.median(d * d, axis=0) / 0.4549
    return float(v) if np.ndim(v) == 0 else v


def walk_levels(residual: np.ndarray) -> tuple[float, float, float, float]:
    """(gamma(1), gamma(n/5), random-walk variance per row, white variance) of a residual, from its
    robust variogram at one row and at a fifth of the log."""
    m = max(2, residual.size // 5)
    g1, gm = variogram(residual, 1), variogram(residual, m)
    q = max((gm - g1) / (m - 1), 0.0)
    return g1, gm, q, max((g1 - q) / 2.0, 0.0)


def wander(residual: np.ndarray) -> tuple[float, float, float]:
    """(variogram ratio gamma(M)/gamma(1), the ratio white noise stays below, Kalman gain).

    White noise has a flat variogram; a random walk's grows linearly with the lag. M is a fifth of
    the log; the threshold is 1 + 4 standard deviations of the ratio for white noise, which is
    3.2 / sqrt(n) (simulated for n = 1e3 .. 1e5)."""
    n = residual.size
    if n < 50:
        return 1.0, np.inf, 0.0
    g1, gm, q, white = walk_levels(residual)
    ratio = gm / g1 if g1 > 0 else 1.0
    threshold = wander_threshold(n)
    gain = level_gain(q / max(white, 1e-300))  # a residual that is all random walk: 1, differenced
    return float(ratio), float(threshold), float(gain)


def wander_threshold(n: int) -> float:
    """The variogram ratio gamma(n/5)/gamma(1) white noise stays below: 1 + 4 standard deviations
    of the ratio, which are 3.2 / sqrt(n) (simulated for n = 1e3 .. 1e5)."""
    return 1.0 + 4.0 * 3.2 / np.sqrt(n)


def unseen_walk(white: float, n: int) -> float:
    """The random-walk variance per row that the variogram test of :func:`wander` cannot see in
    ``n`` rows of white noise of variance ``white``: a walk of q per row raises gamma(m)/gamma(1) by
    about (m - 1) q / (2 white), m = n/5, so it stays below the threshold while q is below
    2 white (threshold - 1) / (m - 1) (an end variance of about 128 white / sqrt(n): 2.4 white
    sigmas at 500 rows, 1.1 at 10,000). A walk that small is no evidence that the log has none."""
    m = max(2, n // 5)
    return 2.0 * white * (wander_threshold(n) - 1.0) / (m - 1)


def null_draws(n: int, draw) -> np.ndarray:
    """The re-tests' draws of noise over ``n`` rows, ``draw(rng, count)`` making one set: sets of
    NULL_DRAWS, each from its own fixed seed (the first set is the same on every log length)."""
    sets = int(np.clip(NULL_ROWS // (NULL_DRAWS * n), 1, MAX_NULL_SETS))
    return np.concatenate([draw(np.random.default_rng(NULL_SEED + k), NULL_DRAWS) for k in range(sets)])


def _noise_draws(levels: tuple[float, float, float], n: int) -> np.ndarray:
    """:func:`null_draws` of white noise, flicker and a random walk at ``levels``."""
    return null_draws(n, lambda rng, count: noise_draws(rng, levels, count, n))


def null_threshold(values: np.ndarray) -> float:
    """The point of the re-tests' null ``values`` a cause must exceed: between the two largest,
    as NULL_QUANTILE is in one set of NULL_DRAWS, whatever the number of sets."""
    return float(np.quantile(values, max(0.0, 1.0 - (1.0 - NULL_QUANTILE) * NULL_DRAWS / len(values))))


def beats_walks(ctx: Context, channel: str, state: dict, without: dict, gained: float, resid: np.ndarray) -> bool:
    """Whether the held-out evidence ``gained`` that the columns ``state`` adds to ``without`` is more,
    relative to the wander left after them (``resid``: the residual of ``state``), than random walks
    give: beyond the :func:`null_threshold` of
    :func:`null_draws` of white noise plus a random walk at the levels the residual *without* them
    shows (its variogram at 1 and n/5 rows; fixed seed: reproducible).

    The evidence is counted in units of the residual's variogram at n/5 rows once the columns are
    fitted (each draw's the same way). A line or a settling fitted to a random walk takes part of it
    and leaves a residual that still wanders about as much, so this ratio hardly depends on the
    walk's level, and a walk level read from the residual without the cause, which a real drift
    inflates, does not decide the test. A real drift under flicker leaves the flicker's bounded
    wander: counted in raw held-out variance against walks that large, aging drifts of 6 to 16 white
    sigmas under flicker were dropped in 15 of 20 logs (issue 32 notes)."""
    n = resid.size
    lag = max(2, n // 5)
    _, _, q, white = walk_levels(residual(ctx, without, channel))
    draws = _noise_draws((white, 0.0, q), n)
    gains = _null_gains(ctx, channel, state, without, draws)
    x = ctx.design(channel, state)[0]
    left = draws.T - x @ np.linalg.lstsq(x, draws.T, rcond=None)[0]      # each draw's residual, as the log's
    wander_left = variogram(left, lag)                                   # per draw (column)
    return gained / max(variogram(resid, lag), 1e-300) > null_threshold(gains / wander_left)


def _null_quantile(ctx: Context, channel: str, state: dict, without: dict, draws, rivals=()) -> float:
    """The :func:`null_threshold` of :func:`_null_gains`."""
    return null_threshold(_null_gains(ctx, channel, state, without, draws, rivals))


def _null_gains(ctx: Context, channel: str, state: dict, without: dict, draws, rivals=()) -> np.ndarray:
    """Per draw, the held-out evidence that the columns ``state`` adds to ``without``
    gets on each of ``draws`` (series of noise alone). A cause with a searched parameter (a time
    constant) is searched on each draw as on the log (its grid, each fold's value the one its
    training data prefer): noise fitted at the value the log chose would give it less than noise
    gives a cause that may choose its value (on flicker a lag's held-out evidence is several times
    what it gets at a fixed time constant).

    With ``rivals`` (other causes that could have been added to ``without`` instead), each draw
    counts the largest evidence of any of them or of the added cause: the selection named the best
    of the causes it tried, so the noise is given the same choice (the best of eight is up to eight
    times as likely as one to pass a 1 % test of one; logs of 500 rows of noise alone named a cause
    in 6 of 130 seeds before, 2 after)."""
    draws = FoldTargets(np.asarray(draws, dtype=float).T, ctx.blocks)   # [rows, draws]: one design, every draw
    w = ctx.weights[channel]

    def folds(x):                                                   # (train, held) per fold and draw
        return SegmentNormals(x, draws, ctx.blocks, w).folds()

    base = folds(ctx.design(channel, without)[0])[1].sum(axis=0)
    added = [c for c in state if c not in without]
    gains = [base - _null_held(ctx, channel, state, added, folds)]
    for cause in rivals:
        if cause not in state:
            gains.append(base - _null_held(ctx, channel, {**without, cause: {}}, [cause], folds))
    return np.max(gains, axis=0)


def _null_held(ctx: Context, channel: str, state: dict, added: list[str], folds) -> np.ndarray:
    """Held-out SSE per draw of the design of ``state``; one added cause with a searched parameter
    is searched on every draw (each fold's value the one its training data prefer)."""
    pname = searched_parameter(added[0]) if len(added) == 1 else None
    if pname is None:
        return folds(ctx.design(channel, state)[0])[1].sum(axis=0)
    cause = added[0]
    runs = [folds(ctx.design(channel, {**state, cause: {**state[cause], pname: float(v)}})[0])
            for v in grid(ctx, cause)]
    return nested_held(np.array([r[0] for r in runs]), np.array([r[1] for r in runs])).sum(axis=0)


def check_against_wander(ctx: Context, state: dict, accepted: list[Candidate]):
    """Re-test the accepted time-like causes when the residual without them wanders.

    A bias random walk drifts; over one run it can look like an aging slope, a warm-up or a
    hysteresis step (a level that changes a few times), and the white-noise held-out test cannot
    tell. Causes tied to the temperature ramps themselves (lag, ramp rate) or to other channels
    are not time-like: a random walk does not repeat with the programme. If the residual of the
    model without the time-like causes is not white (once a warm-up has soaked up a random walk,
    the rest looks white), each of them is tested again, dropped from the final model: held-out
    evidence >= MIN_EVIDENCE on innovations of the white-plus-random-walk noise of the final
    residual (its level taken with the causes in place, so a real drift is not taken for a walk),
    and the held-out rms ratio of the data as logged >= MIN_GAIN (innovations are dominated by the
    white steps of every row). Differencing also discards what separates two causes whose steps
    fall on the same rows (a hysteresis flip at a ramp reversal, where the ramp-rate term flips
    too): a cause that fails on innovations is kept when it is large (ratio >= WANDER_GAIN) and
    its evidence, in units of the wander left after it, is beyond what random walks give at the
    level the residual *without* it shows (:func:`beats_walks`; the walk as large as the data allow
    without the cause, its level made nearly irrelevant by the units). The weakest failure
    is removed, until all pass. Returns the state, the accepted causes and the ones removed (cause ->
    the held-out rms ratio it had on the data as logged).
    """
    ch = "output"
    dropped: dict[str, float] = {}
    while True:
        out_causes = [c for c in accepted if c.cause in TIME_TIED]
        if not out_causes:
            return state, accepted, dropped
        others = {k: x for k, x in state.items() if k not in TIME_TIED}
        ratio, threshold, _ = wander(residual(ctx, others, ch))
        if ratio <= threshold:
            return state, accepted, dropped
        resid = residual(ctx, state, ch)
        gain = wander(resid)[2]
        full_raw = ctx.normals(ch, state)[0].folds()[1].sum()
        verdicts = []
        for cand in out_causes:
            without = {k: v for k, v in state.items() if k != cand.cause}
            held_raw = ctx.normals(ch, without)[0].folds()[1].sum()
            ratio_raw = float(np.sqrt(held_raw / full_raw)) if full_raw > 0 else np.inf
            evidence = _innovation_evidence(ctx, ch, state, without, gain)
            if (evidence < MIN_EVIDENCE and ratio_raw >= WANDER_GAIN
                    and beats_walks(ctx, ch, state, without, held_raw - full_raw, resid)):
                evidence = MIN_EVIDENCE
            verdicts.append((evidence, ratio_raw, cand))
        failing = [v for v in verdicts if v[1] < MIN_GAIN or v[0] < MIN_EVIDENCE]
        if not failing:
            return state, accepted, dropped
        _, ratio_raw, weakest = min(failing, key=lambda v: v[0])
        dropped[weakest.cause] = ratio_raw
        accepted = [c for c in accepted if c is not weakest]
        state = {k: v for k, v in state.items() if k != weakest.cause}


def check_against_noise(ctx: Context, state: dict, accepted: list[Candidate]):
    """Every named cause on the output must beat what the residual's own coloured noise gives it.

    A bias random walk or flicker too slight for the variogram test of :func:`check_against_wander`
    (short logs: a few hundred rows cannot tell a small wander from white noise) still gives a line or
    a settling a held-out evidence of tens of white-noise variances, and the white-noise rule names
    it; flicker-dominated noise does the same for a lag or a ramp-rate term, whose columns follow the
    slow programme. So the noise of the final residual is estimated (white, a flicker band and a random
    walk, :func:`fxdsp.diagnose.noise.band_levels`, with the model's columns projected out of each
    shape, as they are out of the residual: the noise the whitening of the final numbers takes; a
    flicker fitted from one row on misplaced noise between white, flicker and walk on flicker whose
    band starts slower, and this re-test then dropped lags and hysteresis steps of SNR 5..20 under
    flicker, issue 32 notes), its walk no smaller than :func:`unseen_walk` (a line or a settling can
    take the whole of a walk in a short log, and the fit then finds none), and each
    output cause's held-out evidence must exceed the :func:`null_threshold` of the best that
    :func:`null_draws` of that noise give it or any other cause the log could show (fixed seeds; a time
    constant searched on every draw, :func:`_null_quantile`); the weakest failure is removed until all pass."""
    ch = "output"
    while True:
        out_causes = [c for c in accepted if ch in affected_channels(ctx, c.cause)]
        if not out_causes:
            return state, accepted
        white, flicker, walk = band_levels(residual(ctx, state, ch), ctx.design(ch, state)[0])
        levels = (white, flicker, max(walk, unseen_walk(white, ctx.series.n)))
        draws = _noise_draws(levels, ctx.series.n)
        full = ctx.normals(ch, state)[0].folds()[1].sum()
        rivals = [c for c in tried(ctx) if ch in affected_channels(ctx, c)]
        margins = []
        for cand in out_causes:
            without = {k: v for k, v in state.items() if k != cand.cause}
            gained = ctx.normals(ch, without)[0].folds()[1].sum() - full
            margins.append((gained - _null_quantile(ctx, ch, state, without, draws, rivals), cand))
        dropped = _without_weakest(margins, state, accepted)
        if dropped is None:
            return state, accepted
        state, accepted = dropped


def check_against_readout(ctx: Context, state: dict, accepted: list[Candidate]):
    """A cause seen only on a quantised readout (``temp_c`` or ``freq_hz`` logged to a fixed step) must
    beat what the readout's step gives it.

    A thermometer logged to 0.1 C reads one value through a dwell: its error there is one constant
    per dwell, up to half a step, not white noise that averages down, and a programme with three
    dwell temperatures offers a quadratic three constants to fit (a 500-row `none` log named an RTD
    curvature of 0.015 C rms on a 0.1 C step, 4.8 jackknife sigmas). So each such cause's held-out
    evidence on its channel must exceed the :func:`null_threshold` of :func:`null_draws` of the
    readout's error alone: the model without the cause read through the step at a random grid
    offset, with no white noise to dither it, the least favourable case
    (:func:`fxdsp.diagnose.noise.readout_draws`; with the residual's white noise less the step's
    q^2/12 added, that log still named the curvature at p < 1/400). The weakest failure is removed
    until all pass. A channel not on a grid (:func:`fxdsp.ramps.quantisation_step`, the step the
    ramp reader finds) keeps the white-noise test alone."""

    while True:
        margins = []
        for cand in accepted:
            channels = affected_channels(ctx, cand.cause)
            if "output" in channels:
                continue
            without = {k: v for k, v in state.items() if k != cand.cause}
            for ch in channels:
                step = quantisation_step(ctx.series.target(ch)) / ctx.norm[ch][1]
                if step == 0.0:
                    continue
                fitted = ctx.target(ch) - residual(ctx, without, ch)
                draws = null_draws(ctx.series.n, lambda rng, count: readout_draws(rng, fitted, step, count))
                gained = ctx.normals(ch, without)[0].folds()[1].sum() - ctx.normals(ch, state)[0].folds()[1].sum()
                margins.append((gained - _null_quantile(ctx, ch, state, without, draws), cand))
        dropped = _without_weakest(margins, state, accepted)
        if dropped is None:
            return state, accepted
        state, accepted = dropped


def _without_weakest(margins: list, state: dict, accepted: list[Candidate]):
    """The state and causes without the failing cause (margin <= 0) of least margin; None when none
    fails. ``margins``: (margin, candidate) pairs."""
    failing = [m for m in margins if m[0] <= 0]
    if not failing:
        return None
    weakest = min(failing, key=lambda m: m[0])[1]
    return {k: v for k, v in state.items() if k != weakest.cause}, [c for c in accepted if c is not weakest]


def _innovation_evidence(ctx: Context, ch: str, state: dict, without: dict, gain: float) -> float:
    """Held-out evidence of ``state`` over ``without`` on innovations of gain ``gain``, in units of
    the innovations' white variance."""
    saved_weight = ctx.weights[ch]
    ctx.whitening[ch] = lambda values, axis: innovations(values, gain, axis=axis)
    try:
        ctx.weights[ch] = 1.0 / white_noise_variance(innovations(residual(ctx, state, ch), gain))
        full = ctx.normals(ch, state)[0].folds()[1].sum()
        return float(ctx.normals(ch, without)[0].folds()[1].sum() - full)
    finally:
        ctx.whitening.pop(ch, None)
        ctx.weights[ch] = saved_weight


def last_added_gain(ctx: Context, state: dict, cand: Candidate) -> tuple[float, float]:
    """(held-out evidence, held-out rms ratio) of one cause as the last one added to ``state``,
    over the channels it affects (the ratio: its best channel)."""
    without = {k: v for k, v in state.items() if k != cand.cause}
    evidence, ratio = 0.0, 0.0
    for ch in affected_channels(ctx, cand.cause):
        full = ctx.normals(ch, state)[0].folds()[1].sum()
        held = ctx.normals(ch, without)[0].folds()[1].sum()
        evidence += held - full
        ratio = max(ratio, float(np.sqrt(held / full)) if full > 0 else np.inf)
    return evidence, ratio


def order_by_gain(ctx: Context, state: dict, accepted: list[Candidate]) -> list[Candidate]:
    """The named causes, largest held-out gain (as the last one added) first."""
    gains = {id(c): last_added_gain(ctx, state, c) for c in accepted}
    return sorted(accepted, key=lambda c: (-gains[id(c)][1], -gains[id(c)][0]))


def _min_gain(cause: str) -> float:
    """The held-out rms ratio a cause must reach as the last one added. A time-like cause needs
    WANDER_GAIN: a line (or a settling, a level change) fitted to a bias random walk of end std s
    takes about a tenth of s^2 per row (the slope of a Brownian path on [0, 1] has variance 6 s^2 / 5),
    a ratio near sqrt(1 + (s / sigma)^2 / 10), 1.4 for a walk of three white sigmas, and it does so
    in logs too short for the residual to show the walk (a few hundred rows: the wander and noise
    re-tests see white noise there), where its held-out evidence is far above MIN_EVIDENCE."""
    return WANDER_GAIN if cause in TIME_TIED else MIN_GAIN


def prune(ctx: Context, state: dict, accepted: list[Candidate]):
    """Backward check of the final model: every cause must still pass the acceptance rule when it
    is the last one added (a cause accepted early can become redundant after a later one, or after
    a time-like cause was removed by the wander check), a time-like one with the larger gain of
    :func:`_min_gain`. The weakest failure goes first."""
    while accepted:
        verdicts = [(*last_added_gain(ctx, state, cand), cand) for cand in accepted]
        failing = [v for v in verdicts if v[1] < _min_gain(v[2].cause) or v[0] < MIN_EVIDENCE]
        if not failing:
            break
        weakest = min(failing, key=lambda v: v[0])[2]
        accepted = [c for c in accepted if c is not weakest]
        state = {k: v for k, v in state.items() if k != weakest.cause}
    return state, accepted


def check_final(ctx: Context, state: dict, accepted: list[Candidate]):
    """:func:`check_against_noise` and :func:`prune` until neither removes a cause: a cause that
    passed the noise re-test beside another (each judged as the last one added) is judged again once
    prune has removed the other, on its own (a warm-up and a lag that share a flicker's slow part
    each pass beside the other; the lag alone does not)."""
    while True:
        before = set(state)
        state, accepted = check_against_noise(ctx, state, accepted)
        state, accepted = check_against_readout(ctx, state, accepted)
        state, accepted = prune(ctx, state, accepted)
        if set(state) == before:
            return state, accepted
