"""`fxdsp diagnose-bench [--rows N ...]`: seconds to diagnose simulated logs of N rows, file to report
(a benchmark, not a test; see :mod:`fxdsp.diagnose.bench`)."""

from __future__ import annotations

import tempfile
from pathlib import Path
from fxdsp.commands.options import count

WARM_UP_ROWS = 500


def configure(parser) -> None:
    parser.add_argument("--rows", type=count(WARM_UP_ROWS), nargs="+", default=[6000, 1_000_000], metavar="N",
                        help="rows of each simulated log (default: 6000 1000000)")


def run(args) -> int:
    from fxdsp.diagnose.bench import bench

    with tempfile.TemporaryDirectory() as tmp:
        bench(WARM_UP_ROWS, Path(tmp))  # numba's cache and the imports, out of the timings
        for rows in args.rows:
            seconds, n, data = bench(rows, Path(tmp))
            print(f"{int(n):>9d} rows: {seconds:7.2f} s  -> {data['cause']} {data['parameters']} "
                  f"gain {data['gain']['ratio']:.2f}")
    return 0
