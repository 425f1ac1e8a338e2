"""Bit-exact compensation of a chamber log with the blocks of a (calibrated) config.

A chamber log is sampled every ~10 s and its ``output`` is already demodulated, so at log rate the
paper 002 path is::

    temp_c -> rtd.adc_code -> rtd (LUT) -> T code -> piecewise.sf -> sf_divide -> bias_subtract
                                                  -> piecewise.bias ------------^

i.e. the demodulator and the low-pass filters of the 96 kHz chain are skipped. That is legitimate
because the SF division commutes with demodulation when SF(T) varies slowly: demod(x / SF) =
demod(x) / SF as long as SF is constant over the low-pass filter's memory (tens of ms against a
thermal time constant of minutes), and the final low-pass filter has unity DC gain. What is *not*
modelled at log rate is the fixed-point error of the mixer and filters themselves (checked at
96 kHz by the block tests and the paper 003 reproduction).

Lag-aware variant (``compensate_lagged``): the T code goes through the ``lag`` block (a first-order
die-temperature estimate, config table ``[lag]``) before the coefficient engines.

Paper 001: ``freq_hz`` -> ``freq2temp`` -> ``piecewise.bias001`` -> ``bias_subtract001`` (the
``chain_paper001`` of the design). Paper 000: a = (Df - K0(t)) / K1(t) through the config's
``chain_paper000`` (its formats are the config's: ``[bias_subtract000]``, ``[sf_divide000]``).
"""

from __future__ import annotations

import numpy as np

from fxdsp.blocks.freq2temp import Freq2Temp
from fxdsp.chains import build
from fxdsp.config import Config
from fxdsp.errors import InputError, MissingColumn
from fxdsp.fixed import Format, OverflowLog, Rules, quantize, to_float
from fxdsp.repro.calconfig import FS_MV

ROUND = Rules("half_up", "saturate")
# paper 000: difference frequency Df in Hz (LSB 1.5e-5 Hz = 0.3 ug at 52 Hz/g)
# paper 002's frequency thermometer: the 8 kHz drive frequency word
DRIVE_FREQ_FORMAT = Format.parse("s32.17")
KINV_FORMAT = Format.parse("s24.18")


def _column(log_data: dict, name: str) -> np.ndarray:
    """A log column the compensation reads, refused by name when the log lacks it (a command that read
    the log says why its reader set it aside: fxdsp.logfile.saying_why_columns_are_missing)."""
    if name not in log_data:
        raise MissingColumn(f"log: the compensation needs the {name} column", name)
    return _finite(name, log_data[name])


def _finite(name: str, values) -> np.ndarray:
    arr = np.asarray(values, float)
    if arr.ndim != 1 or not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: must be a 1-D array of finite numbers")
    return arr


class Compensator002:
    """Paper 002 at log rate: output (mV) and RTD temperature (C) -> rate (deg/s), bit-exact."""

    def __init__(self, config: Config | str | None, chain: str = "chain_paper002"):
        d = build(config)
        self.design = d
        # the blocks by role in the config's gyro_rtd chain (fxdsp.sensors.GyroRtd), whatever their names
        self.chain = d.chain(chain, "the paper 002 log-rate compensation")
        s = self.chain.sensor
        if s is None or s.name != "gyro_rtd":
            raise InputError(f"chain.{chain.removeprefix('chain_')}.sensor: the paper 002 compensation reads a gyro_rtd")
        self.rtd, self.sf, self.divide, self.bias, self.subtract = s.rtd, s.sf, s.divide, s.bias, s.subtract
        if self.subtract.in_format != self.divide.out_format:
            raise InputError(f"{self.subtract.name}: its input {self.subtract.in_format} must equal "
                             f"{self.divide.name}.out_format {self.divide.out_format} for the log-rate path")
        self.lag = s.lag
        # the words of the lag a log-rate run uses: the chain's, else the config's [lag] table
        self.lag_template = s.lag if s.lag is not None else d.blocks.get("lag")
        self.rate_fs_dps = d.rate_full_scale_dps  # 1 FS of the quotient = this many deg/s

    def temperature_code(self, temp_c, log: OverflowLog | None = None) -> np.ndarray:
        """The RTD's ADC code of the logged temperature, converted by the rtd block (LUT)."""
        log = OverflowLog() if log is None else log
        code = self.rtd.adc_code(_finite("temp_c", temp_c), log)
        return self.rtd.stream(log, code=code)["temp"]

    def temperature_code_direct(self, temp_c) -> np.ndarray:
        """A temperature estimate (C) quantised straight into the temperature format."""
        return quantize(_finite("temp_c", temp_c), self.rtd.temp_format, ROUND)

    def run(self, output_mv, temp_code, log: OverflowLog | None = None) -> dict[str, np.ndarray]:
        log = OverflowLog() if log is None else log
        x = quantize(_finite("output", output_mv) / FS_MV, self.divide.in_format, ROUND, log, "input")
        sf = self.sf.stream(log, temp=temp_code)["y"]
        v = self.divide.stream(log, x=x, sf=sf)["y"]
        b = self.bias.stream(log, temp=temp_code)["y"]
        r = self.subtract.stream(log, x=v, bias=b)["y"]
        return {"rate_dps": to_float(r, self.subtract.out_format) * self.rate_fs_dps,
                "temp_c": to_float(temp_code, self.rtd.temp_format), "overflows": log}

    def compensate(self, log_data: dict, temp_c=None) -> dict[str, np.ndarray]:
        """Compensate a log; ``temp_c`` (C) replaces the RTD path by a direct temperature estimate."""
        ovf = OverflowLog()
        code = (self.temperature_code(_column(log_data, "temp_c"), ovf) if temp_c is None
                else self.temperature_code_direct(temp_c))
        return self.run(_column(log_data, "output"), code, ovf)

    def compensate_lagged(self, log_data: dict) -> dict[str, np.ndarray]:
        """RTD code -> ``lag`` block (die-temperature estimate, config's [lag]) -> compensation."""
        if self.lag_template is None:
            raise InputError("config: has no [lag] table for the lag-aware temperature estimate")
        ovf = OverflowLog()
        code = self.temperature_code(_column(log_data, "temp_c"), ovf)
        te = self.lag_template.run(log=ovf, temp=code).outputs["te"]
        return self.run(_column(log_data, "output"), te, ovf)

    def frequency_thermometer(self, f0_hz: float, k_hz_per_c: float) -> Freq2Temp:
        """A freq2temp block on the drive frequency (paper 001's idea applied to paper 002's gyro)."""
        return Freq2Temp(DRIVE_FREQ_FORMAT, self.rtd.temp_format, KINV_FORMAT, f0_hz, k_hz_per_c,
                         Rules("half_up", "saturate"))

    def compensate_by_frequency(self, log_data: dict, f0_hz: float, k_hz_per_c: float) -> dict:
        f2t = self.frequency_thermometer(f0_hz, k_hz_per_c)
        ovf = OverflowLog()
        f = quantize(_column(log_data, "freq_hz"), DRIVE_FREQ_FORMAT, ROUND, ovf, "freq")
        code = f2t.stream(ovf, f=f)["temp"]
        return self.run(_column(log_data, "output"), code, ovf)


