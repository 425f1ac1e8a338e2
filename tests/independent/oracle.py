"""What a log's own noise allows: each cause's parameters estimated by a *known-baseline oracle*.

The oracle is told everything the generator drew except the noise: the true baseline, the true
thermometer and resonator lines, and the effects outside the contract. It subtracts them from the
logged channel and fits what is left (the causes' effects plus the noise) with every cause of that
channel at once, at its true shape, a constant free; a warm-up's time constant is searched. No
diagnosis can know more, so where the oracle's estimate is off by more than the tolerance the log
does not determine that parameter to it: the miss is the noise's, not the diagnosis's.

Written, like chamber_logs, from the contract and the generator's hidden truth alone: it imports
nothing of fxdsp. A thermal lag's time constant needs the lagged temperature for every candidate
value, which only the generator's programme gives; it is left out (``None``)."""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import minimize_scalar

from .chamber_logs import IndependentLog

# the logged channel of each cause and, per channel, the hidden noise-free series it is measured as
CHANNEL = {"hysteresis": "output", "ramp_rate": "output", "aging_drift": "output", "quadrature_leak": "output",
           "sf_nonlinearity": "output", "warmup": "output", "thermal_lag": "output",
           "rtd_nonlinearity": "temp_c", "frequency_nonlinearity": "freq_hz"}
CLEAN = {"output": "output_clean", "temp_c": "temp_true", "freq_hz": "freq_clean"}


def _effects(log: IndependentLog, channel: str) -> dict[str, np.ndarray]:
    """The hidden effect series on ``channel``, by name (the contract's causes and outside effects)."""
    out = {}
    for key, v in log.hidden.items():
        if not key.startswith("effect:"):
            continue
        name = key[len("effect:"):]
        if CHANNEL.get(name, "output") == channel:
            out[name] = np.asarray(v, float)
    return out


def _least_squares(columns: list[np.ndarray], y: np.ndarray) -> tuple[np.ndarray, float]:
    x = np.column_stack(columns)
    coef = np.linalg.lstsq(x, y, rcond=None)[0]
    r = y - x @ coef
    return coef, float(r @ r)


def known_baseline_parameters(log: IndependentLog) -> dict[str, dict[str, float | None]]:
    """Per true cause, its parameters as the oracle estimates them (None: not estimated)."""
    t = np.asarray(log.columns["time_s"], float)
    out: dict[str, dict[str, float | None]] = {c: {p: None for p in ps} for c, ps in log.truth.items()}
    for channel in sorted({CHANNEL[c] for c in log.truth}):
        effects = _effects(log, channel)
        # everything the oracle knows (clean series less every cause of the contract on it) removed:
        # the causes' effects and the noise are left
        known = np.asarray(log.hidden[CLEAN[channel]], float) - sum(
            (v for k, v in effects.items() if k in log.truth), np.zeros_like(t))
        y = np.asarray(log.columns[channel], float) - known
        linear = [c for c in log.truth if CHANNEL[c] == channel and c not in ("warmup", "thermal_lag")]
        if "thermal_lag" in log.truth and channel == "output":
            y = y - effects["thermal_lag"]   # its shape needs its time constant: known, not estimated
        shapes = [effects[c] / _linear_value(log, c) for c in linear]
        base = [np.ones_like(t), *shapes]
        if "warmup" in log.truth and channel == "output":
            span = max(float(np.ptp(t)), 1.0)
            step = max(float(np.median(np.diff(t))) if t.size > 1 else 1.0, 1e-3)

            def sse(log_tau: float) -> float:
                return _least_squares([*base, np.exp(-t / np.exp(log_tau))], y)[1]

            grid = np.linspace(np.log(step), np.log(10.0 * span), 121)
            k = int(np.argmin([sse(v) for v in grid]))
            lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
            log_tau = minimize_scalar(sse, bounds=(lo, hi), method="bounded",
                                      options={"xatol": 1e-6}).x if hi > lo else grid[k]
            coef, _ = _least_squares([*base, np.exp(-t / np.exp(log_tau))], y)
            out["warmup"] = {"a": float(coef[-1]), "tau_s": float(np.exp(log_tau))}
        else:
            coef, _ = _least_squares(base, y)
        for j, c in enumerate(linear):
            out[c][next(iter(log.truth[c]))] = float(coef[1 + j])
    return out


