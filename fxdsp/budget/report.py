"""PNG plots (matplotlib Agg) and the Markdown report of ``fxdsp budget --report DIR``."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import scipy.signal as sps  # noqa: E402

from fxdsp.budget.attribution import Attribution  # noqa: E402
from fxdsp.budget.hybrid import CATEGORIES  # noqa: E402


def plot_spectra(att: Attribution, fs: float, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(9, 5))
    nper = min(8192, att.total_error.size)
    for s in att.sources:
        if s.error is None or not np.any(s.error):
            continue
        f, p = sps.welch(s.error * att.scale, fs=fs, nperseg=nper)
        ax.loglog(f[1:], p[1:], lw=0.8, label=s.source.name)
    f, p = sps.welch(att.total_error * att.scale, fs=fs, nperseg=nper)
    ax.loglog(f[1:], p[1:], "k", lw=1.6, label="total")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"PSD ({att.unit}^2/Hz)")
    ax.set_title(f"{att.chain}.{att.port}: output error spectrum per source (one source quantised at a time)")
    ax.legend(fontsize=6, ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_attribution(att: Attribution, path: Path) -> None:
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 5), gridspec_kw={"width_ratios": [3, 1]})
    names = [s.source.name for s in att.sources]
    ms = [s.rms**2 for s in att.sources]
    a1.barh(names, ms, color=[f"C{CATEGORIES.index(s.source.category)}" for s in att.sources])
    a1.set_xscale("log")
    a1.set_xlabel(f"mean square at the output ({att.unit}^2)")
    a1.axvline(att.total_rms**2, color="k", ls="--", label=f"total {att.total_rms:.3g} {att.unit} rms")
    a1.legend(fontsize=7)
    a1.tick_params(axis="y", labelsize=7)
    cats = att.by_category()
    a2.bar(range(len(cats)), list(cats.values()), color=[f"C{i}" for i in range(len(cats))])
    a2.set_xticks(range(len(cats)), [c.replace(" ", "\n") for c in cats], fontsize=6)
    a2.set_yscale("log")
    a2.set_title("by category", fontsize=8)
    fig.suptitle(f"{att.chain}.{att.port}: attribution (power sum {att.power_sum_db:+.2f} dB vs total)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_sweeps(sweeps: dict, unit: str, target: float | None, path: Path, title: str) -> None:
    fig, ax = plt.subplots(figsize=(9, 5.5))
    for i, (name, pts) in enumerate(sweeps.items()):
        if not pts:
            continue
        w, e = zip(*pts)
        ax.semilogy(w, e, marker="o", ms=3, lw=0.8, label=name, color=f"C{i % 10}", ls="-" if i < 10 else "--")
    if target:
        ax.axhline(target, color="k", ls=":", label="target")
    ax.set_xlabel("word length of the knob (bits; integer bits kept)")
    ax.set_ylabel(f"rms error ({unit})")
    ax.set_title(title)
    ax.legend(fontsize=6, ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_allan(allan, path: Path) -> None:
    """Log-log Allan deviation with the bias-instability point and the 1 s value marked."""
    fig, ax = plt.subplots(figsize=(8, 5.5))
    ok = allan.adev > 0  # a zero deviation (exactly constant error) has no place on a log axis
    ax.loglog(allan.taus[ok], allan.adev[ok], "o-", ms=3, lw=1.0, label="overlapping Allan deviation")
    if allan.bi_adev > 0:
        ax.loglog([allan.bi_tau], [allan.bi_adev], "rv", label=f"min {allan.bi_adev:.3g} {allan.unit} "
                  f"(B = min/0.664 = {allan.flicker_floor:.3g})")
    if allan.adev_1s > 0:
        how = "measured" if allan.measured_1s else "extrapolated"
        ax.loglog([1.0], [allan.adev_1s], "ks", label=f"tau 1 s ({how}): ARW {allan.arw:.3g} deg/sqrt(h)")
    _save_allan(fig, ax, allan.unit, f"{allan.chain}.{allan.port}: fixed minus float error, {allan.temp_c:g} C, "
                f"input {allan.level:g}", path)


def _save_allan(fig, ax, unit: str, title: str, path: Path) -> None:
    """An Allan deviation plot's axes, legend and grid, written to ``path``."""
    ax.set_xlabel("tau (s)")
    ax.set_ylabel(f"Allan deviation ({unit})")
    ax.set_title(title)
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_drive_sweep(sweep, path: Path) -> None:
    """rms and |mean| of the chain error (nominal and quasi-static) against the drive frequency."""
    f = np.array([p.f_hz for p in sweep.points])
    series = {"rms (nominal)": [p.rms for p in sweep.points], "|mean| (nominal)": [abs(p.mean) for p in sweep.points],
              "rms (quasi-static)": [p.static_rms for p in sweep.points],
              "|mean| (quasi-static)": [abs(p.static_mean) for p in sweep.points]}
    fig, ax = plt.subplots(figsize=(8, 5))
    for i, (name, v) in enumerate(series.items()):
        ax.plot(f, v, marker="o", ms=3, lw=0.9, ls="-" if "rms" in name else "--", color=f"C{i}", label=name)
    ax.axvline(sweep.f0, color="k", ls=":", lw=0.8, label=f"f0 {sweep.f0:g} Hz")
    ax.set_yscale("log", nonpositive="mask")  # an exact zero (no error at all) is left out
    ax.set_xlabel("drive frequency (Hz)")
    ax.set_ylabel(f"error ({sweep.unit})")
    ax.set_title(f"{sweep.chain}.{sweep.port} vs drive frequency ({sweep.temp_range_c[0]:g}..{sweep.temp_range_c[1]:g} C, "
                 f"a {sweep.a_ppm_per_c:g} ppm/C)")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_reference_allan(ra, path: Path) -> None:
    """The reference's Allan deviation locked to the drive loop against the open-loop NCO's drift."""
    fig, ax = plt.subplots(figsize=(8, 5.5))
    ax.loglog(ra.taus, ra.adev_locked, "o-", ms=3, lw=1.0, label="locked to the drive loop (fixed - float)")
    ax.loglog(ra.taus, ra.adev_open, "--", lw=1.0, label=f"open loop: the centre word's drift "
              f"{ra.open_drift_rad_per_h:.3g} rad/h")
    _save_allan(fig, ax, "deg/h", f"{ra.table}: demodulator reference error as rate on the nominal quadrature, "
                f"{ra.seconds:g} s", path)
