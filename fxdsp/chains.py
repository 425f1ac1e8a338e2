"""The signal chains of the papers, composed from the blocks, and the design built from one config.

* paper 002 (RTD path, its figure 4): RTD code -> temperature -> SF(T) -> sense / SF(T) -> demod (I)
  -> I - bias(T) -> final low-pass -> rate.
* paper 001 (frequency path): frequency word -> T = (f - f0)/k -> q(T) quadratic -> rate - q(T).
* paper 000 (QVBA): K0(t), K1(t) cubic in t = T - 25 C are configurations of the same piecewise
  engine (``piecewise.k0``, ``piecewise.k1``).

Every chain is a Block: bit-exact ``run`` on stored integers, float ``reference`` built from the
blocks' own references, and a physically meaningful stimulus (temperature sweep, rate steps).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .blocks.base import Block
from .blocks.bias_subtract import BiasSubtract
from .blocks.demod import Demod
from .blocks.freq2temp import Freq2Temp
from .blocks.iir import Iir
from .blocks.lag import Lag
from .blocks.piecewise import Piecewise
from .blocks.rtd import Rtd
from .blocks.sf_divide import SfDivide
from .config import Config, load_config
from .fixed import Format, OverflowLog, Rules, quantize


def _same(fmt_a: Format, fmt_b: Format, field_a: str, field_b: str) -> None:
    """Blocks connect wire to wire: a format mismatch is a config error, not a silent resize."""
    if fmt_a != fmt_b:
        raise ValueError(f"{field_a}: {fmt_a} must equal {field_b} ({fmt_b}) to connect the chain")


class Paper002Chain(Block):
    name = "chain_paper002"

    def __init__(self, rtd: Rtd, sf: Piecewise, divide: SfDivide, demod: Demod, bias: Piecewise,
                 subtract: BiasSubtract, lpf: Iir):
        _same(sf.temp_format, rtd.temp_format, "piecewise.sf temperature", "rtd.temp_format")
        _same(divide.sf_format, sf.out_format, "sf_divide sf input", "piecewise.sf.out_format")
        _same(demod.in_format, divide.out_format, "demod input", "sf_divide.out_format")
        _same(subtract.in_format, demod.data_format, "bias_subtract input", "demod.data_format")
        _same(subtract.bias_format, bias.out_format, "bias_subtract bias input", "piecewise.bias.out_format")
        _same(lpf.data_format, subtract.out_format, "iir.data_format", "bias_subtract.out_format")
        self.rtd, self.sf, self.divide, self.demod = rtd, sf, divide, demod
        self.bias, self.subtract, self.lpf = bias, subtract, lpf
        self.inputs = {"vsa": divide.in_format, "rtd_code": rtd.adc_format}
        self.outputs = {"temp": rtd.temp_format, "rate": lpf.data_format}

    def reset(self) -> None:
        self.demod.reset()
        self.lpf.reset()

    def _run(self, log: OverflowLog, vsa: np.ndarray, rtd_code: np.ndarray) -> dict[str, np.ndarray]:
        temp = self.rtd._run(log, code=rtd_code)["temp"]
        sf = self.sf._run(log, temp=temp)["y"]
        v = self.divide._run(log, x=vsa, sf=sf)["y"]
        i, _ = self.demod.iq(log, v)
        b = self.bias._run(log, temp=temp)["y"]
        r = self.subtract._run(log, x=i, bias=b)["y"]
        rate = self.lpf._run(log, x=r)["y"]
        return {"temp": temp, "rate": rate}

    def reference(self, vsa: np.ndarray, rtd_code: np.ndarray) -> dict[str, np.ndarray]:
        temp = self.rtd.reference(code=rtd_code)["temp"]
        sf = self.sf.reference(temp=temp)["y"]
        v = self.divide.reference(x=vsa, sf=sf)["y"]
        i = self.demod.reference(x=v)["i"]
        b = self.bias.reference(temp=temp)["y"]
        r = self.subtract.reference(x=i, bias=b)["y"]
        return {"temp": temp, "rate": self.lpf.reference(x=r)["y"]}

    def sensor_inputs(self, t_c: np.ndarray, rate_fs: np.ndarray, quad_fs: float = 0.0,
                      rng: np.random.Generator | None = None, noise_fs: float = 0.0) -> dict[str, np.ndarray]:
        """Inputs of a device whose SF and bias follow this config's own calibration exactly:
        sense = SF(T) * (rate + bias(T)) on the in-phase carrier (+ quadrature), RTD code of T."""
        n = len(t_c)
        sf = self.sf.reference(temp=t_c)["y"]
        bias = self.bias.reference(temp=t_c)["y"]
        x = self.demod.carrier(sf * (rate_fs + bias), 0.0, n) + self.demod.carrier(sf * quad_fs, np.pi / 2, n)
        if rng is not None and noise_fs:
            x = x + rng.normal(0.0, noise_fs, n)
        sat = Rules("half_up", "saturate")
        return {"vsa": quantize(x, self.divide.in_format, sat), "rtd_code": self.rtd.adc_code(t_c)}

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Temperature swept -20..60 C, rate stepping through +-0.3 FS and zero, a quadrature term."""
        n = max(n, 8192)
        t_c = np.linspace(-20.0, 60.0, n)
        steps = np.array([0.0, 0.3, -0.3, 0.1, 0.0, -0.05, 0.2, 0.0])
        rate = np.repeat(steps, -(-n // steps.size))[:n]
        return self.sensor_inputs(t_c, rate, quad_fs=0.05, rng=rng, noise_fs=1e-3)

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        nom = self.nominal_stimulus(rng, n)
        # saturation: full-scale sense input at the coldest and hottest ends of the RTD range
        m = 1024
        hot = self.rtd.adc_code(np.full(m, 60.0))
        full = quantize(self.demod.carrier(self.divide.in_format.max_value * 1.1, 0.0, m), self.divide.in_format,
                        Rules("half_up", "saturate"))
        return {"vsa": np.concatenate([nom["vsa"], full]), "rtd_code": np.concatenate([nom["rtd_code"], hot])}

    def parameters(self) -> dict:
        return {"blocks": ["rtd", "piecewise.sf", "sf_divide", "demod", "piecewise.bias", "bias_subtract", "iir"]}


class Paper001Chain(Block):
    name = "chain_paper001"

    def __init__(self, f2t: Freq2Temp, bias: Piecewise, subtract: BiasSubtract):
        _same(bias.temp_format, f2t.temp_format, "piecewise.bias001 temperature", "freq2temp temperature")
        _same(subtract.bias_format, bias.out_format, "bias_subtract001 bias input", "piecewise.bias001.out_format")
        self.f2t, self.bias, self.subtract = f2t, bias, subtract
        self.inputs = {"f": f2t.freq_format, "rate_in": subtract.in_format}
        self.outputs = {"temp": f2t.temp_format, "rate": subtract.out_format}

    def _run(self, log: OverflowLog, f: np.ndarray, rate_in: np.ndarray) -> dict[str, np.ndarray]:
        temp = self.f2t._run(log, f=f)["temp"]
        b = self.bias._run(log, temp=temp)["y"]
        return {"temp": temp, "rate": self.subtract._run(log, x=rate_in, bias=b)["y"]}

    def reference(self, f: np.ndarray, rate_in: np.ndarray) -> dict[str, np.ndarray]:
        temp = self.f2t.reference(f=f)["temp"]
        b = self.bias.reference(temp=temp)["y"]
        return {"temp": temp, "rate": self.subtract.reference(x=rate_in, bias=b)["y"]}

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Chamber points -10..50 C; zero-rate output = the quadratic bias of the same config + noise."""
        t_c = np.repeat(np.arange(-10.0, 51.0, 10.0), -(-n // 7))[:n] + rng.normal(0, 0.05, n)
        q = self.bias.reference(temp=t_c)["y"]
        noise = rng.normal(0.0, 1.0, n)
        rate = quantize(q + noise, self.subtract.in_format, Rules("half_up", "saturate"))
        return {"f": self.f2t.freq_code(t_c), "rate_in": rate}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        nom = self.nominal_stimulus(rng, n)
        extra = self.f2t.stimulus(rng, 0)["f"]
        fi = self.subtract.in_format
        rate_extra = np.resize(np.array([fi.min_int, fi.max_int, 0, -1, 1], np.int64), extra.size)
        return {"f": np.concatenate([nom["f"], extra]), "rate_in": np.concatenate([nom["rate_in"], rate_extra])}

    def parameters(self) -> dict:
        return {"blocks": ["freq2temp", "piecewise.bias001", "bias_subtract001"]}


@dataclass
class Design:
    """Every block and chain of one config, by the names used for vectors and RTL."""

    config: Config
    blocks: dict[str, Block] = field(default_factory=dict)
    chains: dict[str, Block] = field(default_factory=dict)
    seed: int = 1
    samples: int = 1024
    fs_hz: float = 96000.0
    rate_full_scale_dps: float = 200.0

    @property
    def all(self) -> dict[str, Block]:
        return {**self.blocks, **self.chains}


def build(config: Config | str | None = None, chains: bool = True) -> Design:
    """Build every block and chain from a config (path, Config, or None for the built-in default).
    Any unknown key or table anywhere in the config is an error naming it. ``chains=False`` builds
    the blocks alone, for block-level work on formats the chains could not connect."""
    cfg = config if isinstance(config, Config) else load_config(config)
    stim = cfg.section("stimulus")
    system = cfg.section("system")
    fs = system.number("fs_hz", low=0, low_open=True)
    design = Design(cfg, seed=stim.integer("seed", 1, low=0), samples=stim.integer("samples", 1024, low=16, high=10**7),
                    fs_hz=fs, rate_full_scale_dps=system.number("rate_full_scale_dps", 200.0, low=0, low_open=True))

    rtd = Rtd.from_config(cfg.section("rtd"))
    sf = Piecewise.from_config(cfg.section("piecewise.sf"), rtd.temp_format)
    div_sec = cfg.section("sf_divide")
    divide = SfDivide.from_config(div_sec, div_sec.format("in_format"), sf.out_format)
    demod = Demod.from_config(cfg.section("demod"), fs, divide.out_format)
    bias = Piecewise.from_config(cfg.section("piecewise.bias"), rtd.temp_format)
    subtract = BiasSubtract.from_config(cfg.section("bias_subtract"), demod.data_format, bias.out_format)
    lpf = Iir.from_config(cfg.section("iir"), fs, "iir")

    f2t_sec = cfg.section("freq2temp")
    f2t = Freq2Temp.from_config(f2t_sec, f2t_sec.format("temp_format"))
    bias001 = Piecewise.from_config(cfg.section("piecewise.bias001"), f2t.temp_format)
    sub001_sec = cfg.section("bias_subtract001")
    subtract001 = BiasSubtract.from_config(sub001_sec, sub001_sec.format("in_format"), bias001.out_format)

    lag = Lag.from_config(cfg.section("lag"), rtd.temp_format)

    qvba_temp = cfg.section("piecewise").format("qvba_temp_format", "s18.9")
    k0 = Piecewise.from_config(cfg.section("piecewise.k0"), qvba_temp)
    k1 = Piecewise.from_config(cfg.section("piecewise.k1"), qvba_temp)

    design.blocks = {"rtd": rtd, "iir": lpf, "demod": demod, "piecewise_sf": sf, "piecewise_bias": bias,
                     "piecewise_bias001": bias001, "piecewise_k0": k0, "piecewise_k1": k1, "sf_divide": divide,
                     "bias_subtract": subtract, "bias_subtract001": subtract001, "freq2temp": f2t,
                     "lag": lag}
    if chains:
        design.chains = {"chain_paper002": Paper002Chain(rtd, sf, divide, demod, bias, subtract, lpf),
                         "chain_paper001": Paper001Chain(f2t, bias001, subtract001)}
    cfg.check_all_read()
    return design
