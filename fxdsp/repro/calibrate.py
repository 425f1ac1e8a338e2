"""Fits of the papers' compensations in the form the config tables take (float; quantised later).

Paper 002 here differs from :func:`fxdsp.sim.calibration.calibrate_paper002` in two ways that the
reproduction needs: the points come from :func:`fxdsp.repro.points.rate_table_points` (no settling
criterion: like the paper, a point is whatever the run gives after its dwell), and the polynomial
order per segment is a parameter (1: the paper's linear segments; 2: this project's quadratic
segments through three calibration points each). Any temperature column can drive it (the RTD's
``temp_c``, or a temperature estimated from the resonant frequency).
"""

from __future__ import annotations

import numpy as np

from fxdsp.repro.points import rate_table_points
from fxdsp.errors import InputError, MissingColumn


def fit_segments(temps_c, values, order: int = 1) -> dict:
    """Piecewise polynomials of ``order`` through consecutive calibration points.

    Points p_0 < ... < p_{n-1}: segment k spans p_{k m} .. p_{(k+1) m} (m = order), the last one
    ending at p_{n-1}; each is a least-squares fit (exact when it holds m + 1 points). Returns inner
    breakpoints (where a segment starts) and ascending coefficients in absolute T."""
    if order not in (1, 2, 3):
        raise InputError(f"order: must be 1, 2 or 3, got {order!r}")
    t = np.asarray(temps_c, float)
    v = np.asarray(values, float)
    if t.size != v.size:
        raise InputError("values: need one value per calibration temperature")
    if t.size < order + 1:
        raise InputError(f"temps_c: order {order} needs at least {order + 1} calibration points, got {t.size}")
    idx = np.argsort(t)
    t, v = t[idx], v[idx]
    starts = list(range(0, t.size - 1, order))
    if len(starts) > 1 and starts[-1] + order > t.size - 1:
        starts[-1] = t.size - 1 - order  # last segment: the last m + 1 points
    coefs, bps = [], []
    for k, s in enumerate(starts):
        e = min(s + order, t.size - 1)
        sl = slice(s, e + 1)
        coefs.append([float(c) for c in np.polynomial.polynomial.polyfit(t[sl], v[sl], order)])
        if k > 0:
            bps.append(float(t[s]))
    return {"breakpoints_c": bps, "coefficients": coefs, "order": order}


def eval_segments(fit: dict, temp_c) -> np.ndarray:
    t = np.asarray(temp_c, float)
    seg = np.searchsorted(np.asarray(fit["breakpoints_c"], float), t, side="right")
    coef = np.asarray(fit["coefficients"], float)
    out = np.zeros_like(t)
    for k in range(coef.shape[0]):
        m = seg == k
        out[m] = np.polynomial.polynomial.polyval(t[m], coef[k])
    return out


def calibrate002(log: dict, order: int = 1, temp=None) -> dict:
    """SF(T) then bias(T) after SF division (deg/s), piecewise of ``order``; ``temp`` overrides the
    log's temp_c (e.g. a frequency-derived or lag-corrected temperature)."""
    pts = rate_table_points(log, temp=temp)
    sf = fit_segments(pts["temp_c"], pts["sf"], order)
    bias_dps = pts["bias"] / eval_segments(sf, pts["temp_c"])
    bias = fit_segments(pts["temp_c"], bias_dps, order)
    sf_nominal = float(eval_segments(sf, [25.0])[0])
    return {"paper": "002", "order": order, "sf": sf, "bias": bias, "sf_nominal": sf_nominal,
            "points": {k: v.tolist() for k, v in pts.items()}}


def frequency_thermometer(log: dict, temp_col: str = "temp_c") -> dict:
    """f = f0 + k T by least squares against ``temp_col`` on the settled tail of each rate-table
    point (the zero-rate stretch before it): the resonator's own thermometer for paper 002."""
    if "freq_hz" not in log:
        raise MissingColumn("log: needs the freq_hz column for a frequency thermometer", "freq_hz")
    pts_t = rate_table_points(log, temp=log[temp_col], sort=False)["temp_c"]
    pts_f = rate_table_points(log, temp=log["freq_hz"], sort=False)["temp_c"]
    k, f0 = np.polyfit(pts_t, pts_f, 1)
    return {"f0_hz": float(f0), "k_hz_per_c": float(k)}
