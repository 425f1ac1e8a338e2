"""The one TOML config: formats, arithmetic rules, coefficients, segments and stimulus.

Every block reads its own table through a :class:`Section`, which validates each value on the way
in and, once the block is built, rejects any key it did not read (a typo in a config is an error
naming the field, with the nearest valid key suggested). The built-in default lives in
``fxdsp/configs/default.toml``.

A misspelt key is named as such even when it is a required one, whose absence stops the block
before the unknown-key check: the error of a missing key first looks in its table for an unknown key
close to it (``sf_divide.in_fromat: unknown key (did you mean 'in_format'?)``). Which keys a table
may hold is learnt from the built-in default: the keys of its table there and every key the design
reads from it (optional ones included), so a valid sibling such as ``r2_ohm`` is never taken for a
misspelt ``r1_ohm``.
"""

from __future__ import annotations

import difflib
import functools
import math
import re
import tomllib
from contextlib import contextmanager
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from fxdsp.fixed import Format, Rules
from fxdsp.fixed.rules import check_overflow, check_rounding
from fxdsp.errors import InputError, InputTypeError

DEFAULT_CONFIG_NAME = "default.toml"


def default_config_text() -> str:
    return resources.files("fxdsp.configs").joinpath(DEFAULT_CONFIG_NAME).read_text(encoding="utf-8")


def load_config(path: str | Path | None = None) -> "Config":
    """Parse a TOML config file into a :class:`Config` (the built-in default when ``path`` is None).

    Only the TOML is read here; the values are checked when a design is built from it
    (:func:`fxdsp.build`), where any bad value, unknown key or table is an error naming its
    dotted path (``rtd.lut_index_bitz: unknown key (did you mean 'lut_index_bits'?)``).
    FileNotFoundError for a missing file, ValueError for text that is not TOML."""
    if path is None:
        return Config(tomllib.loads(default_config_text()), source="<default>")
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FileNotFoundError(2, "config file not found", str(p)) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{p}: not valid TOML: {exc}") from None
    return Config(data, source=str(p))


def table_at(data: dict, dotted: str) -> dict:
    """The raw table of parsed config ``data`` at a dotted path (``"demod.lpf"``); KeyError if absent."""
    for part in dotted.split("."):
        data = data[part]
    return data


def nearest(name: str, choices) -> str | None:
    """The valid name closest to a misspelt one, or None: a name one edit away (a character
    changed, added, dropped, or two neighbours swapped: ``0r_ohm`` is ``r0_ohm``, not ``r4_ohm``;
    short names such as ``fs``/``sf`` fall below difflib's cutoff), else difflib's best match."""
    choices = sorted(set(choices))
    one = [c for c in choices if one_edit(name, c)]
    near = difflib.get_close_matches(name, one or choices, n=1, cutoff=0.0 if one else 0.6)
    return near[0] if near else None


def one_edit(a: str, b: str) -> bool:
    if a == b or abs(len(a) - len(b)) > 1:
        return False
    if len(a) == len(b):
        diff = [i for i in range(len(a)) if a[i] != b[i]]
        return len(diff) == 1 or (len(diff) == 2 and diff[1] == diff[0] + 1
                                  and a[diff[0]] == b[diff[1]] and a[diff[1]] == b[diff[0]])
    short, long_ = (a, b) if len(a) < len(b) else (b, a)
    return any(long_[:i] + long_[i + 1:] == short for i in range(len(long_)))


