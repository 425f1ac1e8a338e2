"""Golden vectors: per block and per chain, ``$readmemh`` hex files of every input and expected
output, and a ``manifest.json`` with formats, parameters, seed, sample count and sha256 of every file.

Hex encoding: one word per line, two's complement in ceil(wl/4) hex digits (lower case), exactly
what ``$readmemh`` loads into a ``reg [wl-1:0] mem [0:n-1]``. Deterministic: the same config and
seed give byte-identical files (the manifest's sha256 values prove it).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from fxdsp.chains import Design, stream_key
from fxdsp.fixed import Format
from fxdsp.fixed.hexfile import hex_words, read_hex_words
from fxdsp.outputs import staged

MANIFEST = "manifest.json"


def to_hex_lines(q: np.ndarray, fmt: Format) -> str:
    """Stored integers of ``fmt`` -> $readmemh text (the one encoder, :func:`fxdsp.fixed.hexfile.hex_words`)."""
    return hex_words(q, fmt.wl)


def from_hex_lines(text: str, fmt: Format) -> np.ndarray:
    """$readmemh text -> stored integers of ``fmt`` (sign-extended when signed)."""
    return read_hex_words(text, fmt.wl, fmt.signed)


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode("ascii")).hexdigest()


def generate(design: Design) -> dict[str, str]:
    """All vector files in memory: relative path -> text (manifest included)."""
    files: dict[str, str] = {}
    manifest: dict = {"generator": "fxdsp vectors", "config": design.config.name, "seed": design.seed,
                      "samples": design.samples, "hex": "two's complement, ceil(wl/4) digits per line",
                      "blocks": {}}
    for name, block in design.all.items():
        # each block its own stream, keyed by its name: adding a block never changes another's vectors
        rng = np.random.default_rng([design.seed, stream_key(name)])
        stim = block.stimulus(rng, design.samples)
        result = block.run(**stim)
        n = len(next(iter(stim.values())))
        entry = {"samples": n, "inputs": {}, "outputs": {}, "overflows": dict(result.overflows),
                 "parameters": block.parameters()}
        for kind, ports, data in (("inputs", block.inputs, stim), ("outputs", block.outputs, result.outputs)):
            for port, fmt in ports.items():
                rel = f"{name}/{port}.hex"
                text = to_hex_lines(data[port], fmt)
                files[rel] = text
                entry[kind][port] = {"file": rel, "format": str(fmt), "signed": fmt.signed, "wl": fmt.wl,
                                     "fl": fmt.fl, "sha256": _sha256(text)}
        manifest["blocks"][name] = entry
    files[MANIFEST] = json.dumps(manifest, indent=1, sort_keys=True, allow_nan=False) + "\n"
    return files


def _previous_set(files: dict[str, str], out: Path, patterns: tuple[str, ...]) -> list[Path]:
    """The files a previous set in ``out`` owned: those its manifest listed (a set with a manifest
    owns nothing else, so ``--out .`` cannot reach other files), else the files matching ``patterns``."""
    if not out.is_dir():
        return []
    if MANIFEST not in files:
        return sorted({p for pattern in patterns for p in out.glob(pattern)})
    try:
        old = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
        return [out / port["file"] for entry in old["blocks"].values() for kind in ("inputs", "outputs")
                for port in entry[kind].values()]
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return []   # no readable previous manifest: nothing is known to be ours


def write(files: dict[str, str], out: Path, patterns: tuple[str, ...] = ("**/*.hex",)) -> None:
    """The set replaced as a whole: every file staged first, then all moved into place together, and
    the files of the previous set that this one lacks removed in the same step (:mod:`fxdsp.outputs`).
    An interrupted run leaves the previous set, manifest included, as it was."""
    with staged() as stage:
        for rel, text in files.items():
            stage.write_text(out / rel, text, encoding="ascii")
        for path in _previous_set(files, out, patterns):
            if path.resolve().parent.is_relative_to(out.resolve()) and path.relative_to(out).as_posix() not in files:
                stage.remove(path)


# what the manifest records of the config's name (its file's, for whoever reads the set): not its
# content, which every vector and parameter entry carries; a check compares contents
NAME_ONLY = ("config",)


def _same_manifest(rel: str, on_disk: str, text: str) -> bool:
    """Whether two manifests differ only in the config's name (the same config at another path)."""
    if rel != MANIFEST:
        return False
    try:
        a, b = json.loads(on_disk), json.loads(text)
    except ValueError:
        return False
    if not (isinstance(a, dict) and isinstance(b, dict)):
        return False
    return {k: v for k, v in a.items() if k not in NAME_ONLY} == {k: v for k, v in b.items() if k not in NAME_ONLY}


def check(files: dict[str, str], out: Path, patterns: tuple[str, ...] = ("**/*.hex",)) -> list[str]:
    """Differences between freshly generated files and those on disk (empty list: identical); files
    on disk matching ``patterns`` that the generator does not produce are reported too."""
    problems = []
    for rel, text in sorted(files.items()):
        path = out / rel
        if not path.exists():
            problems.append(f"missing: {rel}")
            continue
        on_disk = path.read_text(encoding="ascii", errors="replace")
        if on_disk != text and not _same_manifest(rel, on_disk, text):
            a, b = on_disk.splitlines(), text.splitlines()
            line = next((i + 1 for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)) + 1)
            problems.append(f"differs: {rel} (first at line {line})")
    known = set(files)
    if out.is_dir():
        for path in sorted({p for pattern in patterns for p in out.glob(pattern)}):
            rel = path.relative_to(out).as_posix()
            if rel not in known:
                problems.append(f"unexpected: {rel}")
    return problems


def write_or_check(files: dict[str, str], out: Path, check_only: bool,
                   patterns: tuple[str, ...] = ("**/*.hex",)) -> list[str]:
    """The generate-or-``--check`` step shared by every command that writes committed files: with
    ``check_only`` the differences against ``out`` (see :func:`check`; empty when identical),
    otherwise write the files and return no differences. Reporting is the command's job."""
    if check_only:
        return check(files, out, patterns)
    write(files, out, patterns)
    return []


def load(out: Path, name: str) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict]:
    """Read one block's committed vectors: (inputs, expected outputs, manifest entry)."""
    return _load(lambda rel: (Path(out) / rel).read_text(), name)


def load_generated(files: dict[str, str], name: str) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict]:
    """One block's vectors from a set :func:`generate` returned (the texts it writes), as :func:`load`."""
    return _load(files.__getitem__, name)


def _load(read, name: str):
    manifest = json.loads(read(MANIFEST))
    entry = manifest["blocks"][name]
    data = {}
    for kind in ("inputs", "outputs"):
        data[kind] = {port: from_hex_lines(read(spec["file"]), Format.parse(spec["format"]))
                      for port, spec in entry[kind].items()}
    return data["inputs"], data["outputs"], entry
