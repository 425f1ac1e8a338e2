"""The causes of the measured-data contract (shared/spec/measured-data.md, section 3): one record each.

A record holds everything the project knows about a cause: its contract name and parameters, the
log channel it shows in, the columns a log needs to show it, where the simulator injects it and how
(:mod:`fxdsp.sim.generate`), the term the diagnosis fits for it (:mod:`fxdsp.diagnose.model`), how
its nonlinear parameter is searched, the explanation the report gives, and the hardware remedy each
calibration procedure has for it (:mod:`fxdsp.extend.plan`). The physics functions live in
:mod:`fxdsp.mechanisms`, shared by the simulator and the fit. Adding a cause is one record here,
its physics function and its tests; the packaged report schema's cause enum is checked against
:data:`CAUSES` by a test.

The diagnosis terms are written on the diagnosis's ``Series`` (time ``t``, ``dtdt``, hysteresis state
``hyst``, ``quad``, ``rate``, ``sf_estimate``): the attributes it derives from a log, read by name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from fxdsp import mechanisms as mech
from fxdsp.errors import InputError

# where in the simulator's signal path a cause acts, in the order the generator computes them:
# the RTD element's readout, the temperature the sensor sees, the rate it senses, its output, and
# the resonant frequency
STAGES = ("rtd", "te", "rate", "output", "freq")
CHANNELS = ("output", "temp_c", "freq_hz")


@dataclass(frozen=True)
class Remedy:
    """A change of the compensation hardware (never the sensor) that removes a cause."""

    cause: str
    stage: str          # "lag", "trim", "order", "cvd": the name the report and the ablation use
    what: str           # one line for the report
    parameters: dict


@dataclass(frozen=True)
class Search:
    """How the diagnosis searches a cause's nonlinear parameter: a geometric grid of ``points`` time
    constants from two samples to ``span`` x the log's duration, on a log axis."""

    parameter: str
    span: float
    points: int


@dataclass(frozen=True)
class Cause:
    name: str
    parameters: tuple[str, ...]          # the contract's names, in its order and units
    channel: str                         # the log channel where it shows (its held-out gain is counted)
    explain: str = ""                    # the report's sentence, formatted with the fitted parameters
    needs: tuple[str, ...] = ()          # optional log columns without which it cannot be seen at all
    # diagnosis: whether a log can show it at all (its column, a temperature that moves, a rate table),
    # from the diagnosis's context (``ctx.series``, ``ctx.has_rate``, ``ctx.orders``)
    shows: Callable[[object], bool] = field(default=lambda ctx: True)
    also_freq: bool = False              # it also moves freq_hz when the log has it (a lag of the die)
    # simulator: the stage it acts on and the new value of that stage's signal, from the parameters,
    # the signal so far and the generator's other signals (t, rtd_true, temp_clean, te, quad)
    stage: str | None = None
    inject: Callable[[dict, np.ndarray, dict], np.ndarray] | None = None
    # diagnosis: the output design's column (its coefficient, in the output's unit, is the
    # parameter ``linear``), or a curvature: an x^2 column in its channel's design (x: the
    # thermometer scaled by ``scale``), whose parameter is ``curvature(coef, j, sd_y, scale)`` from
    # the design's coefficients (j: the x^2 column's index, sd_y: the channel's normalisation)
    term: Callable[[object, dict], np.ndarray] | None = None
    linear: str | None = None
    curvature: Callable[[np.ndarray, int, float, object], float] | None = None
    search: Search | None = None
    time_tied: bool = False              # a function of time alone: a look-alike of slow noise wander
    # the column or time scale whose structure it claims (the `against` of the contract's section 5):
    # named, it must leave none there (fxdsp.diagnose.remaining)
    signature: str = "time_s"
    transient: bool = False              # lives at the start of the log rather than throughout it
    # it bends the thermometer's reading, not the element's temperature: named, the output is fitted
    # against temp_c with that bend taken out (fxdsp.diagnose.model.element_temperature)
    misreads_thermometer: bool = False
    # its column is not known row by row: dated from the thermometer's ramps (a knee, a smoothed
    # derivative: off by rows at every corner) or a noisy readout (quad: its own white noise). Prewhitening
    # weighs the fast changes, where those errors are, so it would weigh them most (and shrink the
    # parameter towards 0): a channel fitted with such a cause keeps ordinary least squares for its
    # numbers (fxdsp.diagnose.whitening)
    column_uncertain: bool = False
    explain_extra: Callable[[dict], dict] = field(default=lambda p: {})
    # extend: per calibration procedure, the remedy built from the fitted parameters, or why the
    # chain needs none
    remedies: Mapping[str, Callable[[dict], Remedy]] = field(default_factory=dict)
    absorbed: Mapping[str, str] = field(default_factory=dict)
    # the project's hidden-cause generator (fxdsp.diagnose.hidden): (effects, noise) of this cause
    # sized to a drawn SNR x its channel's effective white noise, from a draw context ``d`` (rng,
    # snr, sign, t, truth (the clean log's truth), sigma (effective noise per channel), levels,
    # simulate(effects) -> (noise-free log, truth))
    draw: Callable[[object], tuple[dict, dict]] | None = None

    def channels(self, has_freq: bool) -> list[str]:
        """Channels whose fit the cause changes (and where its held-out evidence is counted)."""
        return [self.channel] + (["freq_hz"] if self.also_freq and has_freq else [])


