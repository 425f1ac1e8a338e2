"""What remains unexplained (the contract's section 5): structure in the final model's residual that
the log's own noise would not give, the columns or time scales it follows, and its held-out size.

The list of causes is not the world: after the named causes are fitted, each channel's residual is
tested against families of shapes that no cause of the list has, or has only in part:

=================  ==============  =================================================================
family             against         columns added to the final model
=================  ==============  =================================================================
step               time_s          a level change at one instant (scanned over the log)
periodic           time_s          a sinusoid of 1 .. 24 cycles per log (scanned)
trend              time_s          time, time^2, time^3 (Legendre: a drift that is not a line)
temperature        temp_c          the thermometer^4, ^5 beyond the cubic baseline (^3, ^4 beyond a
                                   channel's line), and heating against cooling x (1, thermometer)
temperature rate   d(temp_c)/dt    dT/dt x (1, thermometer), |dT/dt|, and the thermometer through
                                   lags of a fiftieth and a tenth of the log (a second time constant)
rate               rate_dps        rate^2, |rate| (the output, with a rate table)
quadrature         quad            quad, quad^2, quad x thermometer (the output, with quad)
=================  ==============  =================================================================

The statistics weigh the noise as white plus a random walk (a local level), its ratio fitted by
maximum likelihood: every fit is generalised least squares on the steady-state Kalman innovations of
that noise (:func:`fxdsp.diagnose.context.innovations`), so a wander is weighed as noise, not taken
for a step or a drift. A family's statistic is its likelihood ratio, n log(SSE without / SSE with),
each side profiled over the noise ratio (and, for a scanned family, maximised over the scan).

Calibration: the log's own noise is estimated from the residual as white noise, flicker (a sum of
AR(1) processes of equal variance, correlation times from one row to three times the log, spaced by
sqrt(10): 1/f) and a random walk, by fitting the three Allan-variance shapes to the residual's
robust Allan variance (medians of squared differences of adjacent means: a step moves a few of
them, not the median). DRAWS series of that noise (fixed seed: the same log gives the same answer)
go through the same statistics; each family's ratio is standardised by its null median and spread
(90 % point minus median), and a channel's structure is significant when the largest standardised
ratio exceeds the 1 - LEVEL / k point (k: the channels tested) of a Gumbel law fitted to the same
maximum over the draws. The split of the slow noise between flicker and a walk rests on the few
long-tau Allan points of one log, and a walk taken for flicker would make the log's own wander look
like a drift: a family is significant only when it is against two nulls, the fitted noise and the
residual's noise fitted as white and a walk alone, and its p-value is the larger of the two. The
families are taken in turn (forward selection): the most significant one joins the model and the
others are tested again on top of it, so one effect is reported once.

Rows next to a ramp's start or end (within half the first derivative's window, two sampling
intervals and two time constants of the corners' rounding by the chamber's air lag: fxdsp.ramps,
RampReading.unresolved) are set aside: a reading cannot date a corner to the row, nor say where in
its rounded stretch the chamber turned (a hysteresis state dated from the setpoint or from the
reading differs there), and a model right to within that leaves a spike of a few rows at each
corner that a step would otherwise be taken for.

The same test runs on a series that is itself a held-out error (series_structure: ``fxdsp extend``'s
compensated output before and after its remedies), on top of a cubic in temp_c instead of a model.

The size is held-out: the significant families' columns are fitted to the held-out residual on the
training folds and predict the held-out folds; ``rms`` is the square root of the held-out sum of
squares they remove, per row, in the channel's unit. Structure no larger than MIN_SIZE times the
channel's white noise, or than the resolution of a quantised reading (q / sqrt(12), the reading's
and its thermometer's through the channel's slope), is not reported as significant: the channel's
entry in ``channels`` keeps what was found and why it was set aside.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from fxdsp import mechanisms as mech
from fxdsp.causes import CAUSES
from fxdsp.diagnose.blockfit import SegmentNormals
from fxdsp.diagnose.context import MIN_EVIDENCE, MIN_GAIN, Context, innovations, level_gain, white_noise_variance
from fxdsp.diagnose.results import channel_gain, heldout_residuals
from fxdsp.diagnose.noise import noise_draws, noise_levels
from fxdsp.numeric import orthonormal_basis
from fxdsp.diagnose.selection import last_added_gain
from fxdsp.ramps import quantisation_step

LEVEL = 0.01            # the contract's 1 % level, over the whole report
DRAWS = 64              # null series (white noise, flicker, random walk) per channel and round
SEED = 20261128
MAX_ROWS = 1500         # longer logs are tested on means of consecutive rows (slow shapes keep their
                        # size, the white noise averages down, the random walk stays a random walk)
MAX_FOUND = 3           # families reported per channel at most (forward selection)
EDGE_ROWS = 3           # a step is not looked for in the first and last rows (a warm-up's or the end's)
MAX_CYCLES = 24         # periodic terms scanned: 1 .. 24 cycles per log (at most rows / 10)
# random-walk to white variance ratios per row over which the likelihood is profiled (0: white)
WALK_RATIOS = (0.0, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0)
# the thermometer powers beyond each channel's contract polynomial (cubic B and S; linear freq, temp)
POWERS = {"output": (4, 5), "freq_hz": (3, 4), "temp_c": (3, 4)}
# the share of the log the second-time-constant lags take
LAG_SHARES = (0.02, 0.1)
# the smallest structure reported, in units of the channel's white noise per reading (rms): the
# effects the list misses are several times the noise; below half of it, what is left is a named
# cause's parameter a little off or a reading's resolution, nothing a calibration changes for
MIN_SIZE = 0.5


@dataclass
class Family:
    """Columns tested together (``width`` 0), or candidates of which the best is taken: a step at
    every row (``width`` 1: no columns, the scan is a filter) or pairs of columns (``width`` 2)."""

    name: str
    against: str
    columns: np.ndarray                      # [rows, k] (fixed), [rows, 0] (steps), [rows, 2 * candidates]
    width: int = 0
    labels: list = field(default_factory=list)  # per candidate: what it is (a period; steps: none)


@dataclass
class Structure:
    """One channel's verdict."""

    channel: str
    significant: bool
    rms: float
    fraction: float
    against: list
    found: list                              # (family name, what it looks like) of significant families
    statistic: float                         # the largest standardised likelihood ratio
    threshold: float
    p_value: float
    curve: np.ndarray | None = None          # the structure found, at every row, in the channel's unit
    parts: np.ndarray | None = None          # [rows, found]: each family's share of ``curve``
    note: str = ""                           # why a channel was not tested

    def as_dict(self) -> dict:
        return {"channel": self.channel, "significant": self.significant, "rms": self.rms,
                "fraction": self.fraction, "against": list(self.against),
                "found": [w for _, w in self.found], "statistic": round(self.statistic, 3),
                "threshold": round(self.threshold, 3), "p_value": float(f"{self.p_value:.3g}"),
                **({"note": self.note} if self.note else {})}


