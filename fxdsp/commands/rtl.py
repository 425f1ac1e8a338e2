"""``fxdsp rtl [--config F] [--only NAMES] [--sim icarus|verilator] [--waves] --out DIR``

The RTL regression of exactly the design in F (default: the built-in config): its golden vectors
(``DIR/vectors``) and Verilog headers and ROMs (``DIR/hdl``) are written, and every block and chain
of F (or those named) is simulated in each of its variants against the bit-exact model of F
(:mod:`fxdsp.hdl.regression`: golden, random with input gaps, corners, a long stream).
``DIR/report.md`` and ``DIR/report.json``: per DUT the samples, cycles per sample and verdict, for a
failure the first mismatch (DUT, stream, sample index, port, got, expected) and a waveform
(``DIR/waves/*.vcd``) of a window around it; ``--waves`` writes one for every DUT.

Exit status: 0 when every DUT is bit-exact, 1 on any mismatch, 2 on bad input or a missing
simulator (one line saying what to install). DIR is written whole or not at all.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from fxdsp.commands.options import SEED, count
from fxdsp.outputs import IN, IN_DIR, OUT_DIR

PATHS = {"--config": IN, "--rtl": IN_DIR, "--out": OUT_DIR, "--cache": OUT_DIR}
# Icarus builds no model to cache (fxdsp.cli refuses the option rather than ignore it)
ONLY_WITH = {"--cache": ("--sim=verilator",)}


def _cache_default() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "fxdsp" / "verilator"


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--only", default=None, metavar="NAMES",
                        help="comma-separated blocks or chains to simulate (default: every one of the config)")
    parser.add_argument("--sim", default="icarus", choices=("icarus", "verilator"), help="simulator (default icarus)")
    parser.add_argument("--waves", action="store_true",
                        help="write a waveform of every DUT's golden stream too (failures always get one)")
    parser.add_argument("--long", type=count(), default=None, metavar="N",
                        help="samples of the long stream (default: 100000 on Verilator; 20000, serial 2000, on Icarus)")
    parser.add_argument("--seed", type=SEED, default=1, help="seed of the random and long streams (default 1)")
    parser.add_argument("--rtl", default=None, metavar="DIR", help="Verilog sources (default: the RTL in the package)")
    parser.add_argument("--cache", default=None, metavar="DIR",
                        help="Verilator model cache (default: $XDG_CACHE_HOME/fxdsp/verilator or ~/.cache/...)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder: vectors, headers, report, waves")


def run(args) -> int:
    from fxdsp.chains import build
    from fxdsp.errors import InputError
    from fxdsp.outputs import json_text, staged, write_tree
    from fxdsp.hdl.params import design_files
    from fxdsp.hdl.regression import duts, markdown, regression

    only = [n.strip() for n in args.only.split(",") if n.strip()] if args.only is not None else None
    if only is not None and not only:
        raise InputError("--only: no block or chain named")
    if args.rtl is not None and not sorted(Path(args.rtl).glob("*.v")):
        raise InputError(f"--rtl: no Verilog sources (*.v) in {args.rtl}")
    design = build(args.config)
    design.with_rtl()
    duts(design, only)   # an unknown name, or one without RTL, is bad input before any work
    models = None
    if args.sim == "verilator":
        models = Path(args.cache) if args.cache else _cache_default()
        models.mkdir(parents=True, exist_ok=True)
    files = design_files(design)        # what is written is what the golden streams check
    with staged() as stage:
        out = stage.dir(args.out)
        report = regression(design, files["vectors"], out, sim=args.sim, only=only, waves=args.waves,
                            rtl=Path(args.rtl) if args.rtl else None, models=models, seed=args.seed, long_n=args.long)
        write_tree(out, files)
        (out / "report.json").write_text(json_text(report, "report.json", indent=1), encoding="utf-8")
        (out / "report.md").write_text(markdown(report), encoding="utf-8")
    bad = [r for r in report["duts"] if not r["passed"]]
    for r in bad:
        m = r["first_mismatch"]
        failing = [(s, v) for s, v in r["streams"].items() if not v["ok"]]
        where = (f"{m['stream']} stream, sample {m['sample']}, port {m['port']}: got {m['got_value']}, expected "
                 f"{m['expected_value']}") if m else f"{failing[0][0]} stream: {failing[0][1]['errors'][0]}" + \
            (f" (and {len(failing) - 1} more stream(s))" if len(failing) > 1 else "")
        sys.stdout.write(f"rtl: MISMATCH {r['dut']}: {where}"
                         + (f"; waveform {Path(args.out) / r['waves'][0]['file']}" if r["waves"] else "") + "\n")
    sys.stdout.write(f"rtl: {len(report['duts']) - len(bad)} of {len(report['duts'])} DUTs bit-exact on "
                     f"{args.sim} in {report['seconds']} s; report {Path(args.out) / 'report.md'}\n")
    return 1 if bad else 0
