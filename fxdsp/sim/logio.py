"""Writing (and, for the bench's own use, reading) canonical logs (shared/spec/measured-data.md §1).

The file is comma separated, UTF-8, one header row, optional ``#`` comment lines before it. Columns
are written in the contract's order: time_s, temp_c, output, then the optional ones present. Numbers
use 12 significant digits: enough for a 38 kHz beam frequency to 1e-7 Hz, far below any noise.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from fxdsp.logfile import CANONICAL, read_log as read_contract, REQUIRED as REQUIRED_COLUMNS
from fxdsp.errors import InputError


def _comment_lines(header_comments) -> list[str]:
    if not header_comments:
        return []
    items = header_comments.items() if isinstance(header_comments, dict) else ((None, c) for c in header_comments)
    lines = []
    for key, value in items:
        text = f"{key}: {value}" if key is not None else str(value)
        lines.extend(f"# {part}" for part in text.splitlines() or [""])
    return lines


def write_log(path, log: dict, header_comments: dict | list | None = None) -> None:
    """Write ``log`` (column -> 1-D array) as a canonical CSV, with ``# key: value`` comment lines."""
    missing = [c for c in REQUIRED_COLUMNS if c not in log]
    if missing:
        raise InputError(f"log: missing required column {missing[0]!r}")
    unknown = [c for c in log if c not in CANONICAL]
    if unknown:
        raise InputError(f"log: {unknown[0]!r} is not a canonical column ({', '.join(CANONICAL)})")
    names = [c for c in CANONICAL if c in log]
    data = np.column_stack([np.asarray(log[c], float) for c in names])
    if data.ndim != 2 or any(np.asarray(log[c]).shape != (data.shape[0],) for c in names):
        raise InputError("log: all columns must be 1-D arrays of the same length")
    buffer = io.StringIO()
    for line in _comment_lines(header_comments):
        buffer.write(line + "\n")
    buffer.write(",".join(names) + "\n")
    np.savetxt(buffer, data, fmt="%.12g", delimiter=",")
    Path(path).write_text(buffer.getvalue(), encoding="utf-8")  # an OSError names the file (the CLI reports it)


def read_log(path) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """(columns, header comments as key -> value) of a canonical log. The columns come from the one
    reader of the contract (:func:`fxdsp.logfile.read_log`: unusable rows dropped, duplicate
    or missing columns and a flat output refused); the ``# key: value`` lines are this writer's."""
    columns = read_contract(path).columns
    comments = {}
    with open(path, encoding="utf-8-sig") as handle:
        for line in handle:
            if not line.startswith("#"):
                break
            key, sep, value = line[1:].strip().partition(":")
            if sep:
                comments[key.strip()] = value.strip()
    return dict(columns), comments
