"""``fxdsp extend LOG [--map C=S ...] [--chain auto|NAME] [--config BASE] [--widen]
[--strict] [--no-rtl] --out DIR``

From a measured log to a compensation the FPGA can load, with the proof that it works: diagnose the
log, give every named cause that has one its hardware remedy, calibrate the chain, write the
extended config, its golden vectors, Verilog headers and ROMs, run the cocotb regression on that
config (Icarus), and report the held-out error before/after, with each stage turned off in turn,
the bit-exact status and the hardware cost. DIR is written whole or not at all.

The extended config is the user's design (``--config``, default: the built-in config) with only the
calibrated coefficients and the remedies' keys changed (:mod:`fxdsp.extend.design`): every format,
rounding and overflow rule stays the user's. A format too narrow for a calibrated coefficient or a
remedy is exit 2 naming the field and the width it needs; ``--widen`` widens it instead and lists
each change (field, from, to) in the report. A named cause without a hardware remedy in the chain
(warm-up, hysteresis, ...) no longer stops the others: the report and the summary line state each
such cause uncompensated, with its held-out size in the log's units; ``--strict`` refuses instead
(exit 2 naming it).
Exit status: 0, or 1 when the RTL regression found a mismatch (the report says where).
"""

from __future__ import annotations

import sys
from pathlib import Path

from fxdsp.outputs import IN, OUT_DIR

PATHS = {"log": IN, "--apply": IN, "--config": IN, "--out": OUT_DIR}


def configure(parser) -> None:
    parser.add_argument("log", metavar="LOG", help="log file (canonical CSV, or foreign with --map)")
    parser.add_argument("--map", action="append", default=[], metavar="CANONICAL=SOURCE",
                        help="read canonical column CANONICAL from column SOURCE (repeatable)")
    parser.add_argument("--delimiter", default=",", help="field delimiter (default ','; '\\t' for tab)")
    parser.add_argument("--time-format", default=None, metavar="F", help="strptime format of the time column")
    parser.add_argument("--chain", default="auto", metavar="NAME",
                        help="compensation chain: a chain of the config (paper002 for [chain.paper002]; its "
                             "calibration follows its sensor: gyro_rtd from rate-table steps, gyro_freq from the "
                             "resonator's frequency, none: a reading minus a bias polynomial of a temperature word), "
                             "thermometer (the config's, else one extend writes), or auto (the first gyro_rtd chain "
                             "when the log has rate-table steps in rate_dps, else the first gyro_freq chain when it "
                             "has freq_hz, else thermometer)")
    parser.add_argument("--config", default=None, metavar="BASE.toml", help="base config (default: built-in)")
    parser.add_argument("--apply", metavar="LOG2",
                        help="run the compensation fitted on LOG on a second run's log (same --map); its "
                             "before/after error joins the report")
    parser.add_argument("--widen", action="store_true",
                        help="widen a format of --config that a calibrated coefficient or a remedy does not fit "
                             "(same fraction bits, more integer bits; each change listed in the report) instead of "
                             "exit 2")
    parser.add_argument("--strict", action="store_true",
                        help="exit 2 when a named cause has no hardware remedy in the chain (default: apply the "
                             "remedies there are and report the rest uncompensated, with their held-out size)")
    parser.add_argument("--no-rtl", action="store_true", help="skip the cocotb regression (no simulator needed)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder (replaced whole)")


def run(args) -> int:
    from fxdsp.logfile import parse_mapping, read_log, saying_why_columns_are_missing
    from fxdsp.errors import InputError
    from fxdsp.extend.pipeline import extend_log
    from fxdsp.outputs import staged

    delimiter = {"\\t": "\t", "tab": "\t"}.get(args.delimiter, args.delimiter)
    if len(delimiter) != 1:
        raise InputError(f"--delimiter {args.delimiter!r}: expected one character")
    base_text = Path(args.config).read_text(encoding="utf-8") if args.config else None
    result = extend_log(args.log, parse_mapping(args.map), delimiter, args.time_format, args.chain, base_text,
                        rtl=not args.no_rtl, widen=args.widen, strict=args.strict,
                        base_name=f"--config {args.config}" if args.config else None)
    if args.apply:
        second = read_log(args.apply, parse_mapping(args.map), delimiter, args.time_format)
        with saying_why_columns_are_missing(second):
            result.apply(second.columns, Path(args.apply).name, second.notes)
    with staged() as stage:
        result.write(stage.dir(args.out))
    rep = result.report
    s, reg = rep["summary"], rep.get("regression")
    status = "not run" if reg is None else ("bit-exact" if reg["passed"] else "MISMATCH")
    left = "".join(f"; {u['cause']} uncompensated (held-out {u['heldout_size']:.3g} {u['unit']})"
                   for u in rep["uncompensated"])
    changes = rep["design"]["changes"]
    sys.stdout.write(f"extend: {rep['chain']} chain, causes {','.join(rep['diagnosis']['causes'])}"
                     f", remedies {','.join(r['stage'] for r in rep['remedies']) or 'none'}{left}; held-out rms "
                     f"{s['rms_before']:.4g} -> {s['rms_after']:.4g} (gain {s['gain']:.3g}); "
                     + (f"applied to {rep['applied']['log']}: gain {rep['applied']['gain']:.3g}; " if args.apply else "")
                     + (f"{len(changes)} format change(s) to the base config, listed in the report; " if changes else "")
                     + f"RTL {status}; report {Path(args.out) / 'report.md'}\n")
    return 0 if reg is None or reg["passed"] else 1
