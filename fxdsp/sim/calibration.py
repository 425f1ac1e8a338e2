"""The papers' calibration fits, in float (the bit-exact chain and the TOML config come later).

Every fit returns a plain dict of coefficients and breakpoints, so it can be written as JSON or TOML
without conversion:

* paper 002 (:func:`calibrate_paper002`): at each calibration temperature the SF is the rate-table
  slope and the bias the zero-rate mean; SF(T) = a_i T + b_i and then, on the SF-compensated output
  (deg/s), bias(T) = c_i T + d_i, each by least squares on the segments between calibration points
  (T in C on the RTD, absolute, as in the paper). SF first, because dividing changes the bias;
* paper 001 (:func:`calibrate_paper001`): f = k T + f0 against the chamber reference, then the
  quadratic bias q(T) on T = (f - f0)/k, the resonator's own temperature;
* paper 000 (:func:`calibrate_paper000_records`, :func:`calibrate_paper000_log`): four-position
  tumble K0 = (E90 + E270)/2, K1 = (E0 - E180)/(2g) per temperature, then cubics in t = T - 25 C.

Logs are cut into temperature plateaus by :func:`find_plateaus`, which needs nothing but the log.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from fxdsp.ramps import sample_interval
from fxdsp.errors import InputError, MissingColumn

G = 1.0  # the tumble's input unit: accelerations in g, so K1 is per g and K0/K1 is in g


# --- plateaus ------------------------------------------------------------------------------------

def find_plateaus(time_s, temp_c, window_s: float = 1200.0, tol_c: float = 0.15,
                  min_duration_s: float = 1200.0) -> list[np.ndarray]:
    """Index arrays of the settled stretches of a chamber run.

    A sample is settled when temp_c has stayed within ``tol_c`` over the ``window_s`` before it, so
    the first ``window_s`` after a ramp are discarded (the part where the die still catches up).
    Consecutive settled samples lasting at least ``min_duration_s`` form a plateau.
    """
    t = np.asarray(time_s, float)
    temp = np.asarray(temp_c, float)
    if t.size < 3:
        return []
    dt = sample_interval(t)
    n = max(int(round(window_s / dt)), 1)
    if n >= t.size:   # the window reaches past the log's start at every sample: nothing is settled
        return []
    # trailing window [i - n, i]: a centred filter of size n+1 shifted by n/2
    shift = n // 2
    hi = maximum_filter1d(temp, size=n + 1, origin=shift, mode="nearest")
    lo = minimum_filter1d(temp, size=n + 1, origin=shift, mode="nearest")
    settled = (hi - lo) <= tol_c
    settled[:n] = False  # the window does not reach back far enough yet
    edges = np.flatnonzero(np.diff(np.concatenate([[0], settled.astype(int), [0]])))
    out = []
    for start, stop in zip(edges[::2], edges[1::2]):
        if t[stop - 1] - t[start] >= min_duration_s:
            out.append(np.arange(start, stop))
    return out


# --- piecewise-linear fits (paper 002) -------------------------------------------------------------

def fit_piecewise_linear(temps_c, values, breakpoints) -> dict:
    """y = a_i T + b_i on each segment [bp_i, bp_i+1], least squares over the points inside it
    (a calibration point on a boundary serves both neighbours)."""
    x = np.asarray(temps_c, float)
    y = np.asarray(values, float)
    bp = np.sort(np.asarray(breakpoints, float))
    slopes, intercepts = [], []
    for lo, hi in zip(bp[:-1], bp[1:]):
        inside = (x >= lo - 1e-9) & (x <= hi + 1e-9)
        if inside.sum() < 2:
            raise InputError(f"segment [{lo:g}, {hi:g}] C has fewer than two calibration points")
        a, b = np.polyfit(x[inside], y[inside], 1)
        slopes.append(float(a))
        intercepts.append(float(b))
    return {"breakpoints_c": [float(v) for v in bp], "slopes": slopes, "intercepts": intercepts}


def eval_piecewise_linear(fit: dict, temp_c) -> np.ndarray:
    """Evaluate a piecewise-linear fit; outside the breakpoints the end segments extend."""
    t = np.asarray(temp_c, float)
    bp = np.asarray(fit["breakpoints_c"])
    seg = np.clip(np.searchsorted(bp, t, side="right") - 1, 0, len(fit["slopes"]) - 1)
    return np.asarray(fit["slopes"])[seg] * t + np.asarray(fit["intercepts"])[seg]


def calibration_points_paper002(log: dict) -> dict[str, np.ndarray]:
    """Per plateau: RTD temperature, SF (rate-table slope) and zero-rate bias, in output units."""
    if "rate_dps" not in log:
        raise MissingColumn("log: paper 002 calibration needs the rate_dps column (rate-table steps)", "rate_dps")
    temps, sfs, biases = [], [], []
    for idx in find_plateaus(log["time_s"], log["temp_c"]):
        rate, out = log["rate_dps"][idx], log["output"][idx]
        if np.unique(rate).size < 2 or not np.any(rate == 0):
            continue  # no rate-table sequence on this plateau: not a calibration point
        sf, _ = np.polyfit(rate, out, 1)
        temps.append(np.mean(log["temp_c"][idx]))
        sfs.append(sf)
        biases.append(np.mean(out[rate == 0]))
    if not temps:
        raise InputError("log: no temperature plateau with a rate-table sequence (rate_dps steps)")
    merged = merge_repeats(np.asarray(temps), np.asarray(sfs), np.asarray(biases))
    if len(merged[0]) < 2:
        raise InputError("log: fewer than two calibration temperatures with a rate-table sequence")
    return {"temp_c": merged[0], "sf": merged[1], "bias": merged[2]}


def merge_repeats(temps, *values, tol_c: float = 2.0):
    """Sort calibration points by temperature and average repeats of the same setpoint (a second
    run), so that every segment spans two distinct temperatures."""
    order = np.argsort(temps)
    temps = temps[order]
    values = [v[order] for v in values]
    groups = np.concatenate([[0], np.cumsum(np.diff(temps) > tol_c)])
    out = [np.array([temps[groups == g].mean() for g in np.unique(groups)])]
    out += [np.array([v[groups == g].mean() for g in np.unique(groups)]) for v in values]
    return out


def calibrate_paper002(log: dict) -> dict:
    """Paper 002's piecewise-linear compensation on the RTD temperature.

    Returns ``{"sf": {breakpoints_c, slopes, intercepts}, "bias": {...}, "points": {...}}``: SF in
    output unit per deg/s, bias in deg/s *after* SF division (the order of the hardware).
    """
    pts = calibration_points_paper002(log)
    sf_fit = fit_piecewise_linear(pts["temp_c"], pts["sf"], pts["temp_c"])
    bias_dps = pts["bias"] / eval_piecewise_linear(sf_fit, pts["temp_c"])
    bias_fit = fit_piecewise_linear(pts["temp_c"], bias_dps, pts["temp_c"])
    return {"paper": "002", "sf": sf_fit, "bias": bias_fit,
            "points": {k: [float(v) for v in vals] for k, vals in pts.items()}}


def compensate_paper002(cal: dict, temp_c, output) -> np.ndarray:
    """Rate in deg/s: output / SF(T) - bias(T)."""
    return (np.asarray(output, float) / eval_piecewise_linear(cal["sf"], temp_c)
            - eval_piecewise_linear(cal["bias"], temp_c))


# --- paper 001 --------------------------------------------------------------------------------------

def calibrate_paper001(log: dict, bias_order: int = 2) -> dict:
    """Paper 001: linear f(T) against the reference thermometer, quadratic bias on T from f
    (``bias_order`` 3: a cubic, for a resonator whose frequency turns over).

    Per plateau the means of ref_temp_c (temp_c when there is no reference), freq_hz and output are
    taken; ``bias_poly`` is ascending in T (C) like the paper's -0.25 T^2 - 36.92 T + 1469.5.
    """
    if "freq_hz" not in log:
        raise MissingColumn("log: paper 001 calibration needs the freq_hz column", "freq_hz")
    thermometer = log["ref_temp_c"] if "ref_temp_c" in log else log["temp_c"]
    plateaus = find_plateaus(log["time_s"], thermometer)
    if bias_order not in (2, 3):
        raise InputError(f"bias_order: must be 2 or 3, got {bias_order!r}")
    if len(plateaus) < bias_order + 1:
        raise InputError(f"log: paper 001 calibration needs at least {bias_order + 1} temperature plateaus")
    temps = np.array([np.mean(thermometer[i]) for i in plateaus])
    freqs = np.array([np.mean(log["freq_hz"][i]) for i in plateaus])
    bias = np.array([np.mean(log["output"][i]) for i in plateaus])
    k, f0 = np.polyfit(temps, freqs, 1)
    resid = freqs - (f0 + k * temps)
    t_from_f = (freqs - f0) / k
    q = np.polynomial.polynomial.polyfit(t_from_f, bias, bias_order)
    span = freqs.max() - freqs.min()
    return {"paper": "001", "f0_hz": float(f0), "k_hz_per_c": float(k),
            "bias_poly": [float(c) for c in q],
            "max_freq_residual_hz": float(np.abs(resid).max()),
            "linearity": float(np.abs(resid).max() / span) if span > 0 else float("nan"),
            "points": {"temp_c": temps.tolist(), "freq_hz": freqs.tolist(), "output": bias.tolist()}}


def compensate_paper001(cal: dict, freq_hz, output) -> np.ndarray:
    """Sout = Spre - q(T), T = (f - f0)/k: no thermometer but the resonator."""
    t = (np.asarray(freq_hz, float) - cal["f0_hz"]) / cal["k_hz_per_c"]
    return np.asarray(output, float) - np.polynomial.polynomial.polyval(t, cal["bias_poly"])


# --- paper 000 --------------------------------------------------------------------------------------

def tumble_coefficients(e0, e90, e180, e270, g: float = G) -> tuple:
    """Four-position tumble: K0 = (E90 + E270)/2, K1 = (E0 - E180)/(2g),
    K2 = (E0 + E180 - E90 - E270)/(2 g^2)."""
    e0, e90, e180, e270 = (np.asarray(v, float) for v in (e0, e90, e180, e270))
    return (e90 + e270) / 2, (e0 - e180) / (2 * g), (e0 + e180 - e90 - e270) / (2 * g * g)


def fit_paper000(temps_c, k0, k1, t_ref_c: float = 25.0, order: int = 3) -> dict:
    """Cubic K0(t), K1(t) in t = T - 25 C by least squares; ascending coefficients."""
    t = np.asarray(temps_c, float) - t_ref_c
    if t.size <= order:
        raise InputError(f"paper 000 fit needs more than {order} temperatures, got {t.size}")
    return {"paper": "000", "t_ref_c": t_ref_c,
            "k0_poly": [float(c) for c in np.polynomial.polynomial.polyfit(t, k0, order)],
            "k1_poly": [float(c) for c in np.polynomial.polynomial.polyfit(t, k1, order)]}


def calibrate_paper000_records(records: list[dict], run: int | None = 1) -> dict:
    """Fit from tumble records ``{"run", "temp_c", "E": {0: .., 90: .., 180: .., 270: ..}}``
    (as :func:`fxdsp.sim.qvba.tumble_run` returns), using one run or all (``run=None``)."""
    chosen = [r for r in records if run is None or r["run"] == run]
    temps = [r["temp_c"] for r in chosen]
    k0, k1, _ = tumble_coefficients(*([r["E"][a] for r in chosen] for a in (0, 90, 180, 270)))
    return fit_paper000(temps, k0, k1)


def tumble_points_from_log(log: dict) -> dict[str, np.ndarray]:
    """K0, K1 per temperature plateau of a paper000 log; the applied-input column (rate_dps) holds
    a = g cos(theta): +1 g at 0 deg, 0 at 90/270 deg, -1 g at 180 deg."""
    if "rate_dps" not in log:
        raise MissingColumn("log: paper 000 calibration needs the applied-input column rate_dps (a in g)", "rate_dps")
    temps, k0s, k1s = [], [], []
    for idx in find_plateaus(log["time_s"], log["temp_c"]):
        a, out = log["rate_dps"][idx], log["output"][idx]
        up, level, down = np.isclose(a, G), np.isclose(a, 0.0), np.isclose(a, -G)
        if not (up.any() and level.any() and down.any()):
            continue
        e0, e180, e_level = out[up].mean(), out[down].mean(), out[level].mean()
        k0, k1, _ = tumble_coefficients(e0, e_level, e180, e_level)
        temps.append(np.mean(log["temp_c"][idx]))
        k0s.append(float(k0))
        k1s.append(float(k1))
    if len(temps) < 4:
        raise InputError("log: paper 000 calibration needs tumbles at four or more temperatures")
    return {"temp_c": np.asarray(temps), "k0": np.asarray(k0s), "k1": np.asarray(k1s)}


def calibrate_paper000_log(log: dict) -> dict:
    pts = tumble_points_from_log(log)
    fit = fit_paper000(pts["temp_c"], pts["k0"], pts["k1"])
    fit["points"] = {k: v.tolist() for k, v in pts.items()}
    return fit


def compensate_paper000(cal: dict, temp_c, output) -> np.ndarray:
    """Acceleration in g: a = (Df - K0(t)) / K1(t)."""
    t = np.asarray(temp_c, float) - cal["t_ref_c"]
    k0 = np.polynomial.polynomial.polyval(t, cal["k0_poly"])
    k1 = np.polynomial.polynomial.polyval(t, cal["k1_poly"])
    return (np.asarray(output, float) - k0) / k1
