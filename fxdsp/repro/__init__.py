"""Calibration -> TOML config -> bit-exact compensation of a chamber log, and the reproductions of
the four papers (``fxdsp repro``; report in docs/REPRODUCTIONS.md).

Modules: :mod:`~fxdsp.repro.points` (per-temperature SF/bias points, tempco),
:mod:`~fxdsp.repro.calibrate` (fits in table form), :mod:`~fxdsp.repro.calconfig` (quantised
calibrated config), :mod:`~fxdsp.repro.bitexact` (log-rate bit-exact compensation),
:mod:`~fxdsp.repro.paper002` / ``paper001`` / ``paper000`` / ``paper003`` (the reproductions),
:mod:`~fxdsp.repro.report` (plots and markdown), :mod:`~fxdsp.commands.repro` (the command).
"""
