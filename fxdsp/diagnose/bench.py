"""Benchmark (not a test): seconds to diagnose a 6k-row and a 1M-row simulated log, file to report.

    fxdsp diagnose-bench [--rows 6000 1000000]

Each log is the paper002 chamber run with a thermal lag, every optional column, sampled so that it
has about the requested number of rows; the time covers reading the CSV and the whole diagnosis.
"""

from __future__ import annotations

import time
from pathlib import Path

PAPER002_DURATION_S = 58_800.0  # about 16.3 h at duration_scale 1


def bench(rows: int, directory: Path) -> tuple[float, float, dict]:
    from fxdsp.diagnose.api import diagnose_file
    from fxdsp.diagnose.report import report_dict
    from fxdsp.sim import generate_log, write_log

    step = PAPER002_DURATION_S / rows
    log = generate_log("paper002", {"thermal_lag": {"tau_s": 900.0}}, seed=7, time_step_s=step)
    path = directory / f"bench_{rows}.csv"
    write_log(path, log)
    start = time.perf_counter()
    diag = diagnose_file(path)
    seconds = time.perf_counter() - start
    return seconds, float(len(log["time_s"])), report_dict(diag)
