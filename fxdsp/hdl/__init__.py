"""Verilog side of fxdsp: parameter headers and ROM files generated from the built design
(:mod:`fxdsp.hdl.params`), the ``fxdsp hdl-gen`` and ``fxdsp hw-report`` commands."""
