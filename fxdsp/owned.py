"""Folder outputs own only their files: what fxdsp wrote in each folder it writes into.

Every folder a command writes into (a ``PATHS`` entry of kind ``OUT_DIR``, see :mod:`fxdsp.outputs`)
holds a record, :data:`RECORD`, in ``sha256sum`` format: each file fxdsp wrote there with the
content it wrote (``sha256sum -c .fxdsp-owned`` verifies it). In such a folder a command replaces
or removes only a file that the record lists with its present content:

* a file it would replace that the record does not list (a user's own file of the same name), or
  that was changed since (edited by hand), is refused before anything moves: one line naming it,
  and every file stays as it was;
* a stale file of a set it would remove is kept when the record does not list it;
* no input file of the run is ever replaced, wherever it lies; an input that a folder output owns
  (a previous run's output given back as this run's input) is refused before any work, since this
  run may write over it.

The command line declares each run's paths (:func:`declaring`, from the command's ``PATHS``); a
library caller that passes paths itself declares none, and nothing here applies to its writes.
"""

from __future__ import annotations

import hashlib
import os
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path

from fxdsp.errors import InputError

RECORD = ".fxdsp-owned"
# the digest recorded for a file fxdsp appends to while it runs (a sweep's journal): owned whatever it holds
APPENDED = "0" * 64
_HEADER = ("# fxdsp: the files it wrote in this folder and their sha256 (sha256sum -c checks them);\n"
           "# it replaces or removes no other file here\n")


@dataclass
class Declared:
    """The resolved paths of one run, each with the option that named it."""
    inputs: dict[Path, str] = field(default_factory=dict)      # input files
    input_dirs: dict[Path, str] = field(default_factory=dict)  # input folders
    out_dirs: dict[Path, str] = field(default_factory=dict)    # folder outputs

    def root_of(self, final: Path) -> Path | None:
        """The declared folder output holding ``final`` (the innermost), or None."""
        path = Path(final).resolve()
        holders = [r for r in self.out_dirs if path.is_relative_to(r) and path != r]
        return max(holders, key=lambda r: len(r.parts)) if holders else None


_CURRENT: ContextVar[Declared | None] = ContextVar("fxdsp_declared_paths", default=None)


@contextmanager
def declaring(declared: Declared):
    """The paths of the command running inside the block (set by the command line)."""
    token = _CURRENT.set(declared)
    try:
        yield declared
    finally:
        _CURRENT.reset(token)


def current() -> Declared | None:
    return _CURRENT.get()


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def read_record(root: Path) -> dict[str, str]:
    """relative path -> sha256 of what fxdsp wrote in ``root``; {} without a (readable) record.
    A line that is not ``<64 hex digits>  <path>`` owns nothing."""
    try:
        text = (Path(root) / RECORD).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return {}
    owned = {}
    for line in text.splitlines():
        digest, sep, rel = line.partition("  ")
        if sep and len(digest) == 64 and all(c in "0123456789abcdef" for c in digest) and rel:
            owned[rel] = digest
    return owned


def record_text(owned: dict[str, str]) -> str:
    return _HEADER + "".join(f"{owned[rel]}  {rel}\n" for rel in sorted(owned))


def _is_ours(root: Path, path: Path) -> bool:
    digest = read_record(root).get(path.relative_to(root).as_posix())
    return digest is not None and (digest == APPENDED or digest == file_sha256(path))


def guard_replace(final: Path) -> None:
    """InputError when writing ``final`` would replace an input of the run, or a file in a folder
    output that fxdsp did not write there (or that was changed since)."""
    declared = current()
    if declared is None:
        return
    path = Path(final).resolve()
    if path in declared.inputs:
        raise InputError(f"{final} is the input {declared.inputs[path]}: the output would write over it; "
                         f"nothing written")
    if not path.is_file():
        return
    for folder, option in declared.input_dirs.items():
        if path.is_relative_to(folder):
            raise InputError(f"{final} is in the input folder {option} ({folder}): the output would write over it; "
                             f"nothing written")
    root = declared.root_of(path)
    if root is not None and not _is_ours(root, path):
        rel = path.relative_to(root).as_posix()
        why = "was changed since fxdsp wrote it" if rel in read_record(root) else "was not written by fxdsp"
        raise InputError(f"{declared.out_dirs[root]}: {final} {why} (see {root / RECORD}): move it away or "
                         f"choose another folder; nothing written")


def may_remove(final: Path) -> bool:
    """Whether a stale file of a replaced set may go: in a declared folder output only when fxdsp
    wrote it there and it is unchanged (a library caller's own folders: always)."""
    declared = current()
    if declared is None:
        return True
    path = Path(final).resolve()
    root = declared.root_of(path)
    if root is None:
        return path not in declared.inputs
    return path.is_file() and _is_ours(root, path)


def guard_owned_inputs(declared: Declared) -> None:
    """InputError when an input file is one that a folder output of the run owns (before any work)."""
    for path, option in declared.inputs.items():
        root = declared.root_of(path)
        if root is not None and path.is_file() and _is_ours(root, path):
            raise InputError(f"{option}: {path} is a file fxdsp wrote in the output folder {declared.out_dirs[root]} "
                             f"({root}), which this run may replace: copy it elsewhere first")


def claim(final: Path) -> None:
    """For a file a command writes in place (not staged, e.g. a journal appended to as the run goes):
    refuse it as :func:`guard_replace` does, then list it as fxdsp's whatever it will hold."""
    guard_replace(final)
    update({Path(final): APPENDED}, [])


def digests(moves) -> dict[Path, str]:
    """sha256 of each staged file (``(staged, final)`` pairs) that becomes a file of a declared
    folder output: what :func:`update` records once it is moved."""
    declared = current()
    if declared is None:
        return {}
    return {final: file_sha256(staged) for staged, final in moves if declared.root_of(final) is not None}


def update(written: dict[Path, str], removed: list[Path]) -> None:
    """Record files moved into declared folder outputs (final -> sha256 of what was written) and drop
    removed ones; entries whose file is gone are dropped too. Each record is replaced whole (written
    aside, then renamed)."""
    declared = current()
    if declared is None:
        return
    changes: dict[Path, dict[str, str]] = {}
    for final, digest in written.items():
        root = declared.root_of(final)
        if root is not None:
            changes.setdefault(root, {})[Path(final).resolve().relative_to(root).as_posix()] = digest
    for final in removed:
        root = declared.root_of(final)
        if root is not None:
            changes.setdefault(root, {})[Path(final).resolve().relative_to(root).as_posix()] = ""
    for root, entries in changes.items():
        owned = read_record(root)
        for rel, digest in entries.items():
            if digest:
                owned[rel] = digest
            else:
                owned.pop(rel, None)
        owned = {rel: d for rel, d in owned.items() if (root / rel).is_file() or d == APPENDED}
        root.mkdir(parents=True, exist_ok=True)
        tmp = root / (RECORD + ".tmp")
        tmp.write_text(record_text(owned), encoding="utf-8")
        os.replace(tmp, root / RECORD)
