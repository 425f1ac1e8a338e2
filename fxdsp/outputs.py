"""Outputs that cannot be lost: checked before any work, written aside, moved into place together.

Every command declares its path options in a module-level ``PATHS`` table (option dest -> kind:
``IN`` an input file, ``IN_DIR`` an input folder, ``OUT_FILE`` a file it writes, ``OUT_DIR`` a folder
it writes into). :func:`check_paths` validates them all before the command does any work: no path
is empty, blank or holds a NUL; an input file is UTF-8 text (not compressed, not binary: the file and
the byte named); an output must be of the right kind (a file target is not a folder, a folder
target not a file), the folder that holds it must exist and be writable, and no output may be an
input or another output. A bad path is one :class:`~fxdsp.errors.InputError` naming the option.
A folder output owns only the files fxdsp wrote there (:mod:`fxdsp.owned`): any other file in it,
and any input of the run, is never replaced or removed.

Writing goes through :func:`staged`: each output is written to a staging folder created beside its
target (same file system), and only when the whole command has succeeded are the staged files moved
into place with ``os.replace``, with SIGINT held off during the moves. An interrupt, a full disk or a
late error before that leaves the previous outputs intact and no partial ones; the staging folder is
removed. Files of a directory output that the command does not produce are left alone (``--out .``
never wipes a folder). A power cut in the middle of the moves can still leave a mix: the moves are
renames, the shortest window a file system offers without journalling of our own.

``FXDSP_UNSAFE_DIRECT_WRITES=1`` (test-only) writes straight into the targets: the interrupt and fuzz
tests use it to show that they fail without the staging.
"""

from __future__ import annotations

import codecs
import json
import math
import os
import re
import shutil
import tempfile
import tomllib
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from fxdsp import owned
from fxdsp.errors import InputError
from fxdsp.interrupts import interrupts_held

IN, IN_DIR, OUT_FILE, OUT_DIR = "in", "in-dir", "out-file", "out-dir"
_WHAT = {IN: "file to read", IN_DIR: "folder to read", OUT_FILE: "file to write", OUT_DIR: "folder to write into"}
DIRECT_ENV = "FXDSP_UNSAFE_DIRECT_WRITES"


def _direct() -> bool:
    return os.environ.get(DIRECT_ENV, "") == "1"


def _nearest_existing(path: Path) -> Path:
    p = path
    while not p.exists():
        if p.parent == p:
            break
        p = p.parent
    return p


def check_output(path: Path, kind: str, option: str) -> None:
    """ValueError naming ``option`` when ``path`` cannot be written as a ``kind`` output."""
    if path.exists():
        if kind == OUT_FILE and path.is_dir():
            raise InputError(f"{option}: {path} is a directory, expected a file")
        if kind == OUT_DIR and not path.is_dir():
            raise InputError(f"{option}: {path} exists and is not a directory")
    holder = path.parent
    if not holder.exists():
        raise InputError(f"{option}: cannot write {path}: the folder {holder} does not exist")
    if not holder.is_dir():
        raise InputError(f"{option}: cannot write {path}: {holder} is a file, not a folder")
    # files are replaced (written aside, then renamed), so the holding folder must be writable
    writable = path if kind == OUT_DIR and path.exists() else holder
    if not os.access(writable, os.W_OK | os.X_OK):
        raise InputError(f"{option}: cannot write {path}: {writable} is not writable")


# compressed files a user may hand over for a text one (a log straight from the logger's archive)
_COMPRESSED = ((b"\x1f\x8b", "gzip-compressed"), (b"PK\x03\x04", "a zip archive"), (b"\xfd7zXZ\x00", "xz-compressed"),
               (b"\x28\xb5\x2f\xfd", "zstd-compressed"), (b"BZh", "bzip2-compressed"))
_CHUNK = 1 << 20


def check_text_input(path: Path, option: str) -> None:
    """InputError naming ``option`` and the file when an input file is not UTF-8 text (every input
    of the commands is: TOML, CSV, JSON): compressed, binary (a NUL byte), or not decodable, with
    the byte where it fails. Checked whole, before any work, so no reader later fails on it without
    saying which file."""
    with open(path, "rb") as f:
        head = f.read(10)
        for magic, what in _COMPRESSED:
            if head.startswith(magic) and (magic != b"BZh" or head[3:4].isdigit() and head[4:10] == b"1AY&SY"):
                raise InputError(f"{option}: {path} is {what}; expected text (decompress it first)")
        for bom, what in ((codecs.BOM_UTF32_LE, "UTF-32"), (codecs.BOM_UTF32_BE, "UTF-32"),
                          (codecs.BOM_UTF16_LE, "UTF-16"), (codecs.BOM_UTF16_BE, "UTF-16")):
            if head.startswith(bom):
                raise InputError(f"{option}: {path} is {what} text; expected UTF-8 (save it as UTF-8)")
        f.seek(0)
        decoder = codecs.getincrementaldecoder("utf-8")()
        offset = 0
        while True:
            chunk = f.read(_CHUNK)
            nul = chunk.find(b"\0")
            if nul >= 0:
                raise InputError(f"{option}: {path} is binary (a NUL byte at byte {offset + nul}); expected text")
            try:
                decoder.decode(chunk, final=not chunk)
            except UnicodeDecodeError as exc:
                raise InputError(f"{option}: {path} is not UTF-8 text ({exc.reason} at byte {offset + exc.start})") \
                    from None
            if not chunk:
                return
            offset += len(chunk)


