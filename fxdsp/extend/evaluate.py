"""Held-out compensated-output error with and without each remedy, in the log's units.

gyro_rtd (a chain like paper 002's): the bit-exact log-rate compensation
(:class:`fxdsp.repro.bitexact.Compensator002`: RTD code -> SF and bias engines -> divide -> subtract,
the chain's own blocks) of the extended config, against the
applied rate (``rate_dps``), on the rows the calibration did not read (every row outside the
rate-table windows, :func:`fxdsp.repro.points.rate_table_windows`: ramps, dwells before their
last hour). Error in deg/s times the calibrated SF at 25 C = the log's output unit (mV). The lag
runs bit-exactly at the log's rate (the same [lag] word lengths and rounding, alpha for the log's
interval; the FPGA runs it at [lag] rate_hz, the same filter); the phase trim at log rate is the
rotation the trimmed NCO applies to the demodulated pair, I' = I cos(theta) + Q sin(theta), with
the config's quantised trim word (the demodulator itself is verified at 96 kHz by the regression).

thermometer: the output has no applied input, so the error is what the compensation leaves of the
output's temperature dependence: a cubic bias(T) fitted on the training folds of the diagnosis's
time-blocked folds and evaluated on the held-out fold (the temperature the engine sees: the
bit-exact code, through the bit-exact lag when chosen). The final config is fitted on every row;
its bit-exact blocks are checked against the float polynomial on the log.

Every variant turns stages off one at a time ("without lag", "without trim"), so the report shows
that the stage produced the gain.
"""

from __future__ import annotations

import numpy as np

from fxdsp.diagnose.extension import heldout_residual, log_rate_lag
from fxdsp.errors import InputError
from fxdsp.extend.plan import parameter
from fxdsp.fixed import OverflowLog, Rules, quantize, to_float
from fxdsp.repro.points import rate_table_windows
from fxdsp.repro.stages import stage_inputs, trim_angle

ROUND = Rules("half_up", "saturate")


def heldout_rows_rate_table(columns: dict) -> np.ndarray:
    held = np.ones(len(columns["time_s"]), dtype=bool)
    for _, rows in rate_table_windows(columns):
        held[rows] = False
    return held


def heldout_error(err: np.ndarray, held: np.ndarray, fitted: str) -> dict:
    """rms and max |error| on the rows the calibration did not read (``fitted``: what it read); a log
    whose every row it read has no held-out error to measure: bad input, named."""
    if not held.any():
        raise InputError(f"log: every row lies in the calibration's {fitted}: no held-out row to measure the "
                         "compensated error on")
    return {"rms": float(np.sqrt(np.mean(err[held] ** 2))), "max_abs": float(np.abs(err[held]).max())}


SWITCHABLE = {"lag", "trim", "cvd"}   # stages a variant turns off one at a time


def _variants(stages: set[str]) -> dict[str, set[str]]:
    """before (none), after (all), and all but one of each switchable stage."""
    out = {"before": set(), "after": set(stages)}
    for s in sorted(stages & SWITCHABLE):
        out[f"without {s}"] = set(stages) - {s}
    return out


def tau_of(remedies) -> float | None:
    return parameter(remedies, "lag", "tau_s")

def compensate002(columns: dict, config_text_: str, on: set[str], tau_s: float | None, theta: float,
                  chain: str = "chain_paper002"):
    """(rate error in deg/s per row, overflow count) of a config's bit-exact log-rate compensation
    through the gyro_rtd ``chain`` with the stages ``on``: the lag at the log's rate, the trim as
    the reference rotation."""
    from fxdsp.extend.configure import config_from_text
    from fxdsp.repro.bitexact import Compensator002

    comp = Compensator002(config_from_text(config_text_), chain)
    ovf = OverflowLog()
    code, out = stage_inputs(comp, columns, on, tau_s, theta, ovf)
    got = comp.run(out, code, ovf)
    return got["rate_dps"] - np.asarray(columns["rate_dps"], float), int(ovf.total)



def gyro_rtd_applied(columns: dict, variants: dict, remedies, roles) -> dict:
    """A second run's error (every row: nothing of it was fitted) with the configs fitted on the first."""
    errors = {}
    for name in ("before", "after"):
        v = variants["variants"][name]
        err, n_ovf = compensate002(columns, variants["_configs"][name], set(v["stages"]), tau_of(remedies),
                                   variants["trim_rad"] or 0.0, roles.instance)
        errors[name] = (err * v["sf_nominal_mv_per_dps"], n_ovf)
    return applied_result(errors, len(columns["time_s"]))


