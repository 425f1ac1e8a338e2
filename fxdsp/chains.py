"""The signal chains of the papers, composed from the blocks, and the design built from one config.

* paper 002 (RTD path, its figure 4): RTD code -> temperature -> SF(T) -> sense / SF(T) -> demod (I)
  -> I - bias(T) -> final low-pass -> rate. Optional stages, chosen by the config (absent = the
  paper's chain, bit for bit): ``[chain_paper002] stages = ["lag"]`` puts the ``lag`` block between
  the RTD readout and the SF/bias engines (they see the die-temperature estimate Te; the ``temp``
  port stays the thermometer's reading), and ``[demod] phase_trim_rad`` rotates the NCO reference.
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


class Paper002Chain(Block):
    """Paper 002's chain as one block: ``vsa`` (sense ADC) and ``rtd_code`` -> ``temp`` and
    ``rate``, through rtd, [lag], SF(T), divide, demod, bias(T), subtract and the final low-pass."""

    name = "chain_paper002"

    # members in the order of the chain's ovf vector (bit 0 first), by instance name; a chain with the
    # lag stage has "lag" after "rtd" (its instance attribute MEMBERS)
    MEMBERS = ("rtd", "piecewise_sf", "piecewise_bias", "sf_divide", "demod", "bias_subtract", "iir")
    STAGES = ("lag",)   # the optional stages a config may choose ([chain_paper002] stages)

    def __init__(self, rtd: Rtd, sf: Piecewise, divide: SfDivide, demod: Demod, bias: Piecewise,
                 subtract: BiasSubtract, lpf: Iir, lag: Lag | None = None):
        """The blocks must already be connected wire to wire (``build`` derives each input format from
        the output it is wired to). ``lag``: the optional thermal-lag stage between the RTD readout
        and the SF / bias engines, fed once per chain sample (it updates every ``lag.decimation``)."""
        self.rtd, self.sf, self.divide, self.demod = rtd, sf, divide, demod
        self.bias, self.subtract, self.lpf = bias, subtract, lpf
        self.lag = lag
        if lag is not None:
            if lag.temp_format != rtd.temp_format:
                raise ValueError(f"{self.name}: lag.temp_format {lag.temp_format} must be rtd.temp_format "
                                 f"{rtd.temp_format}")
            self.MEMBERS = ("rtd", "lag", *type(self).MEMBERS[1:])
        self.stages = ("lag",) if lag is not None else ()
        # the blocks that carry state across calls, by their key in get_state / set_state
        self._stateful: dict[str, Block] = {"demod": demod, "iir": lpf, **({"lag": lag} if lag is not None else {})}
        self.inputs = {"vsa": divide.in_format, "rtd_code": rtd.adc_format}
        self.outputs = {"temp": rtd.temp_format, "rate": lpf.data_format}

    def reset(self) -> None:
        for block in self._stateful.values():
            block.reset()

    def get_state(self) -> dict:
        return {key: block.get_state() for key, block in self._stateful.items()}

    def set_state(self, state) -> None:
        keys = set(self._stateful)
        if not isinstance(state, dict) or set(state) != keys:
            raise ValueError(f"{self.name}: state: expected a previous result's state {{{', '.join(sorted(keys))}}}")
        for key, block in self._stateful.items():
            block.set_state(state[key])

    def stream(self, log: OverflowLog, vsa: np.ndarray, rtd_code: np.ndarray) -> dict[str, np.ndarray]:
        temp = self.rtd.stream(log, code=rtd_code)["temp"]
        te = self.lag.stream(log, temp=temp)["te"] if self.lag is not None else temp  # what the engines see
        sf = self.sf.stream(log, temp=te)["y"]
        v = self.divide.stream(log, x=vsa, sf=sf)["y"]
        i, _ = self.demod.iq(log, v)
        b = self.bias.stream(log, temp=te)["y"]
        r = self.subtract.stream(log, x=i, bias=b)["y"]
        rate = self.lpf.stream(log, x=r)["y"]
        return {"temp": temp, "rate": rate}

    def reference(self, vsa: np.ndarray, rtd_code: np.ndarray) -> dict[str, np.ndarray]:
        temp = self.rtd.reference(code=rtd_code)["temp"]
        te = self.lag.reference(temp=temp)["te"] if self.lag is not None else temp
        sf = self.sf.reference(temp=te)["y"]
        v = self.divide.reference(x=vsa, sf=sf)["y"]
        i = self.demod.reference(x=v)["i"]
        b = self.bias.reference(temp=te)["y"]
        r = self.subtract.reference(x=i, bias=b)["y"]
        return {"temp": temp, "rate": self.lpf.reference(x=r)["y"]}

    def sensor_analog(self, t_c: np.ndarray, rate_fs: np.ndarray, quad_fs: float = 0.0,
                      rng: np.random.Generator | None = None, noise_fs: float = 0.0) -> dict:
        """A device whose SF and bias follow this config's own calibration exactly, before its ADCs:
        sense = SF(T) * (rate + bias(T)) on the in-phase carrier (+ quadrature, + white noise), and
        the RTD bridge's ADC input. ``analog`` with the noise, ``clean`` without it."""
        n = len(t_c)
        sf = self.sf.reference(temp=t_c)["y"]
        bias = self.bias.reference(temp=t_c)["y"]
        clean = self.demod.carrier(sf * (rate_fs + bias), 0.0, n) + self.demod.carrier(sf * quad_fs, np.pi / 2, n)
        x = clean + rng.normal(0.0, noise_fs, n) if rng is not None and noise_fs else clean
        frac = self.rtd.adc_fraction(t_c)
        return {"analog": {"vsa": x, "rtd_frac": frac}, "clean": {"vsa": clean, "rtd_frac": frac}}

    def digitise(self, analog: dict) -> dict[str, np.ndarray]:
        """The chain's ADCs: sense ADC (nearest, saturating) and the RTD bridge ADC."""
        return {"vsa": quantize(analog["vsa"], self.divide.in_format, Rules("half_up", "saturate")),
                "rtd_code": self.rtd.adc_quantize(analog["rtd_frac"])}

    def sensor_inputs(self, t_c: np.ndarray, rate_fs: np.ndarray, quad_fs: float = 0.0,
                      rng: np.random.Generator | None = None, noise_fs: float = 0.0) -> dict[str, np.ndarray]:
        """The ADC codes of :meth:`sensor_analog`."""
        return self.digitise(self.sensor_analog(t_c, rate_fs, quad_fs, rng, noise_fs)["analog"])

    def nominal_analog(self, rng: np.random.Generator, n: int) -> dict:
        """Temperature swept -20..60 C, rate stepping through +-0.3 FS and zero, a quadrature term,
        white noise: the analog signals, the programme (``t_c``, ``rate_fs``) and the ADC codes."""
        n = max(n, 8192)
        t_c = np.linspace(-20.0, 60.0, n)
        steps = np.array([0.0, 0.3, -0.3, 0.1, 0.0, -0.05, 0.2, 0.0])
        rate = np.repeat(steps, -(-n // steps.size))[:n]
        out = self.sensor_analog(t_c, rate, quad_fs=0.05, rng=rng, noise_fs=1e-3)
        out.update(t_c=t_c, rate_fs=rate, codes=self.digitise(out["analog"]))
        return out

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        return self.nominal_analog(rng, n)["codes"]

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        nom = self.nominal_stimulus(rng, n)
        # saturation: full-scale sense input at the coldest and hottest ends of the RTD range
        m = 1024
        hot = self.rtd.adc_code(np.full(m, 60.0))
        full = quantize(self.demod.carrier(self.divide.in_format.max_value * 1.1, 0.0, m), self.divide.in_format,
                        Rules("half_up", "saturate"))
        return {"vsa": np.concatenate([nom["vsa"], full]), "rtd_code": np.concatenate([nom["rtd_code"], hot])}

    def parameters(self) -> dict:
        out = {"blocks": [b.name for b in (self.rtd, self.sf, self.divide, self.demod, self.bias, self.subtract,
                                           self.lpf)]}
        if self.stages:  # only when chosen: a config without them records what it always did
            out["stages"] = list(self.stages)
        return out


def paper002_stages(cfg: Config) -> tuple[str, ...]:
    """The optional stages ``[chain_paper002] stages`` chooses, in chain order (absent table or key:
    none, the paper's chain)."""
    sec = cfg.optional_section("chain_paper002")
    if sec is None:
        return ()
    chosen = sec.names("stages", Paper002Chain.STAGES, [])
    return tuple(s for s in Paper002Chain.STAGES if s in chosen)


class Paper001Chain(Block):
    """Paper 001's chain as one block: frequency word ``f`` and ``rate_in`` -> ``temp`` and ``rate``,
    through freq2temp, the quadratic bias(T) and the subtraction."""

    name = "chain_paper001"

    MEMBERS = ("freq2temp", "piecewise_bias001", "bias_subtract001")

    def __init__(self, f2t: Freq2Temp, bias: Piecewise, subtract: BiasSubtract):
        self.f2t, self.bias, self.subtract = f2t, bias, subtract
        self.inputs = {"f": f2t.freq_format, "rate_in": subtract.in_format}
        self.outputs = {"temp": f2t.temp_format, "rate": subtract.out_format}

    def stream(self, log: OverflowLog, f: np.ndarray, rate_in: np.ndarray) -> dict[str, np.ndarray]:
        temp = self.f2t.stream(log, f=f)["temp"]
        b = self.bias.stream(log, temp=temp)["y"]
        return {"temp": temp, "rate": self.subtract.stream(log, x=rate_in, bias=b)["y"]}

    def reference(self, f: np.ndarray, rate_in: np.ndarray) -> dict[str, np.ndarray]:
        temp = self.f2t.reference(f=f)["temp"]
        b = self.bias.reference(temp=temp)["y"]
        return {"temp": temp, "rate": self.subtract.reference(x=rate_in, bias=b)["y"]}

    def nominal_analog(self, rng: np.random.Generator, n: int) -> dict:
        """Chamber points -10..50 C; zero-rate output = the quadratic bias of the same config + noise:
        the analog frequency and rate (``clean`` without the noise) and their words."""
        t_c = np.repeat(np.arange(-10.0, 51.0, 10.0), -(-n // 7))[:n] + rng.normal(0, 0.05, n)
        q = self.bias.reference(temp=t_c)["y"]
        noise = rng.normal(0.0, 1.0, n)
        f = self.f2t.frequency(t_c)
        codes = {"f": self.f2t.freq_code(t_c),
                 "rate_in": quantize(q + noise, self.subtract.in_format, Rules("half_up", "saturate"))}
        return {"analog": {"f": f, "rate_in": q + noise}, "clean": {"f": f, "rate_in": q}, "codes": codes, "t_c": t_c}

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        return self.nominal_analog(rng, n)["codes"]

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        nom = self.nominal_stimulus(rng, n)
        extra = self.f2t.stimulus(rng, 0)["f"]
        fi = self.subtract.in_format
        rate_extra = np.resize(np.array([fi.min_int, fi.max_int, 0, -1, 1], np.int64), extra.size)
        return {"f": np.concatenate([nom["f"], extra]), "rate_in": np.concatenate([nom["rate_in"], rate_extra])}

    def parameters(self) -> dict:
        return {"blocks": [b.name for b in (self.f2t, self.bias, self.subtract)]}


@dataclass(frozen=True)
class Port:
    """One port of an instance: its format and the physical unit its real value is read in."""

    name: str
    format: Format
    unit: str = ""        # physical unit of the table rows ("C", "deg/h", "ppm", ...)
    scale: float = 1.0    # real value x scale = value in ``unit``


@dataclass(frozen=True)
class Instance:
    """One row of the design's instance table: everything outside a block needs to know about it.

    ``name`` is the one name of the instance (vectors directory, RTL instance and parameter header,
    budget rows, hardware report); it is its config table with the dots spelled as underscores
    (``piecewise.sf`` -> ``piecewise_sf``), and the model's overflow counters are named after the
    table (``piecewise.sf.acc``). A chain's ovf vector is its members' vectors, bit 0 first."""

    name: str
    config_path: str
    block: Block
    module: str                       # RTL module
    inputs: tuple[Port, ...]
    outputs: tuple[Port, ...]
    members: tuple[str, ...] = ()     # a chain's member instances, in ovf bit order
    has_ready: bool = False           # the RTL module has an in_ready output (multi-cycle)

    @property
    def ports(self) -> dict[str, Port]:
        return {p.name: p for p in (*self.inputs, *self.outputs)}


@dataclass
class Design:
    """Every block and chain of one config, and the instance table that names them."""

    config: Config
    seed: int
    samples: int
    fs_hz: float
    rate_full_scale_dps: float
    blocks: dict[str, Block] = field(default_factory=dict)
    chains: dict[str, Block] = field(default_factory=dict)
    instances: dict[str, Instance] = field(default_factory=dict)

    @property
    def all(self) -> dict[str, Block]:
        return {**self.blocks, **self.chains}

    def ovf_fields(self, name: str) -> list[tuple[str, str, int]]:
        """The RTL ovf vector of an instance, bit 0 first: (member instance, counter, width) per field.
        A block's counters are its config path + field counter (``demod.lpf_i.section0``)."""
        inst = self.instances[name]
        out = []
        for member in inst.members or (name,):
            m = self.instances[member]
            out += [(member, f"{m.config_path}.{f.counter}", f.width) for f in m.block.datapath.ovf]
        return out

    def ovf_width(self, name: str) -> int:
        return sum(w for _, _, w in self.ovf_fields(name))

    def ovf_bit(self, name: str, counter: str) -> int:
        """Bit position of the first flag of ``counter`` in the ovf vector of instance ``name``."""
        bit = 0
        for _, c, w in self.ovf_fields(name):
            if c == counter:
                return bit
            bit += w
        raise ValueError(f"{name}: no ovf field counts {counter!r}")


# RTL modules that take several cycles per sample and so have an in_ready output
HAS_READY = {"sf_divide", "chain_paper002"}


def _units(design: "Design") -> dict[str, dict[str, tuple[str, float]]]:
    """Physical unit of every instance port: the paper 002 signal path is in fractions of the
    sense full scale (rate FS = [system].rate_full_scale_dps), paper 001's rate in deg/h."""
    fs = ("deg/h", design.rate_full_scale_dps * 3600.0)
    temp, degh = ("C", 1.0), ("deg/h", 1.0)
    return {"rtd": {"temp": temp}, "lag": {"temp": temp, "te": temp}, "freq2temp": {"temp": temp},
            "piecewise_sf": {"temp": temp, "y": ("ppm", 1e6)}, "piecewise_bias": {"temp": temp, "y": fs},
            "piecewise_bias001": {"temp": temp, "y": degh}, "piecewise_k0": {"temp": temp, "y": ("Hz", 1.0)},
            "piecewise_k1": {"temp": temp, "y": ("Hz/g", 1.0)}, "sf_divide": {"x": fs, "y": fs},
            "demod": {"x": fs, "i": fs, "q": fs, "amp": fs, "phase": ("mrad", 1e3)},
            "bias_subtract": {"x": fs, "bias": fs, "y": fs}, "bias_subtract001": {"x": degh, "bias": degh, "y": degh},
            "iir": {"x": fs, "y": fs}, "chain_paper002": {"vsa": fs, "temp": temp, "rate": fs},
            "chain_paper001": {"f": ("Hz", 1.0), "rate_in": degh, "temp": temp, "rate": degh}}


def _instance_table(design: "Design") -> dict[str, Instance]:
    units = _units(design)
    table = {}
    for name, block in design.all.items():
        u = units.get(name, {})
        ports = [tuple(Port(p, f, *u.get(p, ("", 1.0))) for p, f in ports.items())
                 for ports in (block.inputs, block.outputs)]
        members = getattr(block, "MEMBERS", ())
        module = name if members else block.datapath.MODULE
        if name != block.name.replace(".", "_"):
            raise AssertionError(f"instance {name} is not named after its config table {block.name}")
        table[name] = Instance(name, block.name, block, module, ports[0], ports[1], members, module in HAS_READY)
    return table


def build(config: Config | str | None = None, chains: bool = True) -> Design:
    """Build every block and chain from a config (path, Config, or None for the built-in default).
    Any unknown key or table anywhere in the config is an error naming it. Every format an input
    is wired to is derived from the output that drives it. ``chains=False`` builds the blocks
    alone, for block-level work on formats the chains could not connect."""
    cfg = config if isinstance(config, Config) else load_config(config)
    stim = cfg.section("stimulus")
    system = cfg.section("system")
    fs = system.number("fs_hz", low=0, low_open=True)
    design = Design(cfg, seed=stim.integer("seed", low=0), samples=stim.integer("samples", low=16, high=10**7),
                    fs_hz=fs, rate_full_scale_dps=system.number("rate_full_scale_dps", low=0, low_open=True))

    rtd = Rtd.from_config(cfg.section("rtd"))
    sf = Piecewise.from_config(cfg.section("piecewise.sf"), rtd.temp_format)
    div_sec = cfg.section("sf_divide")
    divide = SfDivide.from_config(div_sec, div_sec.format("in_format"), sf.out_format)
    demod_sec = cfg.section("demod")
    demod = Demod.from_config(demod_sec, fs, divide.out_format, chains)
    bias = Piecewise.from_config(cfg.section("piecewise.bias"), rtd.temp_format)
    sub_sec = cfg.section("bias_subtract")
    subtract = BiasSubtract.from_config(sub_sec, demod.data_format, bias.out_format)
    iir_sec = cfg.section("iir")
    lpf = Iir.from_config(iir_sec, fs, iir_sec.wired_format("data_format", subtract.out_format,
                                                             "bias_subtract.out_format", chains), "iir")

    f2t_sec = cfg.section("freq2temp")
    f2t = Freq2Temp.from_config(f2t_sec, f2t_sec.format("temp_format"))
    bias001 = Piecewise.from_config(cfg.section("piecewise.bias001"), f2t.temp_format)
    sub001_sec = cfg.section("bias_subtract001")
    subtract001 = BiasSubtract.from_config(sub001_sec, sub001_sec.format("in_format"), bias001.out_format)

    stages = paper002_stages(cfg)
    # the chain's lag stage is the [lag] block, fed once per chain sample and updated at its rate_hz
    wired = (fs, "system.fs_hz", chains) if "lag" in stages else ()
    lag = Lag.from_config(cfg.section("lag"), rtd.temp_format, *wired)

    qvba_temp = cfg.section("piecewise").format("qvba_temp_format")
    k0 = Piecewise.from_config(cfg.section("piecewise.k0"), qvba_temp)
    k1 = Piecewise.from_config(cfg.section("piecewise.k1"), qvba_temp)

    design.blocks = {"rtd": rtd, "iir": lpf, "demod": demod, "piecewise_sf": sf, "piecewise_bias": bias,
                     "piecewise_bias001": bias001, "piecewise_k0": k0, "piecewise_k1": k1, "sf_divide": divide,
                     "bias_subtract": subtract, "bias_subtract001": subtract001, "freq2temp": f2t,
                     "lag": lag}
    if chains:
        design.chains = {"chain_paper002": Paper002Chain(rtd, sf, divide, demod, bias, subtract, lpf,
                                                         lag if "lag" in stages else None),
                         "chain_paper001": Paper001Chain(f2t, bias001, subtract001)}
    design.instances = _instance_table(design)
    cfg.check_all_read()
    return design
