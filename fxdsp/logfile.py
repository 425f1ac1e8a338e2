"""Read a measured log (canonical CSV or a foreign log through a column mapping) into numpy arrays.

The contract (shared/spec/measured-data.md, section 1): comma-separated, one header row, `#` lines
ignored, columns in any order; foreign logs through ``--map canonical=source``, a delimiter and a
date-time format. Rows whose mapped values are not finite or are absurd sentinels (9.9e37, -1e38)
are dropped and counted. Everything that makes a log unusable raises InputError with one line.
"""

from __future__ import annotations

import datetime as _dt
import io
from contextlib import contextmanager
import re
from dataclasses import dataclass, field

import numpy as np

from fxdsp.errors import InputError, MissingColumn

REQUIRED = ("time_s", "temp_c", "output")
OPTIONAL = ("ref_temp_c", "rate_dps", "freq_hz", "quad")
CANONICAL = REQUIRED + OPTIONAL

# instruments write +-1e38-like placeholders for "no reading"; nothing physical in a log is that big
SENTINEL_ABS = 1e30
# a reference whose span is below this share of temp_c's cannot be temp_c's reference: the contract has
# temp_c equal to ref_temp_c up to an offset and a gain, and a readout in degC of a thermometer in degC
# has a gain near one, not a hundred (a probe left in a bath, stuck or disconnected: its one reading)
STILL_REFERENCE_SHARE = 0.01


@dataclass
class Log:
    """Canonical columns (float arrays of equal length) plus bookkeeping for the report."""

    columns: dict[str, np.ndarray]
    dropped: int = 0
    source: str = ""
    notes: list[str] = field(default_factory=list)
    # the optional columns set aside (stuck, still, empty), each with its note: what a command that
    # needs one of them says instead of only that it is missing
    ignored: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.columns = _ignore_columns_that_carry_nothing(self.columns, self.notes, self.ignored)

    def __len__(self) -> int:
        return int(self.columns["time_s"].size)

    def has(self, name: str) -> bool:
        return name in self.columns


def _usable(values: np.ndarray) -> np.ndarray:
    """Which values are usable readings: finite and not a logger's sentinel."""
    return np.isfinite(values) & (np.abs(values) < SENTINEL_ABS)


def _usable_span(values: np.ndarray) -> float:
    """Peak-to-peak of the usable values; nan with fewer than two."""
    usable = values[_usable(values)]
    return float(np.ptp(usable)) if usable.size > 1 else float("nan")


# readout channels that are fitted as channels of their own: one value in every usable row is a
# stuck counter or a disconnected input, not a reading
STUCK_READOUTS = ("freq_hz", "quad")


@contextmanager
def saying_why_columns_are_missing(*logs: Log):
    """Work on ``logs`` during which a missing column (:class:`fxdsp.errors.MissingColumn`) that a log's
    reader set aside (stuck, still, empty: :attr:`Log.ignored`) is refused with the reason, not only
    with the column's name: the user's log has the column, and the one line must say why it was not
    used."""
    try:
        yield
    except MissingColumn as exc:
        why = [log.ignored[exc.column] for log in logs if exc.column in log.ignored]
        if not why:
            raise
        raise MissingColumn(f"{exc}; the log's {'; '.join(why)}", exc.column) from None


def _set_aside(name: str, why: str, notes: list, ignored: dict) -> None:
    """Record an optional column the reader ignores: its note, and the column with it."""
    notes.append(why)
    ignored[name] = why