def _curvature_rms(temp_c, ref_c) -> float:
    """rms of temp - (a + b ref) over every row: what is left once an affine map is fitted."""
    ref = np.asarray(ref_c, float)
    X = np.column_stack([np.ones_like(ref), ref])
    resid = np.asarray(temp_c, float) - X @ np.linalg.lstsq(X, temp_c, rcond=None)[0]
    return float(np.sqrt(np.mean(resid**2)))


def gyro_rtd_variants(columns: dict, remedies, design, roles) -> dict:
    """Per variant (a set of stages): its own calibration with those stages in place, its config
    (in the user's ``design``, :class:`fxdsp.extend.design.Design`) and its bit-exact held-out
    error. "after" is the extended config; "before" the plain calibration (no stage)."""
    from fxdsp.extend.configure import _design, config_from_text, config_text, gyro_rtd_config, remedy_tables
    from fxdsp.repro.bitexact import Compensator002

    design = _design(design)
    stages = {r.stage for r in remedies}
    held = heldout_rows_rate_table(columns)
    # the remedies' own words (trim word, lag word lengths) do not depend on the calibration
    words = remedy_tables(remedies, roles, design, design.fitting())
    probe = Compensator002(config_from_text(config_text(words, design.text, add_missing=True)), roles.instance)
    theta = trim_angle(probe.chain.sensor.demod.nco) if "trim" in stages else 0.0
    results, series, configs, cals, changes = {}, {}, {}, {}, {}
    for name, on in _variants(stages).items():
        chosen = [r for r in remedies if r.stage in on]
        code, x = stage_inputs(probe, columns, on, tau_of(remedies), theta)
        text, cal, changes[name] = gyro_rtd_config(columns, chosen, design, roles, output=x,
                                                   temp_c=to_float(code, probe.rtd.temp_format)
                                                   if on & {"lag", "cvd"} else None)
        # the variant's own RTD table reads the log (the probe's is CVD whenever any variant's is)
        err, n_ovf = compensate002(columns, text, on, tau_of(remedies), theta, roles.instance)
        err = err * float(cal["sf_nominal"])
        results[name] = {"stages": sorted(on), **heldout_error(err, held, "rate-table windows"), "overflows": n_ovf,
                         "sf_nominal_mv_per_dps": float(cal["sf_nominal"])}
        if "cvd" in stages and "ref_temp_c" in columns:
            # the table's own effect, before the compensation's floor: the temperature the engines
            # see against the reference, after removing the affine part every calibration absorbs
            results[name]["temp_vs_ref_c"] = _curvature_rms(to_float(code, probe.rtd.temp_format), columns["ref_temp_c"])
        series[name], configs[name], cals[name] = err, text, cal
    return {"unit": "mV (output unit; deg/s x the variant's calibrated SF at 25 C)",
            "heldout": "rows outside the calibration's rate-table windows", "heldout_rows": int(held.sum()),
            "rows": int(held.size), "variants": results, "trim_rad": theta if "trim" in stages else None,
            "_series": series, "_held": held, "_configs": configs, "_cals": cals, "_changes": changes}


def compensate001(columns: dict, config_text_: str, chain: str = "chain_paper001") -> tuple[np.ndarray, int]:
    """(error in deg/h per row, overflow count) of a gyro_freq ``chain`` with a config: its output
    minus the applied rate at the nominal 3600 deg/h per deg/s."""
    from fxdsp.extend.configure import config_from_text
    from fxdsp.repro.bitexact import Compensator001
    from fxdsp.sim.model import PAPER001_SF0

    applied = PAPER001_SF0 * np.asarray(columns["rate_dps"], float) if "rate_dps" in columns else 0.0
    got = Compensator001(config_from_text(config_text_), chain).compensate(columns)
    return got["rate_deg_h"] - applied, int(got["overflows"].total)


def applied_result(errors: dict, log_rows: int) -> dict:
    """Before/after rms over every row of a second run ({name: (error, overflows)})."""
    out = {name: {"rms": float(np.sqrt(np.mean(e**2))), "max_abs": float(np.abs(e).max()), "overflows": n}
           for name, (e, n) in errors.items()}
    gain = out["before"]["rms"] / out["after"]["rms"] if out["after"]["rms"] > 0 else float("inf")
    return {"rows": log_rows, "variants": out, "gain": gain}


def gyro_freq_applied(columns: dict, variants: dict, roles) -> dict:
    return applied_result({k: compensate001(columns, variants["_configs"][k], roles.instance)
                           for k in ("before", "after")},
                          len(columns["time_s"]))


