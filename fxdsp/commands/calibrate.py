"""``fxdsp calibrate``: fit a paper's compensation from a canonical chamber log.

    fxdsp simulate --scenario paper002 --out run.csv
    fxdsp calibrate --paper 002 run.csv --json cal.json
    fxdsp calibrate --paper 002 run.csv --config-out cal.toml --apply run2.csv

paper 002: piecewise-linear SF(T) and bias(T) on the RTD; paper 001: f(T) and quadratic bias on the
resonator's temperature; paper 000: cubic K0(t), K1(t) from the four-position tumble.

``--config-out F`` quantises the fit into a TOML config (a copy of the default with the calibrated
tables, see :mod:`fxdsp.repro.calconfig`; paper 001's thermometer is checked bit-exactly against the
calibration reference first). ``--apply LOG2`` runs the bit-exact compensation with that config on a
second run's log and adds its figures to the output under ``"apply"``. ``--config BASE`` writes the
calibration into BASE instead of the built-in config; for paper 002 an extended config (``fxdsp
extend``: lag stage, phase trim) keeps its stages, is calibrated with them in place and applied
through them: fit on run 1, apply on run 2, for extended configs too.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fxdsp.commands.options import Number
from fxdsp.outputs import IN, OUT_FILE, json_text, staged
from fxdsp.sim import calibration
from fxdsp.logfile import read_log, saying_why_columns_are_missing
from fxdsp.errors import InputError

FITS = {"002": calibration.calibrate_paper002, "001": calibration.calibrate_paper001,
        "000": calibration.calibrate_paper000_log}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", metavar="LOG.csv", help="canonical log (e.g. from fxdsp simulate)")
    parser.add_argument("--paper", required=True, metavar="ID", help=f"which paper's fit: {', '.join(FITS)}")
    parser.add_argument("--json", metavar="OUT.json", help="write the coefficients as JSON (default: stdout)")
    parser.add_argument("--config-out", metavar="F.toml", help="write the calibrated, quantised TOML config")
    parser.add_argument("--apply", metavar="LOG2.csv",
                        help="compensate a second run's log bit-exactly with the calibrated config")
    parser.add_argument("--config", metavar="BASE.toml",
                        help="write the calibration into this config instead of the built-in one; paper 002: an "
                             "extended config (fxdsp extend) keeps its lag / phase trim, is calibrated with them "
                             "in place, and --apply runs them")
    parser.add_argument("--order", type=Number(int, 1, 3), default=1, metavar="N",
                        help="paper 002: polynomial order per segment for the config (1 = the paper's, 2)")


PATHS = {"log": IN, "--apply": IN, "--config": IN, "--json": OUT_FILE, "--config-out": OUT_FILE}
# the base config and the order shape the calibrated config, written or applied (fxdsp.cli refuses them
# on a run that does neither, rather than ignore them)
ONLY_WITH = {"--config": ("--config-out", "--apply"), "--order": ("--config-out", "--apply")}


def run(args) -> int:
    with staged() as stage:  # the config and the JSON land together, or neither does
        return _run(args, stage)


def _run(args, stage) -> int:
    if args.paper not in FITS:
        raise InputError(f"--paper: unknown paper {args.paper!r}; expected one of {', '.join(FITS)}")
    read = read_log(args.log)   # the contract's reader: bad rows dropped, bad logs refused
    log = read.columns
    with saying_why_columns_are_missing(read):
        result = FITS[args.paper](log)
    if read.notes:   # what the reader set aside (a column ignored) is said, not silently fitted around
        result["notes"] = list(read.notes)
    if args.config_out or args.apply:
        from fxdsp.repro.apply import apply_config, calibrated_config

        base = Path(args.config).read_text(encoding="utf-8") if args.config else None
        text, cal = calibrated_config(args.paper, log, args.order, base)
        # file names only: the same run gives the same JSON wherever its files lie
        result["config"] = {"path": Path(args.config_out).name if args.config_out else None, "order": args.order}
        if cal.get("stages"):
            result["config"]["stages"] = cal["stages"]
        if "thermometer_check" in cal:
            result["config"]["thermometer_check"] = cal["thermometer_check"]
        if args.config_out:
            stage.write_text(args.config_out, text)
        if args.apply:
            second = read_log(args.apply)
            with saying_why_columns_are_missing(second):
                result["apply"] = {"log": Path(args.apply).name, **apply_config(args.paper, text, second.columns)}
    text = json_text(result, "--json" if args.json else "calibrate", indent=2)
    if args.json:
        stage.write_text(args.json, text)
        if "apply" in result:
            for key, value in result["apply"].items():
                sys.stdout.write(f"{key}: {value}\n")
    else:
        sys.stdout.write(text)
    return 0
