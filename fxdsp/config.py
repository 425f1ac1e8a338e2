"""The one TOML config: formats, arithmetic rules, coefficients, segments and stimulus.

Every block reads its own table through a :class:`Section`, which validates each value on the way
in and, once the block is built, rejects any key it did not read (a typo in a config is an error
naming the field, with the nearest valid key suggested). The built-in default lives in
``fxdsp/configs/default.toml``.
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .fixed import Format, Rules
from .fixed.rules import check_overflow, check_rounding

DEFAULT_CONFIG_NAME = "default.toml"


def default_config_text() -> str:
    return resources.files("fxdsp.configs").joinpath(DEFAULT_CONFIG_NAME).read_text(encoding="utf-8")


def load_config(path: str | Path | None = None) -> "Config":
    """Parse a TOML config (the built-in default when ``path`` is None)."""
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
        raise ValueError(f"{p}: not valid TOML: {exc}") from None
    return Config(data, source=str(p))


class Section:
    """A config table read field by field; every error names ``path.key``."""

    def __init__(self, data: dict[str, Any], path: str):
        if not isinstance(data, dict):
            raise ValueError(f"{path}: expected a table, got {type(data).__name__}")
        self.data = data
        self.path = path
        self._read: set[str] = set()

    def field(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def has(self, key: str) -> bool:
        return key in self.data

    def _get(self, key: str, default: Any):
        self._read.add(key)
        if key in self.data:
            return self.data[key]
        if default is _REQUIRED:
            raise ValueError(f"{self.field(key)}: missing")
        return default

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
            raise ValueError(f"{self.field(key)}: {stated} must equal {source_field} ({wired}) to connect "
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
            raise TypeError(f"{self.field(prefix + 'rounding')}: expected a string")
        if not isinstance(overflow, str):
            raise TypeError(f"{self.field(prefix + 'overflow')}: expected a string")
        check_rounding(rounding, self.field(prefix + "rounding"))
        check_overflow(overflow, self.field(prefix + "overflow"))
        return Rules(rounding, overflow)

    def choice(self, key: str, choices: tuple[str, ...], default: Any = None) -> str:
        value = self._get(key, _REQUIRED if default is None else default)
        if value not in choices:
            raise ValueError(f"{self.field(key)}: {value!r} is not one of {', '.join(choices)}")
        return value

    def names(self, key: str, choices: tuple[str, ...], default: Any = None) -> list[str]:
        """A list of distinct names, each one of ``choices`` (e.g. the optional stages of a chain)."""
        value = self._get(key, _REQUIRED if default is None else default)
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise TypeError(f"{self.field(key)}: expected a list of names, got {value!r}")
        for v in value:
            if v not in choices:
                raise ValueError(f"{self.field(key)}: {v!r} is not one of {', '.join(choices)}")
        if len(set(value)) != len(value):
            raise ValueError(f"{self.field(key)}: a name is listed twice in {value!r}")
        return list(value)

    def number(self, key: str, default: Any = None, *, low: float | None = None, high: float | None = None,
               low_open: bool = False) -> float:
        value = self._get(key, _REQUIRED if default is None else default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError(f"{self.field(key)}: expected a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{self.field(key)}: must be finite, got {value}")
        if low is not None and (value <= low if low_open else value < low):
            raise ValueError(f"{self.field(key)}: must be {'>' if low_open else '>='} {low}, got {value}")
        if high is not None and value > high:
            raise ValueError(f"{self.field(key)}: must be <= {high}, got {value}")
        return value

    def integer(self, key: str, default: Any = None, *, low: int | None = None, high: int | None = None) -> int:
        value = self._get(key, _REQUIRED if default is None else default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{self.field(key)}: expected an integer, got {value!r}")
        if low is not None and value < low:
            raise ValueError(f"{self.field(key)}: must be >= {low}, got {value}")
        if high is not None and value > high:
            raise ValueError(f"{self.field(key)}: must be <= {high}, got {value}")
        return value

    def numbers(self, key: str, default: Any = None) -> list[float]:
        value = self._get(key, _REQUIRED if default is None else default)
        if not isinstance(value, list):
            raise TypeError(f"{self.field(key)}: expected a list of numbers, got {value!r}")
        out = []
        for i, v in enumerate(value):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
                raise TypeError(f"{self.field(key)}[{i}]: expected a finite number, got {v!r}")
            out.append(float(v))
        return out

    def matrix(self, key: str) -> list[list[float]]:
        value = self._get(key, _REQUIRED)
        if not isinstance(value, list) or not value or not all(isinstance(r, list) for r in value):
            raise TypeError(f"{self.field(key)}: expected a list of lists of numbers")
        rows = []
        for i, row in enumerate(value):
            if not row:
                raise ValueError(f"{self.field(key)}[{i}]: empty row")
            for j, v in enumerate(row):
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
                    raise TypeError(f"{self.field(key)}[{i}][{j}]: expected a finite number, got {v!r}")
            rows.append([float(v) for v in row])
        return rows

    def sub(self, key: str) -> "Section":
        self._read.add(key)
        if key not in self.data:
            raise ValueError(f"{self.field(key)}: missing table")
        return Section(self.data[key], self.field(key))

    def done(self) -> None:
        """Reject keys nobody read: they are typos or options that do not exist."""
        unknown = [k for k in self.data if k not in self._read]
        if unknown:
            key = unknown[0]
            near = difflib.get_close_matches(key, sorted(self._read), n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            raise ValueError(f"{self.field(key)}: unknown key{hint}")


_REQUIRED = object()


class Config:
    """The parsed TOML. ``section('rtd')`` hands a block its table; ``check_all_read`` after all
    blocks are built rejects unknown top-level tables and keys."""

    def __init__(self, data: dict[str, Any], source: str = "<dict>"):
        self.data = data
        self.source = source
        self.root = Section(data, "")
        self._sections: dict[str, Section] = {}

    @property
    def name(self) -> str:
        """The source as written into outputs: a file's name without its folder (no absolute path in
        a written file: the same config gives the same bytes wherever it lies), or ``<default>``."""
        return self.source if self.source.startswith("<") else Path(self.source).name

    def section(self, dotted: str) -> Section:
        node, prefix = self.root, ""
        for part in dotted.split("."):
            prefix = f"{prefix}.{part}" if prefix else part
            if prefix not in self._sections:
                self._sections[prefix] = node.sub(part)
            node = self._sections[prefix]
        return node

    def optional_section(self, dotted: str) -> Section | None:
        node = self.data
        for part in dotted.split("."):
            if not isinstance(node, dict) or part not in node:
                return None
            node = node[part]
        return self.section(dotted)

    def check_all_read(self) -> None:
        """Every key of every table a block read, and every top-level table, must have been used."""
        for sec in self._sections.values():
            sec.done()
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
            raise ValueError(f"{path}: {f} cannot be written to a config")
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
