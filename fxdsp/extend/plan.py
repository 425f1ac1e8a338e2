"""Which named cause the FPGA can remedy, and how, per calibration procedure (the chain's sensor,
:mod:`fxdsp.extend.roles`).

A remedy changes the compensation hardware, never the sensor: a lag filter on the temperature code
before the coefficient engines (``thermal_lag``), a phase trim of the demodulator's reference
(``quadrature_leak``), a Callendar-Van Dusen RTD table (``rtd_nonlinearity``: the element's
curvature, read with the linear law), a higher polynomial order (``frequency_nonlinearity`` in
a ``gyro_freq`` chain: a resonator that turns over bends its linear frequency thermometer).
A cause with no remedy in the chosen chain (hysteresis, ramp rate, aging, warm-up, a rate-cubic SF
non-linearity, ...) does not stop the others: :func:`plan` returns the remedies it has and the
causes it leaves uncompensated, and the report states each of those with its held-out size in the
log's units (:func:`fxdsp.extend.evaluate.uncompensated_sizes`), so the config never silently leaves
an error in. ``strict`` (``fxdsp extend --strict``) keeps the refusal: an InputError (exit 2)
naming the causes that have none. A cause the chain absorbs (:data:`ABSORBED`) needs nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

from fxdsp.errors import InputError


@dataclass(frozen=True)
class Remedy:
    cause: str
    stage: str          # "lag", "trim", "order": the name the report and the ablation use
    what: str           # one line for the report
    parameters: dict


def _lag(diag) -> Remedy:
    tau = float(diag.parameters["thermal_lag"]["tau_s"])
    return Remedy("thermal_lag", "lag", f"lag filter (tau {tau:.4g} s) on the temperature code before the "
                  "coefficient engines", {"tau_s": tau})


def _trim(diag) -> Remedy:
    import math

    c = float(diag.parameters["quadrature_leak"]["c"])
    return Remedy("quadrature_leak", "trim", f"demodulation phase trim {-math.atan(c):+.5f} rad (-atan c, "
                  f"c = {c:.4g})", {"c": c, "phase_trim_rad": -math.atan(c)})


def _cubic(diag) -> Remedy:
    k2 = float(diag.parameters["frequency_nonlinearity"]["k2_hz_per_c2"])
    return Remedy("frequency_nonlinearity", "order", f"cubic instead of quadratic bias in the frequency's temperature "
                  f"(the resonator turns over, k2 = {k2:.3g} Hz/C^2, bending the linear f -> T read-out)",
                  {"bias_order": 3})


def _cvd(diag) -> Remedy:
    b = float(diag.parameters["rtd_nonlinearity"]["b_per_c"])
    return Remedy("rtd_nonlinearity", "cvd", f"Callendar-Van Dusen RTD table (B/A = {b:.3g} /C: the element's "
                  "curvature, read linearly until now)", {"b_per_c": b})


# procedure -> cause -> remedy builder; "none" needs none
REMEDIES = {
    "gyro_rtd": {"thermal_lag": _lag, "quadrature_leak": _trim, "rtd_nonlinearity": _cvd},
    "gyro_freq": {"frequency_nonlinearity": _cubic},
    # the thermometer chain's bias polynomial is already a cubic: a curved readout needs nothing more
    "thermometer": {"thermal_lag": _lag},
}
ABSORBED = {"thermometer": {"rtd_nonlinearity": "absorbed by the cubic bias polynomial"},
            # the resonator is its own thermometer: the chamber thermometer's lag and curvature do not
            # reach a compensation driven by freq_hz
            "gyro_freq": {"thermal_lag": "the resonant frequency reads the die itself",
                         "rtd_nonlinearity": "the chamber thermometer is not in the path"}}


def parameter(remedies, stage: str, key: str):
    """A parameter of the remedy of ``stage`` (None when no remedy has that stage)."""
    return next((r.parameters[key] for r in remedies if r.stage == stage), None)


def plan(diag, roles, strict: bool = False) -> tuple[list[Remedy], list[tuple[str, str]]]:
    """(the remedies of every named cause that has one in the chain of ``roles``
    (:class:`fxdsp.extend.roles.Roles`), in the diagnosis's order; the named causes left
    uncompensated, as (cause, reason)). ``strict``: InputError (exit 2) naming the causes that have
    no remedy instead."""
    table, absorbed = REMEDIES[roles.procedure], ABSORBED.get(roles.procedure, {})
    where = f"the {roles.chain} chain ({roles.procedure} calibration)"
    missing = [c for c in diag.causes if c not in table and c not in absorbed and c != "none"]
    if missing and strict:
        raise InputError(f"extend: {', '.join(missing)} {'has' if len(missing) == 1 else 'have'} no hardware "
                         f"remedy in {where} (remedies: {', '.join(sorted(table))}); "
                         f"diagnosed causes: {', '.join(diag.causes)} (--strict)")
    reason = f"no hardware remedy in {where} (remedies: {', '.join(sorted(table))})"
    return [table[c](diag) for c in diag.causes if c in table], [(c, reason) for c in missing]
