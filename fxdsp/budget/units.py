"""Targets like ``10deg/h``, ``0.5mC``, ``1mg``, ``0.25xnoise`` or ``25%noise``: parsed into (value
in the port's physical unit, port) for a chain, the port found by its unit."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from fxdsp.chains import Design
from fxdsp.float_vs_fixed import port_units
from fxdsp.errors import InputError

_TARGET_RE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(\S+)\s*$")

# unit families: a target unit -> (the port unit it is read against, factor to that unit)
FAMILIES = {"deg/h": {"deg/h": 1.0, "dph": 1.0, "deg/s": 3600.0, "dps": 3600.0},
            "C": {"C": 1.0, "degC": 1.0, "mC": 1e-3},
            "mg": {"mg": 1.0, "g": 1e3, "ug": 1e-3},
            "ppm": {"ppm": 1.0},
            "Hz": {"Hz": 1.0, "mHz": 1e-3}}
NOISE_UNITS = {"xnoise": 1.0, "%noise": 0.01}
UNITS = [u for f in FAMILIES.values() for u in f] + ["FS", *NOISE_UNITS]


@dataclass
class Target:
    text: str
    value: float      # in the port's physical unit
    port: str
    unit: str         # physical unit of value
    chain: str


def _port(option: str, chain: str, ports: list[str], what: str) -> str:
    if len(ports) != 1:
        found = f"its outputs {', '.join(ports)} all are" if ports else "none of its outputs is"
        raise InputError(f"{option}: a target in {what} needs one such output of {chain}; {found}")
    return ports[0]


def parse_target(text: str, design: Design, chain: str, sensor_noise: dict[str, float] | None = None,
                 option: str = "--target") -> Target:
    """ValueError naming ``option`` on a bad number, an unknown unit or a unit no output of the chain
    has. The port is the chain output in the unit's family (deg/h, C, mg, ppm, Hz); ``FS``: the
    output whose stored value is a fraction of the rate full scale; ``xnoise`` / ``%noise``: the
    output with sensor noise (``sensor_noise``: port -> rms in its unit)."""
    m = _TARGET_RE.match(text or "")
    if not m:
        raise InputError(f"{option}: {text!r} is not <value><unit> (e.g. 10deg/h, 5mC, 0.25xnoise)")
    value, unit = float(m.group(1)), m.group(2)
    if not np.isfinite(value) or value <= 0:
        raise InputError(f"{option}: the value must be a positive number, got {m.group(1)}")
    units = {p: u for (c, p), u in port_units(design).items() if c == chain and p in design.chains[chain].outputs}
    for family, factors in FAMILIES.items():
        if unit in factors:
            port = _port(option, chain, [p for p, (u, _) in units.items() if u == family], family)
            return Target(text, value * factors[unit], port, family, chain)
    if unit == "FS":
        fs = design.rate_full_scale_dps * 3600.0
        port = _port(option, chain, [p for p, (u, k) in units.items() if u == "deg/h" and k == fs],
                     "FS (the rate full scale)")
        return Target(text, value * fs, port, "deg/h", chain)
    if unit in NOISE_UNITS:
        noisy = {p: n for p, n in (sensor_noise or {}).items() if n}
        if not noisy:
            raise InputError(f"{option}: {chain} has no sensor noise on its outputs to take a fraction of")
        port = _port(option, chain, list(noisy), "noise")
        return Target(text, value * NOISE_UNITS[unit] * noisy[port], port, units.get(port, ("", 1.0))[0], chain)
    raise InputError(f"{option}: unknown unit {unit!r} in {text!r}; expected one of {', '.join(UNITS)}")
