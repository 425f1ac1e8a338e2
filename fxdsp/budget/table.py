"""Item 1: bit-exact vs float reference of every block and chain on its nominal stimulus, with SNR
and ENOB added to :mod:`fxdsp.float_vs_fixed`'s statistics (same stimulus, same seeds, same units).

SNR = 10 log10(P_signal / P_error) with P_signal the mean square of the float reference output and
P_error the mean square of the difference (bias included); ENOB = (SNR - 1.76) / 6.02.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxdsp.chains import Design
from fxdsp.float_vs_fixed import ErrorStats, block_errors


@dataclass
class BudgetRow:
    stats: ErrorStats

    @property
    def signal_rms(self) -> float:
        return self.stats.signal_rms

    @property
    def snr_db(self) -> float:
        if self.stats.rms == 0:
            return float("inf")
        return float(20 * np.log10(self.signal_rms / self.stats.rms)) if self.signal_rms else float("-inf")

    @property
    def enob(self) -> float:
        return (self.snr_db - 1.76) / 6.02

    def as_dict(self) -> dict:
        s = self.stats
        return {"block": s.block, "port": s.port, "samples": s.samples, "lsb": s.lsb, "unit": s.unit,
                "max_abs_lsb": s.max_lsb, "rms_lsb": s.rms_lsb, "mean_lsb": s.mean / s.lsb,
                "max_abs": s.max_abs * s.scale, "rms": s.rms * s.scale, "mean": s.mean * s.scale,
                "snr_db": self.snr_db, "enob": self.enob, "overflows": s.overflows}


def budget_rows(design: Design, samples: int | None = None, names: list[str] | None = None) -> list[BudgetRow]:
    rows = []
    for name in names or list(design.all):
        rows.extend(BudgetRow(stats) for stats in block_errors(design, name, samples))
    return rows


def format_rows(rows: list[BudgetRow]) -> str:
    head = (f"{'block.port':26s} {'n':>5s} {'max LSB':>8s} {'rms LSB':>8s} {'mean LSB':>9s} {'max|e|':>10s} "
            f"{'rms':>10s} {'mean':>10s} {'unit':6s} {'SNR dB':>7s} {'ENOB':>5s}")
    lines = [head, "-" * len(head)]
    for row in rows:
        s = row.stats
        snr = "inf" if not np.isfinite(row.snr_db) else f"{row.snr_db:.1f}"
        enob = "inf" if not np.isfinite(row.enob) else f"{row.enob:.1f}"
        lines.append(f"{s.block + '.' + s.port:26s} {s.samples:5d} {s.max_lsb:8.2f} {s.rms_lsb:8.2f} "
                     f"{s.mean / s.lsb:+9.2f} {s.max_abs * s.scale:10.4g} {s.rms * s.scale:10.3g} "
                     f"{s.mean * s.scale:+10.3g} {s.unit:6s} {snr:>7s} {enob:>5s}")
    return "\n".join(lines)
