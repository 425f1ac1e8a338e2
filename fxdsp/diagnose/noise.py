"""The noise of a log's residual as white noise, flicker and a random walk: estimated from its robust
Allan variance, and drawn again (the null the diagnosis's tests are calibrated on).

Flicker is a sum of AR(1) processes of equal variance whose correlation times run from one row to
three times the series, spaced by sqrt(10): a 1/f spectrum over the whole band. The three shapes of
the Allan variance (white a / tau, the flicker construction's, the walk's q tau / 3) are fitted to the
residual's Allan variance taken robustly (medians of squared differences of adjacent means: a step
or an outlier moves a few differences, not the median), by non-negative least squares weighted to
equal relative errors. The whitening of the final numbers (fxdsp.diagnose.whitening) and the noise
re-test of the selection (fxdsp.diagnose.selection.check_against_noise) ask for the flicker's band
(:func:`band_levels`: its lower edge where the fit is best); the nulls of what remains and the draws
of the uncertainties keep the flicker from one row on (:func:`noise_levels`).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.signal import lfilter

from fxdsp.numeric import orthonormal_basis

FLICKER_RATIO = np.sqrt(10.0)   # correlation times of the flicker's AR(1) components, from 1 row on


def flicker_times(n: int) -> np.ndarray:
    """Correlation times (rows) of the AR(1) components whose equal-variance sum is the flicker: from
    one row to three times the series, spaced by sqrt(10) (a 1/f spectrum over the whole band)."""
    k = int(np.ceil(np.log(3.0 * n) / np.log(FLICKER_RATIO))) + 1
    return FLICKER_RATIO ** np.arange(k)


def _ar1_avar(phi: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Allan variance at ``tau`` rows of a unit-variance AR(1) of coefficient ``phi`` (closed form:
    the variance of a tau-mean less the covariance of two adjacent ones)."""
    phi, tau = np.asarray(phi, float)[:, None], np.asarray(tau, float)[None, :]
    one = 1.0 - phi
    inside = tau * (1.0 + phi) / one - 2.0 * phi * (1.0 - phi ** tau) / one ** 2
    across = phi * (1.0 - phi ** tau) ** 2 / one ** 2
    return (inside - across) / tau ** 2


def _flicker_avar(n: int, tau: np.ndarray) -> np.ndarray:
    """Allan variance of the flicker construction with unit variance per component."""
    return _ar1_avar(np.exp(-1.0 / flicker_times(n)), tau).sum(axis=0)


