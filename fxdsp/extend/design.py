"""The user's design, kept: what ``fxdsp extend`` may change in ``--config``.

The extended config (``config.toml``) is the base config (``--config``, default: the built-in one)
with three kinds of change, and no other:

* the coefficients calibrated from the log, :func:`calibrated_keys` (per calibration procedure, in
  the chain's own tables, :mod:`fxdsp.extend.roles`): segment breakpoints and polynomial
  coefficients, the resonator thermometer's f0/k, a gyro_rtd chain's rate scale;
* the keys of the remedies applied, :func:`remedy_keys` (per procedure and stage): rewritten, or
  added to their table when the base lacks them;
* with ``--widen`` only, a format (or the lag's guard bits) that a calibrated coefficient or a
  remedy needs wider than the user's: the same fraction length, more integer bits. Each is listed
  in the report (``changes``: field, from, to, why). Without ``--widen`` such a need is an
  :class:`~fxdsp.errors.InputError` naming the field and the width it needs.

``config_base.toml`` (the "before" of the report) is the base config with the calibrated
coefficients only. Every other format, rounding, overflow rule, order, t0 and setting stays the
user's: a polynomial keeps the user's t0_c (the fit is re-expanded about it) and the user's order
(a lower-order fit is padded with zero coefficients; a remedy that raises the order, paper 001's
cubic bias, adds a format for the new power, listed in ``changes``).

What has to fit, checked on the temperatures the engines see in the log (the check the user's word
lengths must pass to compensate that log without saturating):

* every calibrated coefficient in its ``coef_format`` (half_up, as the engine quantises it);
* the Horner sums (every partial acc * t + c_k) in ``acc_format``, the polynomial in ``out_format``;
* the log's input word: the divider's ``in_format`` (output / 4096 mV, gyro_rtd), the subtraction's
  ``in_format`` (gyro_freq, thermometer); the resonator thermometer's 1/k in ``kinv_format``;
* the lag: its state moves by round(alpha * d), so a difference below 0.5 / alpha state LSBs never
  moves it. With ``state_guard_bits`` g that dead band is 0.5 / (alpha 2^g) temperature codes: the
  remedy needs 2^g >= 1/alpha (a dead band of at most half a code), alpha = 1 - exp(-1/(rate tau)).

The thermometer chain without ``--config`` is the one exception: the built-in config has no design
for it (its ``[piecewise.bias001]`` and ``[bias_subtract001]`` are paper 001's gyro bias, in deg/h),
so its formats are chosen from the log (:func:`fxdsp.extend.configure.thermometer_tables`) and
every key that differs from the built-in is listed in ``changes`` with that reason.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np

from fxdsp.config import default_config_text
from fxdsp.errors import InputError
from fxdsp.fixed import Format
from fxdsp.fixed.ops import round_unfitted

def _polynomial(table: str) -> tuple[str, str]:
    return (f"{table}.breakpoints_c", f"{table}.coefficients")


def calibrated_keys(roles) -> tuple[str, ...]:
    """The dotted keys the calibration of ``roles`` (:class:`fxdsp.extend.roles.Roles`) writes:
    values only, never a format, in the chain's own tables."""
    t = roles.tables
    if roles.procedure == "gyro_rtd":
        return ("system.rate_full_scale_dps", *_polynomial(t["sf"]), *_polynomial(t["bias"]))
    if roles.procedure == "gyro_freq":
        return (f"{t['f2t']}.f0_hz", f"{t['f2t']}.k_hz_per_c", *_polynomial(t["bias"]))
    return _polynomial(t["bias"])


def remedy_keys(roles) -> dict[str, tuple[str, ...]]:
    """Remedy stage -> the dotted keys it writes (rewritten, or added to their table) in the chain of
    ``roles``: the lag's time constant and, where the chain had no lag, the netlist edit inserting it."""
    t, net = roles.tables, roles.netlist_table
    lag = t.get("lag", "lag")
    edit = () if "lag" in t or roles.written else (f"{net}.instances", f"{net}.wires", f"{net}.inputs")
    if roles.procedure == "gyro_rtd":
        return {"lag": (f"{lag}.tau_s", *edit), "trim": (f"{t['demod']}.phase_trim_rad",),
                "cvd": tuple(f"{t['rtd']}.{k}" for k in ("law", "cvd_a", "cvd_b", "cvd_c"))}
    if roles.procedure == "gyro_freq":
        # the cubic bias: one more coefficient per segment, and a format for it
        return {"order": (f"{t['bias']}.coef_format",)}
    # the instrument's temperature arrives once per logged row: extend's own chain and its lag run
    # at the log's rate
    return {"lag": (f"{lag}.tau_s", *edit, *((f"{lag}.rate_hz",) if roles.written else ()))}