def _temperature_moves(ctx) -> bool:
    return float(np.ptp(ctx.series.temp)) > 0


def _sf_cubic_visible(ctx) -> bool:
    """A rate table whose rates make rate^3 no multiple of rate (a tumble's cos(theta) in {1, 0, -1}
    does), with the scale factor estimated."""
    s = ctx.series
    if not (ctx.has_rate and ctx.orders[1] is not None and s.sf_estimate is not None):
        return False
    u = s.rate / np.max(np.abs(s.rate))
    return np.linalg.matrix_rank(np.column_stack([u, u ** 3]), tol=1e-6) == 2


def _lag_remedy(p: dict) -> Remedy:
    tau = float(p["tau_s"])
    return Remedy("thermal_lag", "lag", f"lag filter (tau {tau:.4g} s) on the temperature code before the "
                  "coefficient engines", {"tau_s": tau})


def phase_trim_rad(c: float) -> float:
    """The demodulator's reference trim that cancels a quadrature leak c: -atan(c) (a phase error
    theta leaks Q into I as I cos(theta) + Q sin(theta), i.e. c = tan(theta))."""
    return -math.atan(c)


def _trim_remedy(p: dict) -> Remedy:
    c = float(p["c"])
    return Remedy("quadrature_leak", "trim", f"demodulation phase trim {phase_trim_rad(c):+.5f} rad (-atan c, "
                  f"c = {c:.4g})", {"c": c, "phase_trim_rad": phase_trim_rad(c)})


def _cubic_remedy(p: dict) -> Remedy:
    k2 = float(p["k2_hz_per_c2"])
    return Remedy("frequency_nonlinearity", "order", f"cubic instead of quadratic bias in the frequency's temperature "
                  f"(the resonator turns over, k2 = {k2:.3g} Hz/C^2, bending the linear f -> T read-out)",
                  {"bias_order": 3})


def _cvd_remedy(p: dict) -> Remedy:
    b = float(p["b_per_c"])
    return Remedy("rtd_nonlinearity", "cvd", f"Callendar-Van Dusen RTD table (B/A = {b:.3g} /C: the element's "
                  "curvature, read linearly until now)", {"b_per_c": b})


# the generator's draw ranges: time constants log-uniform in these (s)
TAU_LAG_RANGE = (300.0, 4000.0)
TAU_WARMUP_RANGE = (900.0, 7200.0)


def _rms(x) -> float:
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean((x - x.mean()) ** 2)))


def _log_uniform(rng, bounds) -> float:
    return float(np.exp(rng.uniform(*np.log(bounds))))


def _draw_lag(d):
    """A lag sets the channel noise itself: the output and RTD noise are scaled together so that
    the effective output noise is the lag's rms / SNR."""
    effects = {"thermal_lag": {"tau_s": _log_uniform(d.rng, TAU_LAG_RANGE)}}
    lagged, clean = d.simulate(effects), d.clean
    lam = _rms(lagged["output"] - clean["output"]) / d.snr / d.sigma["output"]
    noise = {"output": lam * d.levels["output"], "temp_c": lam * d.levels["temp_c"],
             "freq_hz": max(_rms(lagged["freq_hz"] - clean["freq_hz"]) / d.snr, 1e-12)}
    return effects, noise


def _draw_warmup(d):
    tau = _log_uniform(d.rng, TAU_WARMUP_RANGE)
    shape = np.exp(-d.t / tau)
    head = d.t < 3 * tau
    return {"warmup": {"a": d.sign * d.snr * d.sigma["output"] / float(np.sqrt(np.mean(shape[head] ** 2))),
                       "tau_s": tau}}, {}


def _sized(name: str, channel: str, shape: Callable[[object], np.ndarray] | None = None):
    """A draw of a cause with one parameter: sign x SNR x the channel's noise / rms of its shape
    (the cause's signature at a parameter of 1; no shape: a step of 1 itself)."""
    def draw(d):
        size = d.sign * d.snr * d.sigma[channel]
        return {name: {PARAMETERS[name][0]: size / _rms(shape(d)) if shape else size}}, {}
    return draw


def _sf_cubic_shape(d) -> np.ndarray:
    s = np.polynomial.polynomial.polyval(d.truth["Te"] - 25.0, d.truth["baseline"]["sf_poly"])
    return s * d.truth["rate_dps"] ** 3


