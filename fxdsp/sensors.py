"""The physical stimulus of a chain's inputs: the sensor a chain reads, named by its table's ``sensor``.

A sensor model finds the blocks it needs in the chain by their kind and wiring (the coefficient
engine that drives the divider's ``sf``, the one that drives the subtraction's ``bias``), so it
works on any netlist that has them, in any order, with stages inserted. It produces the analog
signals of a device whose temperature behaviour is the chain's own calibration, the ADC words of
them, and the stimulus of the vectors (nominal signals plus saturation corners).

* ``gyro_rtd`` (paper 002): sense = SF(T) (rate + bias(T)) on the in-phase carrier (+ quadrature,
  + noise), temperature through the RTD bridge ADC.
* ``gyro_freq`` (paper 001): the drive-mode resonant frequency f(T) = f0 + k T and the zero-rate
  output q(T) + noise.
* ``qvba`` (paper 000): temperature word and difference frequency Df = K0(t) + K1(t) a.

A chain without ``sensor`` is stimulated port by port with the stimulus of the block input each
chain input drives.
"""

from __future__ import annotations

import numpy as np

from fxdsp.errors import InputError
from fxdsp.fixed import Rules, quantize
from fxdsp.netlist import Endpoint

NEAREST_SAT = Rules("half_up", "saturate")   # an ADC: nearest code, clipped at full scale
# the gyro's quadrature in the nominal stimulus (FS): an untrimmed MEMS gyro's 10 deg/s at 200 deg/s
NOMINAL_QUADRATURE_FS = 0.05


