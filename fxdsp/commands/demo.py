"""`fxdsp demo`: the main job on the built-in default configuration.

Generates the golden vectors into ``vectors/`` and prints, for every block and chain, the float
vs fixed difference on its nominal stimulus (in LSBs and physical units), plus the RTD readout's
error against the true temperature.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fxdsp.chains import build
from fxdsp.float_vs_fixed import all_errors, format_table
from fxdsp.outputs import IN, OUT_DIR
from fxdsp.vectors import generate, write


PATHS = {"--config": IN, "--out": OUT_DIR}


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--out", default="vectors", help="where to write the golden vectors (default: vectors)")


def rtd_true_error(design) -> str:
    """True temperature -> bridge -> ADC -> fixed conversion, against the true temperature."""
    rtd = design.blocks["rtd"]
    t = np.linspace(-20.0, 60.0, 8001)
    got = rtd.real_outputs(rtd.run(code=rtd.adc_code(t)))["temp"]
    e = got - t
    return (f"RTD readout vs true temperature over -20..60 C ({rtd.physics.law} law, {rtd.adc_format.wl}-bit ADC, "
            f"{2**rtd.k} LUT segments): max |e| {np.abs(e).max() * 1e3:.2f} mC, rms {np.sqrt(np.mean(e**2)) * 1e3:.2f} mC")


def run(args) -> int:
    design = build(args.config)
    files = generate(design)
    out = Path(args.out)
    write(files, out)
    print(f"fxdsp demo: config {design.config.source}, seed {design.seed}")
    print(f"golden vectors: {len(files)} files for {len(design.all)} blocks and chains written to {out}/")
    print()
    print("float reference vs bit-exact model, nominal stimulus of each block:")
    print(format_table(all_errors(design)))
    print()
    print(rtd_true_error(design))
    return 0