def allan_levels(resid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(tau in rows, robust Allan variance): tau = 1, 2, 4 ... while at least 8 means fit; each from
    the median squared difference of adjacent non-overlapping means (a step or an outlier moves a few
    differences, not the median). ``resid`` may hold several series along its last axis: one row of
    Allan variances each."""
    resid = np.asarray(resid, float)
    n = resid.shape[-1]
    taus, avar = [], []
    tau = 1
    while n // tau >= 8:
        means = resid[..., :n // tau * tau].reshape(*resid.shape[:-1], -1, tau).mean(axis=-1)
        d = np.diff(means, axis=-1)
        taus.append(tau)
        avar.append(0.5 * np.median(d * d, axis=-1) / 0.4549)
        tau *= 2
    return np.array(taus, float), np.moveaxis(np.array(avar, float), 0, -1)


# unit series of each kind drawn to learn its Allan variance once a model's columns are fitted out
SHAPE_DRAWS = 8
SHAPE_SEED = 20261128


@lru_cache(maxsize=4)
def _unit_draws(n: int) -> np.ndarray:
    """[kind, draw, row] unit white noise, flicker and random walk of ``n`` rows (the same for every
    residual of that length: drawn once, read only)."""
    rng = np.random.default_rng([SHAPE_SEED, n])
    out = np.stack([noise_draws(rng, levels, SHAPE_DRAWS, n)
                    for levels in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))])
    out.flags.writeable = False
    return out


def _projected_shapes(x: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """[tau, kind] robust Allan variance of unit white noise, flicker and random walk after the
    columns ``x`` are fitted out of them by least squares, as they are out of a residual (a model
    with slow columns, a drift, a warm-up, a cubic in a temperature that moves once, takes the slow
    part of a random walk or a flicker with it: the residual's Allan variance then falls at long tau,
    and shapes fitted as if nothing were taken would put the noise's level too low there)."""
    return _fitted_out(_unit_draws(x.shape[0]), x, taus.size)


def _fitted_out(draws: np.ndarray, x: np.ndarray, n_taus: int) -> np.ndarray:
    """[tau, kind] mean robust Allan variance (first ``n_taus``) of ``draws`` [kind, draw, row] once
    the columns ``x`` are fitted out of each."""
    q = orthonormal_basis(x)
    return allan_levels(draws - (draws @ q) @ q.T)[1][..., :n_taus].mean(axis=1).T


def noise_levels(resid: np.ndarray, x: np.ndarray | None = None, flicker: bool = True) -> tuple[float, float, float]:
    """(white variance, flicker variance per component, random-walk variance per row) of a residual:
    its robust Allan variance fitted, by non-negative least squares weighted to equal relative errors,
    with the three shapes (a / tau, the flicker construction's, q tau / 3); with ``x``, the model
    columns the residual was fitted on, the shapes are those of each noise with ``x`` fitted out;
    ``flicker`` False: white and a walk alone (all the slow noise taken for a walk)."""
    return fit_levels(*allan_shapes(resid, x), flicker=flicker)


def allan_shapes(resid: np.ndarray, x: np.ndarray | None = None):
    """(robust Allan variance of ``resid``, the three noises' shapes at its taus, the residual's
    variance): what :func:`fit_levels` fits, computed once for several fits of one residual."""
    taus, avar = allan_levels(resid)
    if taus.size < 2 or not np.all(avar > 0):
        return avar, None, float(np.var(resid))
    if x is None:
        basis = np.column_stack([1.0 / taus, _flicker_avar(resid.size, taus), taus / 3.0])
    else:
        basis = _projected_shapes(np.asarray(x, float), taus)
    return avar, basis, float(np.var(resid))


def fit_levels(avar: np.ndarray, basis: np.ndarray | None, variance: float,
               flicker: bool = True) -> tuple[float, float, float]:
    """:func:`noise_levels` from :func:`allan_shapes` (``basis`` None: too short to fit, all white)."""
    from scipy.optimize import nnls

    if basis is None:
        return variance or 1.0, 0.0, 0.0
    use = np.array([True, flicker, True])
    coef = np.zeros(3)
    coef[use], _ = nnls((basis / avar[:, None])[:, use], np.ones_like(avar))
    return float(coef[0]) or float(avar[0]), float(coef[1]), float(coef[2])


@lru_cache(maxsize=4)
def _unit_component_draws(n: int) -> np.ndarray:
    """[component, draw, row] unit-variance draws of each AR(1) component of the flicker, alone."""
    rng = np.random.default_rng([SHAPE_SEED, n, 1])
    k = flicker_times(n).size
    out = np.stack([noise_draws(rng, (0.0, np.eye(k)[i], 0.0), SHAPE_DRAWS, n) for i in range(k)])
    out.flags.writeable = False
    return out


# the flicker band's lower edge is searched among its first components (1, 3.2, 10 and 32 rows)
BAND_EDGES = 4


def band_levels(resid: np.ndarray, x: np.ndarray | None = None) -> tuple[float, np.ndarray, float]:
    """(white variance, variance of each flicker component [flicker_times], walk variance per row):
    :func:`noise_levels` with the flicker's band starting at the component that fits best, not at
    one row. A flicker whose fastest part is slower than a row (the independent generator's starts at
    five sample intervals) is otherwise fitted as more white noise and a flicker at about half its
    level (pure noise, white 1 and 3.3 per component: 1.9 and 1.9; with the edge searched: 0.7..0.97
    and 2.4..2.9), which is what whitening must know. The edge is chosen by the fit's weighted residual."""
    from scipy.optimize import nnls

    n = resid.size
    times = flicker_times(n)
    taus, avar = allan_levels(resid)
    if taus.size < 2 or not np.all(avar > 0):
        return float(np.var(resid)) or 1.0, np.zeros(times.size), 0.0
    if x is None:
        shapes = np.column_stack([1.0 / taus, _ar1_avar(np.exp(-1.0 / times), taus).T, taus / 3.0])
    else:
        unit = _unit_draws(n)
        shapes = _fitted_out(np.concatenate([unit[[0]], _unit_component_draws(n), unit[[2]]]), np.asarray(x, float),
                             taus.size)
    best = None
    for edge in range(min(BAND_EDGES, times.size)):
        basis = np.column_stack([shapes[:, 0], shapes[:, 1 + edge:1 + times.size].sum(axis=1), shapes[:, -1]])
        coef, misfit = nnls(basis / avar[:, None], np.ones_like(avar))
        if best is None or misfit < best[0] * (1.0 - 1e-9):
            best = (misfit, edge, coef)
    _, edge, coef = best
    return float(coef[0]) or float(avar[0]), np.where(np.arange(times.size) >= edge, coef[1], 0.0), float(coef[2])


def noise_draws(rng: np.random.Generator, levels: tuple, draws: int, n: int) -> np.ndarray:
    """``draws`` series of ``n`` rows of white noise, flicker and a random walk at ``levels`` (the
    flicker's variance one for every component, or one each: :func:`band_levels`)."""
    white, flicker, walk = levels
    out = rng.standard_normal((draws, n)) * np.sqrt(white)
    if walk > 0:
        out += np.cumsum(rng.standard_normal((draws, n)), axis=1) * np.sqrt(walk)
    if np.any(np.asarray(flicker) > 0):
        times = flicker_times(n)
        for t, v in zip(times, np.broadcast_to(flicker, times.shape)):
            phi = np.exp(-1.0 / t)
            e = rng.standard_normal((draws, n)) * np.sqrt(v * (1.0 - phi * phi))
            start = rng.standard_normal(draws) * np.sqrt(v)
            out += lfilter([1.0], [1.0, -phi], e, axis=1, zi=(phi * start)[:, None])[0]
    return out


def readout_draws(rng: np.random.Generator, fitted: np.ndarray, step: float, draws: int) -> np.ndarray:
    """``draws`` series of the error of a readout of quantisation ``step`` that reads ``fitted`` (the
    channel's model) exactly, at a grid offset drawn uniformly within one step: its reading error,
    each row's distance to the grid. Only what ``fitted`` carries (the reference thermometer's own
    noise) dithers it: the least favourable case, where a dwell's error is one constant."""
    x = fitted[None, :] + rng.uniform(0.0, step, (draws, 1))
    return step * np.floor(x / step + 0.5) - x