def gyro_freq_variants(columns: dict, remedies, design, roles) -> dict:
    """gyro_freq (paper 001's procedure): before (the paper's quadratic bias) and after (with the
    remedies), each calibrated on the plateaus; error = the bit-exact chain's output minus the
    applied rate (deg/h at the nominal 3600 deg/h per deg/s) on the rows outside the plateaus."""
    from fxdsp.extend.configure import gyro_freq_config
    from fxdsp.sim.calibration import find_plateaus

    thermometer = columns["ref_temp_c"] if "ref_temp_c" in columns else columns["temp_c"]
    held = np.ones(len(columns["time_s"]), dtype=bool)
    for rows in find_plateaus(columns["time_s"], thermometer):
        held[rows] = False
    stages = {r.stage for r in remedies}
    results, series, configs, cals, changes = {}, {}, {}, {}, {}
    for name, on in _variants(stages).items():
        text, cal, changes[name] = gyro_freq_config(columns, [r for r in remedies if r.stage in on], design, roles)
        err, n_ovf = compensate001(columns, text, roles.instance)
        results[name] = {"stages": sorted(on), **heldout_error(err, held, "temperature plateaus"), "overflows": n_ovf}
        series[name], configs[name], cals[name] = err, text, cal
    return {"unit": "deg/h (output unit)", "heldout": "rows outside the calibration's temperature plateaus",
            "heldout_rows": int(held.sum()), "rows": int(held.size), "variants": results, "_series": series,
            "_held": held, "_configs": configs, "_cals": cals, "_changes": changes}


def without_lag(config, roles):
    """The design of ``config`` with the chain's lag removed from its netlist (the lag's table
    stays: the same words, run apart at another rate)."""
    import copy

    from fxdsp.chains import build
    from fxdsp.config import Config
    from fxdsp.netlist import without_stage

    data = copy.deepcopy(config.data)
    data["chain"][roles.chain] = without_stage(data["chain"][roles.chain], "lag")
    return build(Config(data, source=config.name + " (the chain's lag apart)"))


def heldout_poly_residual(y: np.ndarray, temp: np.ndarray, folds: np.ndarray, order: int = 3) -> np.ndarray:
    """Per row: the output minus a polynomial of ``order`` in temp fitted on the other folds
    (:func:`fxdsp.diagnose.extension.heldout_residual` without a rate)."""
    return heldout_residual(y, temp, None, folds, order=order)


def thermometer_errors(columns: dict, codes: dict, fmt, remedies, folds: np.ndarray, order: int = 3) -> dict:
    """Held-out rms of the output compensated by a polynomial of ``order`` (the config's bias
    polynomial), with and without the lag (float fits on the bit-exact temperature ``codes`` of
    :func:`thermometer_words`, in ``fmt``)."""
    stages = {r.stage for r in remedies}
    y = np.asarray(columns["output"], float)
    results, series = {}, {}
    for name, on in _variants(stages).items():
        te = to_float(codes["Te"] if "lag" in on else codes["T"], fmt)
        resid = heldout_poly_residual(y, te, folds, order)
        rms = float(np.sqrt(np.mean(resid**2)))
        results[name] = {"stages": sorted(on), "rms": rms, "max_abs": float(np.abs(resid).max()), "overflows": 0}
        series[name] = resid
    return {"unit": "output unit", "heldout": f"time-blocked folds of the diagnosis (a polynomial of order {order} "
            "in T fitted on the others)",
            "heldout_rows": int(y.size), "rows": int(y.size), "variants": results, "_series": series,
            "_held": np.ones(y.size, dtype=bool)}


def thermometer_bitexact(design, roles, codes: dict, output, fit: dict) -> dict:
    """The config's thermometer chain (the lag if it has one, the bias engine, the subtractor) on the
    log, bit-exact, against the float polynomial it quantises: the arithmetic's own error, in the
    output unit. ``codes``: :func:`thermometer_words`. extend's own chain runs at the log's rate
    whole; a chain of the config whose lag updates at its own rate runs without it on the lag's
    log-rate output ``Te`` (the same words, alpha for the log's interval)."""
    chain = design.chain(roles.instance, "fxdsp extend's thermometer calibration")
    lagged = "lag" in chain.stages
    if lagged and not roles.written:
        chain = without_lag(design.config, roles).chains[roles.instance]
    temp, reading, port = roles.inputs["temp"], roles.inputs["reading"], roles.outputs["compensated"]
    ovf = OverflowLog()
    y = quantize(np.asarray(output, float), chain.inputs[reading], ROUND, ovf, "output")
    fmt = chain.outputs[port]
    word = codes["Te"] if lagged and not roles.written else codes["T"]   # Te: thermometer_words
    if chain.inputs[temp] != codes["format"]:
        raise InputError(f"{roles.netlist_table}: its temperature word {chain.inputs[temp]} is not the lag's "
                         f"{codes['format']}")
    r = to_float(chain.stream(ovf, **{temp: word, reading: y})[port], fmt)
    out = {"rms_compensated": float(np.sqrt(np.mean(r**2))), "overflows": int(ovf.total), "lsb": fmt.lsb,
           "_series": r}
    if fit is not None:
        te = to_float(codes.get("Te", codes["T"]), codes["format"])
        want = np.asarray(output, float) - np.polynomial.polynomial.polyval(te - fit["t0_c"], fit["coefficients"])
        out["max_abs_vs_float"] = float(np.abs(r - want).max())
    return out


