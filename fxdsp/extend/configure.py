"""The extended config: the chain's calibration from the log, plus every planned remedy, in the
user's design (:mod:`fxdsp.extend.design`).

Written as a copy of the base config (``--config``, default: the built-in one) with only the
calibrated and remedied keys rewritten in place (:func:`fxdsp.repro.calconfig.config_text`), so a
diff against the base shows exactly what the extension changed: the calibrated coefficients
(:func:`fxdsp.extend.design.calibrated_keys`), the remedies' keys (``remedy_keys``), and with ``--widen``
the formats listed in the report's ``changes``. Every format, rounding and overflow rule stays the
base's; a calibrated value or a remedy that does not fit it is an InputError naming the field.

The calibration is chosen by the chain's sensor and writes the chain's own tables
(:mod:`fxdsp.extend.roles`; below, the built-in chains' table names):

* gyro_rtd (paper 002's procedure): the paper's SF and bias segments from the log's rate-table
  sequences (:func:`fxdsp.repro.calibrate.calibrate002`, quadratic segments with the ``order``
  remedy) in the base's SF and bias engines' formats, t0 and order; ``[system]
  rate_full_scale_dps`` = 4096 mV / SF(25 C) (the quotient's scale); ``lag``: ``[lag] tau_s``
  and the lag inserted into the chain's netlist after its RTD (the lag then updates at the base's
  ``[lag] rate_hz``, a divisor of the chain's rate); ``trim``: the chain's demodulator's
  ``phase_trim_rad``; ``cvd``: the chain's RTD law and its coefficients.
* gyro_freq (paper 001's): f0/k of the resonator thermometer against the reference and the bias
  polynomial in the frequency's temperature (a cubic instead of the paper's quadratic with the
  ``order`` remedy, for a resonator whose frequency turns over: one format added for the new power).
* thermometer (an instrument read against a thermometer, such as the tckit voltmeter): a config's
  chain without a sensor whose output is a reading minus a bias polynomial of a temperature word
  (the lag remedy inserted after its temperature input), or, when the config has none, the chain
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
from fxdsp.netlist import chain_inputs_to, with_stage
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


def lag_rate_hz(design: Design, roles, log_rate_hz: float | None = None) -> float:
    """The rate the lag updates at: the log's rows (the thermometer chain extend writes), else the
    base's lag ``rate_hz`` (left out: the chain's ``fs_hz``, else [system] fs_hz)."""
    if roles.written:
        return float(log_rate_hz)
    chain_fs = design.value(f"{roles.netlist_table}.fs_hz", design.value("system.fs_hz"))
    return float(design.value(f"{roles.tables.get('lag', 'lag')}.rate_hz", chain_fs))


def remedy_tables(remedies, roles, design=None, fitting: Fitting | None = None,
                  log_rate_hz: float | None = None) -> dict:
    """Config tables of the lag, trim and CVD remedies (calibration tables apart), in the chain's own
    tables (``roles``, :class:`fxdsp.extend.roles.Roles`). ``fitting``: the lag's guard bits are
    checked against the design (widened with --widen)."""
    design = _design(design)
    tables: dict = {}
    stages = _stages(remedies)
    if "cvd" in stages:
        # the element R0 (1 + A T + B T^2) that the linear law R0 (1 + beta T) has been reading:
        # A = beta, and B/A = b makes the readout's T + b T^2 the curvature the log showed (its
        # affine part, T + b (T - 25)^2 against T + b T^2, the calibration's segments absorb)
        rtd = roles.table("rtd")
        beta = float(design.value(f"{rtd}.beta_per_c", 2.183e-3))
        b = parameter(remedies, "cvd", "b_per_c")
        tables[rtd] = {"law": "cvd", "cvd_a": beta, "cvd_b": b * beta, "cvd_c": 0.0}
    if "lag" in stages:
        tau = parameter(remedies, "lag", "tau_s")
        rate = lag_rate_hz(design, roles, log_rate_hz)
        lag = roles.tables.get("lag", "lag")
        tables[lag] = {"tau_s": tau}
        if roles.written:
            tables[lag]["rate_hz"] = rate
        if fitting is not None:
            tables[lag].update(fitting.lag(tau, rate, lag))
        if not roles.written and not roles.has("lag"):
            # the netlist edit: the lag after the chain's thermometer (or its temperature input),
            # before the coefficient engines
            net = design.table(roles.netlist_table)
            thermometer = roles.tables.get("rtd", roles.tables.get("f2t"))
            edited = with_stage(net, "lag", instance=thermometer, chain_input=roles.inputs.get("temp"))
            tables[roles.netlist_table] = {k: v for k, v in edited.items() if v != net.get(k)}
    if "trim" in stages:
        tables[roles.table("demod")] = {"phase_trim_rad": parameter(remedies, "trim", "phase_trim_rad")}
    return tables


def gyro_rtd_config(columns: dict, remedies, design, roles, output=None, temp_c=None) -> tuple[str, dict, list]:
    """(config text, calibration, changes) of the chain with ``remedies`` in place. The calibration
    reads what the engines will see with them: ``output`` after the trim's rotation and ``temp_c``
    after the lag (None: the log's columns), so the tables do not absorb what a remedy removes. The
    coefficients go into the design's formats (:meth:`fxdsp.extend.design.Fitting.piecewise`)."""
    design = _design(design)
    sf_t, bias_t, div_t = roles.table("sf"), roles.table("bias"), roles.table("divide")
    # the segments' order is the user's (the lower of the two tables': the calibration fits both at
    # one order; the other is padded with zero coefficients)
    order = min(len(design.table(t)["coefficients"][0]) - 1 for t in (sf_t, bias_t))
    order = max(order, 2 if "order" in _stages(remedies) else 1)
    cal = calibrate002(columns if output is None else {**columns, "output": output}, order, temp=temp_c)
    fit = design.fitting()
    values = paper002_coefficients(cal)
    temps = columns["temp_c"] if temp_c is None else temp_c
    # the calibration's SF and bias (paper 002's names) go into the chain's own engines
    tables = {table: fit.piecewise(table, values[name]["coefficients"], values[name]["breakpoints_c"], temps)
              for name, table in (("piecewise.sf", sf_t), ("piecewise.bias", bias_t))}
    tables["system"] = values["system"]
    x = np.asarray(columns["output"] if output is None else output, float) / FS_MV
    user_in = design.table(div_t)["in_format"]
    in_fmt = fit.holding(f"{div_t}.in_format", user_in, x, f"the log's output / {FS_MV:g} mV (the divider's input)")
    if in_fmt != user_in:
        tables[div_t] = {"in_format": in_fmt}
    tables.update(remedy_tables(remedies, roles, design, fit))
    what = "; ".join(r.what for r in remedies) or "no remedy"
    text = config_text(tables, design.text, provenance=f"calibrated by fxdsp extend ({roles.chain} chain, gyro_rtd): {what}",
                       add_missing=True)
    return text, cal, fit.changes


def gyro_freq_config(columns: dict, remedies, design, roles) -> tuple[str, dict, list]:
    """(config text, calibration, changes) of paper 001's chain: f0/k of the resonator thermometer
    against the reference, then the bias polynomial (cubic with the ``order`` remedy) in T from f,
    in the design's formats. The thermometer is checked bit-exactly against the calibration points
    (a failing f0/k raises)."""
    from fxdsp.repro.paper001 import THERMO_TOL_C, check_thermometer
    from fxdsp.sim.calibration import calibrate_paper001

    design = _design(design)
    f2t_t, bias_t, sub_t = roles.table("f2t"), roles.table("bias"), roles.table("subtract")
    cal = calibrate_paper001(columns, bias_order=3 if "order" in _stages(remedies) else 2)
    values = paper001_coefficients(cal)   # paper 001's names: into the chain's own tables
    fit = design.fitting()
    f2t = design.table(f2t_t)
    freq = np.asarray(columns["freq_hz"], float)
    temps = (freq - cal["f0_hz"]) / cal["k_hz_per_c"]
    tables = {f2t_t: dict(values["freq2temp"])}
    for key, vals, what in (("freq_format", [cal["f0_hz"], *freq], "the log's freq_hz and the calibrated f0"),
                            ("kinv_format", [1.0 / cal["k_hz_per_c"]], "1/k of the calibrated thermometer"),
                            ("temp_format", temps, "the temperature the calibrated f0/k read from freq_hz")):
        got = fit.holding(f"{f2t_t}.{key}", f2t[key], vals, what)
        if got != f2t[key]:
            tables[f2t_t][key] = got
    order = next((r.what for r in remedies if r.stage == "order"), None)
    coef = values["piecewise.bias001"]
    tables[bias_t] = fit.piecewise(bias_t, coef["coefficients"], coef["breakpoints_c"],
                                   temps, remedy=order and "the order remedy (cubic bias)")
    sub_in = design.table(sub_t)["in_format"]
    got = fit.holding(f"{sub_t}.in_format", sub_in, columns["output"], "the log's output")
    if got != sub_in:
        tables[sub_t] = {"in_format": got}
    what = "; ".join(r.what for r in remedies) or "no remedy"
    text = config_text(tables, design.text, provenance=f"calibrated by fxdsp extend ({roles.chain} chain, gyro_freq): {what}")
    pts = cal["points"]
    check = check_thermometer(config_from_text(text), pts["temp_c"], pts["freq_hz"], chain=roles.instance)
    if not check["ok"]:
        raise InputError(f"{f2t_t}: calibrated f0/k put the calibration points {check['mean_error_c']:+.3f} C "
                         f"off the reference (limit {THERMO_TOL_C} C)")
    cal["thermometer_check"] = check
    return text, cal, fit.changes


def thermometer_tables(temp_c, te_c, output, rate_hz: float, temp_format: str, data: dict) -> dict:
    """The thermometer chain's tables without a user design: bias(T) = cubic least squares of
    ``output`` on ``te_c`` (the temperature the engine sees), centred at the mean temperature;
    formats from the data; ``data`` the base config's, whose chains feeding the subtraction follow
    its unit."""
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
    # every chain whose input feeds the same subtraction (paper 001's, with or without its drive
    # loop): that input is now in the log's unit too
    feeds = chain_inputs_to(data, "bias_subtract001", "x")
    units = {chain: {"input_units": {name: "sensor"}} for chain, name in feeds.items()}
    return {"freq2temp": {"temp_format": temp_format}, **units,
            "piecewise.bias001": bias, "bias_subtract001": {"in_format": word, "out_format": word},
            "_fit": {"t0_c": t0, "coefficients": [float(c) for c in coef], "coef_wl": THERMO_COEF_WL}}


def user_thermometer_tables(fit: Fitting, roles, te_c, output) -> dict:
    """The thermometer chain's tables in the user's design (``--config``): a least-squares
    polynomial of the order of the chain's bias engine about its t0_c, in its formats."""
    design = fit.design
    bias_t, sub_t = roles.table("bias"), roles.table("subtract")
    user = design.table(bias_t)
    if roles.written:
        # extend's own chain reads paper 001's bias engine with the lag's (the RTD's) temperature word
        rtd_fmt, f2t_fmt = design.table("rtd")["temp_format"], design.table("freq2temp")["temp_format"]
        if Format.parse(f2t_fmt, "freq2temp.temp_format") != Format.parse(rtd_fmt, "rtd.temp_format"):
            raise InputError(f"freq2temp.temp_format: the thermometer chain's bias engine reads the lag's temperature "
                             f"code, in rtd.temp_format {rtd_fmt}; the config has {f2t_fmt} (set it to {rtd_fmt})")
    order = len(user["coefficients"][0]) - 1
    t0 = float(user.get("t0_c", 0.0))
    te = np.asarray(te_c, float)
    y = np.asarray(output, float)
    coef = np.polynomial.polynomial.polyfit(te - t0, y, order)
    bias = fit.piecewise(bias_t, [coef], [], te, t0_fit=t0)
    tables = {bias_t: bias}
    sub_in = design.table(sub_t)["in_format"]
    got = fit.holding(f"{sub_t}.in_format", sub_in, y, "the log's output")
    if got != sub_in:
        tables[sub_t] = {"in_format": got}
    fmts = bias.get("coef_format", user["coef_format"])
    widest = max(Format.parse(f).wl for f in ([fmts] if isinstance(fmts, str) else fmts))
    tables["_fit"] = {"t0_c": t0, "coefficients": [float(c) for c in coef], "coef_wl": widest}
    return tables


def thermometer_config(te_c, output, remedies, design, roles, log_rate_hz: float | None = None,
                       temp_format: str | None = None) -> tuple[str, dict, list]:
    """(config text, the float fit, changes) of the thermometer chain with ``remedies``: the user's
    design with ``--config``, else the log's (every key that differs from the built-in listed).
    extend's own chain (``roles.written``) is written into the config; a chain of the config is
    edited only by the remedies."""
    design = _design(design)
    fit = design.fitting()
    if design.given or not roles.written:
        tables = user_thermometer_tables(fit, roles, te_c, output)
    else:
        tables = thermometer_tables(te_c, te_c, output, log_rate_hz, temp_format, design.data)
        for table, keys in tables.items():
            if table.startswith("_"):
                continue
            for key, value in keys.items():
                dotted = f"{table}.{key}"
                was = design.value(dotted)
                if dotted not in ("piecewise.bias001.coefficients", "piecewise.bias001.breakpoints_c") and was != value:
                    fit.record(dotted, was, value, NO_THERMOMETER_DESIGN)
    fitted = tables.pop("_fit")
    tables.update(remedy_tables(remedies, roles, design, fit, log_rate_hz))
    what = "; ".join(r.what for r in remedies) or "no remedy"
    text = config_text(tables, design.text, provenance=f"{roles.chain} chain by fxdsp extend: {what}",
                       add_missing=True)
    if roles.written:
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