class Sensor:
    """Base: role lookup on the chain (each error names the chain's ``sensor`` field)."""

    name = ""

    def __init__(self, chain):
        self.chain = chain
        self.net = chain.netlist

    def _fail(self, what: str) -> InputError:
        return InputError(f"{self.net.name}.sensor: {self.name!r} needs {what}")

    def of_kind(self, kind: str, optional: bool = False):
        found = [p for p in self.net.instances if self.chain.kinds[p] == kind]
        if len(found) > 1:
            raise self._fail(f"one {kind} block, the chain has {', '.join(found)}")
        if not found:
            if optional:
                return None
            raise self._fail(f"a {kind} block in the chain")
        return self.chain.members[found[0]]

    def driver(self, block, port: str):
        """The block whose output drives ``block``'s input ``port``."""
        src = self.net.driver(block.name, port)
        if not isinstance(src, Endpoint):
            raise self._fail(f"{block.name}.{port} driven by a block, not by the chain input {src!r}")
        return self.chain.members[src.instance]

    def input_of(self, block, port: str) -> str:
        """The name of the chain input that drives ``block``'s input ``port``."""
        src = self.net.driver(block.name, port)
        if isinstance(src, Endpoint):
            raise self._fail(f"{block.name}.{port} driven by a chain input, not by {src}")
        return src

    def output_of(self, block, port: str) -> str:
        """The name of the chain output that ``block``'s output ``port`` drives."""
        for name, src in self.net.outputs.items():
            if src == Endpoint(block.name, port):
                return name
        raise self._fail(f"{block.name}.{port} among the chain's outputs")

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        return self.nominal_analog(rng, n)["codes"]

    # chamber points: temperatures drawn in CHAMBER_C, the physical input alternating between 0 and
    # CHAMBER_LEVEL (the sensor's own unit); STEADY_LEVEL: the constant input of a long steady run
    CHAMBER_C = (-20.0, 60.0)
    CHAMBER_LEVEL = 0.0
    STEADY_LEVEL = 0.0
    # the physical input of a Monte-Carlo operating point is drawn uniformly in +-LEVEL_SPAN, in
    # LEVEL_UNIT (fxdsp sweep montecarlo)
    LEVEL_SPAN = 0.0
    LEVEL_UNIT = ""

    def held_inputs(self, t_c: np.ndarray, level: np.ndarray, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """The chain's input words for a device held at temperatures ``t_c`` under the physical input
        ``level`` (per sample), with the sensor's noise drawn from ``rng``."""
        raise NotImplementedError

    def analog_inputs(self, analog: dict) -> dict[str, np.ndarray]:
        """The analog signals of :meth:`nominal_analog` by the chain input each one is the ADC input
        of, in the real units of that input's format (its ADC = quantise to the format, nearest)."""
        raise NotImplementedError


class GyroRtd(Sensor):
    """Paper 002's gyro: sense carrier scaled by SF(T) and offset by bias(T), RTD bridge ADC."""

    name = "gyro_rtd"
    CHAMBER_C = (-20.0, 60.0)
    CHAMBER_LEVEL = 0.2    # rate, fraction of full scale
    STEADY_LEVEL = 0.1
    LEVEL_SPAN, LEVEL_UNIT = 0.3, "FS"   # the nominal stimulus' rate steps span +-0.3 FS

    def __init__(self, chain):
        super().__init__(chain)
        self.rtd = self.of_kind("rtd")
        self.divide = self.of_kind("sf_divide")
        self.demod = self.of_kind("demod")
        self.subtract = self.of_kind("bias_subtract")
        self.lpf = self.of_kind("iir")
        self.lag = self.of_kind("lag", optional=True)
        self.sf = self.driver(self.divide, "sf")
        self.bias = self.driver(self.subtract, "bias")
        self.vsa, self.code = self.input_of(self.divide, "x"), self.input_of(self.rtd, "code")

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
        return {self.vsa: quantize(analog["vsa"], self.divide.in_format, NEAREST_SAT),
                self.code: self.rtd.adc_quantize(analog["rtd_frac"])}

    def analog_inputs(self, analog: dict) -> dict[str, np.ndarray]:
        return {self.vsa: analog["vsa"], self.code: analog["rtd_frac"]}

    def held_inputs(self, t_c: np.ndarray, level: np.ndarray, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Rate ``level`` (FS) with the nominal stimulus' quadrature (0.05 FS) and sense noise
        (1e-3 FS), which dithers the ADCs as in a real sensor."""
        return self.sensor_inputs(t_c, level, quad_fs=NOMINAL_QUADRATURE_FS, rng=rng, noise_fs=1e-3)

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
        out = self.sensor_analog(t_c, rate, quad_fs=NOMINAL_QUADRATURE_FS, rng=rng, noise_fs=1e-3)
        out.update(t_c=t_c, rate_fs=rate, codes=self.digitise(out["analog"]))
        return out

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        nom = self.nominal_stimulus(rng, n)
        # saturation: full-scale sense input at the coldest and hottest ends of the RTD range
        m = 1024
        hot = self.rtd.adc_code(np.full(m, 60.0))
        full = quantize(self.demod.carrier(self.divide.in_format.max_value * 1.1, 0.0, m), self.divide.in_format,
                        NEAREST_SAT)
        return {self.vsa: np.concatenate([nom[self.vsa], full]), self.code: np.concatenate([nom[self.code], hot])}


class GyroFreq(Sensor):
    """Paper 001's gyro: resonant frequency f(T) = f0 + k T and a zero-rate output q(T) + noise."""

    name = "gyro_freq"
    CHAMBER_C = (-10.0, 50.0)
    CHAMBER_LEVEL = 100.0  # rate, deg/h (the rate input's unit)
    STEADY_LEVEL = 100.0
    LEVEL_SPAN, LEVEL_UNIT = 100.0, "deg/h"
    NOISE = 1.0            # zero-rate output noise, deg/h

    def __init__(self, chain):
        super().__init__(chain)
        self.f2t = self.of_kind("freq2temp")
        self.subtract = self.of_kind("bias_subtract")
        self.bias = self.driver(self.subtract, "bias")
        self.f, self.rate_in = self.input_of(self.f2t, "f"), self.input_of(self.subtract, "x")

    def analog_inputs(self, analog: dict) -> dict[str, np.ndarray]:
        return {self.f: analog["f"], self.rate_in: analog["rate_in"]}

    def held_inputs(self, t_c: np.ndarray, level: np.ndarray, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Zero-rate output q(T) plus the rate ``level`` (deg/h) and the output noise."""
        rate = self.bias.reference(temp=t_c)["y"] + level + rng.normal(0.0, self.NOISE, len(t_c))
        return {self.f: self.f2t.freq_code(t_c), self.rate_in: quantize(rate, self.subtract.in_format, NEAREST_SAT)}

    def nominal_analog(self, rng: np.random.Generator, n: int) -> dict:
        """Chamber points -10..50 C; zero-rate output = the quadratic bias of the same config + noise:
        the analog frequency and rate (``clean`` without the noise) and their words."""
        t_c = np.repeat(np.arange(-10.0, 51.0, 10.0), -(-n // 7))[:n] + rng.normal(0, 0.05, n)
        q = self.bias.reference(temp=t_c)["y"]
        noise = rng.normal(0.0, self.NOISE, n)
        f = self.f2t.frequency(t_c)
        codes = {self.f: self.f2t.freq_code(t_c),
                 self.rate_in: quantize(q + noise, self.subtract.in_format, NEAREST_SAT)}
        return {"analog": {"f": f, "rate_in": q + noise}, "clean": {"f": f, "rate_in": q}, "codes": codes, "t_c": t_c}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        nom = self.nominal_stimulus(rng, n)
        extra = self.f2t.stimulus(rng, 0)["f"]
        fi = self.subtract.in_format
        rate_extra = np.resize(np.array([fi.min_int, fi.max_int, 0, -1, 1], np.int64), extra.size)
        return {self.f: np.concatenate([nom[self.f], extra]),
                self.rate_in: np.concatenate([nom[self.rate_in], rate_extra])}


class Qvba(Sensor):
    """Paper 000's quartz vibrating-beam accelerometer: Df = K0(t) + K1(t) a, t = T - 25 C, with
    K0(t), K1(t) the chain's own engines (the one driving the subtraction's bias and the one
    driving the divider's scale factor); the temperature word read directly."""

    name = "qvba"
    G_STEPS = (0.0, 1.0, -1.0, 0.5, 0.0, -0.25, 2.0, -2.0)   # the tumble's +-1 g and a few more
    CHAMBER_C = (-35.0, 75.0)
    CHAMBER_LEVEL = 1.0    # acceleration, g
    STEADY_LEVEL = 1.0
    LEVEL_SPAN, LEVEL_UNIT = 1.0, "g"   # the tumble's +-1 g
    NOISE_HZ = 1e-4        # frequency-counter noise

    def __init__(self, chain):
        super().__init__(chain)
        self.subtract = self.of_kind("bias_subtract")
        self.divide = self.of_kind("sf_divide")
        self.k0 = self.driver(self.subtract, "bias")
        self.k1 = self.driver(self.divide, "sf")
        self.df = self.input_of(self.subtract, "x")
        self.temp = self.input_of(self.k0, "temp")
        if self.input_of(self.k1, "temp") != self.temp:
            raise self._fail("K0 and K1 fed by the same temperature input")

    def sensor_analog(self, t_c: np.ndarray, accel_g: np.ndarray, rng: np.random.Generator | None = None,
                      noise_hz: float = 0.0) -> dict:
        k0 = self.k0.reference(temp=t_c)["y"]
        k1 = self.k1.reference(temp=t_c)["y"]
        clean = k0 + k1 * accel_g
        df = clean + rng.normal(0.0, noise_hz, len(t_c)) if rng is not None and noise_hz else clean
        return {"analog": {"df": df, "temp": t_c}, "clean": {"df": clean, "temp": t_c}}

    def analog_inputs(self, analog: dict) -> dict[str, np.ndarray]:
        return {self.df: analog["df"], self.temp: analog["temp"]}

    def held_inputs(self, t_c: np.ndarray, level: np.ndarray, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Acceleration ``level`` (g) with the counter's noise."""
        return self.digitise(self.sensor_analog(t_c, level, rng, self.NOISE_HZ)["analog"])

    def digitise(self, analog: dict) -> dict[str, np.ndarray]:
        """The frequency counter's word (nearest, saturating) and the temperature word."""
        return {self.df: quantize(analog["df"], self.subtract.in_format, NEAREST_SAT),
                self.temp: quantize(analog["temp"], self.k0.temp_format, NEAREST_SAT)}

    def nominal_analog(self, rng: np.random.Generator, n: int) -> dict:
        """Temperature swept -35..75 C (the paper's six chamber points 20 C apart and beyond), the
        acceleration stepping through the tumble's +-1 g and 0.5..2 g, counter noise 1e-4 Hz."""
        n = max(n, 4096)
        t_c = np.linspace(-35.0, 75.0, n)
        a = np.repeat(np.array(self.G_STEPS), -(-n // len(self.G_STEPS)))[:n]
        out = self.sensor_analog(t_c, a, rng, self.NOISE_HZ)
        out.update(t_c=t_c, accel_g=a, codes=self.digitise(out["analog"]))
        return out

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        nom = self.nominal_stimulus(rng, n)
        fi, ft = self.subtract.in_format, self.k0.temp_format
        corners = np.array([fi.min_int, fi.max_int, 0, -1, 1], np.int64)
        temps = quantize(np.array([-40.0, 85.0, 25.0, -40.0, 85.0]), ft, NEAREST_SAT)
        return {self.df: np.concatenate([nom[self.df], np.repeat(corners, 5)]),
                self.temp: np.concatenate([nom[self.temp], np.tile(temps, 5)])}


SENSORS = {s.name: s for s in (GyroRtd, GyroFreq, Qvba)}


def sensor_for(chain) -> Sensor | None:
    """The chain's sensor model (None: no ``sensor`` in its table)."""
    name = chain.netlist.sensor
    if name is None:
        return None
    if name not in SENSORS:
        raise InputError(f"{chain.netlist.name}.sensor: {name!r} is not one of {', '.join(SENSORS)}")
    return SENSORS[name](chain)
