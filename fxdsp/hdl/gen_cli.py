"""`fxdsp hdl-gen [--config F] [--out DIR] [--check]`: write (or verify) the Verilog parameter
headers and ROM files of every RTL block instance, from the same config as the models."""

from __future__ import annotations

import sys
from pathlib import Path

from ..chains import build
from .params import generate


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--out", default="hdl/gen", help="directory of the generated files (default: hdl/gen)")
    parser.add_argument("--check", action="store_true",
                        help="regenerate in memory and compare with --out; exit 1 on any difference")


def check(files: dict[str, str], out: Path) -> list[str]:
    problems = []
    for rel, text in sorted(files.items()):
        path = out / rel
        if not path.exists():
            problems.append(f"missing: {rel}")
        elif path.read_text(encoding="ascii", errors="replace") != text:
            problems.append(f"differs: {rel}")
    if out.is_dir():
        for path in sorted(list(out.glob("*.vh")) + list(out.glob("*.hex"))):
            if path.name not in files:
                problems.append(f"unexpected: {path.name}")
    return problems


def run(args) -> int:
    files = generate(build(args.config))
    out = Path(args.out)
    if args.check:
        problems = check(files, out)
        if problems:
            for p in problems[:20]:
                print(p, file=sys.stderr)
            print(f"fxdsp hdl-gen: {len(problems)} difference(s) against {out}", file=sys.stderr)
            return 1
        print(f"hdl files in {out} match the config ({len(files)} files)")
        return 0
    out.mkdir(parents=True, exist_ok=True)
    for rel, text in files.items():
        (out / rel).write_text(text, encoding="ascii")
    print(f"wrote {len(files)} files to {out}")
    return 0
