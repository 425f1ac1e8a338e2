"""Prewhitening for the final numbers: the causes' parameters by feasible generalised least squares.

The selection scores causes by held-out sums of squares in white-noise units: ordinary least squares
on the rows as logged. For the numbers that is the wrong estimator when the noise is coloured: a
random walk or a flicker puts most of the residual's variance at low frequencies, and ordinary least
squares weighs a slow stretch of it as heavily as the fast changes (a settling's first hour, a rate-
table step) that carry most of what the log says about a parameter. On the independent generator's
held-out warm-up log 5034 (white noise and a walk) the diagnosis's tau was off by 27 %, and so was an
ordinary fit told the true baseline (26 %); on the whitened rows it is off by 9 % (issue 32 notes).

So each channel's final model is fitted again on whitened rows: the noise its ordinary residual shows
is estimated as white + flicker + a random walk (fxdsp.diagnose.noise.band_levels, the model's columns
fitted out of the shapes, the flicker's band starting where it fits best), and the design and the target go through that noise's steady-state Kalman innovations
filter (white noise: no filter; a walk: close to differencing). Any fixed filter leaves the estimate
unbiased when the columns are right; one that whitens makes it efficient. Each channel's weight
becomes 1 / the variance of its whitened residual, so channels still add in units of their own noise.
The sds are taken of this estimator (the block jackknife and the noise draws, fxdsp.diagnose.
uncertainty) and bounded below by the ordinary fit's (the engine): the noise model comes from the same
log (a flicker fitted from one row on came out at about half its level on the generator's flicker
logs, which made the whitened fit's own sd too small; the band's edge is now searched, but the draws
of fxdsp.diagnose.uncertainty still take the flicker from one row on).

Not where a cause's column is not known row by row (fxdsp.causes ``column_uncertain``): hysteresis
and a ramp-rate term are dated from the thermometer's ramps, off by rows at every corner; the
quadrature readout carries its own white noise. Whitening weighs the fast changes, which is where
those errors are (hysteresis + ramp rate, independent 5018: h -2.43 -> -0.77 against a true -2.88;
two flicker quadrature leaks shrank by 30 and 37 %). Such a channel keeps ordinary least squares. The
rows are the log's own sample slots, as every other test of the diagnosis reads them.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
from scipy.linalg import solve_discrete_are
from scipy.signal import lfilter

from fxdsp.causes import CAUSES
from fxdsp.diagnose.context import Context, residual
from fxdsp.diagnose.noise import band_levels, flicker_times

# a noise component below this share of the white variance is left out of the filter (none left: white)
NEGLIGIBLE = 1e-9


def noise_prewhitener(levels: tuple[float, float, float], n: int):
    """The steady-state Kalman innovations filter (values, axis -> innovations) of white noise +
    flicker + a random walk at ``levels`` (fxdsp.diagnose.noise: white variance, the variance of every
    flicker component or of each, walk variance per row) on ``n`` rows; None when the noise is white.

    The state is the walk and the flicker's AR(1) components, x' = A x + w, y = c x + white. The
    predictor x^(t+1) = F x^t + L y_t, F = A - L c, gives innovations e = y - c x^, whose transfer
    function 1 - c (zI - F)^-1 L is applied as a sum of first-order sections over F's eigenvalues (one
    polynomial of that order would put its clustered poles near 1 outside the unit circle)."""
    white, flicker, walk = levels
    if not (white > 0 and np.isfinite([white, walk]).all() and np.isfinite(flicker).all()):
        return None
    phis, qs = [], []
    if walk > NEGLIGIBLE * white:
        phis.append(1.0)
        qs.append(walk)
    times = flicker_times(n)
    for t, v in zip(times, np.broadcast_to(flicker, times.shape)):
        if v > NEGLIGIBLE * white:
            phi = float(np.exp(-1.0 / t))
            phis.append(phi)
            qs.append(v * (1.0 - phi * phi))
    if not phis:
        return None
    a = np.diag(phis)
    c = np.ones((1, len(phis)))
    p = solve_discrete_are(a.T, c.T, np.diag(qs), np.array([[white]]))
    gain = a @ p @ c.T / float((c @ p @ c.T)[0, 0] + white)
    poles, vectors = np.linalg.eig(a - gain @ c)
    weights = (c @ vectors).ravel() * np.linalg.solve(vectors, gain).ravel()

    def innovations(values: np.ndarray, axis: int = 0) -> np.ndarray:
        # the prediction c x^ is a sum of first-order sections: w y(t-1) + pole * its previous value
        predicted = sum(w * lfilter([0.0, 1.0], [1.0, -pole], values, axis=axis) for pole, w in zip(poles, weights))
        return values - np.real(predicted)
    return innovations


@contextmanager
def prewhitened(ctx: Context, state: dict):
    """Every channel's fits whitened, while the block runs, by the innovations filter of the noise its
    residual under ``state`` shows (ordinary least squares; white, flicker and a walk, the model's
    columns fitted out of the shapes: fxdsp.diagnose.noise), and its weight 1 / the whitened
    residual's variance."""
    saved = dict(ctx.weights)
    filters = {}
    for ch in ctx.series.channels():
        if any(CAUSES[c].column_uncertain and CAUSES[c].channel == ch for c in state):
            continue
        whiten = noise_prewhitener(band_levels(residual(ctx, state, ch), ctx.design(ch, state)[0]), ctx.series.n)
        if whiten is not None:
            filters[ch] = whiten
    try:
        for ch, whiten in filters.items():
            ctx.whitening[ch] = whiten
            ctx.weights[ch] = 1.0 / (float(np.var(residual(ctx, state, ch, whitened=True))) or 1.0)
        yield filters
    finally:
        for ch in filters:
            ctx.whitening.pop(ch, None)
        ctx.weights.update(saved)
