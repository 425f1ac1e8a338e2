"""The diagnosis as the contract's JSON report, a replay model, and a human report with plots."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fxdsp.causes import CAUSES
from fxdsp.diagnose.context import MIN_EVIDENCE, MIN_GAIN, Diagnosis
from fxdsp.diagnose.identify import TAU_LENGTHS, Verdict, described, reasons
from fxdsp.diagnose.selection import MAX_NULL_SETS, NULL_DRAWS, NULL_QUANTILE, NULL_ROWS, WANDER_GAIN
from fxdsp.diagnose.remaining import LEVEL, MIN_SIZE
from fxdsp.diagnose.results import heldout_residuals
from fxdsp.diagnose.uncertainty import NOISE_SD_DRAWS
from fxdsp.plots import save_figure

def explanation(diag: Diagnosis) -> str:
    unnamed = "".join(f" {_UNNAMED.format(cause=c, why=reasons(p))}" for c, p in diag.unidentified.items())
    rest = diag.remaining
    if rest.get("significant"):
        # the list of causes is not the world: what is left is said in the same breath
        unnamed += f" Still unexplained: {rest['explanation']}."
    if not diag.causes:
        g = diag.gain
        if diag.wandering:
            # candidates did lower the error: what stopped them is the log's own wander, not their size
            return (f"No cause named: {', '.join(diag.wandering)} passed the first tests on the output "
                    f"(held-out rms {g['rms_before']:.4g} before), but the residual without "
                    f"{'it' if len(diag.wandering) == 1 else 'them'} wanders, and a random walk of the bias at "
                    "that level gives as much, for the wander it leaves (see notes)." + unnamed)
        head = ("No cause in the list" if rest.get("significant") else
                "Nothing beyond the baseline (B and S polynomials in temp_c, linear thermometers) and the noise:"
                " no candidate cause")
        return (f"{head} lowers the held-out rms of its channel by {100 * (MIN_GAIN - 1):.0f} % "
                f"or more with parameters the log determines (output held-out rms {g['rms_before']:.4g})."
                + unnamed)
    parts = []
    for cause in diag.causes:
        params = dict(diag.parameters[cause])
        record = CAUSES[cause]
        parts.append(record.explain.format(**params, **record.explain_extra(params)))
    g = diag.gain
    parts.append(f"Held-out rms of {g['channel']}: {g['rms_before']:.4g} -> {g['rms_after']:.4g} "
                 f"({g['ratio']:.2f}x).")
    return " ".join(parts) + unnamed


_UNNAMED = "{cause} is not named although it lowers the held-out error: {why}."


def _candidate_entry(diag: Diagnosis, c) -> dict:
    """One candidate of the first round: its held-out figures and its parameters with their
    identified flags, or, when its fit is worse than the baseline, a failed fit and no numbers."""
    entry = {"cause": c.cause, "channel": c.channel, "accepted": c.cause in diag.causes}
    if c.failed:
        return {**entry, "fit": "failed",
                "why": "the fitted model predicts held-out data worse than the baseline"}
    entry.update({"fit": "ok", "score": round(float(c.evidence), 3), "rms_after": float(c.rms_after),
                  "rms_before": float(c.rms_before), "ratio": float(c.ratio)})
    if c.nonlinear:
        entry["parameters"] = {k: described(v, c.nonlinear_sd.get(k), c.verdicts[k]) for k, v in c.nonlinear.items()}
    return entry


def parameters_by_cause(diag: Diagnosis) -> dict:
    """Every named cause's parameters with uncertainty and identified flag (all identified: a
    cause is not named on an undetermined number)."""
    out = {}
    for cause in diag.causes:
        unc = diag.uncertainty.get(cause, {})
        out[cause] = {k: described(v, unc.get(k), Verdict(True)) for k, v in diag.parameters[cause].items()}
    return out


def report_dict(diag: Diagnosis) -> dict:
    from fxdsp.diagnose.extension import fpga_extensions

    cause = diag.causes[0] if diag.causes else "none"
    candidates = [_candidate_entry(diag, c) for c in diag.candidates]
    return {
        "cause": cause,
        "causes": list(diag.causes),
        "explanation": explanation(diag),
        "parameters": dict(diag.parameters.get(cause, {})),
        "uncertainty": dict(diag.uncertainty.get(cause, {})),
        "gain": dict(diag.gain),
        "candidates": candidates,
        "rows": dict(diag.rows or {"used": diag.context.series.n, "dropped": 0}),
        "remaining": dict(diag.remaining),
        "notes": list(diag.notes),
        "fpga_extension": fpga_extensions(diag),
        "parameters_by_cause": parameters_by_cause(diag),
        "not_identified": diag.unidentified,
        "detection": diag.context.series.ramps.describe(),
        "baseline": {"bias_order": diag.orders[0], "sf_order": diag.orders[1], **diag.baseline},
        "method": ("blocked cross-validation: 5 folds of interleaved contiguous segments; score = held-out "
                   "SSE drop in units of the channel's white-noise variance; a cause needs a held-out rms "
                   f"ratio >= {MIN_GAIN} and a score >= {MIN_EVIDENCE:g}; forward selection, also started from "
                   "the best pair of causes (two causes can hide each other), and trying the best pair on top of "
                   "the causes in when no single one passes there; time-like causes (aging, warm-up, "
                   "hysteresis, quadrature) re-tested on random-walk innovations when the residual without them "
                   "wanders (the places that frees filled again by the forward selection, from the other causes), "
                   f"or kept when their held-out rms ratio >= {WANDER_GAIN} and their evidence, in units "
                   "of the residual's variogram at a fifth of the log once they are fitted, exceeds "
                   f"the {100 * NULL_QUANTILE:g} % point of {NULL_DRAWS} random walks (at the level of the "
                   "residual without them) counted the same way, and beyond the same point of draws of the "
                   "residual's own noise (white, flicker, random walk fitted to its Allan variance) when that "
                   f"noise is coloured (a short log: up to {MAX_NULL_SETS} sets of {NULL_DRAWS} draws, as many "
                   f"as {NULL_ROWS:,} simulated rows buy, and the 1 - {100 * (1 - NULL_QUANTILE):g} %/sets point); "
                   "a cause seen only on a quantised readout (temp_c or freq_hz on a grid) beyond the same point "
                   "of draws of the readout's own error (its step at a random offset, no noise to dither it); "
                   "numbers (parameters, baseline) by generalised least squares: each channel's final fit "
                   "again on rows whitened by the Kalman innovations of the noise its residual shows (white, "
                   "a flicker band from the edge that fits, random walk), except a channel with a cause whose column is not known row by row "
                   "(hysteresis, ramp rate: dated from the ramps; quadrature: a noisy readout), which keeps "
                   "ordinary least squares; "
                   "uncertainties (each at least the ordinary fit's): the larger of a delete-one-group "
                   "jackknife (20 contiguous groups; a warm-up, or a column one group holds most of: "
                   "the 5 interleaved folds) and the spread (central 68 %) of the parameters over "
                   f"{NOISE_SD_DRAWS} refits of the final model plus draws of the residual's own noise (white, "
                   "flicker and random walk, and white and a walk alone: the larger), a time constant searched "
                   "again on each; a parameter is identified when finite, not at the end of its search "
                   f"range, its uncertainty below its value, and (a time constant) at most 1/{TAU_LENGTHS:g} of "
                   "the log; a cause is named only with identified parameters, and not when it only absorbs part "
                   "of a structure of its kind that remains (that structure, modelled, predicts the held-out data "
                   "better without the cause); remaining structure: the final residual of every channel tested "
                   "against a step, a periodic term, a curved drift, temperature, dT/dt, rate and quadrature "
                   "shapes by likelihood ratios under white noise plus a random walk, calibrated at the "
                   f"{100 * LEVEL:g} % level by draws of the noise fitted to the residual (white, flicker, random "
                   f"walk); reported when also at least {MIN_SIZE:g} of the white noise (held-out rms)"),
    }


def replay_model(diag: Diagnosis) -> dict:
    """The fitted extended model in the simulator's replay format (see fxdsp.sim.model)."""
    base = {k: v for k, v in diag.baseline.items()}
    return {"baseline": base, "effects": {c: dict(diag.parameters[c]) for c in diag.causes}}


