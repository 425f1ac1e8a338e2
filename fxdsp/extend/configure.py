"""The extended config: the chain's calibration from the log, plus every planned remedy, in the
user's design (:mod:`fxdsp.extend.design`).

Written as a copy of the base config (``--config``, default: the built-in one) with only the
calibrated and remedied keys rewritten in place (:func:`fxdsp.repro.calconfig.config_text`), so a
diff against the base shows exactly what the extension changed: the calibrated coefficients
(:data:`fxdsp.extend.design.CALIBRATED`), the remedies' keys (``REMEDY_KEYS``), and with ``--widen``
the formats listed in the report's ``changes``. Every format, rounding and overflow rule stays the
base's; a calibrated value or a remedy that does not fit it is an InputError naming the field.

* paper002: the paper's SF and bias segments from the log's rate-table sequences
  (:func:`fxdsp.repro.calibrate.calibrate002`, quadratic segments with the ``order`` remedy)
  in the base's ``[piecewise.sf]`` / ``[piecewise.bias]`` formats, t0 and order;
  ``[system] rate_full_scale_dps`` = 4096 mV / SF(25 C) (the quotient's scale); ``lag``:
  ``[lag] tau_s`` and the lag inserted into ``[chain.paper002]``'s netlist (the lag then updates at the base's
  ``[lag] rate_hz``, a divisor of ``fs_hz``); ``trim``: ``[demod] phase_trim_rad``; ``cvd``: the
  ``[rtd]`` law and its coefficients.
* paper001: f0/k of the resonator thermometer against the reference and the bias polynomial in the
  frequency's temperature (a cubic instead of the paper's quadratic with the ``order`` remedy, for
  a resonator whose frequency turns over: one format added for the new power).
* thermometer (an instrument read against a thermometer, such as the tckit voltmeter): the chain
  ``[chain.thermometer]`` the extension writes (:func:`thermometer_chain`, at the log's own rate,
  its ``fs_hz``): the log's temperature code -> ``lag`` (with the lag remedy) -> a bias polynomial
  in T (``[piecewise.bias001]``) -> ``bias_subtract001``. The blocks are paper 001's bias engine and
  subtractor; the temperature enters in the RTD's temperature format, which ``[freq2temp]
  temp_format`` must equal (the bias engine reads that code). With ``--config`` the polynomial
  has the config's order, t0 and formats; without it (the built-in config has no thermometer design)
  a cubic with formats chosen for the log's output, each listed in the report's ``changes``.
"""

from __future__ import annotations

import numpy as np

from fxdsp.extend.design import Design, Fitting
from fxdsp.extend.plan import parameter
from fxdsp.errors import InputError
from fxdsp.fixed import Format
from fxdsp.netlist import with_stage
from fxdsp.repro.calconfig import FS_MV, acc_width, config_from_text, config_text, fit_format, \
    paper001_coefficients, paper002_coefficients, piecewise_table, set_table_keys
from fxdsp.repro.calibrate import calibrate002

THERMO_ORDER = 3          # the thermometer chain's bias polynomial without --config: a cubic in T - t0
THERMO_OUT_WL = 32        # the instrument's output word: 32 bits with one bit of headroom
# the bias polynomial's coefficients: its constant term is the whole reading (1 V), subtracted to
# leave microvolts, so it needs the output word's resolution, not the 24 bits of a paper's tempco
THERMO_COEF_WL = 32
NO_THERMOMETER_DESIGN = ("no --config, and the built-in config has no thermometer design (its [piecewise.bias001] "
                         "and [bias_subtract001] are paper 001's gyro bias, in deg/h): chosen for the log's output")


def _stages(remedies) -> set[str]:
    return {r.stage for r in remedies}


def _design(design) -> Design:
    """A Design from a Design, a base config text or None (the built-in)."""
    return design if isinstance(design, Design) else Design(design)


def lag_rate_hz(design: Design, chain: str, log_rate_hz: float | None = None) -> float:
    """The rate the lag updates at: the log's rows (thermometer chain), else the base's [lag]
    rate_hz (left out: [system] fs_hz)."""
    if chain == "thermometer":
        return float(log_rate_hz)
    return float(design.value("lag.rate_hz", design.value("system.fs_hz")))