class Compensator001:
    """Paper 001: freq_hz and output (deg/h) -> compensated rate (deg/h), through chain_paper001."""

    def __init__(self, config: Config | str | None, chain: str = "chain_paper001"):
        self.design = build(config)
        # the blocks and ports by role in the config's gyro_freq chain (fxdsp.sensors.GyroFreq)
        self.chain = self.design.chain(chain, "the paper 001 compensation")
        s = self.chain.sensor
        if s is None or s.name != "gyro_freq":
            raise InputError(f"chain.{chain.removeprefix('chain_')}.sensor: the paper 001 compensation reads a gyro_freq")
        self.rate_port = s.output_of(s.subtract, "y")

    def compensate(self, log_data: dict) -> dict[str, np.ndarray]:
        ovf = OverflowLog()
        s = self.chain.sensor
        f = quantize(_column(log_data, "freq_hz"), s.f2t.freq_format, ROUND, ovf, "freq")
        r = quantize(_column(log_data, "output"), s.subtract.in_format, ROUND, ovf, "rate")
        res = self.chain.run(ovf, **{s.f: f, s.rate_in: r})
        out = self.chain.real_outputs(res)
        # the resonator thermometer's temperature, from its own block (a chain need not output it)
        temp = s.f2t.real_outputs(s.f2t.run(OverflowLog(), f=f))["temp"]
        return {"rate_deg_h": out[self.rate_port], "temp_c": temp, "overflows": ovf}


class Compensator000:
    """Paper 000 through the config's own chain (``[chain.paper000]``, the ``qvba`` sensor's roles):
    a = (Df - K0(t)) / K1(t), t = T - 25 C, in g, bit-exact, with the chain's formats."""

    def __init__(self, config: Config | str | None, chain: str = "chain_paper000"):
        d = build(config)
        self.design = d
        if chain not in d.chains:
            raise InputError(f"config: no {chain} (the paper 000 chain) in {d.config.name}")
        self.chain = d.chains[chain]
        if self.chain.sensor is None or self.chain.sensor.name != "qvba":
            raise InputError(f"chain.{chain.removeprefix('chain_')}.sensor: the paper 000 chain reads a qvba")
        self.k0, self.k1 = self.chain.sensor.k0, self.chain.sensor.k1
        self.temp_format = self.k0.temp_format

    def compensate(self, temp_c, df_hz) -> dict[str, np.ndarray]:
        ovf = OverflowLog()
        s, ins = self.chain.sensor, self.chain.inputs
        t = quantize(_finite("temp_c", temp_c), ins[s.temp], ROUND, ovf, "temp")
        df = quantize(_finite("output", df_hz), ins[s.df], ROUND, ovf, "df")
        res = self.chain.run(log=ovf, **{s.temp: t, s.df: df})
        (port, accel), = res.outputs.items()
        return {"accel_g": to_float(accel, self.chain.outputs[port]), "overflows": ovf}
