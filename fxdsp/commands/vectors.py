"""`fxdsp vectors [--config F] [--out DIR] [--check]`: write or verify the golden vectors."""

from __future__ import annotations

import sys
from pathlib import Path

from ..chains import build
from ..vectors import check, generate, write


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--out", default="vectors", help="directory of the vectors (default: vectors)")
    parser.add_argument("--check", action="store_true",
                        help="regenerate in memory and compare with --out; exit 1 on any difference")


def run(args) -> int:
    design = build(args.config)
    files = generate(design)
    out = Path(args.out)
    if args.check:
        problems = check(files, out)
        if problems:
            for p in problems[:20]:
                print(p, file=sys.stderr)
            print(f"fxdsp vectors: {len(problems)} difference(s) against {out}", file=sys.stderr)
            return 1
        print(f"vectors in {out} match the models ({len(files)} files)")
        return 0
    write(files, out)
    n_blocks = len(design.all)
    print(f"wrote {len(files)} files for {n_blocks} blocks and chains to {out}")
    return 0
