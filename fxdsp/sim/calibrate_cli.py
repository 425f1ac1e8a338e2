"""``fxdsp calibrate``: fit a paper's compensation from a canonical chamber log (float, no fixed point).

    fxdsp simulate --scenario paper002 --out run.csv
    fxdsp calibrate --paper 002 run.csv --json cal.json

paper 002: piecewise-linear SF(T) and bias(T) on the RTD; paper 001: f(T) and quadratic bias on the
resonator's temperature; paper 000: cubic K0(t), K1(t) from the four-position tumble.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from fxdsp.sim import calibration
from fxdsp.sim.logio import read_log

FITS = {"002": calibration.calibrate_paper002, "001": calibration.calibrate_paper001,
        "000": calibration.calibrate_paper000_log}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", metavar="LOG.csv", help="canonical log (e.g. from fxdsp simulate)")
    parser.add_argument("--paper", required=True, metavar="ID", help=f"which paper's fit: {', '.join(FITS)}")
    parser.add_argument("--json", metavar="OUT.json", help="write the coefficients as JSON (default: stdout)")


def run(args) -> int:
    if args.paper not in FITS:
        raise ValueError(f"--paper: unknown paper {args.paper!r}; expected one of {', '.join(FITS)}")
    log, _ = read_log(args.log)
    result = FITS[args.paper](log)
    text = json.dumps(result, indent=2) + "\n"
    if args.json:
        try:
            Path(args.json).write_text(text, encoding="utf-8")
        except OSError as exc:
            raise ValueError(f"--json: cannot write {args.json}: {exc.strerror or exc}") from None
    else:
        sys.stdout.write(text)
    return 0