WIDEN_HINT = "widen it in --config, or pass --widen to let extend widen it (listed in the report)"


def allowed_keys(roles, stages) -> set[str]:
    """The dotted keys an extension of the chain of ``roles`` with remedy ``stages`` may write."""
    keys = set(calibrated_keys(roles))
    remedies = remedy_keys(roles)
    for s in stages:
        keys |= set(remedies.get(s, ()))
    return keys


def needed_format(fmt: Format, values) -> Format:
    """The narrowest format with ``fmt``'s signedness and fraction length, at least as wide as
    ``fmt``, that holds every value rounded half_up (as the engines quantise a coefficient)."""
    v = np.asarray(values, float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return fmt
    q, _ = round_unfitted(v, fmt.fl, "half_up")     # the engines' own rounding, not a second one
    lo, hi = int(q.min()), int(q.max())
    if fmt.min_int <= lo and hi <= fmt.max_int:
        return fmt
    if fmt.signed:
        wl = 1 + max(hi.bit_length() if hi > 0 else 0, (-lo - 1).bit_length() if lo < 0 else 0)
    else:
        wl = hi.bit_length()
    return Format(fmt.signed, max(wl, fmt.wl), fmt.fl)


def shift_poly(coefficients, t_from: float, t_to: float) -> list[float]:
    """Ascending coefficients in (T - t_from) re-expanded in (T - t_to): the same polynomial."""
    c = [float(x) for x in coefficients]
    if t_from == t_to:
        return c
    p = np.polynomial.Polynomial(c)(np.polynomial.Polynomial([t_to - t_from, 1.0]))
    out = [float(x) for x in p.coef] + [0.0] * len(c)
    return out[:len(c)]


def horner_values(coef: np.ndarray, breakpoints, t0: float, temps) -> tuple[np.ndarray, np.ndarray]:
    """(every Horner partial acc and product acc * t, the polynomial) of a piecewise polynomial at
    ``temps``: what the engine's accumulator and output hold there (float)."""
    temps = np.asarray(temps, float)
    seg = np.searchsorted(np.asarray(breakpoints, float), temps, side="right")
    c = coef[seg]                       # rows x (order + 1)
    t = temps - t0
    acc = c[:, -1].copy()
    parts = [acc.copy()]
    for k in range(c.shape[1] - 2, -1, -1):
        prod = acc * t
        acc = prod + c[:, k]
        parts += [prod, acc.copy()]
    return np.concatenate(parts), acc


def engine_temperatures(temps) -> np.ndarray:
    """The temperatures at which a check is made: the log's range on a fine grid plus its values."""
    t = np.asarray(temps, float)
    t = t[np.isfinite(t)]
    if t.size == 0:
        return t
    return np.union1d(np.linspace(t.min(), t.max(), 513), np.unique(t)[:: max(1, t.size // 2000)])


class Design:
    """The base config an extension keeps: its text (``--config`` or the built-in) and ``widen``."""

    def __init__(self, base_text: str | None = None, widen: bool = False, name: str | None = None):
        self.given = base_text is not None
        self.text = base_text if self.given else default_config_text()
        self.data = tomllib.loads(self.text)
        self.widen = widen
        self.name = name or ("--config" if self.given else "the built-in config")

    def table(self, name: str) -> dict:
        node = self.data
        for part in name.split("."):
            if part not in node:
                raise InputError(f"[{name}]: not in {self.name}; the extension writes into the user's tables")
            node = node[part]
        return node

    def value(self, dotted: str, default=None):
        table, _, key = dotted.rpartition(".")
        try:
            return self.table(table).get(key, default)
        except InputError:
            return default

    def fitting(self) -> "Fitting":
        return Fitting(self)


class Fitting:
    """The checks of one config against the user's design, and the changes they made (``--widen``)."""

    def __init__(self, design: Design):
        self.design = design
        self.changes: list[dict] = []

    def record(self, field: str, was, now, why: str) -> None:
        entry = {"field": field, "from": was, "to": now, "why": why}
        if entry not in self.changes:
            self.changes.append(entry)

    def holding(self, field: str, fmt_text: str, values, what: str) -> str:
        """``fmt_text`` when it holds ``values``; else the widened format (``--widen``, listed) or an
        InputError naming the field and the width needed."""
        fmt = Format.parse(fmt_text, field)
        v = np.asarray(values, float)
        if not fmt.signed and v.size and np.nanmin(v) < -0.5 * fmt.lsb:
            raise InputError(f"{field}: {what} reaches {np.nanmin(v):.6g}, below the range of the unsigned {fmt}")
        try:
            need = needed_format(fmt, v)
        except ValueError:
            raise InputError(f"{field}: {what} reaches {np.nanmax(np.abs(v)):.6g}: no "
                             f"{'signed' if fmt.signed else 'unsigned'} format of fraction length {fmt.fl} holds "
                             "it (more than 63 bits)") from None
        if need == fmt:
            return fmt_text
        why = (f"{what} reaches {np.nanmax(np.abs(v)):.6g}; {fmt} holds {fmt.min_value:.6g}..{fmt.max_value:.6g}: "
               f"it needs {need} ({need.wl} bits, {need.wl - fmt.wl} more)")
        if not self.design.widen:
            raise InputError(f"{field}: {why}; {WIDEN_HINT}")
        self.record(field, str(fmt), str(need), why)
        return str(need)

    def piecewise(self, table: str, coefficients, breakpoints, temps, t0_fit: float = 0.0,
                  remedy: str | None = None) -> dict:
        """The keys of ``[table]`` for a calibrated piecewise polynomial (ascending coefficients in
        T - ``t0_fit``) in the user's design: re-expanded about the user's t0_c, padded to the
        user's order, checked against the user's formats on the temperatures ``temps``."""
        user = self.design.table(table)
        t0 = float(user.get("t0_c", 0.0))
        rows = [shift_poly(row, t0_fit, t0) for row in np.atleast_2d(np.asarray(coefficients, float))]
        n_user = len(user["coefficients"][0]) if user.get("coefficients") else len(rows[0])
        n = max(n_user, len(rows[0]))
        coef = np.array([r + [0.0] * (n - len(r)) for r in rows])
        out = {"breakpoints_c": [float(b) for b in breakpoints], "coefficients": coef.tolist()}
        fmts = user["coef_format"]
        if isinstance(fmts, str):
            new = self.holding(f"{table}.coef_format", fmts, coef, "the calibrated coefficients")
        else:
            from fxdsp.repro.calconfig import fit_format

            new = list(fmts)
            for k in range(n):
                if k >= len(new):
                    # a remedy's higher order: the new power gets a format of the last one's width
                    new.append(fit_format(coef[:, k], Format.parse(new[-1]).wl, 1, True, f"{table}.c{k}"))
                    self.record(f"{table}.coef_format[{k}]", None, new[k],
                                f"added for c{k}: {remedy or 'a higher order than the config'}")
                else:
                    new[k] = self.holding(f"{table}.coef_format[{k}]", new[k], coef[:, k], f"the calibrated c{k}")
        if new != fmts:
            out["coef_format"] = new
        grid = engine_temperatures(temps)
        if grid.size:
            partial, value = horner_values(coef, breakpoints, t0, grid)
            where = f"over the log's {grid.min():.4g}..{grid.max():.4g} C"
            acc = self.holding(f"{table}.acc_format", user["acc_format"], partial, f"the Horner sums {where}")
            res = self.holding(f"{table}.out_format", user["out_format"], value, f"the polynomial {where}")
            if acc != user["acc_format"]:
                out["acc_format"] = acc
            if res != user["out_format"]:
                out["out_format"] = res
        return out

    def lag(self, tau_s: float, rate_hz: float, table: str = "lag") -> dict:
        """The lag ``table``'s keys beyond tau_s that the remedy needs: ``state_guard_bits`` when the
        user's leave a dead band of more than half a temperature code (``--widen``), else nothing."""
        user = self.design.table(table)
        alpha = -math.expm1(-1.0 / (rate_hz * tau_s))
        need = max(0, math.ceil(math.log2(1.0 / alpha) - 1e-12))
        g = int(user.get("state_guard_bits", 0))
        if g >= need:
            return {}
        field = f"{table}.state_guard_bits"
        why = (f"the lag of tau {tau_s:.4g} s updated at {rate_hz:.4g} Hz (alpha {alpha:.3g}) has a dead band of "
               f"0.5/(alpha 2^g) = {0.5 / (alpha * 2.0 ** g):.3g} temperature codes with {g} guard bits: it needs "
               f"{need} (2^g >= 1/alpha, {need - g} more state bits)")
        if not self.design.widen:
            raise InputError(f"{field}: {why}; {WIDEN_HINT}")
        self.record(field, g, need, why)
        return {"state_guard_bits": need}


def merge_changes(by_config: dict[str, list[dict]]) -> list[dict]:
    """One list of changes, each with the output configs it is in (``in``)."""
    merged: list[dict] = []
    for name, changes in by_config.items():
        for ch in changes:
            hit = next((m for m in merged if all(m[k] == ch[k] for k in ("field", "from", "to"))), None)
            if hit is None:
                merged.append({**ch, "in": [name]})
            elif name not in hit["in"]:
                hit["in"].append(name)
    return merged