def _rtd_b_per_c(c: np.ndarray, j: int, sd_y: float, sc) -> float:
    """b of temp_c = t0 + t1 x + q x^2 (x = (ref - mid) / half): the curvature over the slope at 25 C
    (the sd_y scale cancels in the ratio)."""
    quad = c[j] / sc.half ** 2  # coefficient of ref^2
    slope = c[1] / sc.half + 2.0 * c[j] * (mech.T_CURVE_C - sc.mid) / sc.half ** 2
    return float(quad / slope) if slope != 0 else float("nan")


_RECORDS = (
    Cause("none", (), "output", shows=lambda ctx: False),
    Cause("thermal_lag", ("tau_s",), "output", signature="d(temp_c)/dt", also_freq=True, shows=_temperature_moves,
          explain=("The sensing element lags the logged temperature through a first-order lag of "
                   "tau = {tau_s:.0f} s: heating and cooling give different outputs at the same temp_c "
                   "and the difference decays through the dwells after each ramp."),
          stage="te", inject=lambda p, te, s: mech.first_order_lag(s["t"], te, p["tau_s"]),
          search=Search("tau_s", 1.0, 36), draw=_draw_lag,
          remedies={"gyro_rtd": _lag_remedy, "thermometer": _lag_remedy},
          absorbed={"gyro_freq": "the resonant frequency reads the die itself"}),
    Cause("ramp_rate", ("k_per_c_per_s",), "output", signature="d(temp_c)/dt", shows=_temperature_moves,
          explain=("The output carries a term proportional to d(temp_c)/dt (k = {k_per_c_per_s:.4g} per C/s): "
                   "a thermal-gradient effect that vanishes as soon as the temperature stops moving."),
          stage="output",
          inject=lambda p, out, s: out + p["k_per_c_per_s"] * mech.rate_of_change(s["t"], s["temp_clean"]),
          term=lambda series, state: series.dtdt, linear="k_per_c_per_s", column_uncertain=True,
          draw=_sized("ramp_rate", "output", lambda d: mech.rate_of_change(d.t, d.truth["temp_c"]))),
    Cause("hysteresis", ("h",), "output", signature="temp_c", shows=lambda ctx: bool(np.any(ctx.series.hyst != 0)),
          explain=("The output differs by {h:.4g} (2h between the two branches) after heating and after "
                   "cooling ramps and keeps that offset through the dwells: hysteresis, not a lag."),
          stage="output", inject=lambda p, out, s: out + p["h"] * mech.ramp_direction(s["t"], s["temp_clean"]),
          term=lambda series, state: series.hyst, linear="h", time_tied=True, column_uncertain=True,
          draw=_sized("hysteresis", "output")),
    Cause("warmup", ("a", "tau_s"), "output", signature="time_s",
          explain="A settling transient after power-on: output += {a:.4g} exp(-t / {tau_s:.0f} s).",
          stage="output", inject=lambda p, out, s: out + mech.warmup(s["t"], **p),
          term=lambda series, state: np.exp(-series.t / state["warmup"]["tau_s"]), linear="a",
          search=Search("tau_s", 0.5, 30), time_tied=True, transient=True, draw=_draw_warmup),
    Cause("aging_drift", ("r_per_h",), "output", signature="time_s",
          explain=("The output drifts linearly with time at {r_per_h:.4g} per hour, independent of "
                   "temperature."),
          stage="output", inject=lambda p, out, s: out + mech.aging_drift(s["t"], p["r_per_h"]),
          term=lambda series, state: series.t / 3600.0, linear="r_per_h", time_tied=True,
          draw=_sized("aging_drift", "output", lambda d: d.t / 3600.0)),
    Cause("quadrature_leak", ("c",), "output", signature="quad", needs=("quad",),
          shows=lambda ctx: ctx.series.quad is not None and float(np.ptp(ctx.series.quad)) > 0,
          explain=("The quadrature channel leaks into the rate channel with coefficient c = {c:.4g} "
                   "(a demodulation phase error of about {phase_mrad:.3g} mrad)."),
          explain_extra=lambda p: {"phase_mrad": 1e3 * float(np.arctan(abs(p["c"])))},
          # the demodulator leaks the true quadrature; the logged quad channel adds its own noise
          stage="output", inject=lambda p, out, s: out + p["c"] * s["quad"],
          term=lambda series, state: series.quad, linear="c", time_tied=True, column_uncertain=True,
          draw=_sized("quadrature_leak", "output", lambda d: d.truth["quad"]),
          remedies={"gyro_rtd": _trim_remedy}),
    Cause("sf_nonlinearity", ("k3",), "output", signature="rate_dps", needs=("rate_dps",), shows=_sf_cubic_visible,
          explain=("The scale factor depends on the rate: output = B + S (rate + k3 rate^3) with "
                   "k3 = {k3:.4g} per (rate unit)^2."),
          stage="rate", inject=lambda p, rate, s: rate + p["k3"] * rate ** 3,
          term=lambda series, state: series.sf_estimate * series.rate ** 3, linear="k3",
          draw=_sized("sf_nonlinearity", "output", _sf_cubic_shape)),
    Cause("rtd_nonlinearity", ("b_per_c",), "temp_c", signature="temp_c", needs=("ref_temp_c",),
          shows=lambda ctx: ctx.series.ref is not None,
          explain=("temp_c is curved against the reference thermometer: b = {b_per_c:.4g} /C, i.e. "
                   "a linear RTD law misreads by b (T - 25)^2 (Callendar-Van Dusen curvature)."),
          stage="rtd", inject=lambda p, rtd, s: s["rtd_true"] + mech.rtd_curvature(s["rtd_true"], p["b_per_c"]),
          curvature=_rtd_b_per_c, misreads_thermometer=True, remedies={"gyro_rtd": _cvd_remedy},
          draw=_sized("rtd_nonlinearity", "temp_c", lambda d: (d.truth["ref_temp_c"] - 25.0) ** 2),
          absorbed={"thermometer": "absorbed by the cubic bias polynomial",
                    "gyro_freq": "the chamber thermometer is not in the path"}),
    Cause("frequency_nonlinearity", ("k2_hz_per_c2",), "freq_hz", signature="temp_c", needs=("freq_hz",),
          shows=lambda ctx: ctx.series.freq is not None,
          explain=("The resonant frequency is curved in temperature: k2 = {k2_hz_per_c2:.4g} Hz/C^2 "
                   "on top of f0 + k Te (a turnover)."),
          stage="freq", inject=lambda p, f, s: f + mech.frequency_curvature(s["te"], p["k2_hz_per_c2"]),
          curvature=lambda c, j, sd_y, sc: float(c[j] * sd_y / sc.half ** 2),
          remedies={"gyro_freq": _cubic_remedy},
          draw=_sized("frequency_nonlinearity", "freq_hz", lambda d: (d.truth["Te"] - 25.0) ** 2)),
)

