"""Parameter uncertainties from the log's own noise: the final model fitted again to itself plus
draws of the noise its residual shows (white, flicker, random walk: fxdsp.diagnose.noise).

Why not the jackknife alone: deleting one of 20 contiguous groups (or one interleaved fold) sees
noise that varies within a group; a random walk or a flicker that wanders over the whole log moves
an aging slope, a warm-up's time constant or a curvature as much as the effect's own size allows,
and leaves every group with the same tilt. On the independent generator's logs the jackknife put
the true value beyond 3 sds for 30 % of aging slopes and 55 % of warm-up time constants (issue 32
notes). The noise along the model's own columns cannot be seen in the residual, so it is read off
the noise model: the residual's slow part may be flicker or a walk, which the Allan variance of a
residual whose slow part the model has taken tells apart poorly, and a walk puts more of itself
along a drift; each interpretation is drawn and the larger sd is kept.

A searched parameter (a time constant) is searched again on every draw (a local grid around the
log's value, refined by a parabola), with the other causes' values held; the linear parameters
are refitted at the log's searched values. The sd is robust (half the central 68 % of the draws;
a time constant's on its log axis). The diagnosis reports, for each parameter, the larger of this
sd and the jackknife's (identify.judge reads it).
"""

from __future__ import annotations

import numpy as np

from fxdsp.diagnose.candidates import affected_channels, local_axis, searched_parameter
from fxdsp.diagnose.context import Context, residual
from fxdsp.diagnose.noise import allan_shapes, fit_levels, noise_draws
from fxdsp.diagnose.results import converter
from fxdsp.numeric import orthonormal_basis, parabolic_argmin

NOISE_SD_DRAWS = 40      # draws per noise interpretation (fixed seeds: same log, same report)
NOISE_SD_SEED = 20261129


def _draws(ctx: Context, state: dict) -> list[dict[str, tuple[np.ndarray, np.ndarray]]]:
    """Per noise interpretation (flicker and a walk; a walk alone): per channel a cause of ``state``
    affects, (the model's fitted values, noise draws [n, NOISE_SD_DRAWS]) in standardised units."""
    channels = [ch for ch in ctx.series.channels() if any(ch in affected_channels(ctx, c) for c in state)]
    fitted, shapes = {}, {}
    for ch in channels:
        resid = residual(ctx, state, ch)        # the final model's, as every other test reads it
        fitted[ch] = ctx.target(ch) - resid
        shapes[ch] = allan_shapes(resid, ctx.design(ch, state)[0])
    out = []
    for k, flicker in enumerate((True, False)):
        one = {}
        for j, ch in enumerate(channels):
            rng = np.random.default_rng([NOISE_SD_SEED, k, j])
            levels = fit_levels(*shapes[ch], flicker=flicker)
            one[ch] = (fitted[ch], noise_draws(rng, levels, NOISE_SD_DRAWS, fitted[ch].size).T)
        out.append(one)
    return out


def _linear_values(ctx: Context, state: dict, draws: dict) -> dict[str, dict[str, np.ndarray]]:
    """Each linear parameter of ``state``'s causes on every draw (the searched values held)."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for ch, (fitted, noise) in draws.items():
        x, names = ctx.design(ch, state)
        # the estimator the diagnosis reports: on the whitened rows when a filter is set
        coef = np.linalg.lstsq(ctx.whiten(ch, x), ctx.whiten(ch, fitted[:, None] + noise), rcond=None)[0]
        for cause in state:
            conv = converter(ctx, ch, cause, names)
            if conv is not None:
                pname, fn = conv
                out.setdefault(cause, {})[pname] = np.array([fn(c) for c in coef.T])
    return out


def _searched_values(ctx: Context, state: dict, cause: str, interpretations: list[dict]) -> list[np.ndarray]:
    """``cause``'s searched parameter on every draw of each interpretation: the weighted full-data SSE
    of its channels on a local grid around the log's value (within the search range; each design
    built once for all draws), each draw's minimum refined by a parabola."""
    pname = searched_parameter(cause)
    axis = local_axis(ctx, cause, state[cause][pname])
    channels = [ch for ch in affected_channels(ctx, cause) if ch in interpretations[0]]
    sse = np.zeros((len(interpretations), axis.size, NOISE_SD_DRAWS))
    # the draws as the fit sees them (whitened when a filter is set), once for every grid point
    targets = {(ch, k): ctx.whiten(ch, draws[ch][0][:, None] + draws[ch][1])
               for ch in channels for k, draws in enumerate(interpretations)}
    for i, a in enumerate(axis):
        trial = {**state, cause: {**state[cause], pname: float(np.exp(a))}}
        for ch in channels:
            q = orthonormal_basis(ctx.whiten(ch, ctx.design(ch, trial)[0]))
            for k in range(len(interpretations)):
                y = targets[ch, k]
                inside = q.T @ y
                sse[k, i] += (np.einsum("ij,ij->j", y, y) - np.einsum("ij,ij->j", inside, inside)) * ctx.weights[ch]
    return [np.exp([parabolic_argmin(axis, one[:, d]) for d in range(NOISE_SD_DRAWS)]) for one in sse]


def noise_sds(ctx: Context, state: dict) -> dict[str, dict[str, float]]:
    """Per cause of ``state``, per parameter: its sd over refits of the model plus draws of the
    residual's noise, the larger of the two interpretations of that noise (module docstring)."""
    out: dict[str, dict[str, float]] = {}
    if not state:
        return out
    interpretations = _draws(ctx, state)
    values = [_linear_values(ctx, state, draws) for draws in interpretations]
    for cause in state:
        pname = searched_parameter(cause)
        if pname is not None:
            for v, searched in zip(values, _searched_values(ctx, state, cause, interpretations)):
                v.setdefault(cause, {})[pname] = searched
    for one in values:
        for cause, params in one.items():
            for pname, v in params.items():
                sd = _spread(v, searched_parameter(cause) == pname)
                out.setdefault(cause, {})[pname] = max(out.get(cause, {}).get(pname, 0.0), sd)
    return out


def _spread(values: np.ndarray, log_axis: bool) -> float:
    """One sd of a parameter's draws, robustly: half the width of their central 68 % (a normal's
    +-1 sd), so a few draws whose time constant ran to the local grid's end do not decide it; a
    time constant's on its log axis (its draws are skewed: a factor either way, not seconds),
    turned back into seconds at the median."""
    lo, mid, hi = np.percentile(np.log(values) if log_axis else values, [15.87, 50.0, 84.13])
    half = 0.5 * float(hi - lo)
    return float(np.exp(mid) * half) if log_axis else half
