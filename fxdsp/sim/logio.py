"""Writing (and, for the bench's own use, reading) canonical logs (shared/spec/measured-data.md §1).

The file is comma separated, UTF-8, one header row, optional ``#`` comment lines before it. Columns
are written in the contract's order: time_s, temp_c, output, then the optional ones present. Numbers
use 12 significant digits: enough for a 38 kHz beam frequency to 1e-7 Hz, far below any noise.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from fxdsp.sim.generate import OPTIONAL_COLUMNS, REQUIRED_COLUMNS

CANONICAL = REQUIRED_COLUMNS + OPTIONAL_COLUMNS


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
        raise ValueError(f"log: missing required column {missing[0]!r}")
    unknown = [c for c in log if c not in CANONICAL]
    if unknown:
        raise ValueError(f"log: {unknown[0]!r} is not a canonical column ({', '.join(CANONICAL)})")
    names = [c for c in CANONICAL if c in log]
    data = np.column_stack([np.asarray(log[c], float) for c in names])
    if data.ndim != 2 or any(np.asarray(log[c]).shape != (data.shape[0],) for c in names):
        raise ValueError("log: all columns must be 1-D arrays of the same length")
    buffer = io.StringIO()
    for line in _comment_lines(header_comments):
        buffer.write(line + "\n")
    buffer.write(",".join(names) + "\n")
    np.savetxt(buffer, data, fmt="%.12g", delimiter=",")
    Path(path).write_text(buffer.getvalue(), encoding="utf-8")  # an OSError names the file (the CLI reports it)


def read_log(path) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Read a canonical CSV written by :func:`write_log`: (columns, header comments as key -> value).

    This is a strict reader for the bench's own files (calibration, round trips); foreign logs with
    mappings and dropped rows are the diagnosis engine's reader's job.
    """
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise ValueError(f"cannot read log {path}: {exc.strerror or exc}") from None
    comments, body = {}, []
    for line in lines:
        if line.startswith("#"):
            key, sep, value = line[1:].strip().partition(":")
            if sep:
                comments[key.strip()] = value.strip()
        elif line.strip():
            body.append(line)
    if not body:
        raise ValueError(f"log {path}: no header row")
    names = [n.strip() for n in body[0].split(",")]
    for required in REQUIRED_COLUMNS:
        if required not in names:
            raise ValueError(f"log {path}: missing column {required!r}")
    if len(body) < 2:
        raise ValueError(f"log {path}: no data rows")
    try:
        data = np.loadtxt(io.StringIO("\n".join(body[1:])), delimiter=",", ndmin=2)
    except ValueError as exc:
        raise ValueError(f"log {path}: {str(exc).splitlines()[0]}") from None
    if data.shape[1] != len(names):
        raise ValueError(f"log {path}: {data.shape[1]} values per row for {len(names)} columns")
    return {n: data[:, i].copy() for i, n in enumerate(names)}, comments