def remedy_tables(remedies, chain: str, design=None, fitting: Fitting | None = None,
                  log_rate_hz: float | None = None) -> dict:
    """Config tables of the lag, trim and CVD remedies (calibration tables apart). ``fitting``: the
    lag's guard bits are checked against the design (widened with --widen)."""
    design = _design(design)
    tables: dict = {}
    stages = _stages(remedies)
    if "cvd" in stages:
        # the element R0 (1 + A T + B T^2) that the linear law R0 (1 + beta T) has been reading:
        # A = beta, and B/A = b makes the readout's T + b T^2 the curvature the log showed (its
        # affine part, T + b (T - 25)^2 against T + b T^2, the calibration's segments absorb)
        beta = float(design.value("rtd.beta_per_c", 2.183e-3))
        b = parameter(remedies, "cvd", "b_per_c")
        tables["rtd"] = {"law": "cvd", "cvd_a": beta, "cvd_b": b * beta, "cvd_c": 0.0}
    if "lag" in stages:
        tau = parameter(remedies, "lag", "tau_s")
        rate = lag_rate_hz(design, chain, log_rate_hz)
        tables["lag"] = {"tau_s": tau}
        if chain == "thermometer":
            tables["lag"]["rate_hz"] = rate
        if fitting is not None:
            tables["lag"].update(fitting.lag(tau, rate))
        if chain == "paper002":   # the netlist edit: rtd.temp -> lag -> the SF and bias engines
            net = design.table("chain.paper002")
            edited = with_stage(net, "lag")
            tables["chain.paper002"] = {k: v for k, v in edited.items() if v != net.get(k)}
    if "trim" in stages:
        tables["demod"] = {"phase_trim_rad": parameter(remedies, "trim", "phase_trim_rad")}
    return tables


def paper002_config(columns: dict, remedies, design=None, output=None, temp_c=None) -> tuple[str, dict, list]:
    """(config text, calibration, changes) of the chain with ``remedies`` in place. The calibration
    reads what the engines will see with them: ``output`` after the trim's rotation and ``temp_c``
    after the lag (None: the log's columns), so the tables do not absorb what a remedy removes. The
    coefficients go into the design's formats (:meth:`fxdsp.extend.design.Fitting.piecewise`)."""
    design = _design(design)
    # the segments' order is the user's (the lower of the two tables': the calibration fits both at
    # one order; the other is padded with zero coefficients)
    order = min(len(design.table(t)["coefficients"][0]) - 1 for t in ("piecewise.sf", "piecewise.bias"))
    order = max(order, 2 if "order" in _stages(remedies) else 1)
    cal = calibrate002(columns if output is None else {**columns, "output": output}, order, temp=temp_c)
    fit = design.fitting()
    values = paper002_coefficients(cal)
    temps = columns["temp_c"] if temp_c is None else temp_c
    tables = {name: fit.piecewise(name, values[name]["coefficients"], values[name]["breakpoints_c"], temps)
              for name in ("piecewise.sf", "piecewise.bias")}
    tables["system"] = values["system"]
    x = np.asarray(columns["output"] if output is None else output, float) / FS_MV
    user_in = design.table("sf_divide")["in_format"]
    in_fmt = fit.holding("sf_divide.in_format", user_in, x, f"the log's output / {FS_MV:g} mV (the divider's input)")
    if in_fmt != user_in:
        tables["sf_divide"] = {"in_format": in_fmt}
    tables.update(remedy_tables(remedies, "paper002", design, fit))
    what = "; ".join(r.what for r in remedies) or "no remedy"
    text = config_text(tables, design.text, provenance=f"calibrated by fxdsp extend (paper 002): {what}",
                       add_missing=True)
    return text, cal, fit.changes


