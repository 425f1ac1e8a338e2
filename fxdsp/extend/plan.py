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
naming the causes that have none. A cause the chain absorbs (:func:`absorbed`) needs nothing. The remedies are part of each cause's
record (:mod:`fxdsp.causes`).
"""

from __future__ import annotations

from fxdsp.causes import CAUSES, Remedy  # noqa: F401 - Remedy: the type plan() returns
from fxdsp.errors import InputError


def remedies(procedure: str) -> dict:
    """cause -> remedy builder (from the cause's fitted parameters) of a calibration procedure."""
    return {c.name: c.remedies[procedure] for c in CAUSES.values() if procedure in c.remedies}


def absorbed(procedure: str) -> dict[str, str]:
    """cause -> why a procedure's chain needs no remedy for it."""
    return {c.name: c.absorbed[procedure] for c in CAUSES.values() if procedure in c.absorbed}


def parameter(remedies, stage: str, key: str):
    """A parameter of the remedy of ``stage`` (None when no remedy has that stage)."""
    return next((r.parameters[key] for r in remedies if r.stage == stage), None)


def plan(diag, roles, strict: bool = False) -> tuple[list[Remedy], list[tuple[str, str]]]:
    """(the remedies of every named cause that has one in the chain of ``roles``
    (:class:`fxdsp.extend.roles.Roles`), in the diagnosis's order; the named causes left
    uncompensated, as (cause, reason)). ``strict``: InputError (exit 2) naming the causes that have
    no remedy instead."""
    table, absorbed_ = remedies(roles.procedure), absorbed(roles.procedure)
    where = f"the {roles.chain} chain ({roles.procedure} calibration)"
    missing = [c for c in diag.causes if c not in table and c not in absorbed_ and c != "none"]
    if missing and strict:
        raise InputError(f"extend: {', '.join(missing)} {'has' if len(missing) == 1 else 'have'} no hardware "
                         f"remedy in {where} (remedies: {', '.join(sorted(table))}); "
                         f"diagnosed causes: {', '.join(diag.causes)} (--strict)")
    reason = f"no hardware remedy in {where} (remedies: {', '.join(sorted(table))})"
    return [table[c](diag.parameters[c]) for c in diag.causes if c in table], [(c, reason) for c in missing]
