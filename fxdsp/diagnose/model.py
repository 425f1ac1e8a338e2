"""The baseline of the contract (section 2) and its extensions (section 3) as linear designs.

Every channel model is linear in its coefficients once the nonlinear parameters of the causes in
play (a lag time constant, a warm-up time constant) are fixed, so a cause is tested by adding a
column (ramp rate, hysteresis state, warm-up, aging, quadrature, S rate^3, curvature) or by
transforming the temperature (lag), and the fit is one least-squares solve. The mechanisms
themselves come from fxdsp.mechanisms, shared with the simulator.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from fxdsp import mechanisms as mech
from fxdsp.causes import CAUSES
from fxdsp.ramps import quantisation_step, read_ramps

T_REF_C = mech.T_CURVE_C

# the causes that add a column to the output design (fxdsp.causes: the column and its parameter)
OUTPUT_TERMS = tuple(c for c in CAUSES.values() if c.channel == "output" and c.term is not None)


@dataclass
class Series:
    """The usable rows of a log, with the derived signals every candidate needs."""

    t: np.ndarray
    temp: np.ndarray
    out: np.ndarray
    ref: np.ndarray | None = None
    rate: np.ndarray | None = None
    freq: np.ndarray | None = None
    quad: np.ndarray | None = None
    dtdt: np.ndarray = field(init=False)
    hyst: np.ndarray = field(init=False)

    def __post_init__(self):
        # ramps, hysteresis state and a derivative smoothed just enough for the log's own noise
        # and ramp rates (fxdsp.ramps states the rules; the report repeats what they found)
        self.ramps = read_ramps(self.t, self.temp)
        self.dtdt = self.ramps.dtdt
        self.hyst = self.ramps.state
        self._freq_thermometer = None
        self._linear_temp = None
        # S(Te) of the calibrated baseline (output unit per rate unit), set by the engine: with it
        # the cubic rate term S k3 rate^3 is one linear column whose coefficient is k3 itself
        self.sf_estimate: np.ndarray | None = None

    def decimated(self, step: int) -> "Series":
        """Every ``step``-th row, derived signals included (computed on the full log first, so the
        smoothing and the ramp states are those of the full log)."""
        new = copy.copy(self)
        for name in ("t", "temp", "out", "ref", "rate", "freq", "quad", "dtdt", "hyst", "sf_estimate"):
            value = getattr(self, name)
            if value is not None:
                setattr(new, name, np.ascontiguousarray(value[::step]))
        new._freq_thermometer = None
        new._linear_temp = None
        return new

    @property
    def n(self) -> int:
        return self.t.size

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def freq_thermometer(self) -> np.ndarray:
        """What the resonator frequency is compared with: the calibrated reference when logged
        (so an RTD curvature is not mistaken for a frequency turnover), mapped onto temp_c's linear
        scale by a straight-line fit (Te lives on that scale); temp_c itself without a reference."""
        if self.ref is None:
            return self.temp
        if self._freq_thermometer is None:
            gain, offset = polyfit(self.ref - T_REF_C, self.temp, 1)
            self._freq_thermometer = offset + gain * (self.ref - T_REF_C)
        return self._freq_thermometer

    @property
    def linear_temp(self) -> np.ndarray:
        """temp_c with its curvature against the reference taken out (a least-squares quadratic in
        ref_temp_c - 25, its square term removed): temp_c's timing and noise on the reference's
        linear scale; temp_c itself without a reference."""
        if self.ref is None:
            return self.temp
        if self._linear_temp is None:
            u = self.ref - T_REF_C
            self._linear_temp = self.temp - polyfit(u, self.temp, 2)[0] * u * u
        return self._linear_temp

    def target(self, channel: str) -> np.ndarray:
        return {"output": self.out, "freq_hz": self.freq, "temp_c": self.temp}[channel]

    def channels(self) -> list[str]:
        out = ["output"]
        if self.freq is not None:
            out.append("freq_hz")
        if self.ref is not None:
            out.append("temp_c")
        return out


def polyfit(x: np.ndarray, y: np.ndarray, degree: int) -> np.ndarray:
    """np.polyfit's coefficients (highest power first), for any x a log can hold: x with fewer
    distinct values than the degree needs (a reference that never moves, a head of rows sharing one
    stamp) is fitted to the degree its values allow, the higher powers 0 (np.polyfit's scaling
    divides by a zero column there, and its SVD fails)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    usable = min(degree, np.unique(x).size - 1)
    coef = np.zeros(degree + 1)
    if usable < 0:
        return coef
    coef[degree - usable:] = np.polyfit(x, y, usable) if usable > 0 else [float(np.mean(y))]
    return coef