def relative_errors(log: IndependentLog, found: dict[str, dict[str, float]]) -> dict[str, float]:
    """``cause.parameter`` -> |found - truth| / |truth| for every true parameter ``found`` gives."""
    out = {}
    for cause, params in log.truth.items():
        for name, value in params.items():
            got = found.get(cause, {}).get(name)
            if got is not None:
                out[f"{cause}.{name}"] = abs(got - value) / abs(value)
    return out


def output_noise_covariance(log: IndependentLog) -> np.ndarray:
    """The covariance [rows, rows] of the output noise the generator drew for ``log`` (its
    description's levels): white on every row; flicker (a sum of stationary AR(1) processes) and a
    random walk from zero at power-on, both functions of the nominal sample slot, so that rows of a
    repeated time stamp share them."""
    noise, sampling = log.description["noise"], log.description["sampling"]
    slot = np.asarray(log.hidden["slot"], float)
    apart = np.abs(slot[:, None] - slot[None, :])
    cov = np.zeros_like(apart)
    for tau in noise["output_flicker_taus_s"]:
        cov += noise["output_flicker_component_sigma"] ** 2 * np.exp(-sampling["dt_s"] / tau) ** apart
    del apart
    cov += noise["output_random_walk_end_std"] ** 2 / sampling["rows_nominal"] * np.minimum(slot[:, None], slot[None, :])
    cov[np.diag_indices_from(cov)] += noise["output_white_sigma"] ** 2
    return cov


def known_noise_estimate(log: IndependentLog, cause: str) -> tuple[float, float]:
    """(estimate, sd) of the linear parameter of an output ``cause`` of ``log``, by generalised least
    squares under the true noise covariance (:func:`output_noise_covariance`), the baseline's known
    shape (a cubic in the element's true temperature; times the rate too when a rate is logged) and
    the other true causes at their true shapes, all with free coefficients.

    The best unbiased estimate any diagnosis could make, and it knows more: the noise's levels and
    the baseline's form. So truth / sd (:func:`detection_z`) says how far the log shows the cause: a
    cause missed at a z of 3 the log does not show; one missed at 10 it does."""
    if not detectable(cause):
        raise ValueError(f"{cause}: not an output cause linear in a parameter")
    x = (np.asarray(log.hidden["te"], float) - 25.0) / 50.0
    cubic = [x ** 0, x, x ** 2, x ** 3]
    columns = cubic + ([np.asarray(log.columns["rate_dps"], float) * c for c in cubic]
                       if "rate_dps" in log.columns else [])
    effects = _effects(log, "output")
    columns += [v for k, v in effects.items() if k != cause]           # others, known shapes
    shape = effects[cause] / _linear_value(log, cause)
    y = np.asarray(log.columns["output"], float)
    chol = np.linalg.cholesky(output_noise_covariance(log))
    whiten = lambda a: solve_triangular(chol, a, lower=True)          # noqa: E731
    xw = whiten(np.column_stack([shape, *columns]))
    coef, *_ = np.linalg.lstsq(xw, whiten(y), rcond=None)
    sd = float(np.sqrt(np.linalg.inv(xw.T @ xw)[0, 0]))
    return float(coef[0]), sd


def detectable(cause: str) -> bool:
    """Whether :func:`known_noise_estimate` estimates ``cause``: an output cause whose effect is a
    parameter times a known shape (not a lag: its time constant shapes it)."""
    return CHANNEL[cause] == "output" and cause != "thermal_lag"


def detection_z(log: IndependentLog, cause: str) -> float:
    """|true parameter| / the sd of :func:`known_noise_estimate`: the signal-to-noise ratio at which
    an estimator told the noise and the baseline's form sees ``cause``."""
    return abs(_linear_value(log, cause)) / known_noise_estimate(log, cause)[1]


def _linear_value(log: IndependentLog, cause: str) -> float:
    """The true value of the parameter ``cause``'s effect is proportional to (a warm-up's a)."""
    params = log.truth[cause]
    return float(params["a"] if cause == "warmup" else next(iter(params.values())))
