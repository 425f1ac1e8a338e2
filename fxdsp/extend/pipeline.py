"""The extension as a library call: a log in, the extended config, artefacts and report out."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fxdsp.chains import build
from fxdsp.fixed import to_float
from fxdsp.ramps import sample_interval
from fxdsp.extend import configure, evaluate, hardware, plan as planning, report as rp
from fxdsp.extend.design import Design, allowed_keys, calibrated_keys, merge_changes
from fxdsp.extend.roles import Roles, needs_column, resolve
from fxdsp.repro.calconfig import config_text
from fxdsp.hdl.params import design_files
from fxdsp.outputs import json_text, write_tree


@dataclass
class Extension:
    report: dict
    config_text: str
    base_config_text: str
    files: dict = field(default_factory=dict)      # {"vectors": {...}, "hdl": {...}}
    errors: dict = field(default_factory=dict)     # with the per-row series, for the plot
    time_s: np.ndarray | None = None
    model: dict = field(default_factory=dict)      # the diagnosed model, for `fxdsp simulate --model`
    remedies: list = field(default_factory=list)
    roles: Roles | None = None                     # the extended chain (fxdsp.extend.roles)

    def apply(self, columns: dict, log_name: str, notes=()) -> dict:
        """Run the configs fitted on this log on a second run's log; the result joins the report, with
        ``notes``: what the reader set aside of the second log (a column ignored, rows dropped)."""
        roles = self.roles
        needs_column(roles, columns, f"--apply {log_name}")
        if roles.procedure == "gyro_freq":
            res = evaluate.gyro_freq_applied(columns, self.errors, roles)
        elif roles.procedure == "gyro_rtd":
            res = evaluate.gyro_rtd_applied(columns, self.errors, self.remedies, roles)
        else:
            res = evaluate.thermometer_applied(columns, {"before": self.base_config_text, "after": self.config_text},
                                               self.remedies, roles)
        self.report["applied"] = {"log": log_name, **res, **({"notes": list(notes)} if notes else {})}
        return self.report["applied"]

    def write(self, folder: Path) -> None:
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "config.toml").write_text(self.config_text, encoding="utf-8")
        (folder / "config_base.toml").write_text(self.base_config_text, encoding="utf-8")
        write_tree(folder, self.files)
        (folder / "model.json").write_text(json_text(self.model, "model.json", indent=1), encoding="utf-8")
        (folder / "report.json").write_text(json_text(self.report, "report.json", indent=1), encoding="utf-8")
        (folder / "report.md").write_text(rp.markdown(self.report), encoding="utf-8")
        rp.plot(self.errors, self.time_s, folder / "heldout_error.png", self.errors["unit"].split(" ")[0])


def columns_of(series) -> dict:
    """The diagnosis's usable rows (spikes set aside) as contract columns."""
    cols = {"time_s": series.t, "temp_c": series.temp, "output": series.out}
    for name, value in (("ref_temp_c", series.ref), ("rate_dps", series.rate), ("freq_hz", series.freq),
                        ("quad", series.quad)):
        if value is not None:
            cols[name] = value
    return cols


def remaining_structure(diag, errors: dict) -> dict:
    """What structure the compensated output's held-out error keeps in every variant: before and after
    the extension, and without each stage (:func:`fxdsp.diagnose.remaining.series_structure`: the
    diagnosis's families and statistics on the error itself); ``fraction`` is of the error before.
    A stage's signature shows where it is off, and not where it is on."""
    from fxdsp.diagnose.remaining import series_explanation, series_structure

    reference = errors["variants"]["before"]["rms"]
    out = {}
    for name in errors["variants"]:
        v = series_structure(diag.context, errors["_series"][name], errors["_held"], reference)
        out[name] = {k: x for k, x in v.as_dict().items() if k != "channel"}
        out[name]["explanation"] = series_explanation(v)
    return out


def extend_log(path, mapping=None, delimiter=",", time_format=None, chain="auto", base_text=None,
               rtl: bool = True, build_root=None, widen: bool = False, strict: bool = False,
               base_name: str | None = None) -> Extension:
    from fxdsp.diagnose.api import diagnose_log
    from fxdsp.logfile import read_log, saying_why_columns_are_missing

    read = read_log(path, mapping, delimiter, time_format)
    diag = diagnose_log(read)
    with saying_why_columns_are_missing(read):
        return extend_diagnosis(diag, Path(str(path)).name, chain, base_text, rtl, build_root, widen=widen,
                                strict=strict, base_name=base_name)


