"""Calibration -> TOML config: quantise a paper's fitted compensation into a copy of the default config.

The calibrated config is the default text with only the calibrated keys rewritten in place (every
other line and table untouched; a rewritten key's trailing comment, which described the old value,
is dropped), so ``fxdsp.chains.build`` reads it like any config and a diff
against the default shows exactly what calibration changed.

Units of the log -> fixed-point mapping (documented choices):

* paper 002: the log's ``output`` is the demodulated rate channel in mV. It enters the SF divider as a
  fraction of a sense full scale of ``FS_MV = 4096 mV`` (+-2048 mV of rate channel = +-205 deg/s at
  10 mV/(deg/s)), in ``LOG_IN_FORMAT = s24.23``: a 10-s log sample is an average, a 24-bit word
  (LSB 4.9e-4 mV = 0.18 deg/h), not a raw 16-bit ADC sample. SF(T) is normalised to the calibrated
  SF at 25 C (``sf_nominal``), so the quotient stays the size of the input; the bias table is in FS
  units after the division: bias_FS = bias_dps * sf_nominal / FS_MV.
* paper 001: temperatures from ``freq2temp`` (f0, k calibrated), bias in deg/h (the log's unit).
* paper 000: K0 in Hz, K1 in Hz/g, cubic in t = T - 25 C.

Coefficient formats are chosen per power so the largest calibrated coefficient fits with one bit of
headroom in a ``COEF_WL``-bit word (:func:`fit_format`); output and accumulator formats likewise from
the range the table takes over -40..85 C; the accumulator is the widest whose Horner product with
t = T - t0 (one bit wider than the default config's temperature word) fits 63 bits, because the top
coefficient is converted into it and every product rounded to it. The output formats the chain wires
onward (the bias tables') are the default config's, which sit below the rate word's LSB.
"""

from __future__ import annotations

import functools

import math
import re
import tomllib

import numpy as np

from fxdsp.chains import build
from fxdsp.config import Config, default_config_text, dumps_value, table_at
from fxdsp.fixed import Format
from fxdsp.errors import InputError

FS_MV = 4096.0
LOG_IN_FORMAT = "s24.23"
COEF_WL = 24
T_RANGE_C = (-40.0, 85.0)


def fit_format(values, wl: int = COEF_WL, headroom_bits: int = 1, signed: bool = True,
               name: str = "values") -> str:
    """The finest ``s<wl>.<fl>`` that holds max|values| with ``headroom_bits`` to spare."""
    v = np.abs(np.asarray(values, float))
    if v.size == 0 or not np.all(np.isfinite(v)):
        raise InputError(f"{name}: need finite values to choose a format")
    peak = float(v.max())
    if peak == 0.0:
        int_bits = 0
    else:
        int_bits = max(math.floor(math.log2(peak)) + 1, -(wl - 2))
    fl = wl - int(signed) - int_bits - headroom_bits
    if fl > 250:
        fl = 250
    return f"{'s' if signed else 'u'}{wl}.{fl}"


def _value_end(lines: list[str], i: int, start: int) -> int:
    """The index after the last line of the value that starts at ``lines[i][start:]`` (a TOML array
    may continue over several lines)."""
    for end in range(i + 1, len(lines) + 1):
        try:
            tomllib.loads("v = " + lines[i][start:] + "".join(lines[i + 1:end]))
            return end
        except tomllib.TOMLDecodeError:
            continue
    return i + 1


def set_table_keys(text: str, table: str, updates: dict, add_missing: bool = False) -> str:
    """Rewrite ``key = value`` lines of ``[table]`` in TOML text. Keys must already exist there,
    unless ``add_missing``: those are then written right after the table's header line (and a table
    the text lacks is appended, with every key)."""
    lines = text.splitlines(keepends=True)
    current = None
    done = set()
    header = re.compile(r"^\s*\[([^\]]+)\]")
    for i, line in enumerate(lines):
        m = header.match(line)
        if m:
            current = m.group(1).strip()
            continue
        if current != table:
            continue
        km = re.match(r"^(\s*)([A-Za-z0-9_]+)(\s*=\s*)", line)
        if km and km.group(2) in updates and km.group(2) not in done:
            key = km.group(2)
            # the base's trailing comment described the old value (a paper's polynomial, an LSB in
            # its units): a rewritten key drops it rather than keep a statement that is now false
            end = _value_end(lines, i, len(km.group(0)))
            lines[i] = f"{km.group(1)}{key}{km.group(3)}{dumps_value(updates[key], f'{table}.{key}')}\n"
            for j in range(i + 1, end):
                lines[j] = ""   # the old value's continuation lines (a list written over several lines)
            done.add(key)
    missing = [k for k in updates if k not in done]
    if missing and add_missing:
        at = next((i for i, line in enumerate(lines) if (m := header.match(line)) and m.group(1).strip() == table),
                  None)
        new = [f"{k} = {dumps_value(updates[k], f'{table}.{k}')}\n" for k in missing]
        if at is not None:
            return "".join(lines[:at + 1] + new + lines[at + 1:])
        if not done:
            tail = "" if not lines or lines[-1].endswith("\n") else "\n"
            return "".join(lines) + tail + f"\n[{table}]\n" + "".join(new)
    if missing:
        raise InputError(f"[{table}].{missing[0]}: not in the base config, cannot rewrite it")
    return "".join(lines)