def spike_rows(values: np.ndarray, threshold: float = 25.0) -> np.ndarray:
    """Isolated one-sample spikes: a reading far from the line through its two neighbours while
    the neighbours agree with each other.

    Not sentinels but non-physical readings (a meter's first reading after a range change, a
    dropped bit: the tckit log starts with 4.67 V in a 1.00002 V channel). A step (rate table) or
    a steep ramp moves the neighbours apart too, so neither is flagged; one spike in a log of 1e-5
    relative variations would otherwise dominate every least-squares fit.
    """
    y = np.asarray(values, dtype=float)
    n = y.size
    flags = np.zeros(n, dtype=bool)
    if n < 7:
        return flags
    dev = np.empty(n)
    gap = np.empty(n)
    dev[1:-1] = y[1:-1] - 0.5 * (y[:-2] + y[2:])
    gap[1:-1] = np.abs(y[2:] - y[:-2])
    dev[0], gap[0] = y[0] - (2 * y[1] - y[2]), np.abs(y[1] - y[2])  # end rows: extrapolate
    dev[-1], gap[-1] = y[-1] - (2 * y[-2] - y[-3]), np.abs(y[-2] - y[-3])
    spread = 1.4826 * np.median(np.abs(dev[1:-1] - np.median(dev[1:-1])))
    # a quantised reading whose noise is below its step toggles by one step now and then: that is
    # the reading's resolution, not a spike (its MAD can be 0)
    spread = max(spread, quantisation_step(y) / np.sqrt(12.0))
    if not spread > 0:
        spread = float(np.std(dev[1:-1]))
    if not spread > 0:
        return flags
    return (np.abs(dev) > threshold * spread) & (np.abs(dev) > 4.0 * gap)


@dataclass(frozen=True)
class Scaling:
    """Affine map of a temperature onto about [-1, 1], for well-conditioned polynomial columns."""

    mid: float
    half: float

    @classmethod
    def of(cls, values: np.ndarray) -> "Scaling":
        lo, hi = float(np.min(values)), float(np.max(values))
        return cls(mid=0.5 * (lo + hi), half=max(0.5 * (hi - lo), 1.0))

    def __call__(self, values: np.ndarray) -> np.ndarray:
        return (values - self.mid) / self.half


def lagged(series: Series, values: np.ndarray, tau_s: float) -> np.ndarray:
    """Te through the contract's lag, started from a de-noised first reading: a noisy start value
    would decay like exp(-t/tau) and look like a warm-up of the same time constant."""
    t = series.t
    head = t <= t[0] + min(0.1 * tau_s, 600.0)
    if head.sum() >= 3:
        slope, intercept = polyfit(t[head] - t[0], values[head], 1)
        start = float(intercept)
    else:
        start = float(values[0])
    return mech.first_order_lag(t, values, tau_s, initial=start)


def element_temperature(series: Series, state: dict) -> np.ndarray:
    """The element's temperature as the output is fitted against it (before a thermal lag): what
    temp_c reads, or, once a cause of ``state`` is a misreading of the thermometer (the RTD's
    curvature: the element itself is not curved), temp_c with that misreading taken out."""
    if any(CAUSES[name].misreads_thermometer for name in state if name in CAUSES):
        return series.linear_temp
    return series.temp