CAUSES: dict[str, Cause] = {c.name: c for c in _RECORDS}
# cause name -> parameter names, in the contract's order and units
PARAMETERS: dict[str, tuple[str, ...]] = {c.name: c.parameters for c in _RECORDS}


def check_records(records) -> None:
    """Every cause but ``none`` is injected by the simulator and fitted by the diagnosis: a record
    that is not fails the import, never a silently ignored ``--effect``."""
    for c in records:
        if c.channel not in CHANNELS:
            raise AssertionError(f"cause {c.name}: channel {c.channel!r} is none of {CHANNELS}")
        if c.name == "none":
            continue
        if c.stage not in STAGES or c.inject is None:
            raise AssertionError(f"cause {c.name}: no simulator stage and injection")
        fitted = ((c.term is not None and c.linear in c.parameters) or (c.curvature is not None and len(c.parameters) == 1)
                  or c.search is not None)
        if not fitted:
            raise AssertionError(f"cause {c.name}: no term the diagnosis fits")
        if c.draw is None:
            raise AssertionError(f"cause {c.name}: no draw for the hidden-cause generator")
        if c.search is not None and c.search.parameter not in c.parameters:
            raise AssertionError(f"cause {c.name}: searched parameter {c.search.parameter!r} is not its own")


check_records(_RECORDS)


def check_parameters(cause: str, parameters: dict[str, float]) -> dict[str, float]:
    """Validate a cause name and its parameters against the contract; return them as floats."""
    if cause not in CAUSES:
        raise InputError(f"cause: unknown name {cause!r}; expected one of {', '.join(CAUSES)}")
    expected = PARAMETERS[cause]
    unknown = sorted(set(parameters) - set(expected))
    if unknown:
        raise InputError(f"{cause}: unknown parameter {unknown[0]!r}; expected {', '.join(expected) or 'none'}")
    missing = [p for p in expected if p not in parameters]
    if missing:
        raise InputError(f"{cause}: missing parameter {missing[0]!r}")
    out = {}
    for name in expected:
        value = float(parameters[name])
        if not np.isfinite(value):
            raise InputError(f"{cause}.{name}: must be a finite number, got {parameters[name]!r}")
        out[name] = value
    return out


def inject(stage: str, value: np.ndarray, causes: dict[str, dict], signals: dict) -> np.ndarray:
    """The simulator's signal of ``stage`` with every cause in ``causes`` that acts there applied, in
    the contract's order."""
    for c in _RECORDS:
        if c.stage == stage and c.name in causes:
            value = c.inject(causes[c.name], value, signals)
    return value