def _range(coefficients, breakpoints, t0_c: float) -> float:
    """max |p(T)| of a piecewise polynomial over T_RANGE_C."""
    temps = np.linspace(*T_RANGE_C, 501)
    seg = np.searchsorted(np.asarray(breakpoints, float), temps, side="right")
    coef = np.asarray(coefficients, float)
    vals = np.array([np.polynomial.polynomial.polyval(t - t0_c, coef[s]) for t, s in zip(temps, seg)])
    return float(np.abs(vals).max())


@functools.cache
def _default_data() -> dict:
    return tomllib.loads(default_config_text())


def _default(table: str, key: str):
    """A value of the default config (parsed once: calibrations ask for it hundreds of times)."""
    return table_at(_default_data(), table)[key]


def acc_width(temp_format: str) -> int:
    """The widest accumulator whose product with t = T - t0 (temperature word + 1 bit) fits 63 bits."""
    return 63 - (Format.parse(temp_format).wl + 1)


def piecewise_table(coefficients, breakpoints=(), t0_c: float = 0.0, out_signed: bool = True,
                    out_wl: int = 24, *, acc_wl: int, name: str = "piecewise", coef_wl: int = COEF_WL) -> dict:
    """Keys of a ``[piecewise.*]`` table with formats chosen for these coefficients."""
    coef = np.atleast_2d(np.asarray(coefficients, float))
    if coef.shape[1] < 2 or coef.shape[1] > 4:
        raise InputError(f"{name}.coefficients: need 2..4 coefficients per segment, got {coef.shape[1]}")
    if not np.all(np.isfinite(coef)):
        raise InputError(f"{name}.coefficients: must be finite")
    peak = _range(coef, breakpoints, t0_c)
    out_fmt = fit_format([peak], out_wl, 1, out_signed, f"{name}.out")
    # the accumulator is as wide as the Horner product allows: the top coefficient is converted into
    # it and every product rounded to it, so its LSB times |t|^order bounds the evaluation error
    acc_fmt = fit_format([peak, *np.abs(coef[:, 0])], acc_wl, 2, True, f"{name}.acc")
    # whether acc * t fits 63 bits is the piecewise block's own check, made when the config is built
    return {"breakpoints_c": [float(b) for b in breakpoints],
            "coefficients": [[float(c) for c in row] for row in coef],
            "t0_c": float(t0_c),
            "coef_format": [fit_format(coef[:, k], coef_wl, 1, True, f"{name}.c{k}") for k in range(coef.shape[1])],
            "acc_format": acc_fmt, "out_format": out_fmt}


# --- paper 002 --------------------------------------------------------------------------------------

def lag_table(tau_s: float, rate_hz: float) -> dict:
    """The ``[lag]`` table: the die-temperature estimate ahead of the coefficient engines."""
    if not (math.isfinite(tau_s) and tau_s > 0):
        raise InputError(f"lag.tau_s: must be a finite number > 0, got {tau_s!r}")
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"lag.rate_hz: must be a finite number > 0, got {rate_hz!r}")
    return {"lag": {"tau_s": float(tau_s), "rate_hz": float(rate_hz)}}


def paper002_coefficients(cal: dict) -> dict:
    """The calibrated values of a paper 002 calibration in the config's units, and nothing else (no
    format): ``{table: {key: value}}`` with the SF and bias segments (breakpoints and ascending
    coefficients in absolute T, t0 = 0) and ``[system] rate_full_scale_dps``. SF is normalised to
    the calibrated SF at 25 C (``sf_nominal``), the bias is in FS units after the division."""
    sfn = float(cal["sf_nominal"])
    if not sfn > 0:
        raise InputError(f"sf_nominal: must be > 0, got {sfn!r}")
    sf_coef = np.asarray(cal["sf"]["coefficients"], float) / sfn
    bias_coef = np.asarray(cal["bias"]["coefficients"], float) * sfn / FS_MV
    return {"piecewise.sf": {"breakpoints_c": [float(b) for b in cal["sf"]["breakpoints_c"]],
                             "coefficients": [[float(c) for c in row] for row in sf_coef]},
            "piecewise.bias": {"breakpoints_c": [float(b) for b in cal["bias"]["breakpoints_c"]],
                               "coefficients": [[float(c) for c in row] for row in bias_coef]},
            # 1 FS of the quotient = FS_MV / sf_nominal deg/s: the config's own rate scale
            "system": {"rate_full_scale_dps": FS_MV / sfn}}


