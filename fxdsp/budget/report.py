"""What ``fxdsp budget`` shows: its text tables (attribution, theory, floor, Allan deviation, drive\nsweep), the PNG plots (matplotlib Agg) and the Markdown report of ``--report DIR``."""

from __future__ import annotations

import math
from functools import partial
from pathlib import Path

import numpy as np
import scipy.signal as sps
from tqdm import tqdm as _tqdm

from fxdsp.budget.attribution import Attribution
from fxdsp.budget.drive_loop import format_allan as format_reference_allan, format_budget
from fxdsp.budget import optimise as opt
from fxdsp.budget.floor import (DOMINANT_FACTOR, FLICKER_FACTOR, WITHIN_DB, Allan, DriveSweep,
                                Floor, carrier_chains)
from fxdsp.budget.hybrid import CATEGORIES
from fxdsp.budget.table import format_rows
from fxdsp.float_vs_fixed import port_unit
from fxdsp.plots import pyplot, save_figure

tqdm = partial(_tqdm, disable=None)


def plot_spectra(att: Attribution, fs: float, path: Path) -> None:
    plt = pyplot()
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
    save_figure(fig, path)


def plot_attribution(att: Attribution, path: Path) -> None:
    plt = pyplot()
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
    save_figure(fig, path)


def plot_sweeps(sweeps: dict, unit: str, target: float | None, path: Path, title: str) -> None:
    plt = pyplot()
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
    save_figure(fig, path)


def plot_allan(allan, path: Path) -> None:
    """Log-log Allan deviation with the bias-instability point and the 1 s value marked."""
    plt = pyplot()
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
    save_figure(fig, path)


def plot_drive_sweep(sweep, path: Path) -> None:
    """rms and |mean| of the chain error (nominal and quasi-static) against the drive frequency."""
    plt = pyplot()
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
    save_figure(fig, path)


