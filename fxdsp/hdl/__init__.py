"""Verilog side of fxdsp: the RTL (shipped in the package, ``rtl/*.v``), parameter headers and ROM
files generated from the built design (:mod:`fxdsp.hdl.params`), the one simulation harness
(:mod:`fxdsp.hdl.harness`) and the ``fxdsp rtl``, ``fxdsp hdl-gen`` and ``fxdsp hw-report`` commands."""

from pathlib import Path

# the Verilog sources every command simulates and synthesises (the checkout's hdl/rtl links here)
RTL_DIR = Path(__file__).resolve().parent / "rtl"
# the committed iCE40UP5K report of the default config, as data (the checkout's hdl/HW_REPORT.json)
HW_REPORT_JSON = Path(__file__).resolve().parent / "HW_REPORT.json"