def paper002_tables(cal: dict, order: int = 1) -> dict:
    """SF and bias tables of a paper 002 calibration (:func:`fxdsp.repro.calibrate.calibrate002`),
    with formats chosen for the coefficients (``fxdsp calibrate``, ``fxdsp repro``; ``fxdsp
    extend`` keeps the user's formats instead: :mod:`fxdsp.extend.design`).

    ``cal`` holds ``sf`` and ``bias`` as ``{"breakpoints_c": inner, "coefficients": [[c0, c1, ...]]}``
    in absolute T (C), SF in mV/(deg/s), bias in deg/s, and ``sf_nominal`` (SF at 25 C)."""
    values = paper002_coefficients(cal)
    sf_coef = values["piecewise.sf"]["coefficients"]
    bias_coef = values["piecewise.bias"]["coefficients"]
    acc_wl = acc_width(_default("rtd", "temp_format"))
    sf = piecewise_table(sf_coef, cal["sf"]["breakpoints_c"], 0.0, out_signed=False, out_wl=18, acc_wl=acc_wl,
                         name="piecewise.sf")
    # SF normalised to ~1 in u24.22 (0.24 ppm; the default's u18.16 is a 15 ppm step, i.e.
    # 0.003 deg/s at 200 deg/s); the divider's numerator is 24 + 22 + 10 guard bits = 56 bits
    sf["out_format"] = "u24.22"
    bias = piecewise_table(bias_coef, cal["bias"]["breakpoints_c"], 0.0, out_wl=24, acc_wl=acc_wl,
                           name="piecewise.bias")
    bias["out_format"] = _default("piecewise.bias", "out_format")  # finer than the rate word it is subtracted from
    return {"piecewise.sf": sf, "piecewise.bias": bias, "sf_divide": {"in_format": LOG_IN_FORMAT},
            "system": values["system"]}


def paper001_coefficients(cal: dict) -> dict:
    """The calibrated values of a paper 001 calibration (no format): the resonator thermometer's f0
    and k, and the bias polynomial (ascending in absolute T, one segment, t0 = 0)."""
    return {"freq2temp": {"f0_hz": float(cal["f0_hz"]), "k_hz_per_c": float(cal["k_hz_per_c"])},
            "piecewise.bias001": {"breakpoints_c": [], "coefficients": [[float(c) for c in cal["bias_poly"]]]}}


def paper001_tables(cal: dict) -> dict:
    values = paper001_coefficients(cal)
    q = values["piecewise.bias001"]["coefficients"][0]
    if len(q) == 2:
        q.append(0.0)
    bias = piecewise_table([q], [], 0.0, out_wl=24, acc_wl=acc_width(_default("freq2temp", "temp_format")),
                           name="piecewise.bias001")
    bias["out_format"] = _default("piecewise.bias001", "out_format")  # deg/h, finer than the rate input word
    return {"freq2temp": values["freq2temp"], "piecewise.bias001": bias}


def paper000_tables(cal: dict) -> dict:
    t0 = float(cal.get("t_ref_c", 25.0))
    acc_wl = acc_width(_default("piecewise.k0", "temp_format"))
    return {"piecewise.k0": piecewise_table([cal["k0_poly"]], [], t0, acc_wl=acc_wl, name="piecewise.k0"),
            "piecewise.k1": piecewise_table([cal["k1_poly"]], [], t0, acc_wl=acc_wl, name="piecewise.k1")}


def config_text(tables: dict, base_text: str | None = None, provenance: str = "", add_missing: bool = False) -> str:
    """A copy of ``base_text`` (default config) with ``tables`` ({table: {key: value}}) rewritten
    (``add_missing``: keys the base lacks are added to their table). Raises ValueError when the
    result does not build."""
    text = default_config_text() if base_text is None else base_text
    for table, keys in tables.items():
        text = set_table_keys(text, table, keys, add_missing)
    if provenance:
        text = "".join(f"# {line}\n" for line in provenance.splitlines()) + text
    config_from_text(text)  # must build
    return text


def config_from_text(text: str, source: str = "<calibrated>") -> Config:
    cfg = Config(tomllib.loads(text), source=source)
    build(cfg)
    return Config(tomllib.loads(text), source=source)  # build() marks keys read: hand back a fresh one
