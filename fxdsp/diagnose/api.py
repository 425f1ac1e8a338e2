"""Library entry points: a Log (or a path) in, a Diagnosis out."""

from __future__ import annotations

import numpy as np

from fxdsp.diagnose import model as M
from fxdsp.diagnose.engine import Diagnosis, diagnose_series
from fxdsp.logfile import Log, read_log
from fxdsp.errors import InputError

MIN_ROWS = 50
# channels screened for isolated spikes (rate and quadrature may legitimately jump sample to sample)
SPIKE_CHECKED = ("output", "temp_c", "ref_temp_c", "freq_hz")


def series_from_log(log: Log) -> tuple[M.Series, int]:
    """Usable rows as a Series, and how many spike rows were set aside."""
    cols = log.columns
    spikes = np.zeros(len(log), dtype=bool)
    for name in SPIKE_CHECKED:
        if name in cols:
            spikes |= M.spike_rows(cols[name])
    keep = ~spikes
    if keep.sum() < MIN_ROWS:
        raise InputError(f"{log.source}: too few usable rows ({int(keep.sum())}); need at least {MIN_ROWS}")
    take = lambda name: (np.ascontiguousarray(cols[name][keep]) if name in cols else None)  # noqa: E731
    t = take("time_s")  # repeated stamps are fine: fxdsp.mechanisms handles zero-length intervals
    if t[-1] - t[0] <= 0:
        raise InputError(f"{log.source}: time_s does not advance; a diagnosis needs a time span")
    series = M.Series(t=t, temp=take("temp_c"), out=take("output"), ref=take("ref_temp_c"),
                      rate=take("rate_dps"), freq=take("freq_hz"), quad=take("quad"))
    return series, int(spikes.sum())


def diagnose_log(log: Log) -> Diagnosis:
    series, n_spikes = series_from_log(log)
    diag = diagnose_series(series)
    diag.rows = {"used": series.n, "dropped": log.dropped + n_spikes,
                 "dropped_invalid": log.dropped, "dropped_spikes": n_spikes}
    diag.notes = list(log.notes) + list(diag.notes)
    if n_spikes:
        diag.notes.append(f"{n_spikes} isolated spike row(s) (non-physical one-sample readings) set aside")
    return diag


def diagnose_columns(columns: dict, source: str) -> Diagnosis:
    """A diagnosis of logged columns held in memory (contract names -> arrays)."""
    return diagnose_log(Log(columns={k: np.asarray(v, float) for k, v in columns.items()}, source=source))


def diagnose_file(path, mapping=None, delimiter=",", time_format=None) -> Diagnosis:
    return diagnose_log(read_log(path, mapping, delimiter, time_format))