def paper001_config(columns: dict, remedies, design=None) -> tuple[str, dict, list]:
    """(config text, calibration, changes) of paper 001's chain: f0/k of the resonator thermometer
    against the reference, then the bias polynomial (cubic with the ``order`` remedy) in T from f,
    in the design's formats. The thermometer is checked bit-exactly against the calibration points
    (a failing f0/k raises)."""
    from fxdsp.repro.paper001 import THERMO_TOL_C, check_thermometer
    from fxdsp.sim.calibration import calibrate_paper001

    design = _design(design)
    cal = calibrate_paper001(columns, bias_order=3 if "order" in _stages(remedies) else 2)
    values = paper001_coefficients(cal)
    fit = design.fitting()
    f2t = design.table("freq2temp")
    freq = np.asarray(columns["freq_hz"], float)
    temps = (freq - cal["f0_hz"]) / cal["k_hz_per_c"]
    tables = {"freq2temp": dict(values["freq2temp"])}
    for key, vals, what in (("freq_format", [cal["f0_hz"], *freq], "the log's freq_hz and the calibrated f0"),
                            ("kinv_format", [1.0 / cal["k_hz_per_c"]], "1/k of the calibrated thermometer"),
                            ("temp_format", temps, "the temperature the calibrated f0/k read from freq_hz")):
        got = fit.holding(f"freq2temp.{key}", f2t[key], vals, what)
        if got != f2t[key]:
            tables["freq2temp"][key] = got
    order = next((r.what for r in remedies if r.stage == "order"), None)
    coef = values["piecewise.bias001"]
    tables["piecewise.bias001"] = fit.piecewise("piecewise.bias001", coef["coefficients"], coef["breakpoints_c"],
                                                temps, remedy=order and "the order remedy (cubic bias)")
    sub_in = design.table("bias_subtract001")["in_format"]
    got = fit.holding("bias_subtract001.in_format", sub_in, columns["output"], "the log's output")
    if got != sub_in:
        tables["bias_subtract001"] = {"in_format": got}
    what = "; ".join(r.what for r in remedies) or "no remedy"
    text = config_text(tables, design.text, provenance=f"calibrated by fxdsp extend (paper 001): {what}")
    pts = cal["points"]
    check = check_thermometer(config_from_text(text), pts["temp_c"], pts["freq_hz"])
    if not check["ok"]:
        raise ValueError(f"freq2temp: calibrated f0/k put the calibration points {check['mean_error_c']:+.3f} C "
                         f"off the reference (limit {THERMO_TOL_C} C)")
    cal["thermometer_check"] = check
    return text, cal, fit.changes


def thermometer_tables(temp_c, te_c, output, rate_hz: float, temp_format: str) -> dict:
    """The thermometer chain's tables without a user design: bias(T) = cubic least squares of
    ``output`` on ``te_c`` (the temperature the engine sees), centred at the mean temperature;
    formats from the data."""
    te = np.asarray(te_c, float)
    y = np.asarray(output, float)
    t0 = float(np.round(np.mean(te), 1))
    coef = np.polynomial.polynomial.polyfit(te - t0, y, THERMO_ORDER)
    bias = piecewise_table([coef], [], t0, out_wl=THERMO_OUT_WL, acc_wl=acc_width(temp_format),
                           name="piecewise.bias001", coef_wl=THERMO_COEF_WL)
    # a coefficient finer than the accumulator it is added to only widens the Horner sum past 63
    # bits: cap its fraction at the accumulator's (a tiny cubic term keeps its leading bits)
    acc_fl = Format.parse(bias["acc_format"]).fl
    bias["coef_format"] = [str(Format(True, f.wl, min(f.fl, acc_fl))) for f in map(Format.parse, bias["coef_format"])]
    word = fit_format([np.abs(y).max()], THERMO_OUT_WL, 1, True, "bias_subtract001.in")
    bias["out_format"] = word    # subtracted word for word from the output: the same format
    bias["unit"] = "sensor"      # the log's output unit, not paper 001's deg/h (fxdsp.units)
    # paper 001's chain reads the same engines: its rate input is now in the log's unit too
    return {"freq2temp": {"temp_format": temp_format}, "chain.paper001": {"input_units": {"rate_in": "sensor"}},
            "piecewise.bias001": bias, "bias_subtract001": {"in_format": word, "out_format": word},
            "_fit": {"t0_c": t0, "coefficients": [float(c) for c in coef], "coef_wl": THERMO_COEF_WL}}


