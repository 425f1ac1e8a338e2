"""Golden vectors: per block and per chain, ``$readmemh`` hex files of every input and expected
output, and a ``manifest.json`` with formats, parameters, seed, sample count and sha256 of every file.

Hex encoding: one word per line, two's complement in ceil(wl/4) hex digits (lower case), exactly
what ``$readmemh`` loads into a ``reg [wl-1:0] mem [0:n-1]``. Deterministic: the same config and
seed give byte-identical files (the manifest's sha256 values prove it).
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

from .chains import Design
from .fixed import Format

MANIFEST = "manifest.json"


def to_hex_lines(q: np.ndarray, fmt: Format) -> str:
    """Stored integers -> $readmemh text (two's complement, ceil(wl/4) digits per word)."""
    digits = -(-fmt.wl // 4)
    mask = (1 << fmt.wl) - 1
    words = (np.asarray(q, dtype=np.int64).astype(object) & mask) if fmt.wl > 62 else \
        (np.asarray(q, dtype=np.int64) & np.int64(mask))
    return "".join(f"{int(w):0{digits}x}\n" for w in words)


def from_hex_lines(text: str, fmt: Format) -> np.ndarray:
    """$readmemh text -> stored integers of ``fmt`` (sign-extended when signed)."""
    vals = []
    for ln, line in enumerate(text.splitlines(), 1):
        line = line.split("//")[0].strip()
        if not line:
            continue
        try:
            w = int(line, 16)
        except ValueError:
            raise ValueError(f"line {ln}: {line!r} is not a hex word") from None
        if w >> fmt.wl:
            raise ValueError(f"line {ln}: {line!r} does not fit {fmt.wl} bits")
        if fmt.signed and w >> (fmt.wl - 1):
            w -= 1 << fmt.wl
        vals.append(w)
    return np.array(vals, dtype=np.int64)


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode("ascii")).hexdigest()


def generate(design: Design) -> dict[str, str]:
    """All vector files in memory: relative path -> text (manifest included)."""
    files: dict[str, str] = {}
    manifest: dict = {"generator": "fxdsp vectors", "config": design.config.source, "seed": design.seed,
                      "samples": design.samples, "hex": "two's complement, ceil(wl/4) digits per line",
                      "blocks": {}}
    for index, (name, block) in enumerate(design.all.items()):
        # each block its own stream, derived from (seed, index): adding a block never changes another's vectors
        rng = np.random.default_rng([design.seed, index])
        stim = block.stimulus(rng, design.samples)
        block.reset()
        result = block.run(**stim)
        block.reset()
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
    files[MANIFEST] = json.dumps(manifest, indent=1, sort_keys=True) + "\n"
    return files


def write(files: dict[str, str], out: Path) -> None:
    for rel, text in files.items():
        path = out / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="ascii")


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
        if on_disk != text:
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


def write_or_check(files: dict[str, str], out: Path, check_only: bool, command: str,
                   patterns: tuple[str, ...] = ("**/*.hex",)) -> int:
    """The generate-or-``--check`` step shared by every command that writes committed files:
    exit 1 with the differences on stderr, 0 when identical or written."""
    if check_only:
        problems = check(files, out, patterns)
        if problems:
            for p in problems[:20]:
                print(p, file=sys.stderr)
            print(f"fxdsp {command}: {len(problems)} difference(s) against {out}", file=sys.stderr)
            return 1
        print(f"{out}: {len(files)} files match the config")
        return 0
    write(files, out)
    print(f"wrote {len(files)} files to {out}")
    return 0


def load(out: Path, name: str) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict]:
    """Read one block's committed vectors: (inputs, expected outputs, manifest entry)."""
    manifest = json.loads((out / MANIFEST).read_text())
    entry = manifest["blocks"][name]
    data = {}
    for kind in ("inputs", "outputs"):
        data[kind] = {port: from_hex_lines((out / spec["file"]).read_text(), Format.parse(spec["format"]))
                      for port, spec in entry[kind].items()}
    return data["inputs"], data["outputs"], entry
