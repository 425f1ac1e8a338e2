"""Calibrate a log into a config, and apply a config bit-exactly to a second run's log (used by
``fxdsp calibrate --config-out F --apply LOG2``)."""

from __future__ import annotations

import numpy as np

from fxdsp.fixed import OverflowLog, to_float

from fxdsp.repro import paper001
from fxdsp.repro.bitexact import Compensator000, Compensator001, Compensator002
from fxdsp.repro.calconfig import config_from_text, config_text, paper000_tables, paper001_tables, paper002_tables
from fxdsp.repro.calibrate import calibrate002
from fxdsp.repro.points import rate_table_points, tempco
from fxdsp.repro.stages import config_stages, stage_inputs
from fxdsp.sim.calibration import calibrate_paper000_log, calibrate_paper001, tumble_points_from_log
from fxdsp.errors import InputError

PAPERS = ("002", "001", "000")


def calibrated_config(paper: str, log: dict, order: int = 1, base_text: str | None = None) -> tuple[str, dict]:
    """(config TOML text, calibration) of a paper from a log, written into ``base_text`` (default:
    the built-in config). Paper 002 with a base that carries stages (an extended config from
    ``fxdsp extend``: a lag, a phase trim) is calibrated with them in place, so its tables do not
    absorb what the stages remove. Paper 001's thermometer is checked bit-exactly against the
    calibration reference: a failing f0/k is a ValueError."""
    if paper == "002":
        on = set()
        if base_text is not None:
            comp = Compensator002(config_from_text(base_text))
            on, tau, theta = config_stages(comp.chain)
        if on:
            code, out = stage_inputs(comp, log, on, tau, theta)
            temp = to_float(code, comp.rtd.temp_format) if on & {"lag", "cvd"} else None
            cal = calibrate002({**log, "output": out}, order, temp=temp)
            cal["stages"] = sorted(on)
        else:
            cal = calibrate002(log, order)
        tables = paper002_tables(cal)
    elif paper == "001":
        if order != 1:
            raise InputError("--order: paper 001's bias is one quadratic; only the default order applies")
        cal = calibrate_paper001(log)
        tables = paper001_tables(cal)
    elif paper == "000":
        if order != 1:
            raise InputError("--order: paper 000's K0/K1 are cubics; only the default order applies")
        cal = calibrate_paper000_log(log)
        tables = paper000_tables(cal)
    else:
        raise InputError(f"--paper: unknown paper {paper!r}; expected one of {', '.join(PAPERS)}")
    text = config_text(tables, base_text, provenance=f"calibrated by fxdsp.repro for paper {paper}")
    if paper == "001":
        pts = cal["points"]
        check = paper001.check_thermometer(config_from_text(text), pts["temp_c"], pts["freq_hz"])
        cal["thermometer_check"] = check
        if not check["ok"]:
            raise InputError(f"freq2temp: calibrated f0/k put the calibration points {check['mean_error_c']:+.3f} C "
                             f"off the reference (limit {paper001.THERMO_TOL_C} C)")
    return text, cal


def apply_config(paper: str, config_text_: str, log: dict) -> dict:
    """Bit-exact compensation of ``log`` with a config; figures before and after."""
    cfg = config_from_text(config_text_)
    if paper == "002":
        comp = Compensator002(cfg)
        on, tau, theta = config_stages(comp.chain)
        ovf = OverflowLog()
        code, x = stage_inputs(comp, log, on, tau, theta, ovf)   # the config's stages (none: as before)
        out = comp.run(x, code, ovf)
        ref = log["ref_temp_c"] if "ref_temp_c" in log else log["temp_c"]
        before = rate_table_points(log, temp=ref)
        after = rate_table_points(log, output=out["rate_dps"], temp=ref)
        sf25 = float(np.interp(25.0, before["temp_c"], before["sf"]))
        return {"sf_tempco_ppm_before": tempco(before["temp_c"], before["sf"], True) * 1e6,
                "bias_tempco_deg_h_before": tempco(before["temp_c"], before["bias"] / sf25 * 3600.0),
                "sf_tempco_ppm_after": tempco(after["temp_c"], after["sf"], True) * 1e6,
                "bias_tempco_deg_h_after": tempco(after["temp_c"], after["bias"] * 3600.0),
                "overflows": out["overflows"].total, **({"stages": sorted(on)} if on else {})}
    if paper == "001":
        out = Compensator001(cfg).compensate(log)
        r = out["rate_deg_h"]
        return {"output_std_before": float(np.std(log["output"])), "output_std_after": float(np.std(r)),
                "output_max_abs_after": float(np.abs(r).max()),
                "temp_range_c": [float(out["temp_c"].min()), float(out["temp_c"].max())],
                "overflows": out["overflows"].total}
    if paper == "000":
        out = Compensator000(cfg).compensate(log["temp_c"], log["output"])
        pts = tumble_points_from_log(dict(log, output=out["accel_g"]))
        return {"k0_max_abs_mg": float(np.abs(pts["k0"]).max() * 1e3),
                "k1_max_abs_dev": float(np.abs(pts["k1"] - 1.0).max()),
                "temps_c": pts["temp_c"].tolist(), "overflows": out["overflows"].total}
    raise InputError(f"--paper: unknown paper {paper!r}; expected one of {', '.join(PAPERS)}")