def user_thermometer_tables(fit: Fitting, te_c, output) -> dict:
    """The thermometer chain's tables in the user's design (``--config``): a least-squares
    polynomial of the config's ``[piecewise.bias001]`` order about its t0_c, in its formats."""
    design = fit.design
    user = design.table("piecewise.bias001")
    rtd_fmt, f2t_fmt = design.table("rtd")["temp_format"], design.table("freq2temp")["temp_format"]
    if Format.parse(f2t_fmt, "freq2temp.temp_format") != Format.parse(rtd_fmt, "rtd.temp_format"):
        raise InputError(f"freq2temp.temp_format: the thermometer chain's bias engine reads the lag's temperature "
                         f"code, in rtd.temp_format {rtd_fmt}; the config has {f2t_fmt} (set it to {rtd_fmt})")
    order = len(user["coefficients"][0]) - 1
    t0 = float(user.get("t0_c", 0.0))
    te = np.asarray(te_c, float)
    y = np.asarray(output, float)
    coef = np.polynomial.polynomial.polyfit(te - t0, y, order)
    bias = fit.piecewise("piecewise.bias001", [coef], [], te, t0_fit=t0)
    tables = {"piecewise.bias001": bias}
    sub_in = design.table("bias_subtract001")["in_format"]
    got = fit.holding("bias_subtract001.in_format", sub_in, y, "the log's output")
    if got != sub_in:
        tables["bias_subtract001"] = {"in_format": got}
    fmts = bias.get("coef_format", user["coef_format"])
    widest = max(Format.parse(f).wl for f in ([fmts] if isinstance(fmts, str) else fmts))
    tables["_fit"] = {"t0_c": t0, "coefficients": [float(c) for c in coef], "coef_wl": widest}
    return tables


def thermometer_config(te_c, output, remedies, design=None, log_rate_hz: float | None = None,
                       temp_format: str | None = None) -> tuple[str, dict, list]:
    """(config text, the float fit, changes) of the thermometer chain with ``remedies``: the user's
    design with ``--config``, else the log's (every key that differs from the built-in listed)."""
    design = _design(design)
    fit = design.fitting()
    if design.given:
        tables = user_thermometer_tables(fit, te_c, output)
    else:
        tables = thermometer_tables(te_c, te_c, output, log_rate_hz, temp_format)
        for table, keys in tables.items():
            if table.startswith("_"):
                continue
            for key, value in keys.items():
                dotted = f"{table}.{key}"
                was = design.value(dotted)
                if dotted not in ("piecewise.bias001.coefficients", "piecewise.bias001.breakpoints_c") and was != value:
                    fit.record(dotted, was, value, NO_THERMOMETER_DESIGN)
    fitted = tables.pop("_fit")
    tables.update(remedy_tables(remedies, "thermometer", design, fit, log_rate_hz))
    what = "; ".join(r.what for r in remedies) or "no remedy"
    text = config_text(tables, design.text, provenance=f"thermometer chain by fxdsp extend: {what}")
    chain = thermometer_chain("lag" in _stages(remedies), log_rate_hz)
    text = set_table_keys(text, THERMOMETER_CHAIN, chain, add_missing=True)
    config_from_text(text)   # must build
    return text, fitted, fit.changes


THERMOMETER_CHAIN = "chain.thermometer"


def thermometer_chain(lag: bool, rate_hz: float) -> dict:
    """The thermometer chain's netlist (a ``[chain.thermometer]`` table): the log's temperature code,
    through the lag with the lag remedy, into the bias engine; the log's output minus its bias. Its
    samples are the log's rows (``fs_hz`` = the log's rate: a lag updating at that rate updates on
    every row)."""
    engine = "piecewise.bias001.temp"
    return {"instances": ["lag"] * lag + ["piecewise.bias001", "bias_subtract001"],
            "inputs": [f"temp -> {'lag.temp' if lag else engine}", "reading -> bias_subtract001.x"],
            "wires": [f"lag.te -> {engine}"] * lag + ["piecewise.bias001.y -> bias_subtract001.bias"],
            "outputs": ["bias_subtract001.y -> compensated"], "fs_hz": float(rate_hz)}