def _ignore_columns_that_carry_nothing(columns: dict, notes: list, ignored: dict) -> dict:
    """The columns without an optional readout that holds one value in every usable row, and without
    a ref_temp_c that does not move while temp_c does (each with a note). A stuck resonator counter,
    fitted as the frequency channel, made a true thermal lag fail there (it must explain freq_hz too)
    and the diagnosis named the hysteresis and quadrature beside it without the lag; a still
    reference, fitted as the reference, made the temperature channel's residual the whole of temp_c's
    programme, and a diagnosis named a ramp-rate term for it. The reader asks before it drops rows (an
    ignored column's empty or sentinel cells cost no row), and every other log on being made (Log); a
    new dict either way, the caller's kept."""
    for name in STUCK_READOUTS:
        values = columns.get(name)
        usable = values[_usable(values)] if values is not None else np.empty(0)
        if usable.size >= 1 and np.all(usable == usable[0]):
            _set_aside(name, f"optional column {name!r} holds one value ({usable[0]:g}) in every usable row: "
                       "a stuck or disconnected readout carries nothing to fit, and it was ignored", notes, ignored)
            columns = {k: v for k, v in columns.items() if k != name}
    ref, temp = columns.get("ref_temp_c"), columns.get("temp_c")
    if ref is None or temp is None:
        return columns
    ref_span, temp_span = _usable_span(ref), _usable_span(temp)
    if not (temp_span > 0 and ref_span <= STILL_REFERENCE_SHARE * temp_span):
        return columns
    _set_aside("ref_temp_c", f"optional column 'ref_temp_c' spans {ref_span:.4g} degC while temp_c spans "
               f"{temp_span:.4g} degC: it cannot be temp_c's reference (an offset and a gain apart) and was ignored",
               notes, ignored)
    return {k: v for k, v in columns.items() if k != "ref_temp_c"}


def parse_mapping(items: list[str] | None) -> dict[str, str]:
    """``["time_s=date", ...]`` -> ``{"time_s": "date"}``; unknown canonical targets are bad input."""
    mapping: dict[str, str] = {}
    for item in items or []:
        target, sep, source = item.partition("=")
        target, source = target.strip(), source.strip()
        if not sep or not target or not source:
            raise InputError(f"--map {item!r}: expected CANONICAL=SOURCE, e.g. temp_c=box_temp")
        if target not in CANONICAL:
            raise InputError(f"--map {item!r}: unknown target {target!r}; expected one of {', '.join(CANONICAL)}")
        if target in mapping:   # a dict would keep the last silently
            raise InputError(f"--map {item!r}: {target} is already mapped to {mapping[target]!r}")
        mapping[target] = source
    return mapping


def _unparsed_hint(target: str, cell: str) -> str:
    """The likely reason a column holds no number (a date-time stamp, a decimal comma)."""
    if target == "time_s" and re.search(r"\d[-/.:T ]\d", cell):
        return ": date-time stamps need --time-format (e.g. '%Y-%m-%d %H:%M:%S')"
    if re.fullmatch(r"[-+]?\d+,\d+", cell):
        return ": a decimal comma (the reader takes a decimal point)"
    return ""


def _to_float(name: str, cells: list[str]) -> np.ndarray:
    """Vectorised string -> float; unparseable cells become NaN (they are then dropped and counted)."""
    try:
        return np.asarray(cells, dtype=float)
    except ValueError:
        pass
    out = np.empty(len(cells))
    for i, cell in enumerate(cells):  # slow path, only for logs with junk cells
        try:
            out[i] = float(cell)
        except ValueError:
            out[i] = np.nan
    return out


# strptime directives that the fast path turns into a regular expression
_DIRECTIVES = {"%d": r"(?P<d>\d{1,2})", "%m": r"(?P<m>\d{1,2})", "%Y": r"(?P<Y>\d{4})",
               "%y": r"(?P<y>\d{2})", "%H": r"(?P<H>\d{1,2})", "%M": r"(?P<M>\d{1,2})",
               "%S": r"(?P<S>\d{1,2})", "%f": r"(?P<f>\d{1,6})"}


def _fast_time_regex(fmt: str) -> re.Pattern | None:
    parts, i = [], 0
    seen = set()
    while i < len(fmt):
        if fmt[i] == "%":
            key = fmt[i:i + 2]
            if key not in _DIRECTIVES or key in seen:
                return None
            seen.add(key)
            parts.append(_DIRECTIVES[key])
            i += 2
        else:
            parts.append(re.escape(fmt[i]))
            i += 1
    if not {"%d", "%m"} <= seen or not ({"%Y"} & seen or {"%y"} & seen):
        return None
    return re.compile("^" + "".join(parts) + "$")