def extend_diagnosis(diag, log_name: str, chain="auto", base_text=None, rtl: bool = True,
                     build_root=None, widen: bool = False, strict: bool = False,
                     base_name: str | None = None) -> Extension:
    """``base_text``: the user's design (None: the built-in config), kept but for the calibrated
    coefficients and the remedies' keys (:mod:`fxdsp.extend.design`); ``widen``: a format that is
    too narrow for them is widened and listed instead of refused; ``strict``: a named cause without
    a hardware remedy stops the extension instead of being reported uncompensated."""
    columns = columns_of(diag.context.series)
    design = Design(base_text, widen, base_name)
    roles = resolve(chain, build(configure.config_from_text(design.text)), columns, design.name)
    remedies, missing = planning.plan(diag, roles, strict)
    stages = {r.stage for r in remedies}
    extra = {}
    if roles.procedure == "gyro_rtd":
        errors = evaluate.gyro_rtd_variants(columns, remedies, design, roles)
        base, ext, cal = errors["_configs"]["before"], errors["_configs"]["after"], errors["_cals"]["after"]
        extra["calibration"] = {"order": cal["order"], "sf_nominal_mv_per_dps": cal["sf_nominal"],
                                "points": len(cal["points"]["temp_c"])}
    elif roles.procedure == "gyro_freq":
        errors = evaluate.gyro_freq_variants(columns, remedies, design, roles)
        base, ext, cal = errors["_configs"]["before"], errors["_configs"]["after"], errors["_cals"]["after"]
        extra["calibration"] = {"f0_hz": cal["f0_hz"], "k_hz_per_c": cal["k_hz_per_c"],
                                "bias_poly": cal["bias_poly"], "thermometer_check": cal["thermometer_check"]}
    else:
        rate_hz = 1.0 / sample_interval(columns["time_s"])
        # the lag's words (guard bits: widened with --widen) before its codes are computed
        lag_words = configure.remedy_tables(remedies, roles, design, design.fitting(), rate_hz)
        template = build(configure.config_from_text(config_text(lag_words, design.text, add_missing=True)
                                                    if lag_words else design.text), chains=not roles.written)
        codes = evaluate.thermometer_words(template, roles, columns, evaluate.tau_of(remedies))
        fmt = codes["format"]
        te_code = codes.get("Te", codes["T"])
        temp, te = to_float(codes["T"], fmt), to_float(te_code, fmt)
        base, _, ch_base = configure.thermometer_config(temp, columns["output"], [], design, roles, rate_hz, str(fmt))
        ext, fit, ch_ext = configure.thermometer_config(te, columns["output"], remedies, design, roles, rate_hz,
                                                        str(fmt))
        errors = evaluate.thermometer_errors(columns, codes, fmt, remedies, diag.context.blocks.row_fold(),
                                             order=len(fit["coefficients"]) - 1)
        errors["_changes"] = {"before": ch_base, "after": ch_ext}
        bx = evaluate.thermometer_bitexact(build(configure.config_from_text(ext)), roles, codes, columns["output"],
                                           fit)
        extra["bitexact_chain"] = rp.public(bx)
        extra["fit"] = fit
    ext_cfg = configure.config_from_text(ext)
    design_built = build(ext_cfg)
    files = design_files(design_built)
    changes = merge_changes({"config.toml": errors["_changes"]["after"],
                             "config_base.toml": errors["_changes"]["before"]})
    calibrated = calibrated_keys(roles)
    report = {"log": log_name, "chain": roles.chain, "procedure": roles.procedure,
              "base_config": design.name,
              "diagnosis": {"causes": list(diag.causes), "parameters": diag.parameters,
                            "gain": float(diag.gain["ratio"]), "notes": list(diag.notes)},
              "remedies": [{"cause": r.cause, "stage": r.stage, "what": r.what, "parameters": r.parameters}
                           for r in remedies],
              "uncompensated": evaluate.uncompensated_sizes(diag, missing),
              "design": {"calibrated_keys": list(calibrated),
                         "remedy_keys": sorted(allowed_keys(roles, stages) - set(calibrated)),
                         "widen": bool(widen), "changes": changes},
              "heldout": rp.public(errors), "summary": rp.summary(errors),
              "remaining": remaining_structure(diag, errors), **extra,
              "regression": hardware.regression(design_built, roles, "lag" in stages, build_root) if rtl else None,
              "cost": hardware.cost(design_built, roles.chain, "lag" in stages)}
    from fxdsp.diagnose.report import replay_model

    return Extension(report, ext, base, files, errors, columns["time_s"], replay_model(diag), remedies, roles)
