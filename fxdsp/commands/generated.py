"""Reporting of the commands that write committed generated files (``vectors``, ``hdl-gen``).

The library (:func:`fxdsp.vectors.write_or_check`) writes or compares and returns the differences;
this is the command-line side of it: what is printed and the exit status (1 on any ``--check``
difference, as documented in the README).
"""

from __future__ import annotations

import sys
from pathlib import Path

from fxdsp.vectors import write_or_check

MAX_LISTED = 20  # a regenerated directory can differ everywhere: the first few say enough


def sync_generated(files: dict[str, str], out: Path, check_only: bool, command: str,
                   patterns: tuple[str, ...] = ("**/*.hex",)) -> int:
    """Write ``files`` to ``out`` (or ``--check`` them against it), print the outcome, return the
    exit status."""
    problems = write_or_check(files, out, check_only, patterns)
    if problems:
        for problem in problems[:MAX_LISTED]:
            print(problem, file=sys.stderr)
        print(f"fxdsp {command}: {len(problems)} difference(s) against {out}", file=sys.stderr)
        return 1
    print(f"{out}: {len(files)} files match the config" if check_only else f"wrote {len(files)} files to {out}")
    return 0
