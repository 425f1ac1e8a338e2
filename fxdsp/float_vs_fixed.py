"""Float vs fixed differences of every block and chain, in LSBs and in physical units.

The physical unit of each port comes from the design (:mod:`fxdsp.units`, propagated through the
chains): temperatures in C, rates in deg/h (a signal of the paper 002 chain is a fraction of full
scale; full scale is ``[system].rate_full_scale_dps``), scale factors in ppm, phases in mrad, QVBA K0
in Hz and K1 in Hz/g.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxdsp.chains import Design, stream_key



def angle_ports(design: Design) -> set[tuple[str, str]]:
    """(instance, port) of every port whose value is an angle (fxdsp.units quantity ``rad``): its
    error is taken modulo a turn."""
    return {(name, p.name) for name, inst in design.instances.items() for p in inst.outputs if p.quantity == "rad"}


def port_units(design: Design) -> dict[tuple[str, str], tuple[str, float]]:
    """(instance, port) -> (unit, value-to-unit factor), from the design's instance table."""
    return {(name, p.name): (p.unit, p.scale) for name, inst in design.instances.items()
            for p in (*inst.inputs, *inst.outputs) if p.unit}


def port_unit(design: Design, instance: str, port: str) -> tuple[str, float]:
    """(unit, value-to-unit factor) of one instance port; ("", 1.0) for a port without a unit."""
    return port_units(design).get((instance, port), ("", 1.0))


@dataclass
class ErrorStats:
    block: str
    port: str
    samples: int
    lsb: float
    max_abs: float
    rms: float
    mean: float
    unit: str
    scale: float
    overflows: int
    signal_rms: float = 0.0  # rms of the float reference on the same stimulus (for SNR)

    @property
    def max_lsb(self) -> float:
        return self.max_abs / self.lsb

    @property
    def rms_lsb(self) -> float:
        return self.rms / self.lsb


def block_errors(design: Design, name: str, samples: int | None = None, seed_offset: int = 1000) -> list[ErrorStats]:
    """Run one block's nominal stimulus through the bit-exact model and the float reference."""
    block = design.all[name]
    rng = np.random.default_rng([design.seed, seed_offset, stream_key(name)])
    stim = block.nominal_stimulus(rng, samples or design.samples)
    result = block.run(**stim)
    ref = block.run_float(**stim)
    got = block.real_outputs(result)
    units = port_units(design)
    out = []
    for port, fmt in block.outputs.items():
        r = np.asarray(ref[port], dtype=float)
        r = r[np.isfinite(r)]
        signal_rms = float(np.sqrt(np.mean(r**2))) if r.size else 0.0
        e = got[port] - ref[port]
        keep = np.isfinite(e)
        if (name, port) in angle_ports(design):
            e = (e + np.pi) % (2 * np.pi) - np.pi
            # a phase is only defined where there is an amplitude to measure it on
            keep &= ref["amp"] > 0.05 * np.nanmax(ref["amp"])
        e = e[keep]
        unit, scale = units.get((name, port), ("", 1.0))
        out.append(ErrorStats(name, port, int(e.size), fmt.lsb, float(np.abs(e).max()), float(np.sqrt(np.mean(e**2))),
                              float(e.mean()), unit, scale, result.overflows.total, signal_rms))
    return out


def all_errors(design: Design, samples: int | None = None) -> list[ErrorStats]:
    rows = []
    for name in design.all:
        rows.extend(block_errors(design, name, samples))
    return rows


def format_table(rows: list[ErrorStats]) -> str:
    head = f"{'block.port':28s} {'n':>6s} {'max|e| LSB':>11s} {'rms LSB':>9s} {'max|e|':>11s} {'rms':>10s} {'mean':>11s} unit    ovf"
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(f"{r.block + '.' + r.port:28s} {r.samples:6d} {r.max_lsb:11.2f} {r.rms_lsb:9.2f} "
                     f"{r.max_abs * r.scale:11.4g} {r.rms * r.scale:10.3g} {r.mean * r.scale:11.3g} {r.unit:7s} {r.overflows:3d}")
    return "\n".join(lines)
