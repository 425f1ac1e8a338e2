"""`fxdsp diagnose LOG [--map ...] [--delimiter D] [--time-format F] --json REPORT.json [--report DIR]
[--model-out M.json]`: name the cause(s) where a measured log disagrees with the baseline model."""

from __future__ import annotations

import json
import sys

from fxdsp.outputs import IN, OUT_DIR, OUT_FILE

PATHS = {"log": IN, "--json": OUT_FILE, "--report": OUT_DIR, "--model-out": OUT_FILE}


def configure(parser) -> None:
    parser.add_argument("log", metavar="LOG", help="log file (canonical CSV, or foreign with --map)")
    parser.add_argument("--map", action="append", default=[], metavar="CANONICAL=SOURCE",
                        help="read canonical column CANONICAL from column SOURCE (repeatable), "
                             "e.g. --map temp_c=box_temp")
    parser.add_argument("--delimiter", default=",", help="field delimiter (default ','; '\\t' for tab)")
    parser.add_argument("--time-format", default=None, metavar="F",
                        help="strptime format of the time column, e.g. '%%d/%%m/%%Y-%%H:%%M:%%S' "
                             "(times become seconds since the first row)")
    parser.add_argument("--json", metavar="REPORT.json", default=None,
                        help="write the machine-readable report here (default: print it)")
    parser.add_argument("--report", metavar="DIR", default=None, help="write report.md and PNG plots here")
    parser.add_argument("--model-out", metavar="M.json", default=None,
                        help="write the fitted extended model in the simulator's replay format")


def run(args) -> int:
    from fxdsp.diagnose.api import diagnose_file
    from fxdsp.logfile import parse_mapping
    from fxdsp.diagnose.report import replay_model, report_dict, write_json, write_report
    from fxdsp.errors import InputError

    delimiter = {"\\t": "\t", "tab": "\t"}.get(args.delimiter, args.delimiter)
    if len(delimiter) != 1:
        raise InputError(f"--delimiter {args.delimiter!r}: expected one character")
    diag = diagnose_file(args.log, parse_mapping(args.map), delimiter, args.time_format)
    data = report_dict(diag)
    from fxdsp.outputs import staged

    with staged() as stage:  # all or nothing: a late error leaves no report without its model
        if args.json:
            write_json(stage.path(args.json), data)
        if args.report:
            write_report(diag, stage.dir(args.report))
        if args.model_out:
            write_json(stage.path(args.model_out), replay_model(diag))
    if not args.json:
        print(json.dumps(data, indent=2, allow_nan=False))
    g = data["gain"]
    print(f"cause: {data['cause']}  causes: {','.join(data['causes']) or 'none'}  "
          f"parameters: {json.dumps(data['parameters'])}  held-out gain ({g['channel']}): {g['ratio']:.2f}  "
          f"rows used {data['rows']['used']}, dropped {data['rows']['dropped']}", file=sys.stderr if not args.json else sys.stdout)
    return 0