def plot_reference_allan(ra, path: Path) -> None:
    """The reference's Allan deviation locked to the drive loop against the open-loop NCO's drift."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 5.5))
    ax.loglog(ra.taus, ra.adev_locked, "o-", ms=3, lw=1.0, label="locked to the drive loop (fixed - float)")
    ax.loglog(ra.taus, ra.adev_open, "--", lw=1.0, label=f"open loop: the centre word's drift "
              f"{ra.open_drift_rad_per_h:.3g} rad/h")
    _save_allan(fig, ax, "deg/h", f"{ra.table}: demodulator reference error as rate on the nominal quadrature, "
                f"{ra.seconds:g} s", path)


def attr_dict(a: Attribution) -> dict:
    return {"chain": a.chain, "port": a.port, "unit": a.unit, "samples": a.samples, "total_rms": a.total_rms,
            "total_mean": a.total_mean, "total_std": a.total_std, "sensor_noise_rms": a.sensor_noise_rms,
            "hybrid_vs_bitexact_max_lsb": a.hybrid_max_diff, "power_sum_db": a.power_sum_db,
            "power_sum_with_cross_terms_db": a.with_cross_db, "mean_sum": a.mean_sum, "variance_sum_db": a.var_sum_db,
            "superposition_rms": a.superposition_rms, "tolerance_db": a.tolerance_db, "power_ok": a.power_ok,
            "explanation": a.explanation(), "by_category": a.by_category(),
            "sources": [{"name": s.source.name, "category": s.source.category, "stage": s.source.stage,
                         "rms": s.rms, "mean": s.mean, "std": s.std, "power_share": s.power_share,
                         "white_model_rms": s.model_rms} for s in a.sources],
            "cross_terms": [{"a": x, "b": y, "share": c} for x, y, c in a.cross_terms],
            "theory": [{k: v for k, v in t.__dict__.items()} for t in a.theory]}


def format_attribution(a: Attribution) -> str:
    lines = [f"{a.chain}.{a.port}: total {a.total_rms:.4g} {a.unit} rms (mean {a.total_mean:+.4g}, std {a.total_std:.4g}) "
             f"vs float on the analog inputs, {a.samples} samples; sensor noise at this output {a.sensor_noise_rms:.4g} "
             f"{a.unit} rms; all-on hybrid vs bit-exact: {a.hybrid_max_diff:g} LSB",
             f"  {'source':26s} {'category':25s} {'rms':>10s} {'mean':>11s} {'power %':>8s} {'white model':>11s}"]
    for s in sorted(a.sources, key=lambda s: -s.rms):
        model = f"{s.model_rms:.3g}" if s.model_rms is not None else "-"
        lines.append(f"  {s.source.name:26s} {s.source.category:25s} {s.rms:10.3g} {s.mean:+11.3g} "
                     f"{s.power_share * 100:8.2f} {model:>11s}")
    cats = a.by_category()
    lines.append("  by category (rms): " + ", ".join(f"{c} {math.sqrt(v):.3g}" for c, v in cats.items() if v))
    lines.append(f"  additivity: sum of powers {a.power_sum_db:+.2f} dB vs total (tolerance +-{a.tolerance_db} dB) "
                 f"-> {'OK' if a.power_ok else 'NOT within tolerance'}; with cross terms {a.with_cross_db:+.3f} dB")
    lines.append("  " + a.explanation())
    return "\n".join(lines)


def format_theory(a: Attribution) -> str:
    lines = [f"{a.chain}.{a.port}: rounding points vs theory (q^2/12, zero mean; output vs white-noise model)",
             f"  {'source':24s} {'mode':8s} {'q':>9s} {'mean/q':>7s} {'var dB':>7s} {'MSE dB':>7s} "
             f"{'out':>9s} {'model':>9s} {'out dB':>7s} flag"]
    for t in a.theory:
        lines.append(f"  {t.source:24s} {t.rounding:8s} {t.q:9.3g} {t.local_mean_q:+7.3f} {t.local_var_db:+7.2f} "
                     f"{t.local_mse_db:+7.2f} {t.output_rms:9.3g} {t.model_output_rms:9.3g} {t.output_db:+7.2f} "
                     f"{'FLAG' if t.flagged else 'ok'}")
        for r in t.reasons:
            lines.append(f"      - {r}")
    return "\n".join(lines)


def format_floor(f: Floor) -> str:
    head = f"floor: {f.chain}.{f.port} "
    dom = ", ".join(f"{n} {r:.3g}" + (f" ({20 * math.log10(r / f.total):+.1f} dB)" if f.total > 0 else "")
                    for n, r in f.dominant) or "none"
    tail = f"; dominant (within {20 * math.log10(1 / DOMINANT_FACTOR):.0f} dB of the total): {dom}"
    if f.floor <= 0:
        return head + f"floor 0 (no ADC reaches this output), total {f.total:.3g} {f.unit}: no margin" + tail
    if f.total <= 0:
        return head + f"floor {f.floor:.3g} {f.unit} (ADC), total 0: no margin" + tail
    verdict = f"within {WITHIN_DB:g} dB" if f.within else f"NOT within {WITHIN_DB:g} dB"
    if f.margin_db < 0:  # possible: correlated sources can partly cancel the ADCs' error
        verdict += " (total below the floor: the sources partly cancel)"
    return head + (f"floor {f.floor:.3g} {f.unit} (ADC), total {f.total:.3g}, margin {f.margin_db:+.1f} dB "
                   f"-> {verdict}") + tail


def format_allan(a: Allan) -> str:
    edge = " (at the longest tau: the curve is still falling, an upper bound)" if a.bi_at_longest_tau else ""
    how = ("measured" if a.measured_1s else
           f"extrapolated along tau^-1/2 from tau {a.fit_taus[0]:.3g}..{a.fit_taus[-1]:.3g} s")
    return "\n".join([
        f"{a.chain}.{a.port} bit-exact minus float at {a.temp_c:g} C and a constant input {a.level:g}, {a.samples} "
        f"samples at "
        f"{a.fs:g} Hz after {a.settle} settling samples (allantools.oadev, octave-spaced taus "
        f"{a.taus[0]:.3g}..{a.taus[-1]:.3g} s):",
        f"  bias instability: min adev {a.bi_adev:.3g} {a.unit} at tau {a.bi_tau:.3g} s{edge}; flicker floor "
        f"B = min / {FLICKER_FACTOR} = {a.flicker_floor:.3g} {a.unit} (IEEE 952: sigma = {FLICKER_FACTOR} B on "
        f"the flat part)",
        f"  random walk of the fixed-point design: adev(1 s) {a.adev_1s:.3g} {a.unit} ({how}) -> "
        f"adev(1 s) / 60 = {a.arw:.3g} {a.unit} sqrt(h)" + (" (the angle random walk, deg/sqrt(h))"
                                                           if a.unit == "deg/h" else "")])


def format_sweep(s: DriveSweep) -> str:
    lo_t, hi_t = s.temp_range_c
    lines = [f"{s.chain}.{s.port} vs drive frequency ({s.demod}.f_hz): w(T) = w0 [1 - a (T - T0) / 2], a {s.a_ppm_per_c:g} ppm/C, "
             f"T0 {s.t0_c:g} C, {lo_t:g}..{hi_t:g} C -> {s.band[0]:.2f}..{s.band[1]:.2f} Hz around f0 "
             f"{s.f0:g} Hz, {len(s.points)} points ({s.unit}; nominal = section 1's chain row, static = "
             f"quasi-static chamber points)",
             f"  {'f Hz':>10s} {'rms':>9s} {'mean':>10s} {'static rms':>10s} {'static mean':>11s} {'ovf':>4s}"]
    for p in s.points:
        lines.append(f"  {p.f_hz:10.2f} {p.rms:9.4g} {p.mean:+10.3g} {p.static_rms:10.4g} {p.static_mean:+11.3g} "
                     f"{p.overflows:4d}")
    w = {k: s.worst(k) for k in ("rms", "mean", "static_rms", "static_mean")}
    lines.append(f"  worst over the band: rms {w['rms'].rms:.4g} at {w['rms'].f_hz:.2f} Hz, |mean| "
                 f"{abs(w['mean'].mean):.4g} at {w['mean'].f_hz:.2f} Hz; quasi-static rms "
                 f"{w['static_rms'].static_rms:.4g} at {w['static_rms'].f_hz:.2f} Hz, |mean| "
                 f"{abs(w['static_mean'].static_mean):.4g} at {w['static_mean'].f_hz:.2f} Hz")
    return "\n".join(lines)


def _figures(md: list, out: Path, items, stem: str, plot, text) -> None:
    """Per chain output (``items`` with ``chain`` and ``port``): its text block and its plot."""
    for item in items:
        name = f"{stem}_{item.chain}.{item.port}.png"
        plot(item, out / name)
        md.append("```\n" + text(item) + "\n```\n")
        md.append(f"![{stem.replace('_', ' ')}]({name})\n")


def write_report(out: Path, design, cfg, rows, attrs, statics, target, result, args, floors, allans, sweeps,
            loops, references) -> None:
    out.mkdir(parents=True, exist_ok=True)
    figs = {}
    for (c, p), a in attrs.items():
        tag = f"{c}.{p}"
        plot_spectra(a, design.chains[c].fs_hz if c in carrier_chains(design) else 1.0, out / f"spectrum_{tag}.png")
        plot_attribution(a, out / f"attribution_{tag}.png")
        figs[(c, p)] = tag
    md = [f"# fxdsp error budget\n\nConfig `{cfg.source}`, seed {design.seed}.\n",
          "## 1. Bit-exact vs float reference\n\nFloat fed with the same stored inputs (ADC excluded), nominal "
          "stimulus of each block; physical units per port.\n",
          "```\n" + format_rows(rows) + "\n```\n"]
    if statics:
        md.append("Quasi-static chamber points (settled), per chain output:\n\n```\n" + "\n".join(
            f"{c}.{p}: rms {st['rms']:.4g}, max {st['max_abs']:.4g}, mean {st['mean']:+.4g} "
            f"{port_unit(design, c, p)[0]}, overflows {st['overflows']}"
            for (c, p), st in statics.items()) + "\n```\n\nA nominal stimulus sweeps its temperature range in a "
            "few thousand samples, so the temperature word's rounding becomes a fast sawtooth that an output "
            "low-pass hides; the quasi-static test does not hide it.\n")
    md.append("## 2. Attribution\n\nOne source quantised at a time (the rest in float), against the float chain fed "
              "with the analog (pre-ADC) signals. The all-on hybrid reproduces the bit-exact model (difference "
              "shown).\n")
    for key, a in attrs.items():
        md.append("```\n" + format_attribution(a) + "\n```\n")
        md.append(f"![attribution](attribution_{figs[key]}.png)\n")
    md.append("### Floor and margin\n\nThe floor of an output is the quantisation of the input ADCs carried to it "
              "(power sum of the ADC sources above); margin = 20 log10(total / floor). A non-ADC source whose rms is "
              "at least half the total (power within 6 dB of it) dominates the design error.\n")
    md.append("```\n" + "\n".join(format_floor(f) for f in floors) + "\n```\n")
    md.append("## 3. Theory check\n\nEach rounding point's residue against q^2/12 and zero mean; each source's "
              "output contribution against the white uniform noise model pushed through the same chain (the gain "
              "after the stage).\n")
    for key, a in attrs.items():
        if a.theory:
            md.append("```\n" + format_theory(a) + "\n```\n")
            md.append(f"![spectrum](spectrum_{figs[key]}.png)\n")
    md.append("## 4. Allan deviation\n\nOverlapping Allan deviation of the bit-exact minus float error (both fed "
              "the same ADC codes) at constant temperature and input, for every output of a chain with a "
              "demodulator.\n")
    _figures(md, out, allans, "allan", plot_allan, format_allan)
    md.append("## 5. Drive-frequency sweep\n\nThe design rebuilt with the demodulator's f_hz at each drive "
              "frequency the temperature range produces; both the carrier and the NCO move.\n")
    _figures(md, out, sweeps, "drive_sweep", plot_drive_sweep, format_sweep)
    md.append("## 6. Drive loops\n\nThe bit-exact loop and its float reference closed on the simulated mode from "
              "power-on with the same pick-off noise; the float loop reads the same drive ADC codes, so its errors "
              "are the floor the ADC allows. Frequency word against the mode's true resonance over 10 ms records "
              "after lock; rate error = the reference phase error on the nominal quadrature.\n")
    md.append("```\n" + ("\n".join(format_budget(lb) for lb in loops) or "no drive loop") + "\n```\n")
    for ra in references:
        name = f"reference_allan_{ra.table}.png"
        plot_reference_allan(ra, out / name)
        md.append("```\n" + format_reference_allan(ra) + "\n```\n")
        md.append(f"![reference Allan deviation]({name})\n")
    chain = target.chain if target else args.chain
    port = target.port if target else (list(design.chains[chain].outputs)[-1] if chain else None)
    if chain and opt.knobs_of(cfg.data, chain):
        sweeps_wl = opt.sweep(cfg, chain, port, progress=tqdm)
        unit = port_unit(design, chain, port)[0]
        name = f"wordlength_{chain}.{port}.png"
        plot_sweeps(sweeps_wl, unit, target.value if target else None, out / name,
                       f"{chain}.{port}: error vs word length, one knob at a time (others at default)")
        md.append(f"## 7. Word length\n\n![sweep]({name})\n")
    else:
        md.append(f"## 7. Word length\n\n{chain}: no word-length knobs (fxdsp.budget.optimise.KIND_KNOBS).\n")
    if result:
        md.append(f"Target {args.target} ({result.target.value:.4g} {result.target.unit}, {result.metric}): error "
                  f"{result.default_error:.4g} -> {result.error:.4g}; total bits {result.default_cost['total_bits']} -> "
                  f"{result.cost['total_bits']}.\n\n```\n" + "\n".join(
                      f"{k:30s} {result.default_values[k]:3d} -> {v:3d}" for k, v in result.values.items()) + "\n```\n")
    (out / "budget.md").write_text("\n".join(md), encoding="utf-8")