def thermometer_applied(columns: dict, configs: dict, remedies, roles) -> dict:
    """A second run through the bit-exact chains of the configs fitted on the first: the compensated
    output about its mean (what is left of the temperature dependence)."""
    from fxdsp.chains import build
    from fxdsp.extend.configure import config_from_text

    errors = {}
    for name, stages in (("before", set()), ("after", {r.stage for r in remedies})):
        design = build(config_from_text(configs[name]))
        codes = thermometer_words(design, roles, columns, tau_of(remedies) if "lag" in stages else None)
        got = thermometer_bitexact(design, roles, codes, columns["output"], None)
        errors[name] = (got["_series"] - got["_series"].mean(), got["overflows"])
    return applied_result(errors, len(columns["time_s"]))


def thermometer_words(design, roles, columns: dict, tau_s: float | None) -> dict:
    """The thermometer chain's temperature codes in the word of its bias engine (a built design):
    the logged reading ``T`` and, with a lag time constant ``tau_s`` (else the chain's own lag's, if
    it has one), ``Te``, the bit-exact lag's output at the log's rate; ``format``: that word."""
    lag = design.blocks.get(roles.tables.get("lag", "lag").replace(".", "_"))
    # extend's own chain reads the temperature in the lag's word (the RTD's), a config's chain in
    # the word its bias engine reads
    fmt = lag.temp_format if roles.written else design.blocks[roles.table("bias").replace(".", "_")].temp_format
    chain = design.chains.get(roles.instance)
    if tau_s is None and chain is not None and "lag" in chain.stages:
        tau_s = lag.tau_s   # the chain's own lag, at the log's rate
    if tau_s is not None and lag is None:
        raise InputError(f"[{roles.tables.get('lag', 'lag')}]: the lag remedy needs a lag table in the config")
    code = quantize(np.asarray(columns["temp_c"], float), fmt, ROUND)
    codes = {"T": code, "format": fmt}
    if tau_s is not None:   # the bit-exact lag's output at the log's rate: the lag's words, alpha for its interval
        codes["Te"] = log_rate_lag(lag, tau_s, columns["time_s"]).run(temp=code).outputs["te"]
    return codes


CHANNEL_UNITS = {"output": "output units", "freq_hz": "Hz", "temp_c": "C"}   # the log's units


def uncompensated_sizes(diag, missing) -> list[dict]:
    """Each named cause left uncompensated ((cause, reason) pairs), with its held-out size in the
    log's units: sqrt(rms_without^2 - rms_with^2) of the diagnosis's held-out residuals (every row
    predicted by a fit on the other time-blocked folds) in the channel the cause acts on, the
    diagnosed model with all its causes against the same model without this one. That is the rms
    of the error the cause leaves that nothing else in the model takes up (its share of the
    compensated output's held-out error, added in quadrature)."""
    from fxdsp.diagnose.candidates import affected_channels
    from fxdsp.diagnose.results import heldout_residuals

    ctx, state = diag.context, diag.state
    out = []
    for cause, reason in missing:
        channel = affected_channels(ctx, cause)[0]
        rms = lambda st: float(np.sqrt(np.mean(heldout_residuals(ctx, st, channel) ** 2)))  # noqa: E731
        with_, without = rms(state), rms({k: v for k, v in state.items() if k != cause})
        out.append({"cause": cause, "reason": reason,
                    "heldout_size": float(np.sqrt(max(without**2 - with_**2, 0.0))),
                    "unit": CHANNEL_UNITS.get(channel, channel), "channel": channel,
                    "heldout_rms_with": with_, "heldout_rms_without": without,
                    "parameters": dict(diag.parameters.get(cause, {}))})
    return out