def check_paths(args, paths) -> owned.Declared:
    """Validate every path option of a command before it runs (see the module docstring) and return
    them resolved, for :func:`fxdsp.owned.declaring`. ``paths`` maps the option as the user types it
    (``--out``, or a positional's name) to its kind; it may be a function of ``args`` (``--check``
    turns an output folder into an input)."""
    if callable(paths):
        paths = paths(args)
    seen: dict[Path, tuple[str, str]] = {}
    declared = owned.Declared()
    for option, kind in paths.items():
        value = getattr(args, option.lstrip("-").replace("-", "_"), None)
        if value is None or value == "-":
            continue
        raw = str(value)
        # "" and "  " are no paths (pathlib reads "" as ".": the command would write into the
        # current folder); a NUL no file system accepts
        if not raw.strip():
            raise InputError(f"{option}: an empty path ({raw!r}); name a {_WHAT[kind]}")
        if "\0" in raw:
            raise InputError(f"{option}: {raw!r} holds a NUL character, which no path can")
        path = Path(value)
        # pathlib reads "f.txt/." as "f.txt": a name that ends like a folder is not a file
        if kind in (IN, OUT_FILE) and (raw.endswith(("/", "/.", "/..")) or raw in (".", "..")):
            raise InputError(f"{option}: {raw} names a folder, expected a file")
        if kind == IN:
            if path.is_dir():
                raise InputError(f"{option}: {path} is a directory, expected a file")
            if path.is_file():
                check_text_input(path, option)
        elif kind == IN_DIR:
            if path.exists() and not path.is_dir():
                raise InputError(f"{option}: {path} is not a directory")
        else:
            check_output(path, kind, option)
        key = path.resolve()
        if key in seen:
            other, other_kind = seen[key]
            inputs = (IN, IN_DIR)
            if kind not in inputs or other_kind not in inputs:
                what = "an input" if kind in inputs or other_kind in inputs else "another output"
                raise InputError(f"{option}: {path} is also {other}: an output must not overwrite {what}")
        seen[key] = (option, kind)
        {IN: declared.inputs, IN_DIR: declared.input_dirs, OUT_DIR: declared.out_dirs}.get(kind, {})[key] = option
    owned.guard_owned_inputs(declared)
    return declared