def parse_times(name: str, cells: list[str], fmt: str) -> np.ndarray:
    """Date-time strings -> seconds since the first row (naive times, no time zone or DST shift).

    Dates are checked with datetime (a 31st of February is an error); common numeric formats are
    parsed by one regular expression and numpy's datetime64 arithmetic, which keeps a 1M-row log
    to about a second instead of the ten that per-row strptime would take.
    """
    regex = _fast_time_regex(fmt)
    if regex is not None:
        fields = {k: [] for k in "dmYyHMSf"}
        for row, cell in enumerate(cells):
            match = regex.match(cell.strip())
            if match is None:
                raise InputError(f"column {name!r} row {row + 1}: cannot parse date {cell!r} with format {fmt!r}")
            for k, v in match.groupdict().items():
                fields[k].append(v)
        n = len(cells)
        get = lambda k, default: (np.asarray(fields[k], dtype=np.int64) if fields[k] else np.full(n, default))  # noqa: E731
        year = get("Y", 0) if fields["Y"] else 2000 + get("y", 0)
        month, day = get("m", 1), get("d", 1)
        if np.any((month < 1) | (month > 12)) or np.any((day < 1) | (day > 31)):
            bad = int(np.argmax((month < 1) | (month > 12) | (day < 1) | (day > 31)))
            raise InputError(f"column {name!r} row {bad + 1}: impossible date {cells[bad]!r}")
        months = (year - 1970) * 12 + (month - 1)
        date = months.astype("datetime64[M]").astype("datetime64[D]") + (day - 1)
        if np.any(date.astype("datetime64[M]") != months.astype("datetime64[M]")):
            bad = int(np.argmax(date.astype("datetime64[M]") != months.astype("datetime64[M]")))
            raise InputError(f"column {name!r} row {bad + 1}: impossible date {cells[bad]!r}")
        hour, minute, sec = get("H", 0), get("M", 0), get("S", 0)
        if np.any(hour > 23) or np.any(minute > 59) or np.any(sec > 61):
            bad = int(np.argmax((hour > 23) | (minute > 59) | (sec > 61)))
            raise InputError(f"column {name!r} row {bad + 1}: impossible time {cells[bad]!r}")
        frac = np.asarray([float("0." + f) for f in fields["f"]]) if fields["f"] else np.zeros(n)
        seconds = date.astype(np.int64) * 86400.0 + hour * 3600.0 + minute * 60.0 + sec + frac
    else:
        seconds = np.empty(len(cells))
        for row, cell in enumerate(cells):
            try:
                stamp = _dt.datetime.strptime(cell.strip(), fmt)
            except ValueError:
                raise InputError(f"column {name!r} row {row + 1}: cannot parse date {cell!r} with format {fmt!r}") from None
            if stamp.tzinfo is not None:
                stamp = stamp.astimezone(_dt.timezone.utc).replace(tzinfo=None)
            seconds[row] = (stamp - _dt.datetime(1970, 1, 1)).total_seconds()
    return seconds - seconds[0] if seconds.size else seconds


def _fast_numeric(body: list[str], delimiter: str, usecols: list[int]) -> np.ndarray | None:
    """numpy's C parser for the common case (every used cell a number, nan or inf); None when a
    cell is empty or junk, and the per-cell reader takes over."""
    if not usecols:
        return np.empty((len(body), 0))
    try:
        data = np.loadtxt(io.StringIO("\n".join(body)), delimiter=delimiter, usecols=usecols,
                          ndmin=2, comments=None, dtype=float, quotechar='"')
    except (ValueError, IndexError):
        return None
    return data if data.shape == (len(body), len(usecols)) else None


def lines_and_header(path, delimiter: str = ",") -> tuple[list[str], list[str]]:
    """The non-blank, non-``#`` lines of a text table (UTF-8, BOM allowed) and its header's names
    (stripped, quotes removed; [] for an empty file)."""
    with open(path, encoding="utf-8-sig") as handle:
        lines = [ln.rstrip("\r\n") for ln in handle if ln.strip() and not ln.lstrip().startswith("#")]
    header = [h.strip().strip('"') for h in lines[0].split(delimiter)] if lines else []
    return lines, header


