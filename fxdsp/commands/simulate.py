"""``fxdsp simulate``: write a simulated chamber run as a canonical log.

    fxdsp simulate --scenario paper002 --effect thermal_lag.tau_s=3000 --effect hysteresis=0.05 \\
                   --seed 1 --columns ref_temp_c,freq_hz --out run.csv
    fxdsp simulate --scenario ramp --model diagnosed.json --out replay.csv

``--effect CAUSE=VALUE`` is shorthand for a cause with one parameter; causes with several
parameters (warmup) take one ``--effect CAUSE.PARAM=VALUE`` per parameter.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from fxdsp.commands.options import POSITIVE, SEED
from fxdsp.errors import InputError
from fxdsp.causes import PARAMETERS
from fxdsp.outputs import IN, OUT_FILE, staged
from fxdsp.sim.generate import DEFAULT_TIME_STEP_S, OPTIONAL_COLUMNS, SCENARIOS, generate_log, parse_columns
from fxdsp.sim.logio import write_log
from fxdsp.sim.thermal import NODES, ThermalChain


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", required=True, metavar="NAME",
                        help=f"chamber programme and sensor: {', '.join(SCENARIOS)}")
    parser.add_argument("--effect", action="append", default=[], metavar="CAUSE.PARAM=VALUE",
                        help="inject a contract cause (repeatable); CAUSE=VALUE for one-parameter causes")
    parser.add_argument("--seed", type=SEED, default=0, metavar="N", help="random seed (default 0)")
    parser.add_argument("--columns", default=",".join(OPTIONAL_COLUMNS), metavar="A,B",
                        help=f"optional columns to write (default all: {','.join(OPTIONAL_COLUMNS)}; '' for none)")
    parser.add_argument("--model", metavar="M.json", help="replay a model written by fxdsp diagnose")
    parser.add_argument("--time-step", type=POSITIVE, default=DEFAULT_TIME_STEP_S, metavar="S",
                        help=f"sample interval in seconds (default {DEFAULT_TIME_STEP_S:g})")
    parser.add_argument("--duration-scale", type=POSITIVE, default=1.0, metavar="X",
                        help="multiply dwell/hold durations (ramps keep their rate)")
    parser.add_argument("--noise", action="append", default=[], metavar="KEY=VALUE",
                        help="override a noise level (output, temp_c, ref_temp_c, freq_hz, quad, "
                             "bias_instability, rate_random_walk), or 'off'")
    parser.add_argument("--rtd-node", choices=NODES, metavar="NODE",
                        help="enable the air->package->die heat path with the RTD at NODE "
                             f"({', '.join(NODES)}); default: isothermal contract baseline")
    parser.add_argument("--rtd-element", choices=("ideal", "pt_bridge"), default="ideal",
                        help="thermometer: the contract's ideal linear one, or a Pt element (Callendar-Van Dusen) "
                             "in paper 002's bridge read with the linear law")
    parser.add_argument("--drive-loop", metavar="TABLE",
                        help="read freq_hz through the drive loop [TABLE] (drive, drive001 or one of --config), "
                             "bit-exact, closed on the simulated resonance at 96 kS/s: about 70 s per simulated hour")
    parser.add_argument("--config", metavar="CONFIG.toml",
                        help="the config whose drive loop --drive-loop names (default: the built-in one)")
    parser.add_argument("--out", required=True, metavar="LOG.csv", help="output canonical CSV")


def _number(option: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{option}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{option}: {text!r} is not a finite number")
    return value


def parse_effects(specs: list[str]) -> dict[str, dict[str, float]]:
    """``["thermal_lag.tau_s=3000", "hysteresis=0.1"]`` -> ``{cause: {param: value}}``."""
    effects: dict[str, dict[str, float]] = {}
    for spec in specs:
        key, sep, text = spec.partition("=")
        key = key.strip()
        if key == "none" and not sep:
            effects.setdefault("none", {})
            continue
        if not sep:
            raise InputError(f"--effect {spec!r}: expected CAUSE.PARAM=VALUE or CAUSE=VALUE")
        cause, dot, param = key.partition(".")
        if cause not in PARAMETERS:
            raise InputError(f"--effect {spec!r}: unknown cause {cause!r}; expected one of {', '.join(PARAMETERS)}")
        if not dot:
            if len(PARAMETERS[cause]) != 1:
                names = ", ".join(f"{cause}.{p}" for p in PARAMETERS[cause]) or "no parameters"
                raise InputError(f"--effect {spec!r}: {cause} takes {names}; give each as CAUSE.PARAM=VALUE")
            param = PARAMETERS[cause][0]
        if param not in PARAMETERS[cause]:
            raise InputError(f"--effect {spec!r}: unknown parameter {param!r} of {cause}; "
                             f"expected {', '.join(PARAMETERS[cause]) or 'none'}")
        effects.setdefault(cause, {})[param] = _number(f"--effect {cause}.{param}", text)
    return effects


def _noise(specs: list[str]):
    if specs == ["off"]:
        return "off"
    out = {}
    for spec in specs:
        key, sep, text = spec.partition("=")
        if not sep:
            raise InputError(f"--noise {spec!r}: expected KEY=VALUE or 'off'")
        out[key.strip()] = _number(f"--noise {key.strip()}", text)
    return out


PATHS = {"--model": IN, "--config": IN, "--out": OUT_FILE}


def _drive_loop(args):
    """The drive loop --drive-loop names (None without it); --config alone is bad input."""
    if args.drive_loop is None:
        if args.config is not None:
            raise InputError("--config: only read for --drive-loop, which is not given")
        return None
    from fxdsp.blocks.drive import Drive
    from fxdsp.chains import build

    design = build(args.config) if args.config else build()
    name = args.drive_loop.replace(".", "_")
    loops = [n for n, b in design.blocks.items() if isinstance(b, Drive)]
    if name not in loops:
        raise InputError(f"--drive-loop: {args.drive_loop!r} is not a drive loop of "
                         f"{args.config or 'the built-in config'}; its drive loops: {', '.join(loops) or 'none'}")
    if "freq_hz" not in parse_columns(args.columns):
        raise InputError("--drive-loop: the log has no freq_hz column to read through it (--columns)")
    return design.blocks[name]


def run(args) -> int:
    if args.scenario not in SCENARIOS:
        raise InputError(f"--scenario: unknown name {args.scenario!r}; expected one of {', '.join(SCENARIOS)}")
    effects = parse_effects(args.effect)
    thermal = ThermalChain(rtd_node=args.rtd_node) if args.rtd_node else None
    drive = _drive_loop(args)
    log = generate_log(args.scenario, effects=effects, seed=args.seed, columns=args.columns, rtd_element=args.rtd_element,
                       time_step_s=args.time_step,
                       duration_scale=args.duration_scale,
                       noise=_noise(args.noise), model=args.model, thermal=thermal, drive_loop=drive,
                       progress=drive is not None)
    comments = {"generator": "fxdsp simulate", "scenario": args.scenario, "seed": args.seed,
                "effects": json.dumps(effects, sort_keys=True, allow_nan=False)}
    if args.model:
        comments["model"] = Path(args.model).name   # no folder in a written file
    if args.rtd_node:
        comments["thermal"] = f"air->package->die, RTD on {args.rtd_node}"
    if drive is not None:
        comments["freq_hz"] = f"through the drive loop [{drive.name}], bit-exact, closed on the resonance"
    with staged() as stage:  # an interrupted run leaves the previous log whole
        write_log(stage.path(args.out), log, header_comments=comments)
    return 0
