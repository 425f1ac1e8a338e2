"""The physical mechanisms of the measured-data contract (shared/spec/measured-data.md, section 3).

One implementation serves both directions: `fxdsp simulate` injects a cause with these functions,
`fxdsp diagnose` fits the same functions to a log. Each cause's record (name, parameters, where it
acts, its fit) is in :mod:`fxdsp.causes`.

All functions are float (physics, not fixed point) and work on numpy arrays sampled at possibly
irregular times ``time_s`` (non-decreasing seconds since power-on).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fxdsp.ramps import derivative, read_ramps
from fxdsp.errors import InputError

# reference temperature of the curvature terms of the contract
T_CURVE_C = 25.0


def _as_1d(name: str, values) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 1:
        raise InputError(f"{name}: expected a 1-D array, got shape {arr.shape}")
    return arr


def first_order_lag(time_s, temp_c, tau_s: float, initial: float | None = None) -> np.ndarray:
    """Te with dTe/dt = (temp_c - Te)/tau_s, exact for a piecewise-linear input between samples.

    The first-order-hold solution keeps the result independent of the sampling interval, so the
    same tau fits a log logged every second or every minute.
    """
    t = _as_1d("time_s", time_s)
    u = _as_1d("temp_c", temp_c)
    if t.shape != u.shape:
        raise InputError("time_s and temp_c must have the same length")
    if not tau_s > 0:
        raise InputError(f"tau_s must be > 0, got {tau_s}")
    out = np.empty_like(u)
    if u.size == 0:
        return out
    out[0] = u[0] if initial is None else float(initial)
    dt = np.diff(t)
    a = np.exp(-dt / tau_s)
    # for a ramp u(t) = u0 + s (t - t0): Te1 = u1 - s*tau + (Te0 - u0 + s*tau) * a
    slope = np.divide(np.diff(u), dt, out=np.zeros_like(dt), where=dt > 0)
    # start of each interval; over a zero-length interval (a repeated time stamp, which the contract
    # allows) Te cannot move, which the formula gives when the interval starts at its end value
    u_start = np.where(dt > 0, u[:-1], u[1:])
    return _lag_recursion(out, u, u_start, a, slope * tau_s)


def _lag_recursion(out: np.ndarray, u: np.ndarray, u_start: np.ndarray, a: np.ndarray,
                   s_tau: np.ndarray) -> np.ndarray:
    # a plain loop is fine for logs of ~1e4..1e6 rows; scipy.signal.lfilter cannot take varying a
    te = out[0]
    for i in range(1, u.size):
        te = u[i] - s_tau[i - 1] + (te - u_start[i - 1] + s_tau[i - 1]) * a[i - 1]
        out[i] = te
    return out


_lag_recursion = njit(cache=True)(_lag_recursion)  # compiled: 1M rows in milliseconds, not a second


def rate_of_change(time_s, temp_c) -> np.ndarray:
    """d(temp_c)/dt in C/s by central differences on the (possibly irregular) time grid."""
    return derivative(_as_1d("time_s", time_s), _as_1d("temp_c", temp_c))


def ramp_direction(time_s, temp_c) -> np.ndarray:
    """s of the hysteresis cause: +1 after the last heating ramp, -1 after the last cooling ramp,
    0 before the first ramp; it persists through dwells and takes the ramp's sign from the ramp's
    start, however short (the ramp rules, which scale with the log's noise, are in fxdsp.ramps)."""
    return read_ramps(_as_1d("time_s", time_s), _as_1d("temp_c", temp_c)).state


def warmup(time_s, a: float, tau_s: float) -> np.ndarray:
    """a * exp(-time_s / tau_s): settling after power-on."""
    if not tau_s > 0:
        raise InputError(f"tau_s must be > 0, got {tau_s}")
    return a * np.exp(-_as_1d("time_s", time_s) / tau_s)


def aging_drift(time_s, r_per_h: float) -> np.ndarray:
    """r * time_s / 3600: slow drift with time."""
    return r_per_h * _as_1d("time_s", time_s) / 3600.0


def rtd_curvature(ref_temp_c, b_per_c: float) -> np.ndarray:
    """Deviation of an RTD readout from linear: b * (Tref - 25)^2."""
    return b_per_c * (_as_1d("ref_temp_c", ref_temp_c) - T_CURVE_C) ** 2


def frequency_curvature(te_c, k2_hz_per_c2: float) -> np.ndarray:
    """Turnover of a resonator: k2 * (Te - 25)^2 added to f0 + k Te."""
    return k2_hz_per_c2 * (_as_1d("te_c", te_c) - T_CURVE_C) ** 2
