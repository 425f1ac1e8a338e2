"""Targets like ``10deg/h``, ``0.5mC``, ``0.25xnoise`` or ``25%noise``: parsed into (value in the
port's physical unit, port) for a chain."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..chains import Design

_TARGET_RE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(\S+)\s*$")

# unit -> (port kind, factor to the port's table unit (deg/h for rates, C for temperatures))
RATE_UNITS = {"deg/h": 1.0, "dph": 1.0, "deg/s": 3600.0, "dps": 3600.0}
TEMP_UNITS = {"C": 1.0, "degC": 1.0, "mC": 1e-3}
NOISE_UNITS = {"xnoise": 1.0, "%noise": 0.01}
UNITS = [*RATE_UNITS, "FS", *TEMP_UNITS, *NOISE_UNITS]


@dataclass
class Target:
    text: str
    value: float      # in the port's physical unit (deg/h or C)
    port: str
    unit: str         # physical unit of value
    chain: str


def parse_target(text: str, design: Design, chain: str, sensor_noise: dict[str, float] | None = None,
                 option: str = "--target") -> Target:
    """ValueError naming ``option`` on a bad number, an unknown unit or a unit the chain lacks."""
    m = _TARGET_RE.match(text or "")
    if not m:
        raise ValueError(f"{option}: {text!r} is not <value><unit> (e.g. 10deg/h, 5mC, 0.25xnoise)")
    value, unit = float(m.group(1)), m.group(2)
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{option}: the value must be a positive number, got {m.group(1)}")
    if unit in RATE_UNITS:
        return Target(text, value * RATE_UNITS[unit], "rate", "deg/h", chain)
    if unit == "FS":
        if chain != "chain_paper002":
            raise ValueError(f"{option}: unit 'FS' applies to chain_paper002 only, not {chain}")
        return Target(text, value * design.rate_full_scale_dps * 3600.0, "rate", "deg/h", chain)
    if unit in TEMP_UNITS:
        return Target(text, value * TEMP_UNITS[unit], "temp", "C", chain)
    if unit in NOISE_UNITS:
        noise = (sensor_noise or {}).get("rate", 0.0)
        if not noise:
            raise ValueError(f"{option}: {chain} has no sensor noise on its rate output to take a fraction of")
        return Target(text, value * NOISE_UNITS[unit] * noise, "rate", "deg/h", chain)
    raise ValueError(f"{option}: unknown unit {unit!r} in {text!r}; expected one of {', '.join(UNITS)}")