# -- the families -----------------------------------------------------------------------------------
def _thermometer(ctx: Context, channel: str) -> np.ndarray:
    """The temperature a channel is fitted against, as logged: temp_c for the output, the resonator's
    thermometer for freq_hz, the reference for temp_c."""
    s = ctx.series
    return {"output": s.temp, "freq_hz": s.freq_thermometer, "temp_c": s.ref}[channel]


def families(ctx: Context, channel: str) -> list[Family]:
    """The shapes a channel's residual is tested against (columns at every row of the log)."""
    s = ctx.series
    n = s.n
    u = (s.t - s.t[0]) / max(s.duration, 1e-300)
    raw = _thermometer(ctx, channel)
    x = ctx.scales[channel](raw)
    out = []
    if n > 2 * EDGE_ROWS + 1:
        out.append(Family("step", "time_s", np.empty((n, 0)), 1))
    cycles = np.arange(1, min(MAX_CYCLES, n // 10) + 1)
    if cycles.size:
        phase = 2.0 * np.pi * u[:, None] * cycles[None, :]
        cols = np.empty((n, 2 * cycles.size))
        cols[:, 0::2], cols[:, 1::2] = np.cos(phase), np.sin(phase)
        out.append(Family("periodic", "time_s", cols, 2, [s.duration / k for k in cycles]))
    v = 2.0 * u - 1.0
    out.append(Family("trend", "time_s", np.column_stack([v, 1.5 * v * v - 0.5, 2.5 * v ** 3 - 1.5 * v])))
    moving = float(np.ptp(s.temp)) > 0
    if moving:
        cols = [x ** p for p in POWERS[channel]]
        if np.any(s.hyst != 0):
            cols += [s.hyst, s.hyst * x]
        out.append(Family("temperature", "temp_c", np.column_stack(cols)))
        cols = [s.dtdt, s.dtdt * x, np.abs(s.dtdt)]
        cols += [mech.first_order_lag(s.t, raw, share * s.duration) - raw for share in LAG_SHARES]
        out.append(Family("temperature rate", "d(temp_c)/dt", np.column_stack(cols)))
    if channel == "output" and ctx.has_rate:
        out.append(Family("rate", "rate_dps", np.column_stack([s.rate ** 2, np.abs(s.rate)])))
    if channel == "output" and s.quad is not None and float(np.ptp(s.quad)) > 0:
        q = s.quad - np.mean(s.quad)
        out.append(Family("quadrature", "quad", np.column_stack([q, q * q, q * x])))
    return out


# -- the statistics -------------------------------------------------------------------------------
def _unit(a: np.ndarray) -> np.ndarray:
    rms = np.sqrt(np.mean(a * a, axis=0))
    return a / np.where(rms > 0, rms, 1.0)


def _reverse_filter(values: np.ndarray, r: float, axis: int) -> np.ndarray:
    """out[j] = sum over t >= j of values[t] r^(t - j): the inner product of a series with the
    innovations of a unit step at every row j at once (a step's innovations decay as r^(t - j),
    r = 1 - gain)."""
    flipped = np.flip(values, axis=axis)
    return np.flip(lfilter([1.0], [1.0, -r], flipped, axis=axis), axis=axis)


def _block_means(a: np.ndarray, m: int) -> np.ndarray:
    n = a.shape[0] // m * m
    return a[:n].reshape(n // m, m, *a.shape[1:]).mean(axis=1)


@dataclass
class _Prepared:
    """The model's and the families' columns through one noise ratio's innovation filter (they do
    not depend on the series tested: computed once for the log and its null draws)."""

    gain: float
    basis: np.ndarray                       # orthonormal basis of the filtered model columns
    parts: list                             # per family: what its SSE drop needs


def _prepare(x: np.ndarray, fams: list[Family]) -> list[_Prepared]:
    out = []
    for ratio in WALK_RATIOS:
        gain = level_gain(ratio)
        q = orthonormal_basis(innovations(x, gain, axis=0))
        parts = []
        for fam in fams:
            if fam.width == 1:
                # a step at row j: its innovations are r^(t - j) from j on; their squared norm, less
                # what the model's columns already hold of them, for every j
                r = 1.0 - gain
                n = x.shape[0]
                rows_left = n - np.arange(n)
                norm2 = rows_left.astype(float) if r == 1.0 else (1.0 - r ** (2 * rows_left)) / (1.0 - r * r)
                diag = norm2 - np.sum(_reverse_filter(q, r, axis=0) ** 2, axis=1)
                valid = np.zeros(n, dtype=bool)
                valid[EDGE_ROWS:n - EDGE_ROWS] = True
                ok = valid & (diag > 1e-9 * np.max(np.abs(diag[valid])))
                parts.append((r, np.where(ok, 1.0 / np.where(ok, diag, 1.0), 0.0)))
                continue
            c = innovations(fam.columns, gain, axis=0)
            if fam.width == 0:
                parts.append(orthonormal_basis(c - q @ (q.T @ c), 1e-7))
                continue
            proj = q.T @ c
            diag = np.einsum("ij,ij->j", c, c) - np.einsum("ij,ij->j", proj, proj)
            # pairs (cos, sin): the inverse of each candidate's 2 x 2 Gram matrix (after the model)
            cs = np.einsum("ij,ij->j", c[:, 0::2], c[:, 1::2]) - np.einsum("ij,ij->j", proj[:, 0::2], proj[:, 1::2])
            gcc, gss = diag[0::2], diag[1::2]
            det = gcc * gss - cs * cs
            ok = det > 1e-9 * np.max(np.abs(gcc * gss))
            inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
            parts.append((c, (gss * inv, -cs * inv, gcc * inv)))
        out.append(_Prepared(gain, q, parts))
    return out


def _drops(y: np.ndarray, prep: _Prepared, fams: list[Family]):
    """Per series (rows of ``y``): the SSE of the model's innovations and, per family, the largest
    SSE drop its columns give (and, per series, the scanned candidate that gives it)."""
    yt = innovations(y, prep.gain, axis=1)
    q = prep.basis
    resid = yt - (yt @ q) @ q.T
    sse = np.einsum("ij,ij->i", resid, resid)
    drops, best = [], []
    for fam, part in zip(fams, prep.parts):
        if fam.width == 0:
            a = resid @ part
            drops.append(np.einsum("ij,ij->i", a, a))
            best.append(np.zeros(y.shape[0], dtype=int))
            continue
        if fam.width == 1:
            r, w = part
            a = _reverse_filter(resid, r, axis=1)
            d = a * a * w[None, :]
        else:
            c, w = part
            a = resid @ c
            ac, as_ = a[:, 0::2], a[:, 1::2]
            d = w[0] * ac * ac + 2.0 * w[1] * ac * as_ + w[2] * as_ * as_
        d = np.minimum(d, sse[:, None])
        best.append(np.argmax(d, axis=1))
        drops.append(np.max(d, axis=1))
    return sse, np.array(drops), np.array(best)


def _ratios(y: np.ndarray, prepared: list[_Prepared], fams: list[Family]):
    """(likelihood ratio per family and series, and each family's best candidate for the first series
    at the walk ratio where that family fits it best)."""
    n = y.shape[1]
    sse0 = np.empty((len(prepared), y.shape[0]))
    sse1 = np.empty((len(prepared), len(fams), y.shape[0]))
    picks = []
    for i, prep in enumerate(prepared):
        s0, d, best = _drops(y, prep, fams)
        sse0[i], sse1[i] = s0, s0[None, :] - d
        picks.append(best[:, 0])
    tiny = 1e-300
    lr = n * (np.log(np.maximum(sse0.min(axis=0), tiny))[None, :] - np.log(np.maximum(sse1.min(axis=0), tiny)))
    at = np.argmin(sse1[:, :, 0], axis=0)
    first = [int(picks[int(at[k])][k]) for k in range(len(fams))]
    return np.maximum(lr, 0.0), first


def _gumbel(maxima: np.ndarray) -> tuple[float, float]:
    """Location and scale of the Gumbel law with the mean and spread of ``maxima`` (the null's largest
    standardised ratios): a far tail that DRAWS draws alone would only rank, extrapolated smoothly."""
    beta = max(float(np.std(maxima)), 1e-9) * np.sqrt(6.0) / np.pi
    return float(np.mean(maxima)) - 0.5772156649 * beta, beta


def _gumbel_quantile(maxima: np.ndarray, p: float) -> float:
    mu, beta = _gumbel(maxima)
    return float(mu - beta * np.log(-np.log(p)))


def _gumbel_tail(maxima: np.ndarray, z: float) -> float:
    """P(max > z) under the same law: the p-value the threshold is the LEVEL / k point of."""
    mu, beta = _gumbel(maxima)
    return float(-np.expm1(-np.exp(-(z - mu) / beta)))


def _standardised(y: np.ndarray, x: np.ndarray, fams: list[Family], n_channels: int, nulls: list[tuple]):
    """Each family's standardised likelihood ratio on top of the model ``x`` against each null, the
    threshold of the largest at the report's level, the null's largest standardised ratios (the law
    of that threshold and of a p-value, :func:`_gumbel_tail`), and per family its best candidate;
    a null is noise at its levels (:func:`fxdsp.diagnose.noise.noise_levels`, per tested row: fitted
    to the tested rows put end to end, as the null is drawn). The model's and the families' filtered
    columns and the observed ratios do not depend on the null: computed once."""
    prepared = _prepare(x, fams)
    lr_obs, picks = _ratios(y, prepared, fams)
    n = y.shape[1]
    out = []
    for levels in nulls:
        rng = np.random.default_rng([SEED, n, x.shape[1]])
        null_y = noise_draws(rng, levels, DRAWS, n)
        lr_null, _ = _ratios(null_y, prepared, fams)
        med = np.median(lr_null, axis=1)
        spread = np.maximum(np.quantile(lr_null, 0.9, axis=1) - med, 1e-9)
        z_obs = (lr_obs[:, 0] - med) / spread
        z_null = ((lr_null - med[:, None]) / spread[:, None]).max(axis=0)
        out.append((z_obs, _gumbel_quantile(z_null, 1.0 - LEVEL / n_channels), z_null))
    return out, picks


def channel_structure(ctx: Context, state: dict, channel: str, n_channels: int) -> Structure:
    """The structure left in one channel of the final model ``state``."""
    x_full, _ = ctx.design(channel, state)
    before = channel_gain(ctx, {}, channel)["rms_before"]
    return _structure(ctx, channel, x_full, ctx.target(channel), heldout_residuals(ctx, state, channel),
                      np.ones(ctx.series.n, dtype=bool), n_channels, ctx.norm[channel][1], before)


def series_structure(ctx: Context, series: np.ndarray, rows: np.ndarray, reference: float) -> Structure:
    """The structure left in a series of the output's unit that is itself a held-out error (``fxdsp
    extend``'s compensated output against the applied rate, before and after a compensation), on its
    held-out ``rows``: the output's families on top of what a recalibration would absorb (a cubic in
    temp_c), with the same statistics, calibration and size floor; ``fraction`` is of ``reference``."""
    series = np.asarray(series, float)
    x = ctx.scales["output"](ctx.series.temp)
    model = np.column_stack([np.ones_like(x), x, x * x, x ** 3])
    rows = np.asarray(rows, bool)
    scale = float(np.std(series[rows])) or 1.0
    return _structure(ctx, "output", model, series / scale, series, rows, 1, scale, reference, fitted_model=False)


def _structure(ctx: Context, channel: str, x_full: np.ndarray, y_full: np.ndarray, resid: np.ndarray,
               rows: np.ndarray, n_channels: int, sd_y: float, before: float, fitted_model: bool = True) -> Structure:
    """The families of ``channel`` tested on ``y_full`` (in units of ``sd_y``) on top of the model
    ``x_full``, on ``rows``; ``resid``: the held-out residual (the channel's unit) the size is
    measured on; ``before``: what ``fraction`` is of; ``fitted_model``: the model is the diagnosis's
    (the words then say what its causes do not follow, and MAX_FOUND families are reported at most),
    not a bare cubic (every significant family is: what a compensation removed is among them, and
    the size is measured on ``rows`` alone, :func:`_heldout_rms`)."""
    fams = families(ctx, channel)
    # the rows next to a ramp's corners are set aside: there the reading cannot date the corner to
    # the row, nor follow dT/dt's turn (fxdsp.ramps: RampReading.unresolved), and a model right to
    # within that leaves a spike of a few rows at each corner (a hysteresis state one row late is
    # 2 h on that row) that a step or a rate shape would take for structure
    keep = rows & ~ctx.series.ramps.unresolved(ctx.series.t)
    if keep.sum() < max(2 * EDGE_ROWS + 10, int(rows.sum()) // 2):
        keep = rows.copy()
    m = -(-int(keep.sum()) // MAX_ROWS)
    mean = (lambda a: _block_means(a[keep], m)) if m > 1 else (lambda a: a[keep])
    x = mean(x_full)
    y = mean(y_full)[None, :]
    tested = [Family(f.name, f.against, _unit(mean(f.columns)) if f.width != 1 else mean(f.columns), f.width,
                     f.labels) for f in fams]
    if not float(np.var(y)) > 0 or not tested:
        return Structure(channel, False, 0.0, 0.0, [], [], 0.0, 0.0, 1.0,
                         note="not tested: the channel does not vary" if tested else "not tested: no shape applies")
    # forward selection: the most significant family joins the model (its best candidate), and the
    # others are tested again on top of it, so that one effect is reported once, by the family that
    # fits it best, and not again by every family that overlaps it
    chosen, first = [], None
    left = list(range(len(fams)))
    # the noise of the residual of the model as it stands, its levels fitted with shapes that went
    # through the same model (kept for the later rounds: a found shape's columns would take more of
    # the slow noise with them each round)
    r0 = y[0] - x @ np.linalg.lstsq(x, y[0], rcond=None)[0]
    # two nulls: one log's few long-tau Allan points set the slow noise's split between flicker and
    # a random walk poorly, and a walk taken for flicker makes the log's wander look like a drift or
    # a periodic term; a shape is significant only against both the fitted noise and the same
    # residual's noise fitted as white and a walk alone (the same null when no flicker is fitted)
    levels = noise_levels(r0, x)
    nulls = [levels] + ([noise_levels(r0, x, flicker=False)] if levels[1] > 0 else [])
    while left and (len(chosen) < MAX_FOUND or not fitted_model):
        fam_left = [tested[k] for k in left]
        verdicts, picks = _standardised(y, x, fam_left, n_channels, nulls)
        # the family furthest over its threshold against the null that holds it back most, and that
        # null's verdict on it (its p-value is the larger: significant against one null alone is not)
        margin = np.min([z - thr for z, thr, _ in verdicts], axis=0)
        best = int(np.argmax(margin))
        z_obs, threshold, p_value = max(((z[best], thr, _gumbel_tail(zn, float(z[best])))
                                         for z, thr, zn in verdicts), key=lambda v: v[2])
        if first is None:
            first = (float(z_obs), threshold, p_value)
        if not margin[best] > 0:
            break
        k = left.pop(best)
        f, j = fams[k], picks[best]
        if f.width == 1:  # the step at the first (kept) row of the j-th mean
            t = ctx.series.t
            at = float(t[keep][j * m])
            full, small, label = (t >= at).astype(float)[:, None], (np.arange(x.shape[0]) >= j)[:, None], at
        elif f.width == 2:
            full, small, label = f.columns[:, 2 * j:2 * j + 2], tested[k].columns[:, 2 * j:2 * j + 2], f.labels[j]
        else:
            full, small, label = f.columns, tested[k].columns, None
        chosen.append((f, full, label))
        x = np.column_stack([x, small.astype(float)])
    statistic, threshold, p_value = first
    if not chosen:
        return Structure(channel, False, 0.0, 0.0, [], [], statistic, threshold, p_value)
    # the chosen families' columns at every row and their size
    cols = np.column_stack([c for _, c, _ in chosen])
    # the size, on every row, by least squares with the model: the level before and after a step
    # (a fit weighted for a wander would give the jump between two neighbouring rows instead)
    fitted = np.linalg.lstsq(np.column_stack([x_full, cols])[keep], y_full[keep], rcond=None)[0][x_full.shape[1]:]
    found, offset = [], 0
    for f, c, label in chosen:
        coef = fitted[offset:offset + c.shape[1]] * sd_y
        offset += c.shape[1]
        found.append((f.name, _describe(f, coef, label, channel, fitted_model)))
    # the structure as the final model leaves it: the chosen columns fitted to the model's residual
    # (the model's own coefficients kept; refitted together, a column nearly collinear with a named
    # cause's term, such as a short lag's dT/dt, would take the cause's share with it)
    resid_full = y_full - x_full @ np.linalg.lstsq(x_full[keep], y_full[keep], rcond=None)[0]
    centred = cols - cols[keep].mean(axis=0)
    coef = np.linalg.lstsq(centred[keep], resid_full[keep], rcond=None)[0] * sd_y
    widths = np.cumsum([0] + [c.shape[1] for _, c, _ in chosen])
    parts = np.column_stack([centred[:, a:b] @ coef[a:b] for a, b in zip(widths[:-1], widths[1:])])
    curve = parts.sum(axis=1)
    rms = _heldout_rms(ctx, resid, cols, keep, own_folds=not fitted_model)
    floor = max(resolution(ctx, channel), MIN_SIZE * np.sqrt(white_noise_variance(resid[keep])))
    if rms <= floor:
        # smaller than half the white noise of one reading: a named cause's parameter a little off,
        # a reading on a grid coarser than its noise erring by a fixed amount through each dwell; a
        # pattern, but not an effect a calibration would change for
        return Structure(channel, False, 0.0, 0.0, [], [], statistic, threshold, p_value,
                         note=f"structure of held-out rms {rms:.3g} found, at or below the size floor {floor:.3g}")
    against = sorted({f.against for f, _, _ in chosen}, key=_AGAINST_ORDER.index)
    return Structure(channel, True, rms, rms / before if before > 0 else 0.0, against, found,
                     statistic, threshold, p_value, curve, parts)


_AGAINST_ORDER = ["time_s", "temp_c", "d(temp_c)/dt", "rate_dps", "quad"]


def _describe(f: Family, coef: np.ndarray, label, channel: str, fitted_model: bool = True) -> str:
    if f.name == "step":
        return f"a step of about {coef[0]:+.3g} in {channel} at t = {label / 3600.0:.3g} h"
    if f.name == "periodic":
        return (f"a periodic term in {channel} of about {float(np.hypot(*coef)):.3g} amplitude and "
                f"{label / 3600.0:.3g} h period")
    if not fitted_model:   # on top of a cubic in temp_c alone
        return {"trend": f"a drift of {channel} in time",
                "temperature": f"structure of {channel} against temp_c beyond a cubic (a heating/cooling offset, "
                               "a higher power)",
                "temperature rate": f"structure of {channel} against d(temp_c)/dt (a ramp-rate term, a thermal lag)",
                "rate": f"structure of {channel} against rate_dps (rate^2, |rate|)",
                "quadrature": f"structure of {channel} against quad (a leak)"}[f.name]
    return {"trend": f"a drift of {channel} in time that is not a straight line",
            "temperature": f"structure of {channel} against temp_c beyond the baseline's polynomial and a "
                           "constant heating/cooling offset",
            "temperature rate": f"structure of {channel} against d(temp_c)/dt that one ramp-rate term and one "
                                "lag time constant do not follow",
            "rate": f"structure of {channel} against rate_dps beyond S (rate + k3 rate^3)",
            "quadrature": f"structure of {channel} against quad beyond a constant leak"}[f.name]


def resolution(ctx: Context, channel: str) -> float:
    """The rms error of the channel's reading and of its thermometer's (through the channel's slope
    against it) when they sit on a grid (quantised): q / sqrt(12) each; 0 for readings off a grid."""
    s = ctx.series
    y = s.target(channel)
    raw = _thermometer(ctx, channel)
    q_y, q_x = quantisation_step(y), quantisation_step(raw)
    slope = abs(float(np.polyfit(raw - np.mean(raw), y, 1)[0])) if q_x > 0 and np.ptp(raw) > 0 else 0.0
    return float(np.hypot(q_y, slope * q_x) / np.sqrt(12.0))


def _heldout_rms(ctx: Context, r: np.ndarray, cols: np.ndarray, keep: np.ndarray, own_folds: bool = False) -> float:
    """Root mean square, per row, of the held-out sum of squares that ``cols`` remove from the final
    model's held-out residual ``r`` (fitted on the training folds), in the channel's unit, over the
    rows ``keep`` (the others weigh nothing: zero rows). ``own_folds``: ``r`` is itself a held-out
    error measured on a few stretches of the log (``fxdsp extend``'s rows outside the rate tables),
    where folds leave whole stretches with no training row near them and a column fitted elsewhere
    is extrapolated there (one fold's error a hundred times the others'); the size is then the
    in-sample sum of squares the columns remove less what p columns take from noise alone
    (p sigma^2, sigma^2 from the fit's own residual)."""
    if own_folds:
        y = r[keep] - r[keep].mean()
        x = cols[keep] - cols[keep].mean(axis=0)
        coef, _, p, _ = np.linalg.lstsq(x, y, rcond=None)
        sse1 = float(np.sum((y - x @ coef) ** 2))
        removed = float(np.sum(y * y)) - sse1 - p * sse1 / max(y.size - p - 1, 1)
        return float(np.sqrt(max(removed, 0.0) / max(y.size, 1)))
    w = keep.astype(float)
    ones = w[:, None]
    without = SegmentNormals(ones, r * w, ctx.blocks).folds()[1].sum()
    with_ = SegmentNormals(np.column_stack([ones, cols * w[:, None]]), r * w, ctx.blocks).folds()[1].sum()
    return float(np.sqrt(max(without - with_, 0.0) / max(int(keep.sum()), 1)))


# -- the report's object ----------------------------------------------------------------------------
def remaining(ctx: Context, state: dict, gain: dict, named: list[str]) -> tuple[dict, list[Structure]]:
    """The contract's ``remaining`` object (with ``channels``: each channel's verdict), and the
    verdicts themselves (their fitted structure, for the plots)."""
    channels = ctx.series.channels()
    verdicts = [channel_structure(ctx, state, ch, len(channels)) for ch in channels]
    main = next(v for v in verdicts if v.channel == gain["channel"])
    significant = [v for v in verdicts if v.significant]
    against = sorted({a for v in significant for a in v.against}, key=_AGAINST_ORDER.index)
    return {"significant": bool(significant), "rms": main.rms,
            "fraction": main.rms / gain["rms_before"] if gain["rms_before"] > 0 else 0.0,
            "against": against, "explanation": _explanation(significant, named, ctx.series.freq is not None),
            "channels": {v.channel: v.as_dict() for v in verdicts}}, verdicts


def _claims(record, v: Structure, has_freq: bool) -> bool:
    """Whether a cause claims the structure ``v`` left: it acts in that channel, and its signature
    is among what the structure follows."""
    return v.channel in record.channels(has_freq) and record.signature in v.against


def absorbing_only(ctx: Context, state: dict, accepted: list, structures: list[Structure]) -> dict[str, str]:
    """The named causes that pass only by absorbing part of a structure left in their channel whose
    kind they claim (their record's ``signature`` among its ``against``): tested again as the last one
    added with that structure in the model, the cause fails the acceptance rule, and the structure
    without the cause predicts the held-out data better (by the evidence a cause needs) than the
    cause without the structure. Cause -> what it absorbs, in words."""
    out = {}
    for v in structures:
        if not v.significant:
            continue
        for cand in accepted:
            record = CAUSES[cand.cause]
            if not _claims(record, v, ctx.series.freq is not None):
                continue
            # the structure as one shape per family found, each its size free: fitted with the cause
            # in the model, it is what the cause does not explain (the families' own columns would
            # hold the cause's term itself: dT/dt, time, the heating/cooling state; one shape for all
            # of them would tie a step's size to a small periodic term's found beside it)
            without = {k: x for k, x in state.items() if k != cand.cause}
            ctx.nuisance[v.channel] = v.parts
            try:
                evidence, ratio = last_added_gain(ctx, state, cand)
                shape_alone = ctx.normals(v.channel, without)[0].folds()[1].sum()
            finally:
                ctx.nuisance.pop(v.channel, None)
            cause_alone = ctx.normals(v.channel, state)[0].folds()[1].sum()
            # not named when it adds nothing once the shape is modelled, and the shape without it
            # predicts the held-out data clearly better than it does without the shape
            if (ratio < MIN_GAIN or evidence < MIN_EVIDENCE) and shape_alone < cause_alone - MIN_EVIDENCE:
                out[cand.cause] = "; ".join(w for _, w in v.found)
    return out


def _nothing(noise: str) -> str:
    return (f"nothing beyond {noise} (white, flicker and random walk, fitted to the residual) at the "
            f"{100 * LEVEL:g} % level and at least {MIN_SIZE:g} of the white noise in size")


def series_explanation(v: Structure) -> str:
    """The words for the verdict of :func:`series_structure`: what the series follows, or nothing."""
    return "; ".join(w for _, w in v.found) if v.significant else _nothing("the error's own noise")


def _explanation(significant: list[Structure], named: list[str], has_freq: bool) -> str:
    if not significant:
        return _nothing("the log's own noise")
    parts = []
    for v in significant:
        claimed = [c for c in named if _claims(CAUSES[c], v, has_freq)]
        what = "; ".join(w for _, w in v.found)
        if claimed:
            # named, and still supported with this structure in the model (absorbing_only): a real
            # cause of the same kind beside an effect it does not explain
            names = " and ".join(claimed)
            parts.append(f"{what} (beside the named {names}, which {'does' if len(claimed) == 1 else 'do'} "
                         "not explain it)")
        else:
            parts.append(f"{what} (no cause in the list explains it)")
    return "; ".join(parts)