def read_log(path, mapping: dict[str, str] | None = None, delimiter: str = ",",
             time_format: str | None = None) -> Log:
    """Read ``path``; ``mapping`` is canonical -> source column name (see parse_mapping)."""
    mapping = dict(mapping or {})
    lines, header = lines_and_header(path, delimiter)
    if not lines:
        raise InputError(f"{path}: empty file (no header row)")
    twice = sorted({h for h in header if h and header.count(h) > 1})
    if twice:  # which of the two would be read is a guess: refuse rather than pick one
        raise InputError(f"{path}: column {twice[0]!r} appears more than once in the header")
    body = lines[1:]
    if not body:
        raise InputError(f"{path}: no data rows after the header")
    index = {name: i for i, name in enumerate(header) if name}
    # one source column is one quantity: a column --map assigns is that quantity only (a canonical
    # column mapped elsewhere is not also read under its own name), and no column is mapped twice
    # (time read as temperature too would be diagnosed, and wrongly)
    claimed: dict[str, str] = {}
    for target, source in mapping.items():
        if source in claimed:
            raise InputError(f"--map {target}={source}: column {source!r} is already mapped to {claimed[source]}; "
                             f"each canonical column needs its own source column")
        claimed[source] = target
    # the other canonical names present in the file are used as they are
    sources = {c: c for c in CANONICAL if c in index and c not in claimed}
    sources.update(mapping)
    for target, source in mapping.items():
        if source not in index:
            raise InputError(f"{path}: missing column {source!r} (mapped to {target}); header has {', '.join(index)}")
    missing = [c for c in REQUIRED if c not in sources]
    if missing:
        raise InputError(f"{path}: missing column {missing[0]!r} (use --map {missing[0]}=NAME for a foreign log)")

    columns: dict[str, np.ndarray] = {}
    time_cells = None
    unparsed: dict[str, str] = {}   # a column with no number at all -> its first non-empty cell
    numeric = {t: s for t, s in sources.items() if not (t == "time_s" and time_format)}
    fast = _fast_numeric(body, delimiter, [index[s] for s in numeric.values()])
    if fast is not None and not (time_format and "time_s" in sources):
        columns = {t: fast[:, i].copy() for i, t in enumerate(numeric)}
    else:
        rows = [ln.split(delimiter) for ln in body]
        width = len(header)
        for i, r in enumerate(rows):
            if len(r) < width:
                # a truncated last line (logger stopped mid-write): pad it so that its row is dropped
                rows[i] = r + [""] * (width - len(r))
        for target, source in sources.items():
            cells = [r[index[source]].strip().strip('"') for r in rows]
            if target == "time_s" and time_format:
                time_cells = cells
            elif fast is not None:
                columns[target] = fast[:, list(numeric).index(target)].copy()
            else:
                columns[target] = _to_float(source, cells)
                if not np.any(np.isfinite(columns[target])):
                    unparsed[target] = next((c for c in cells if c), "")

    notes: list[str] = []
    ignored: dict[str, str] = {}
    # an optional column with no usable value at all is an absent column, not a reason to drop every row
    for name in list(columns):
        if name in OPTIONAL:
            values = columns[name]
            if not np.any(_usable(values)):
                del columns[name]
                _set_aside(name, f"optional column {name!r} has no usable value and was ignored", notes, ignored)
    columns = _ignore_columns_that_carry_nothing(columns, notes, ignored)

    n = len(body)
    good = np.ones(n, dtype=bool)
    for values in columns.values():
        good &= _usable(values)
    if time_cells is not None:
        # date stamps of dropped rows are not parsed: a sentinel row often has a placeholder stamp too
        keep_idx = np.flatnonzero(good)
        stamps = parse_times(sources["time_s"], [time_cells[i] for i in keep_idx], time_format)
        time = np.full(n, np.nan)
        time[keep_idx] = stamps
        columns["time_s"] = time
    used = int(good.sum())
    if used == 0:
        for target, cell in unparsed.items():   # a column that is not numbers at all: say which, and why
            if cell and target in columns:
                mapped = f" (mapped to {target})" if sources[target] != target else ""
                raise InputError(f"{path}: column {sources[target]!r}{mapped} holds no number, e.g. "
                                 f"{cell!r}{_unparsed_hint(target, cell)}")
        raise InputError(f"{path}: no usable rows (all {n} rows hold non-finite or sentinel values)")
    columns = {k: np.ascontiguousarray(v[good]) for k, v in columns.items()}
    time = columns["time_s"]
    if time_cells is not None:
        time -= time[0]
    step = np.diff(time)
    if np.any(step < 0):
        bad = int(np.argmax(step < 0))
        raise InputError(f"{path}: non-monotonic time: time_s goes back from {time[bad]:g} to {time[bad + 1]:g} "
                         f"(usable row {bad + 2})")
    flat = columns["output"]
    if flat.size > 1 and np.all(flat == flat[0]):  # nothing to explain or fit: refuse it by name
        raise InputError(f"{path}: column {sources['output']!r} (output) is flat: every usable row is {flat[0]:g}")
    return Log(columns=columns, dropped=n - used, source=str(path), notes=notes, ignored=ignored)