class Section:
    """A config table read field by field; every error names ``path.key``."""

    def __init__(self, data: dict[str, Any], path: str):
        if not isinstance(data, dict):
            raise InputError(f"{path}: expected a table, got {type(data).__name__}")
        self.data = data
        self.path = path
        self._read: set[str] = set()
        self._children: dict[str, Section] = {}

    def field(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def has(self, key: str) -> bool:
        return key in self.data

    def _get(self, key: str, default: Any):
        self._read.add(key)
        if key in self.data:
            return self.data[key]
        if default is _REQUIRED:
            raise self._missing(key, "missing")
        return default

    def _missing(self, key: str, what: str) -> InputError:
        """The error for a required ``key`` (or sub-table) that is absent. When the table holds an
        unknown key (not read, and not one this table may hold) close to it, that key is the typo to
        name; a table the built-in default does not know is not guessed at."""
        known = _known_keys(self.path)
        if known is not None:
            unknown = [k for k in self.data if k not in self._read and k not in known]
            typo = [k for k in unknown if nearest(k, [key]) is not None]
            if typo:
                return InputError(f"{self.field(typo[0])}: unknown key (did you mean {key!r}?)")
            if unknown:
                return InputError(f"{self.field(key)}: {what} (the table has the unknown key {unknown[0]!r})")
        return InputError(f"{self.field(key)}: {what}")

    def format(self, key: str, default: Any = None) -> Format:
        value = self._get(key, _REQUIRED if default is None else default)
        return Format.parse(value, self.field(key))

    def wired_format(self, key: str, wired: Format, source_field: str, enforce: bool = True) -> Format:
        """The format of an input wired to ``source_field``: derived from it, not restated. A config
        that states it anyway must agree (the error names both fields); for block-level work
        (``enforce`` False) a stated format is taken as given."""
        if key not in self.data:
            self._read.add(key)
            return wired
        stated = self.format(key)
        if enforce and stated != wired:
            raise InputError(f"{self.field(key)}: {stated} must equal {source_field} ({wired}) to connect "
                             f"the chain; leave it out, it is derived")
        return stated

    def formats(self, key: str) -> Format | list[Format]:
        """One format, or a list of formats (one per element, e.g. per polynomial power)."""
        value = self._get(key, _REQUIRED)
        if isinstance(value, list):
            return [Format.parse(v, f"{self.field(key)}[{i}]") for i, v in enumerate(value)]
        return Format.parse(value, self.field(key))

    def rules(self, prefix: str = "", default: Rules = Rules()) -> Rules:
        rounding = self._get(prefix + "rounding", default.rounding)
        overflow = self._get(prefix + "overflow", default.overflow)
        if not isinstance(rounding, str):
            raise InputTypeError(f"{self.field(prefix + 'rounding')}: expected a string")
        if not isinstance(overflow, str):
            raise InputTypeError(f"{self.field(prefix + 'overflow')}: expected a string")
        check_rounding(rounding, self.field(prefix + "rounding"))
        check_overflow(overflow, self.field(prefix + "overflow"))
        return Rules(rounding, overflow)

    def choice(self, key: str, choices: tuple[str, ...], default: Any = None) -> str:
        value = self._get(key, _REQUIRED if default is None else default)
        if value not in choices:
            raise InputError(f"{self.field(key)}: {value!r} is not one of {', '.join(choices)}")
        return value

    def names(self, key: str, choices: tuple[str, ...], default: Any = None) -> list[str]:
        """A list of distinct names, each one of ``choices`` (e.g. the optional stages of a chain)."""
        value = self._get(key, _REQUIRED if default is None else default)
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise InputTypeError(f"{self.field(key)}: expected a list of names, got {value!r}")
        for v in value:
            if v not in choices:
                raise InputError(f"{self.field(key)}: {v!r} is not one of {', '.join(choices)}")
        if len(set(value)) != len(value):
            raise InputError(f"{self.field(key)}: a name is listed twice in {value!r}")
        return list(value)

    def number(self, key: str, default: Any = None, *, low: float | None = None, high: float | None = None,
               low_open: bool = False) -> float:
        value = self._get(key, _REQUIRED if default is None else default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputTypeError(f"{self.field(key)}: expected a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise InputError(f"{self.field(key)}: must be finite, got {value}")
        if low is not None and (value <= low if low_open else value < low):
            raise InputError(f"{self.field(key)}: must be {'>' if low_open else '>='} {low}, got {value}")
        if high is not None and value > high:
            raise InputError(f"{self.field(key)}: must be <= {high}, got {value}")
        return value

    def integer(self, key: str, default: Any = None, *, low: int | None = None, high: int | None = None) -> int:
        value = self._get(key, _REQUIRED if default is None else default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputTypeError(f"{self.field(key)}: expected an integer, got {value!r}")
        if low is not None and value < low:
            raise InputError(f"{self.field(key)}: must be >= {low}, got {value}")
        if high is not None and value > high:
            raise InputError(f"{self.field(key)}: must be <= {high}, got {value}")
        return value

    def numbers(self, key: str, default: Any = None) -> list[float]:
        value = self._get(key, _REQUIRED if default is None else default)
        if not isinstance(value, list):
            raise InputTypeError(f"{self.field(key)}: expected a list of numbers, got {value!r}")
        out = []
        for i, v in enumerate(value):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
                raise InputTypeError(f"{self.field(key)}[{i}]: expected a finite number, got {v!r}")
            out.append(float(v))
        return out

    def matrix(self, key: str) -> list[list[float]]:
        value = self._get(key, _REQUIRED)
        if not isinstance(value, list) or not value or not all(isinstance(r, list) for r in value):
            raise InputTypeError(f"{self.field(key)}: expected a list of lists of numbers")
        rows = []
        for i, row in enumerate(value):
            if not row:
                raise InputError(f"{self.field(key)}[{i}]: empty row")
            for j, v in enumerate(row):
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
                    raise InputTypeError(f"{self.field(key)}[{i}][{j}]: expected a finite number, got {v!r}")
            rows.append([float(v) for v in row])
        return rows

    def sub(self, key: str) -> "Section":
        """The sub-table ``key`` (one Section per sub-table: reading it twice gives the same one, and
        :meth:`done` checks it with this table)."""
        self._read.add(key)
        if key not in self._children:
            if key not in self.data:
                raise self._missing(key, "missing table")
            self._children[key] = Section(self.data[key], self.field(key))
        return self._children[key]

    def optional_sub(self, key: str) -> "Section | None":
        """The sub-table ``key``, or None when absent (its name still counts as a valid key here,
        so a misspelt one is reported with it suggested)."""
        self._read.add(key)
        return self.sub(key) if key in self.data else None

    def done(self) -> None:
        """Reject keys nobody read: they are typos or options that do not exist. Sub-tables read
        through :meth:`sub` first, then this table's own keys."""
        for child in self._children.values():
            child.done()
        unknown = [k for k in self.data if k not in self._read]
        if unknown:
            key = unknown[0]
            # the key meant is most likely one the table does not set already
            near = nearest(key, self._read - set(self.data)) or nearest(key, self._read)
            hint = f" (did you mean {near!r}?)" if near else ""
            raise InputError(f"{self.field(key)}: unknown key{hint}")


_REQUIRED = object()


_SCHEMA_BUSY = False
_DESIGN_BUILDER = None


def register_design_builder(build) -> None:
    """The function that builds a design from a Config (:func:`fxdsp.chains.build`, which registers
    itself when imported). The config layer sits below the design and never imports it; the keys a
    table may hold are learnt by building the default through this hook, for an error's hint."""
    global _DESIGN_BUILDER
    _DESIGN_BUILDER = build
    _default_schema.cache_clear()


@functools.cache
def _default_schema() -> dict[str, frozenset[str]]:
    """Table path -> the keys that table may hold: its keys in the built-in default and every key
    a design built from the default reads there (optional keys read with their default included)."""
    global _SCHEMA_BUSY
    build = _DESIGN_BUILDER
    if build is None:   # no design layer loaded: a block read on its own; no guess
        return {}

    _SCHEMA_BUSY = True
    try:
        cfg = Config(tomllib.loads(default_config_text()), source="<default>")
        build(cfg)
    finally:
        _SCHEMA_BUSY = False
    schema: dict[str, frozenset[str]] = {}

    def walk(sec: Section) -> None:
        schema[sec.path] = frozenset(sec._read) | frozenset(sec.data)
        for child in sec._children.values():
            walk(child)

    walk(cfg.root)
    return schema


def _known_keys(path: str) -> frozenset[str] | None:
    """The keys a table at ``path`` may hold, None when unknown (a table the default lacks, or
    while the default itself is being read)."""
    if _SCHEMA_BUSY:
        return None
    try:
        return _default_schema().get(path)
    except Exception:  # noqa: BLE001 - an error message is being made: without the schema, no guess
        return None


class Config:
    """A parsed TOML config (:func:`load_config`, or ``Config(dict)`` from data in memory).

    ``section('rtd')`` hands a block its table; ``check_all_read`` after all blocks are built rejects
    unknown tables and keys, at every depth. Pass it to :func:`fxdsp.build` to get the design."""

    def __init__(self, data: dict[str, Any], source: str = "<dict>"):
        self.data = data
        self.source = source
        self.root = Section(data, "")

    @property
    def name(self) -> str:
        """The source as written into outputs: a file's name without its folder (no absolute path in
        a written file: the same config gives the same bytes wherever it lies), or ``<default>``."""
        return self.source if self.source.startswith("<") else Path(self.source).name

    @contextmanager
    def naming_the_file(self):
        """Any InputError raised inside names the config's file first (a user's config read from a
        file: every fault found in it, by whichever block, chain or generator, says which file)."""
        try:
            yield
        except InputError as exc:
            if self.source.startswith("<") or self.source in str(exc):
                raise
            try:
                named = type(exc)(f"{self.source}: {exc}")
            except TypeError:
                named = InputError(f"{self.source}: {exc}")
            raise named from None

    def section(self, dotted: str) -> Section:
        node = self.root
        for part in dotted.split("."):
            node = node.sub(part)
        return node

    def optional_section(self, dotted: str) -> Section | None:
        node = self.root
        for part in dotted.split("."):
            node = node.optional_sub(part)
            if node is None:
                return None
        return node

    def check_all_read(self) -> None:
        """Every key of every table read (nested ones too), and every top-level table, must have been
        used."""
        self.root.done()


# --- writing ------------------------------------------------------------------------------------
# The package's one TOML writer: `fxdsp budget --config-out` writes whole configs with dumps(), the
# calibration rewrites single values of a commented copy of the default with dumps_value().

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
# a TOML basic string must escape '"', '\' and the control characters (tab may stay, but is
# clearer escaped); every other character is written as is (the file is UTF-8)
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _string(s: str) -> str:
    out = []
    for ch in s:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _key(key: str) -> str:
    if not isinstance(key, str):
        raise TypeError(f"{key!r}: TOML keys are strings, got {type(key).__name__}")
    return key if _BARE_KEY.fullmatch(key) else _string(key)


def dumps_value(value: Any, path: str = "value") -> str:
    """One TOML value on one line: bool, int, finite float (shortest repr, so it reads back exactly),
    str, arrays (lists, tuples, numpy arrays; nested) and inline tables (dicts). ``path`` names the
    value in errors."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        f = float(value)
        if not math.isfinite(f):  # TOML could say inf/nan, but no config field accepts them
            raise InputError(f"{path}: {f} cannot be written to a config")
        return repr(f)
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(dumps_value(v, f"{path}[{i}]") for i, v in enumerate(value)) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_key(k)} = {dumps_value(v, f'{path}.{k}')}" for k, v in value.items()) + "}"
    raise TypeError(f"{path}: cannot write {type(value).__name__} to TOML")


def dumps(data: dict[str, Any], header: str = "") -> str:
    """TOML text that ``tomllib.loads`` reads back to ``data``: nested dicts become ``[a.b]`` tables,
    everything else one ``key = value`` line (:func:`dumps_value`). ``header`` lines become comments."""
    if not isinstance(data, dict):
        raise TypeError(f"data: expected a dict, got {type(data).__name__}")
    lines = [f"# {ln}" if ln else "#" for ln in header.splitlines()]

    def table(node: dict, path: list[str]) -> None:
        values = {k: v for k, v in node.items() if not isinstance(v, dict)}
        tables = {k: v for k, v in node.items() if isinstance(v, dict)}
        # a table holding only tables needs no header of its own; an empty one does, or it is lost
        if path and (values or not tables):
            if lines:
                lines.append("")
            lines.append("[" + ".".join(_key(k) for k in path) + "]")
        for k, v in values.items():
            lines.append(f"{_key(k)} = {dumps_value(v, '.'.join([*path, k]))}")
        for k, v in tables.items():  # after this table's values: they would belong to the sub-table
            table(v, [*path, k])

    table(data, [])
    return "\n".join(lines) + "\n"
