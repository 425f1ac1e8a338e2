"""The extension's report: ``report.json`` (machine-readable), ``report.md`` and ``heldout_error.png``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fxdsp.diagnose.remaining import LEVEL
from fxdsp.plots import save_figure


def public(d):
    """A result without its private (underscore) entries: arrays kept for the plot only."""
    if isinstance(d, dict):
        return {k: public(v) for k, v in d.items() if not str(k).startswith("_")}
    return d


def summary(errors: dict) -> dict:
    """Held-out gain (before / after) and the gain each stage's removal leaves."""
    v = errors["variants"]
    after = v["after"]["rms"]
    gain = v["before"]["rms"] / after if after > 0 else float("inf")
    without = {k.removeprefix("without "): (v["before"]["rms"] / v[k]["rms"] if v[k]["rms"] > 0 else float("inf"))
               for k in v if k.startswith("without ")}
    return {"rms_before": v["before"]["rms"], "rms_after": after, "gain": gain, "gain_without": without}


def _bullets(notes: list) -> list[str]:
    """A markdown list of notes and the blank line after it; nothing without notes."""
    return [f"* {n}" for n in notes] + [""] if notes else []


def markdown(rep: dict) -> str:
    e, s = rep["heldout"], rep["summary"]
    L = [f"# fxdsp extend: {rep['log']}", "",
         f"Chain: **{rep['chain']}**. Diagnosis: causes **{', '.join(rep['diagnosis']['causes']) or 'none'}** "
         f"(held-out gain of the model {rep['diagnosis']['gain']:.3g}).", ""]
    notes = rep["diagnosis"].get("notes", [])   # what the reader and the diagnosis set aside, in their words
    L += (["Set aside or not named (the diagnosis's notes):", ""] if notes else []) + _bullets(notes)
    L += ["## Remedies", ""]
    L += [f"* {r['cause']}: {r['what']}" for r in rep["remedies"]] or ["* none: the calibrated chain as it is"]
    if rep.get("uncompensated"):
        L += ["", "## Uncompensated", "",
              "Named causes this chain has no hardware remedy for: the extended config leaves their error in. Held-out "
              "size: sqrt(rms_without^2 - rms_with^2) of the diagnosis's held-out residuals (each row predicted by a "
              "fit on the other time-blocked folds), the diagnosed model without and with the cause.", "",
              "| cause | held-out size | unit | held-out rms with / without it | why |", "|---|---:|---|---|---|"]
        L += [f"| {u['cause']} | {u['heldout_size']:.4g} | {u['unit']} | {u['heldout_rms_with']:.4g} / "
              f"{u['heldout_rms_without']:.4g} | {u['reason']} |" for u in rep["uncompensated"]]
    d = rep.get("design")
    if d:
        L += ["", "## Design", "",
              f"Base: {rep.get('base_config', 'the built-in config')}. The extended config is the base with the calibrated "
              f"coefficients ({', '.join(d['calibrated_keys'])})"
              + (f" and the remedies' keys ({', '.join(d['remedy_keys'])})" if d["remedy_keys"] else "")
              + " rewritten; every other setting is the base's"
              + (", except:" if d["changes"] else "."), ""]
        if d["changes"]:
            L += ["| field | from | to | in | why |", "|---|---|---|---|---|"]
            L += [f"| {c['field']} | {'-' if c['from'] is None else c['from']} | {c['to']} | {', '.join(c['in'])} | "
                  f"{c['why']} |" for c in d["changes"]]
    L += ["", "## Held-out compensated-output error", "",
          f"Unit: {e['unit']}. Held out: {e['heldout']} ({e['heldout_rows']} of {e['rows']} rows).", "",
          "| variant | stages | rms | max abs | overflows |", "|---|---|---:|---:|---:|"]
    for name, r in e["variants"].items():
        L.append(f"| {name} | {', '.join(r['stages']) or '-'} | {r['rms']:.4g} | {r['max_abs']:.4g} | {r['overflows']} |")
    curv = {k: r["temp_vs_ref_c"] for k, r in e["variants"].items() if "temp_vs_ref_c" in r}
    if curv:
        L += ["", "Temperature the engines see against ref_temp_c, rms after an affine fit (the RTD table's own "
              "effect): " + ", ".join(f"{k} {v:.3g} C" for k, v in curv.items()) + "."]
    L += ["", f"Gain (rms before / after): **{s['gain']:.3g}**" +
          "".join(f"; with {k} turned off: {g:.3g}" for k, g in s["gain_without"].items()), ""]
    if rep.get("remaining"):
        L += ["### What the error still follows", "",
              "The diagnosis's test of what remains (the families of shapes, the log's own noise as the null, "
              f"{100 * LEVEL:g} % level) on the held-out error itself, beyond a cubic in temp_c (what a recalibration absorbs); "
              "fraction of the error before.", "",
              "| variant | structure | rms | fraction | against | what |", "|---|---|---:|---:|---|---|"]
        for name, r in rep["remaining"].items():
            L.append(f"| {name} | {'yes' if r['significant'] else 'no'} | {r['rms']:.4g} | {r['fraction']:.3g} | "
                     f"{', '.join(r['against']) or '-'} | {r['explanation']} |")
        L.append("")
    if rep.get("applied"):
        a = rep["applied"]
        L += [f"Applied to a second run, `{a['log']}` (nothing of it fitted, {a['rows']} rows): rms "
              f"{a['variants']['before']['rms']:.4g} -> {a['variants']['after']['rms']:.4g}, gain **{a['gain']:.3g}**.", ""]
        L += _bullets(a.get("notes", []))
    if rep.get("bitexact_chain"):
        b = rep["bitexact_chain"]
        L += [f"Bit-exact chain of the final config on the log: rms of the compensated output {b['rms_compensated']:.4g}, "
              f"max |bit-exact - float| {b['max_abs_vs_float']:.3g} (LSB {b['lsb']:.3g}), overflows {b['overflows']}.", ""]
    L += ["## Hardware", ""]
    reg = rep.get("regression")
    if reg is None:
        L.append("RTL regression: not run (--no-rtl).")
    else:
        L += [f"RTL regression ({reg['simulator']}, cocotb, this config's generated parameters): "
              f"**{'bit-exact' if reg['passed'] else 'MISMATCH'}**", "", "| block | ok | samples | cycles |",
              "|---|---|---:|---:|"]
        L += [f"| {k} | {'yes' if r['ok'] else 'NO: ' + '; '.join(r['errors'])} | {r['samples']} | {r['cycles']} |"
              for k, r in reg["blocks"].items()]
    c = rep.get("cost")
    if c:
        L += ["", f"Cost ({c['source']}): before = {' + '.join(c['before_rows'])}, after = "
              f"{' + '.join(c['after_rows'])}.", "", "| | " + " | ".join(c["before"]) + " |",
              "|---|" + "---:|" * len(c["before"])]
        for when in ("before", "after"):
            L.append(f"| {when} | " + " | ".join("-" if v is None else str(v) for v in c[when].values()) + " |")
    L += ["", "Files: `config.toml` (extended), `config_base.toml` (calibrated, no remedy), `vectors/`, `hdl/`, "
          "`report.json`, `heldout_error.png`, `model.json` (the diagnosed model: `fxdsp simulate --model`).", ""]
    return "\n".join(L)


def plot(errors: dict, time_s, path: Path, unit: str) -> None:
    from fxdsp.plots import pyplot

    plt = pyplot()

    t = np.asarray(time_s, float) / 3600.0
    held = errors["_held"]
    fig, ax = plt.subplots(figsize=(9, 4))
    for name in ("before", "after"):
        y = np.where(held, errors["_series"][name], np.nan)
        ax.plot(t, y, lw=0.7, label=f"{name} (rms {errors['variants'][name]['rms']:.3g})")
    ax.set_xlabel("time (h)")
    ax.set_ylabel(f"held-out error ({unit})")
    ax.legend(loc="best")
    ax.grid(alpha=0.3)
    save_figure(fig, path)
