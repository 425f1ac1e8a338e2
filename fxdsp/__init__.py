"""fxdsp: bit-accurate fixed-point models of the FPGA blocks that temperature-compensate
vibratory inertial sensors, their float references, golden vectors and error budgets.

The library API (each name imported on first use, so that ``import fxdsp`` and the command line
stay quick: numba and the blocks load only when a name that needs them is touched)::

    import numpy as np
    import fxdsp

    design = fxdsp.build(fxdsp.load_config())            # or build("my.toml"); every block and chain
    iir = design.blocks["iir"]
    codes = fxdsp.quantize(np.full(64, 0.25), iir.inputs["x"])   # real -> stored integers
    result = iir.run(x=codes)                            # bit-exact: stored integers in and out
    y = fxdsp.to_real(result.outputs["y"], iir.outputs["y"])     # stored -> real
    ref = iir.reference(x=np.full(64, 0.25))["y"]        # the float model, on real values

``run`` refuses floats and ``reference`` refuses integer arrays; ``run_real`` quantises real inputs
with the port formats, ``run_float`` feeds the reference the real values of stored inputs.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

# public name -> module that defines it (imported on first access, PEP 562)
_EXPORTS: dict[str, str] = {
    "build": "fxdsp.chains",
    "load_config": "fxdsp.config",
    "Config": "fxdsp.config",
    "quantize": "fxdsp.api",
    "to_real": "fxdsp.api",
    "Format": "fxdsp.fixed.format",
    "Rules": "fxdsp.fixed.rules",
    "OverflowLog": "fxdsp.fixed.ops",
    "Design": "fxdsp.chains",
    "Block": "fxdsp.blocks.base",
    "Result": "fxdsp.blocks.base",
    "Rtd": "fxdsp.blocks.rtd",
    "Lag": "fxdsp.blocks.lag",
    "Piecewise": "fxdsp.blocks.piecewise",
    "SfDivide": "fxdsp.blocks.sf_divide",
    "Demod": "fxdsp.blocks.demod",
    "BiasSubtract": "fxdsp.blocks.bias_subtract",
    "Iir": "fxdsp.blocks.iir",
    "Freq2Temp": "fxdsp.blocks.freq2temp",
    "Chain": "fxdsp.chains",
}

__all__ = [*_EXPORTS]

if TYPE_CHECKING:  # for type checkers and IDEs; at run time the names load lazily
    from fxdsp.api import quantize, to_real
    from fxdsp.blocks.base import Block, Result
    from fxdsp.blocks.bias_subtract import BiasSubtract
    from fxdsp.blocks.demod import Demod
    from fxdsp.blocks.freq2temp import Freq2Temp
    from fxdsp.blocks.iir import Iir
    from fxdsp.blocks.lag import Lag
    from fxdsp.blocks.piecewise import Piecewise
    from fxdsp.blocks.rtd import Rtd
    from fxdsp.blocks.sf_divide import SfDivide
    from fxdsp.chains import Chain, Design, build
    from fxdsp.config import Config, load_config
    from fxdsp.fixed.format import Format
    from fxdsp.fixed.ops import OverflowLog
    from fxdsp.fixed.rules import Rules


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'fxdsp' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value   # cached: the next access is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