def output_design(series: Series, state: dict, orders: tuple[int, int | None], scale: Scaling
                  ) -> tuple[np.ndarray, list[str]]:
    """output = B(Te) + S(Te) * rate_eff [+ cause columns]."""
    pb, ps = orders
    te = element_temperature(series, state)
    if "thermal_lag" in state:
        te = lagged(series, te, state["thermal_lag"]["tau_s"])
    x = scale(te)
    cols, names = [], []
    power = np.ones_like(x)
    powers = []
    for j in range(max(pb, ps if ps is not None else -1) + 1):
        powers.append(power)
        power = power * x
    for j in range(pb + 1):
        cols.append(powers[j])
        names.append(f"b{j}")
    if ps is not None and series.rate is not None:
        rate = series.rate
        for j in range(ps + 1):
            cols.append(rate * powers[j])
            names.append(f"s{j}")
    for cause in OUTPUT_TERMS:
        if cause.name in state:
            cols.append(cause.term(series, state))
            names.append(cause.name)
    if "thermal_lag" in state and has_lag_start(series, state["thermal_lag"]["tau_s"]):
        cols.append(lag_start(series, state["thermal_lag"]["tau_s"]))
        names.append("lag_start")
    return np.column_stack(cols), names


# the share of the log by which a lag's start transient must still be alive to get a column
START_SUPPORT = 0.02


def has_lag_start(series: Series, tau_s: float) -> bool:
    """Whether the lag's start transient outlives the first START_SUPPORT of the log (to 5 %). A
    shorter one dies inside the first held-out segment: its column would be fitted, in the folds
    without that segment, to nothing, and its held-out prediction would be noise amplified."""
    t = series.t
    return bool(np.exp(-(START_SUPPORT * (t[-1] - t[0])) / tau_s) > 0.05)


def lag_start(series: Series, tau_s: float) -> np.ndarray:
    """How an error in the lag's start value shows: the lag is linear, so a start error d adds
    d exp(-(t - t0)/tau) to Te. A nuisance column (not a cause): without it, the noise of the first
    readings would leave a transient that other causes try to explain."""
    return np.exp(-(series.t - series.t[0]) / tau_s)


def freq_design(series: Series, state: dict, scale: Scaling) -> tuple[np.ndarray, list[str]]:
    """freq_hz = f0 + k Te [+ k2 (Te - 25)^2]."""
    te = series.freq_thermometer
    if "thermal_lag" in state:
        te = lagged(series, te, state["thermal_lag"]["tau_s"])
    x = scale(te)
    cols, names = [np.ones_like(x), x], ["f0", "k"]
    cols, names = _curvatures("freq_hz", state, x, cols, names)
    if "thermal_lag" in state and has_lag_start(series, state["thermal_lag"]["tau_s"]):
        cols.append(lag_start(series, state["thermal_lag"]["tau_s"]))
        names.append("lag_start")
    return np.column_stack(cols), names


def temp_design(series: Series, state: dict, scale: Scaling) -> tuple[np.ndarray, list[str]]:
    """temp_c = offset + gain * ref_temp_c [+ curvature]."""
    x = scale(series.ref)
    cols, names = [np.ones_like(x), x], ["t0", "t1"]
    cols, names = _curvatures("temp_c", state, x, cols, names)
    return np.column_stack(cols), names


def _curvatures(channel: str, state: dict, x: np.ndarray, cols: list, names: list) -> tuple[list, list]:
    """The x^2 column of each curvature cause of ``channel`` in play (fxdsp.causes)."""
    for cause in CAUSES.values():
        if cause.curvature is not None and cause.channel == channel and cause.name in state:
            cols.append(x * x)
            names.append(cause.name)
    return cols, names
