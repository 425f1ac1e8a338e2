"""The stages an extended paper-002 config carries (a lag, a demodulation phase trim, a CVD RTD law),
read from its built chain, and how they act on a log at the log's rate: the calibration fits with
them in place and the bit-exact compensation applies them (``fxdsp calibrate``, ``fxdsp extend``).

The lag runs bit-exactly at the log's rate (the same [lag] word lengths and rounding, alpha for the
log's interval); the trim at log rate is the rotation the trimmed NCO applies to the demodulated
pair, I' = I cos(theta) + Q sin(theta), with the config's quantised trim word.
"""

from __future__ import annotations

import math

import numpy as np

from fxdsp.diagnose.extension import log_rate_lag
from fxdsp.fixed import OverflowLog
from fxdsp.errors import MissingColumn


def trim_angle(nco) -> float:
    """The NCO's quantised trim word as an angle in (-pi, pi]."""
    turn = nco.trim / 2.0**nco.phase_bits
    return float(2 * math.pi * (turn - 1.0 if turn > 0.5 else turn))


def config_stages(chain) -> tuple[set[str], float | None, float]:
    """The stages a gyro_rtd chain (built, :class:`fxdsp.chains.Chain`) carries: ({"lag", "trim",
    "cvd"} subset, lag tau, trim angle), read from its own blocks."""
    on, tau = set(), None
    s = chain.sensor
    if s.rtd.physics.law == "cvd":
        on.add("cvd")
    if s.lag is not None:
        on.add("lag")
        tau = s.lag.tau_s
    theta = trim_angle(s.demod.nco)
    if s.demod.nco.trim != 0:
        on.add("trim")
    return on, tau, theta


def linear_readout_codes(rtd, temp_c, ovf=None) -> np.ndarray:
    """The ADC codes behind a temperature read with the linear law R0 (1 + A T) from an element whose
    table is now Callendar-Van Dusen (A = cvd_a): a log's temp_c back to its resistance, then the
    bridge and ADC. What the ``cvd`` remedy assumes of a log: its temp_c is that linear reading."""
    p = rtd.physics
    r = p.r0 * (1.0 + p.a * np.asarray(temp_c, float))
    return rtd.adc_quantize(p.adc_fraction(r), ovf)


def stage_inputs(comp, columns: dict, on: set[str], tau_s: float | None, theta: float, ovf=None):
    """(temperature code the engines see, output the divider sees) with the stages ``on``. A config
    whose RTD table is CVD reads the log's temp_c as a linear reading of that element."""
    if "trim" in on and "quad" not in columns:
        raise MissingColumn("log: the config's demodulation phase trim needs the quad column to compensate at log rate", "quad")
    ovf = OverflowLog() if ovf is None else ovf
    if "cvd" in on:
        code = comp.rtd.stream(ovf, code=linear_readout_codes(comp.rtd, columns["temp_c"], ovf))["temp"]
    else:
        code = comp.temperature_code(columns["temp_c"], ovf)
    if "lag" in on:
        code = log_rate_lag(comp.lag_template, tau_s, columns["time_s"]).run(log=ovf, temp=code).outputs["te"]
    out = np.asarray(columns["output"], float)
    if "trim" in on:
        out = out * math.cos(theta) + np.asarray(columns["quad"], float) * math.sin(theta)
    return code, out