def write_json(path, data: dict) -> None:
    from fxdsp.outputs import json_text

    Path(path).write_text(json_text(data, "diagnose report", indent=2), encoding="utf-8")


# -- human report --------------------------------------------------------------------------------
def write_report(diag: Diagnosis, directory) -> Path:
    """Markdown report plus PNG plots (residual vs temperature / dT/dt / time) in ``directory``."""
    from fxdsp.plots import pyplot

    plt = pyplot()

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    ctx = diag.context
    s = ctx.series
    base_res = heldout_residuals(ctx, {}, "output")
    ext_state = {c: diag.state[c] for c in diag.state if c in _OUTPUT_CAUSES}
    ext_res = heldout_residuals(ctx, ext_state, "output") if ext_state else None
    phase = s.ramps.phase()
    styles = {1: ("heating", "tab:red"), -1: ("cooling", "tab:blue"), 0: ("dwell", "0.6")}
    step = max(1, s.n // 20000)  # a million points make an unreadable, slow scatter
    idx = np.arange(0, s.n, step)

    fig, axes = plt.subplots(3, 1, figsize=(9, 11))
    for code, (label, color) in styles.items():
        m = idx[phase[idx] == code]
        axes[0].plot(s.temp[m], base_res[m], ".", ms=2, color=color, label=label)
        axes[1].plot(s.dtdt[m] * 60.0, base_res[m], ".", ms=2, color=color, label=label)
    axes[0].set_xlabel("temp_c [C]")
    axes[1].set_xlabel("d(temp_c)/dt [C/min]")
    axes[2].plot(s.t[idx] / 3600.0, base_res[idx], ".", ms=2, color="0.4", label="baseline")
    if ext_res is not None:
        axes[2].plot(s.t[idx] / 3600.0, ext_res[idx], ".", ms=2, color="tab:green", label="extended model")
    axes[2].set_xlabel("time [h]")
    for ax in axes:
        ax.set_ylabel("held-out residual of output")
        ax.grid(alpha=0.3)
        ax.legend(markerscale=5, fontsize=8)
    axes[0].set_title("Baseline residual (held-out folds), heating vs cooling")
    save_figure(fig, out / "residuals.png")
    images = ["residuals.png"]

    for channel, label in (("freq_hz", "resonant frequency"), ("temp_c", "temp_c against ref_temp_c")):
        if channel not in s.channels():
            continue
        res = heldout_residuals(ctx, {}, channel)
        fig, ax = plt.subplots(figsize=(9, 4))
        x = s.ref if channel == "temp_c" else s.temp
        for code, (lab, color) in styles.items():
            m = idx[phase[idx] == code]
            ax.plot(x[m], res[m], ".", ms=2, color=color, label=lab)
        ax.set_xlabel("ref_temp_c [C]" if channel == "temp_c" else "temp_c [C]")
        ax.set_ylabel(f"held-out residual of {channel}")
        ax.set_title(f"Baseline residual of the {label}")
        ax.grid(alpha=0.3)
        ax.legend(markerscale=5, fontsize=8)
        save_figure(fig, out / f"residual_{channel}.png")
        images.append(f"residual_{channel}.png")

    images += _remaining_plots(diag, out, idx)

    data = report_dict(diag)
    lines = [f"# fxdsp diagnose: {data['cause']}", "", data["explanation"], "",
             f"Rows used: {data['rows']['used']}, dropped: {data['rows']['dropped']}. "
             f"Baseline orders: B {diag.orders[0]}, S {diag.orders[1]}.", ""]
    if diag.causes:
        lines += ["## Parameters", "", "| cause | parameter | value | uncertainty (1 sd) |", "|---|---|---|---|"]
        for cause in diag.causes:
            for name, value in diag.parameters[cause].items():
                sd = diag.uncertainty.get(cause, {}).get(name, float("nan"))
                lines.append(f"| {cause} | {name} | {value:.6g} | {sd:.3g} |")
        lines.append("")
    g = data["gain"]
    lines += ["## Held-out gain", "", f"{g['channel']}: rms {g['rms_before']:.6g} -> {g['rms_after']:.6g}, "
              f"ratio {g['ratio']:.3f}", "", "## Candidates (first round, against the baseline)", "",
              "| cause | channel | score (noise variances) | held-out rms before | after | ratio | accepted |",
              "|---|---|---|---|---|---|---|"]
    for c in data["candidates"]:
        if c["fit"] == "failed":
            lines.append(f"| {c['cause']} | {c['channel']} | failed fit: {c['why']} | | | | |")
            continue
        lines.append(f"| {c['cause']} | {c['channel']} | {c['score']:.1f} | {c['rms_before']:.4g} | "
                     f"{c['rms_after']:.4g} | {c['ratio']:.3f} | {'yes' if c['accepted'] else ''} |")
    if diag.unidentified:
        lines += ["", "## Not identified (not named, no number given)", "", "| cause | parameter | why |",
                  "|---|---|---|"]
        for cause, params in diag.unidentified.items():
            for name, p in params.items():
                lines.append(f"| {cause} | {name} | {p.get('why', 'determined, but another of its parameters is not')} |")
    rest = data["remaining"]
    lines += ["", "## What remains unexplained", "", f"{'Significant' if rest['significant'] else 'Not significant'}: "
              f"{rest['explanation']}.", "", "| channel | significant | held-out rms | statistic | 1 % threshold | p |",
              "|---|---|---|---|---|---|"]
    for ch, v in rest["channels"].items():
        lines.append(f"| {ch} | {'yes' if v['significant'] else 'no'} | {v['rms']:.4g} | {v['statistic']:.2f} | "
                     f"{v['threshold']:.2f} | {v['p_value']:.3g} |")
    lines += ["", "## How ramps were read", "", data["detection"], ""]
    lines += ["", "## Plots", ""] + [f"![{name}]({name})" for name in images] + ["", "## Method", "",
                                                                               data["method"], ""]
    path = out / "report.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def _remaining_plots(diag: Diagnosis, out: Path, idx: np.ndarray) -> list[str]:
    """Per channel with structure left: the final model's held-out residual against time, and
    against every other column the structure follows, with the structure found drawn over it."""
    from fxdsp.plots import pyplot

    plt = pyplot()

    ctx, s = diag.context, diag.context.series
    axes_of = {"time_s": (s.t / 3600.0, "time [h]"), "temp_c": (s.temp, "temp_c [C]"),
               "d(temp_c)/dt": (s.dtdt * 60.0, "d(temp_c)/dt [C/min]"),
               "rate_dps": (s.rate, "rate_dps [deg/s]"), "quad": (s.quad, "quad")}
    images = []
    for v in diag.structures:
        if not v.significant:
            continue
        res = heldout_residuals(ctx, diag.state, v.channel)
        shown = ["time_s"] + [a for a in v.against if a != "time_s"]
        fig, axes = plt.subplots(len(shown), 1, figsize=(9, 3.6 * len(shown)), squeeze=False)
        for ax, name in zip(axes[:, 0], shown):
            xs, label = axes_of[name]
            ax.plot(xs[idx], res[idx], ".", ms=2, color="0.5", label="final model's held-out residual")
            order = idx[np.argsort(xs[idx], kind="stable")] if name != "time_s" else idx
            ax.plot(xs[order], v.curve[order], "-" if name == "time_s" else ".", ms=2, color="tab:red",
                    label="structure left")
            ax.set_xlabel(label)
            ax.set_ylabel(f"{v.channel}")
            ax.grid(alpha=0.3)
            ax.legend(markerscale=5, fontsize=8)
        axes[0, 0].set_title(f"What the causes leave in {v.channel}: " + "; ".join(w for _, w in v.found)[:110])
        name = f"remaining_{v.channel}.png"
        save_figure(fig, out / name)
        images.append(name)
    return images


_OUTPUT_CAUSES = tuple(c.name for c in CAUSES.values() if c.channel == "output" and c.name != "none")
