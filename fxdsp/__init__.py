"""fxdsp: bit-accurate fixed-point models of the FPGA blocks that temperature-compensate
vibratory inertial sensors, their float references, golden vectors and error budgets."""

__version__ = "0.1.0"
