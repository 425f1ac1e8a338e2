"""Per-temperature measurement points of a paper 002 chamber log, for any dwell length.

:func:`fxdsp.sim.calibration.find_plateaus` needs a settled stretch of 20 min; a verification run
with short dwells has none. Here the rate-table sequences themselves mark the points: each maximal
run of non-zero ``rate_dps`` is one sequence; the zero-rate stretch just before it (at most
``log_s`` seconds) gives the bias, a least-squares line through that stretch and the steps gives
the SF. The temperature of the point is the mean of ``temp_col`` over the samples used.
"""

from __future__ import annotations

import numpy as np
from fxdsp.errors import InputError, MissingColumn


def rate_table_windows(log: dict, log_s: float = 3600.0) -> list[tuple[np.ndarray, np.ndarray]]:
    """(zero-rate rows, all rows) of every rate-table sequence of ``log``: the sequence and the
    contiguous zero-rate stretch (at most ``log_s``) right before it. These rows are what a paper 002
    calibration reads; every other row is held out from it."""
    if "rate_dps" not in log:
        raise MissingColumn("log: needs the rate_dps column (rate-table steps)", "rate_dps")
    if not log_s > 0:
        raise InputError(f"log_s: must be > 0, got {log_s!r}")
    t = np.asarray(log["time_s"], float)
    rate = np.asarray(log["rate_dps"], float)
    moving = rate != 0
    edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(int), [0]])))
    windows = []
    for start, stop in zip(edges[::2], edges[1::2]):
        zero = np.flatnonzero((~moving[:start]) & (t[:start] >= t[start] - log_s))
        # only the contiguous zero-rate stretch right before the sequence
        if zero.size == 0 or zero[-1] != start - 1:
            continue
        zero = zero[zero > (np.flatnonzero(moving[:start])[-1] if moving[:start].any() else -1)]
        if zero.size < 2 or stop - start < 2:
            continue
        windows.append((zero, np.concatenate([zero, np.arange(start, stop)])))
    return windows


def rate_table_points(log: dict, output=None, temp_col: str = "temp_c", log_s: float = 3600.0,
                      temp=None, sort: bool = True) -> dict[str, np.ndarray]:
    """``{"temp_c", "sf", "bias"}`` per rate-table sequence of ``log`` (output units).

    ``output`` replaces ``log["output"]`` (e.g. a compensated rate); ``temp`` replaces the
    temperature column (e.g. the bit-exact temperature code in C)."""
    windows = rate_table_windows(log, log_s)
    rate = np.asarray(log["rate_dps"], float)
    out = np.asarray(log["output"] if output is None else output, float)
    tc = np.asarray(log[temp_col] if temp is None else temp, float)
    temps, sfs, biases = [], [], []
    for zero, idx in windows:
        sf, _ = np.polyfit(rate[idx], out[idx], 1)
        temps.append(float(np.mean(tc[idx])))
        sfs.append(float(sf))
        biases.append(float(np.mean(out[zero])))
    if len(temps) < 2:
        raise InputError("log: fewer than two rate-table sequences with a zero-rate stretch before them")
    order = np.argsort(temps) if sort else np.arange(len(temps))
    return {"temp_c": np.asarray(temps)[order], "sf": np.asarray(sfs)[order], "bias": np.asarray(biases)[order]}


def tempco(temps_c, values, relative: bool = False) -> float:
    """Temperature coefficient as the papers quote it: (max - min) / (T_max - T_min) of the
    per-temperature values; divided by |mean| for a scale factor (times 1e6: ppm/C)."""
    v = np.asarray(values, float)
    tc = np.asarray(temps_c, float)
    if v.size < 2 or tc.size != v.size:
        raise InputError("values: need at least two points, one per temperature")
    span = (v.max() - v.min()) / (tc.max() - tc.min())
    return float(span / abs(v.mean())) if relative else float(span)
