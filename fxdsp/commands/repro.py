"""``fxdsp repro``: run the papers' reproductions and optionally write the report.

    fxdsp repro                          # all four, summary table on stdout
    fxdsp repro --paper 003 --sweep-points 15
    fxdsp repro --paper all --report docs   # docs/REPRODUCTIONS.md + docs/img/*.png

A sub-command module of :mod:`fxdsp.cli`: ``configure(subparser)`` and ``run(args) -> int``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fxdsp.commands.options import count
from fxdsp.errors import InputError
from fxdsp.outputs import OUT_DIR, staged

CHOICES = ("002", "001", "000", "003", "all")

PATHS = {"--report": OUT_DIR}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--paper", default="all", metavar="ID",
                        help=f"which reproduction: {', '.join(CHOICES)} (default all)")
    parser.add_argument("--report", metavar="DIR", help="write DIR/REPRODUCTIONS.md and DIR/img/*.png")
    parser.add_argument("--sweep-points", type=count(3), default=41, metavar="N",
                        help="paper 003 sweep frequencies (default 41)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--drive-loop", action="store_true",
                        help="paper 001: read every log's frequency through the bit-exact drive loop [drive001] "
                             "closed on the simulated resonator at 96 kS/s, as the paper's instrument does, "
                             "instead of the resonance plus white noise (about 45 min: 26 simulated hours)")


def run(args) -> int:
    from fxdsp.repro.report import PAPERS, read_parts, run_all, summary_rows, write_report

    if args.paper not in CHOICES:
        raise InputError(f"--paper: unknown paper {args.paper!r}; expected one of {', '.join(CHOICES)}")
    papers = PAPERS if args.paper == "all" else (args.paper,)
    loop = None
    if args.drive_loop:
        if "001" not in papers:
            raise InputError(f"--drive-loop: reads paper 001's frequency; --paper {args.paper} does not run it")
        from fxdsp.chains import build

        loop = build(chains=False).blocks["drive001"]
    res = run_all(papers, n_freqs=args.sweep_points, progress=not args.quiet, drive_loop=loop)
    rows = summary_rows(res)
    w = [max(len(r[i]) for r in rows) for i in range(4)]
    head = ("paper", "figure", "paper's", "reproduced")
    w = [max(a, len(b)) for a, b in zip(w, head)]
    for r in (head, *rows):
        sys.stdout.write("  ".join(c.ljust(n) for c, n in zip(r, w)).rstrip() + "\n")
    sys.stdout.write(f"({sum(r.get('seconds', 0) for r in res.values()):.1f} s of reproductions)\n")
    if args.report:
        cmd = "fxdsp repro --paper all --report " + args.report if args.paper == "all" else \
            f"fxdsp repro --paper {args.paper} --report {args.report}"
        cmd += " --drive-loop" if args.drive_loop else ""
        with staged() as stage:
            # the papers not run now keep their part of the report (read from the report's folder)
            previous = read_parts(args.report)
            path = Path(args.report) / write_report(res, stage.dir(args.report), command=cmd, previous=previous).name
        sys.stdout.write(f"report: {path}\n")
    return 0
