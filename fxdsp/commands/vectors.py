"""`fxdsp vectors [--config F] [--out DIR] [--check]`: write or verify the golden vectors."""

from __future__ import annotations

from pathlib import Path

from fxdsp.chains import build
from fxdsp.outputs import IN, IN_DIR, OUT_DIR
from fxdsp.vectors import generate
from fxdsp.commands.generated import sync_generated


def PATHS(args) -> dict:
    return {"--config": IN, "--out": IN_DIR if args.check else OUT_DIR}


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--out", default="vectors", help="directory of the vectors (default: vectors)")
    parser.add_argument("--check", action="store_true",
                        help="regenerate in memory and compare with --out; exit 1 on any difference")


def run(args) -> int:
    design = build(args.config)
    return sync_generated(generate(design), Path(args.out), args.check, "vectors")