def plain(value):
    """``value`` as plain JSON data: numpy scalars and arrays made Python, tuples lists, keys text,
    non-finite floats None (strict JSON has no inf or nan; a task that needs them says so itself)."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def json_text(data, what: str, **kw) -> str:
    """Strict JSON (no NaN or Infinity tokens): a non-finite number is refused with one line naming
    ``what`` (the option or report it was going to), never written."""
    try:
        return json.dumps(data, allow_nan=False, **kw) + "\n"
    except ValueError:
        where = _non_finite_in(data, "") or "a value"
        raise InputError(f"{what}: {where} of the result is not a finite number (nan or inf); nothing written") from None


_NON_FINITE = re.compile(r"^[-+]?(nan|inf|infinity)$", re.I)
_NON_FINITE_CELL = re.compile(r"(?:^|,)\s*[-+]?(?:nan|inf|infinity)\s*(?:,|$)", re.I | re.M)


def non_finite_value(path: Path) -> str | None:
    """Where a file that readers parse as numbers holds a non-finite one (the column and row of a CSV,
    the key of a JSON or TOML file), None when it holds none or is of another kind. Every output goes
    through :meth:`Stage.commit`, which refuses such a file: no command writes ``nan`` or ``inf`` text
    into a CSV, JSON or TOML output, whichever writer made it."""
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".json", ".toml"):
        return None
    text = path.read_text(encoding="utf-8", errors="replace")
    if suffix == ".csv":
        if not _NON_FINITE_CELL.search(_csv_body(text)):   # the usual case, even at 10^6 rows: scans in C
            return None
        header = None
        for n, line in enumerate(text.splitlines(), 1):
            if not line.strip() or line.startswith("#"):
                continue
            cells = [c.strip() for c in line.split(",")]
            if header is None:
                header = cells
                continue
            for k, cell in enumerate(cells):
                if _NON_FINITE.match(cell):
                    return f"column {header[k] if k < len(header) else k + 1!r} at line {n}"
        return None
    if suffix == ".json":
        try:
            data = json.loads(text, parse_constant=lambda c: float("nan"))
        except ValueError:
            return None
    else:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError:
            return None
    return _non_finite_in(data, "")


def _csv_body(text: str) -> str:
    """The data rows of a CSV: after its `#` comment lines and its header row. Numbers printed by a
    machine hold no letter n or i, so a body without either holds no non-finite cell."""
    start = 0
    while text.startswith("#", start) or text.startswith("\n", start):
        start = text.find("\n", start) + 1 or len(text)
    body = text[text.find("\n", start) + 1:] if "\n" in text[start:] else ""
    return body if any(c in body for c in "nNiI") else ""


def _non_finite_in(data, key: str) -> str | None:
    if isinstance(data, float) and not math.isfinite(data):
        return f"key {key or '(the value)'!r}"
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for k, v in items:
        found = _non_finite_in(v, f"{key}.{k}" if key else str(k))
        if found:
            return found
    return None


def write_tree(folder: Path, tree: dict[str, dict[str, str]], encoding: str = "ascii") -> None:
    """``{subfolder: {relative path: text}}`` written under ``folder`` (a staged folder: see
    :class:`Stage`), the folders made as needed."""
    for sub, files in tree.items():
        for rel, text in files.items():
            path = Path(folder) / sub / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding=encoding)


class Stage:
    """Staged outputs: :meth:`path` gives where to write the file that will become ``final``."""

    def __init__(self):
        self._dirs: dict[Path, Path] = {}        # nearest existing ancestor -> its staging folder
        self._moves: list[tuple[Path, Path]] = []  # (staged file, final file)
        self._trees: list[tuple[Path, Path]] = []  # (staged folder, final folder): every file in it
        self._removals: list[Path] = []            # stale files of a replaced set

    def _staged(self, final: Path) -> Path:
        base = _nearest_existing(final.parent)
        if base not in self._dirs:
            self._dirs[base] = Path(tempfile.mkdtemp(prefix=".fxdsp-staging-", dir=base))
        return self._dirs[base] / final.resolve().relative_to(base.resolve())

    def path(self, final: str | Path) -> Path:
        """Where to write the file that becomes ``final``."""
        final = Path(final)
        if _direct():
            final.parent.mkdir(parents=True, exist_ok=True)
            return final
        owned.guard_replace(final)   # refused before the file is even written
        staged = self._staged(final)
        staged.parent.mkdir(parents=True, exist_ok=True)
        self._moves.append((staged, final))
        return staged

    def dir(self, final: str | Path) -> Path:
        """A folder whose files (at any depth) become the files of ``final`` (others there are kept)."""
        final = Path(final)
        if _direct():
            final.mkdir(parents=True, exist_ok=True)
            return final
        staged = self._staged(final)
        staged.mkdir(parents=True, exist_ok=True)
        self._trees.append((staged, final))
        return staged

    def write_text(self, final: str | Path, text: str, encoding: str = "utf-8") -> None:
        self.path(final).write_text(text, encoding=encoding)

    def moves(self) -> list[tuple[Path, Path]]:
        """(staged file, the file it becomes) for every file written so far."""
        moves = list(self._moves)
        for staged, final in self._trees:
            moves += [(f, final / f.relative_to(staged)) for f in sorted(staged.rglob("*")) if not f.is_dir()]
        return moves

    def commit(self) -> None:
        moves = self.moves()
        for staged, final in moves:   # before any move: a refused file leaves every target as it was
            where = non_finite_value(staged)
            if where:
                raise InputError(f"{final}: {where} is not a finite number (nan or inf); nothing written")
            owned.guard_replace(final)
        written = owned.digests(moves)
        removals = [final for final in self._removals if owned.may_remove(final)]
        with interrupts_held():
            for staged, final in moves:
                final.parent.mkdir(parents=True, exist_ok=True)
                os.replace(staged, final)
            for final in removals:
                final.unlink(missing_ok=True)
            owned.update(written, removals)
        self.discard()

    def remove(self, final: str | Path) -> None:
        """Delete ``final`` when the staged files are moved into place (a file the new set lacks);
        in a folder output only if fxdsp wrote it there (:func:`fxdsp.owned.may_remove`)."""
        if _direct():
            Path(final).unlink(missing_ok=True)
        else:
            self._removals.append(Path(final))

    def final_of(self, staged: str | Path) -> Path | None:
        """The target a staged path stands for (to name it in an error), or None."""
        staged = Path(staged)
        for s, final in self._moves:
            if s == staged:
                return final
        for s, final in self._trees:
            if staged == s or s in staged.parents:
                return final / staged.relative_to(s)
        return None

    def discard(self) -> None:
        for folder in self._dirs.values():
            shutil.rmtree(folder, ignore_errors=True)
        self._dirs.clear()
        self._moves.clear()
        self._trees.clear()
        self._removals.clear()


@contextmanager
def staged():
    """A :class:`Stage` whose files replace their targets together if the block succeeds, and are
    dropped (targets untouched) if it raises or is interrupted."""
    stage = Stage()
    try:
        yield stage
    except OSError as exc:  # name the target, not its staging copy
        final = stage.final_of(exc.filename) if exc.filename else None
        stage.discard()
        if final is not None:
            raise OSError(exc.errno, exc.strerror, str(final)) from exc
        raise
    except BaseException:
        stage.discard()
        raise
    try:
        stage.commit()   # refuses (a non-finite number, a file it does not own) before any move
    except BaseException:
        stage.discard()
        raise
