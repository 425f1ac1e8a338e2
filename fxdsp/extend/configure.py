"""The extended config: the chain's calibration from the log, plus every planned remedy.

Written as a copy of the base config (``--config``, default: the built-in one) with only the
calibrated and remedied keys rewritten in place (:func:`fxdsp.repro.calconfig.config_text`), so a
diff against the base shows exactly what the extension changed.

* paper002: the paper's SF and bias segments from the log's rate-table sequences
  (:func:`fxdsp.repro.calibrate.calibrate002`, quadratic segments with the ``order`` remedy);
  ``lag``: ``[lag] tau_s`` and ``[chain_paper002] stages = ["lag"]`` (the lag then updates at the
  base's ``[lag] rate_hz``, a divisor of ``fs_hz``); ``trim``: ``[demod] phase_trim_rad``.
* paper001: f0/k of the resonator thermometer against the reference and the bias polynomial in the
  frequency's temperature (a cubic instead of the paper's quadratic with the ``order`` remedy, for
  a resonator whose frequency turns over).
* thermometer (an instrument read against a thermometer, such as the tckit voltmeter): the log's
  temperature code -> ``lag`` (at the log's own rate) -> a cubic bias polynomial in T
  (``[piecewise.bias001]``) -> ``bias_subtract001``. The blocks are paper 001's bias engine and
  subtractor with formats chosen for the log's output; the temperature enters in the RTD's
  temperature format (``[freq2temp] temp_format`` is set to it, so the bias engine reads that code).
"""

from __future__ import annotations

import numpy as np

from fxdsp.config import default_config_text
from fxdsp.extend.plan import parameter
from fxdsp.fixed import Format
from fxdsp.repro.calconfig import acc_width, config_from_text, config_text, fit_format, paper002_tables, \
    piecewise_table
from fxdsp.repro.calibrate import calibrate002

THERMO_ORDER = 3          # the thermometer chain's bias polynomial: a cubic in T - t0
THERMO_OUT_WL = 32        # the instrument's output word: 32 bits with one bit of headroom
# the bias polynomial's coefficients: its constant term is the whole reading (1 V), subtracted to
# leave microvolts, so it needs the output word's resolution, not the 24 bits of a paper's tempco
THERMO_COEF_WL = 32


def _stages(remedies) -> set[str]:
    return {r.stage for r in remedies}


def remedy_tables(remedies, chain: str, base_text: str | None = None) -> dict:
    """Config tables of the lag, trim and CVD remedies (calibration tables apart)."""
    tables: dict = {}
    stages = _stages(remedies)
    if "cvd" in stages:
        # the element R0 (1 + A T + B T^2) that the linear law R0 (1 + beta T) has been reading:
        # A = beta, and B/A = b makes the readout's T + b T^2 the curvature the log showed (its
        # affine part, T + b (T - 25)^2 against T + b T^2, the calibration's segments absorb)
        import tomllib

        beta = float(tomllib.loads(base_text if base_text is not None else default_config_text())["rtd"]
                     .get("beta_per_c", 2.183e-3))
        b = parameter(remedies, "cvd", "b_per_c")
        tables["rtd"] = {"law": "cvd", "cvd_a": beta, "cvd_b": b * beta, "cvd_c": 0.0}
    if "lag" in stages:
        tables["lag"] = {"tau_s": parameter(remedies, "lag", "tau_s")}
        if chain == "paper002":
            tables["chain_paper002"] = {"stages": ["lag"]}
    if "trim" in stages:
        tables["demod"] = {"phase_trim_rad": parameter(remedies, "trim", "phase_trim_rad")}
    return tables


def paper002_config(columns: dict, remedies, base_text: str | None = None, output=None,
                    temp_c=None) -> tuple[str, dict]:
    """(config text, calibration) of the chain with ``remedies`` in place. The calibration reads what
    the engines will see with them: ``output`` after the trim's rotation and ``temp_c`` after the lag
    (None: the log's columns), so the tables do not absorb what a remedy removes."""
    order = 2 if "order" in _stages(remedies) else 1
    cal = calibrate002(columns if output is None else {**columns, "output": output}, order, temp=temp_c)
    what = "; ".join(r.what for r in remedies) or "no remedy"
    text = config_text({**paper002_tables(cal), **remedy_tables(remedies, "paper002", base_text)}, base_text,
                       provenance=f"calibrated by fxdsp extend (paper 002): {what}", add_missing=True)
    return text, cal


def paper001_config(columns: dict, remedies, base_text: str | None = None) -> tuple[str, dict]:
    """(config text, calibration) of paper 001's chain: f0/k of the resonator thermometer against the
    reference, then the bias polynomial (cubic with the ``order`` remedy) in T from f. The
    thermometer is checked bit-exactly against the calibration points (a failing f0/k raises)."""
    from fxdsp.repro.calconfig import paper001_tables
    from fxdsp.repro.paper001 import THERMO_TOL_C, check_thermometer
    from fxdsp.sim.calibration import calibrate_paper001

    cal = calibrate_paper001(columns, bias_order=3 if "order" in _stages(remedies) else 2)
    what = "; ".join(r.what for r in remedies) or "no remedy"
    text = config_text(paper001_tables(cal), base_text, provenance=f"calibrated by fxdsp extend (paper 001): {what}")
    pts = cal["points"]
    check = check_thermometer(config_from_text(text), pts["temp_c"], pts["freq_hz"])
    if not check["ok"]:
        raise ValueError(f"freq2temp: calibrated f0/k put the calibration points {check['mean_error_c']:+.3f} C "
                         f"off the reference (limit {THERMO_TOL_C} C)")
    cal["thermometer_check"] = check
    return text, cal


def thermometer_tables(temp_c, te_c, output, rate_hz: float, temp_format: str) -> dict:
    """The thermometer chain's tables: bias(T) = cubic least squares of ``output`` on ``te_c`` (the
    temperature the engine sees), centred at the mean temperature; formats from the data."""
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
    return {"freq2temp": {"temp_format": temp_format}, "lag": {"rate_hz": float(rate_hz)},
            "piecewise.bias001": bias, "bias_subtract001": {"in_format": word, "out_format": word},
            "_fit": {"t0_c": t0, "coefficients": [float(c) for c in coef], "coef_wl": THERMO_COEF_WL}}


def thermometer_config(tables: dict, remedies, base_text: str | None = None) -> str:
    fit = {k: v for k, v in tables.items() if not k.startswith("_")}
    text = base_text if base_text is not None else default_config_text()
    what = "; ".join(r.what for r in remedies) or "no remedy"
    return config_text({**fit, **remedy_tables(remedies, "thermometer")}, text,
                       provenance=f"thermometer chain by fxdsp extend: {what}")


__all__ = ["paper002_config", "thermometer_tables", "thermometer_config", "remedy_tables", "config_from_text"]
