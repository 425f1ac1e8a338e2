"""`fxdsp hdl-gen [--config F] [--out DIR] [--check]`: write (or verify) the Verilog parameter
headers and ROM files of every RTL block instance, and the Verilog top of every chain
(``<chain>.v``, :mod:`fxdsp.hdl.chain_top`: no chain top is written by hand), from the same config
as the models."""

from __future__ import annotations

from pathlib import Path

from fxdsp.chains import build
from fxdsp.commands.generated import sync_generated
from fxdsp.outputs import IN, IN_DIR, OUT_DIR
from fxdsp.hdl.params import generate


def PATHS(args) -> dict:
    return {"--config": IN, "--out": IN_DIR if args.check else OUT_DIR}


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="directory of the generated files (the project's own: hdl/gen, `make hdl-gen`)")
    parser.add_argument("--check", action="store_true",
                        help="regenerate in memory and compare with --out; exit 1 on any difference")


def run(args) -> int:
    design = build(args.config)
    design.with_rtl()
    files = generate(design)
    return sync_generated(files, Path(args.out), args.check, "hdl-gen", patterns=("*.vh", "*.hex"))
