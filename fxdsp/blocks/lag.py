"""Thermal-lag compensation: a first-order low-pass on the temperature code, so that the coefficient
engine sees an estimate of the die temperature instead of the thermometer's.

When ``fxdsp diagnose`` finds ``thermal_lag`` (the sensing element follows the thermometer through
dTe/dt = (T - Te)/tau), the FPGA should evaluate SF(Te) and bias(Te), not SF(T). This block computes::

    Te[n] = Te[n-1] + alpha * (T[n] - Te[n-1]),   alpha = 1 - exp(-1 / (rate_hz * tau_s))

at the temperature update rate ``rate_hz`` (a chamber-scale tau of hours at 10 Hz gives alpha of
1e-5: far too small for a plain coefficient, so alpha is a ``alpha_bits``-bit mantissa m and a shift
s, alpha = m * 2**-s, m in [2**(alpha_bits-1), 2**alpha_bits)).

Decimation: inside a chain the input arrives at the chain's sample rate, ``decimation`` = N times
the update rate (the chain's fs_hz / rate_hz). The state then updates on every N-th input (the
first after a reset, then every N), and the output holds between updates. Why not update at fs: at
96 kHz a tau of two hours gives alpha = 1.4e-9, whose dead band (0.5/alpha state LSBs) is ~330
temperature codes (0.04 C) even at the 20 guard bits a 63-bit product allows; at 10 Hz it is 0.04
codes. The temperature moves by microkelvin per chain sample: nothing is lost by updating at 10 Hz.

Datapath (stored integers): the state Te carries ``state_guard_bits`` more fraction bits than the
temperature code (without them, steps smaller than 1/alpha LSB would never move the state: a dead
band of 1/alpha codes)::

    d   = (T << g) - Te                         exact
    Te  = Te + round(d * m >> s)                rounding by ``rounding``; Te cannot leave [T range]
    out = round(Te >> g)                        into temp_format (``rounding``), fitted by ``overflow``

The float reference is the exact discrete first-order recursion with the unquantised alpha.
"""

from __future__ import annotations

import math

from dataclasses import dataclass

import numpy as np
from numba import njit

from fxdsp.config import Section
from fxdsp.fixed import Format, OverflowLog, Rules
from fxdsp.fixed.kernels import convert, shift_right_round
from fxdsp.blocks.base import Block, corner_codes
from fxdsp.blocks.datapath import Datapath, limbs, OvfField, RtlPorts, info
from fxdsp.errors import InputError


@njit(cache=True)
def _lag_kernel(x, m, s, g, rounding, lo, hi, overflow, decimation, state):
    """state[0] = Te with g extra fraction bits, state[1] = inputs since the last update (0: the next
    input updates), both carried across calls. Returns (y, overflows counted at updates)."""
    n = x.shape[0]
    y = np.empty(n, dtype=np.int64)
    te = state[0]
    phase = state[1]
    held, _ = convert(te, g, rounding, lo, hi, overflow)   # the output between updates
    count = 0
    for i in range(n):
        if phase == 0:
            d = (x[i] << g) - te
            te += shift_right_round(d * m, s, rounding)
            held, o = convert(te, g, rounding, lo, hi, overflow)
            count += o
        y[i] = held
        phase += 1
        if phase == decimation:
            phase = 0
    state[0] = te
    state[1] = phase
    return y, count


def held(updates: np.ndarray, decimation: int, n: int) -> np.ndarray:
    """Values computed on every ``decimation``-th input, held over the inputs between (n of them)."""
    return np.repeat(updates, decimation)[:n]


@dataclass(frozen=True, eq=False)
class LagDatapath(Datapath):
    """Fields in the order of the ``lag`` RTL module's parameters."""

    MODULE = "lag"
    RTL = RtlPorts(ready=True, serial=True, signed=("temp",))

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """hdl/rtl/lag.v: N + 11 cycles per update sample, N the 16 x 16 limb products of d
        (STATE_W + 1 bits) x alpha (ALPHA_W + 1 bits); at DECIM = 1 every sample updates (with
        DECIM > 1 a held sample takes 1 cycle: no one figure, a ValueError)."""
        if p["DECIM"] != 1:
            raise InputError("lag: DECIM > 1: the samples between updates take 1 cycle, the updates this many")
        return limbs(p["STATE_W"] + 1, p["ALPHA_W"] + 1) + 11

    temp_w: int
    guard: int           # g: state fraction bits beyond the temperature code
    state_w: int
    alpha_w: int
    alpha_m: int         # alpha = alpha_m * 2**-alpha_s
    alpha_s: int
    decim: int           # the state updates on every decim-th input (1: every input)
    rules: Rules
    temp_format: Format = info()
    ovf: tuple = info(default=(OvfField("te", 1),))


class Lag(Block):
    """Thermal-lag compensation: a first-order low-pass ``temp`` -> ``te``, the die-temperature
    estimate the coefficient engines see (module docstring)."""

    name = "lag"

    def __init__(self, temp_format: Format, tau_s: float, rate_hz: float, alpha_bits: int, state_guard_bits: int,
                 rules: Rules, name: str = "lag", decimation: int = 1):
        if isinstance(decimation, bool) or not isinstance(decimation, int) or decimation < 1:
            raise InputError(f"{name}.decimation: must be an integer >= 1, got {decimation!r}")
        if not tau_s > 0:
            raise InputError(f"{name}.tau_s: must be > 0, got {tau_s}")
        if not rate_hz > 0:
            raise InputError(f"{name}.rate_hz: must be > 0, got {rate_hz}")
        self.name = name
        self.temp_format, self.tau_s, self.rate_hz = temp_format, tau_s, rate_hz
        self.alpha = -math.expm1(-1.0 / (rate_hz * tau_s))
        # alpha = m * 2**-s with m normalised to alpha_bits bits (the nearest such m: half_up)
        self.s = alpha_bits - 1 - math.floor(math.log2(self.alpha))
        self.m = int(math.floor(self.alpha * 2.0**self.s + 0.5))
        if self.m >= 1 << alpha_bits:  # rounding carried into a new bit
            self.m >>= 1
            self.s -= 1
        self.alpha_bits, self.g, self.decimation = alpha_bits, state_guard_bits, decimation
        self.rules = rules
        self.state_format = Format(True, temp_format.wl + state_guard_bits + 1, temp_format.fl + state_guard_bits)
        if self.state_format.wl + 1 + alpha_bits > 63:
            raise InputError(f"{name}: state {self.state_format} times a {alpha_bits}-bit alpha exceeds 63 bits; "
                             f"reduce state_guard_bits or alpha_bits")
        self.datapath = LagDatapath(temp_w=temp_format.wl, guard=self.g, state_w=self.state_format.wl,
                                    alpha_w=alpha_bits, alpha_m=self.m, alpha_s=self.s, decim=decimation, rules=rules,
                                    temp_format=temp_format)
        self.inputs = {"temp": temp_format}
        self.outputs = {"te": temp_format}
        self.reset()

    @classmethod
    def from_config(cls, sec: Section, temp_format: Format, wired_rate_hz: float | None = None,
                    rate_source: str = "", enforce: bool = True) -> "Lag":
        """``wired_rate_hz``: the lag's input arrives once per sample of ``rate_source``; ``rate_hz``
        (left out: that rate) is the update rate and must divide it: the lag then updates on every
        (wired / rate)-th input and holds between (for block-level work, ``enforce`` False, a stated
        rate is taken as given and every input updates)."""
        rate = sec.number("rate_hz", wired_rate_hz, low=0, low_open=True)
        decimation = 1
        if wired_rate_hz is not None and enforce:
            ratio = wired_rate_hz / rate
            decimation = round(ratio)
            if decimation < 1 or abs(ratio - decimation) > 1e-9 * ratio:
                raise InputError(f"{sec.field('rate_hz')}: {rate:g} must divide {rate_source} ({wired_rate_hz:g}) "
                                 f"into a whole number of samples: the lag updates once every {rate_source} / "
                                 f"rate_hz samples")
        return cls(temp_format, sec.number("tau_s", low=0, low_open=True), rate,
                   sec.integer("alpha_bits", low=4, high=24), sec.integer("state_guard_bits", low=0, high=40),
                   sec.rules(), name=sec.path, decimation=decimation)

    def reset(self) -> None:
        self.state = np.zeros(2, dtype=np.int64)
        self.primed = False

    def get_state(self) -> dict:
        """Te with the guard bits, inputs since the last update, and whether it has been primed by a
        first reading."""
        return {"te": int(self.state[0]), "phase": int(self.state[1]), "primed": self.primed}

    def set_state(self, state) -> None:
        if not isinstance(state, dict) or set(state) != {"te", "phase", "primed"}:
            raise InputError(f"{self.name}: state: expected a previous result's state {{'te', 'phase', 'primed'}}")
        phase = int(state["phase"])
        if not 0 <= phase < self.decimation:
            raise InputError(f"{self.name}: state: phase {phase} outside 0..{self.decimation - 1}")
        self.state = np.array([int(state["te"]), phase], dtype=np.int64)
        self.primed = bool(state["primed"])

    def stream(self, log: OverflowLog, temp: np.ndarray) -> dict[str, np.ndarray]:
        if not self.primed and temp.size:
            # start settled on the first reading (power-on: die and thermometer at the same temperature)
            self.state[0] = int(temp[0]) << self.datapath.guard
            self.primed = True
        dp = self.datapath
        y, n = _lag_kernel(temp, dp.alpha_m, dp.alpha_s, dp.guard, dp.rules.rounding_code, dp.temp_format.min_int,
                           dp.temp_format.max_int, dp.rules.overflow_code, dp.decim, self.state)
        log.add(f"{self.name}.{dp.ovf[0].counter}", n)
        return {"te": y}

    def reference(self, temp: np.ndarray) -> dict[str, np.ndarray]:
        from scipy.signal import lfilter

        x = np.asarray(temp, dtype=float)
        if x.size == 0:
            return {"te": x}
        updates = x[::self.decimation]   # the inputs the state updates on; the output holds between
        y, _ = lfilter([self.alpha], [1.0, self.alpha - 1.0], updates, zi=[(1.0 - self.alpha) * updates[0]])
        return {"te": held(y, self.decimation, x.size)}

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """A chamber programme at the update rate: dwell, ramp up, dwell, ramp down (+ sensor noise)."""
        n = max(n, 64)
        t = np.arange(n) / self.rate_hz
        span = n / self.rate_hz
        temp = np.interp(t, [0, 0.1 * span, 0.4 * span, 0.6 * span, 0.9 * span, span], [20, 20, 60, 60, -10, -10])
        temp = temp + rng.normal(0, 0.01, n)
        f = self.temp_format
        return {"temp": np.clip(np.floor(temp * 2.0**f.fl + 0.5), f.min_int, f.max_int).astype(np.int64)}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """Full-scale steps both ways (the state slews across the whole range), corners, nominal."""
        f = self.temp_format
        hold = int(min(4096, 3 * self.decimation / self.alpha))
        parts = [np.full(8, 0, np.int64), np.full(hold, f.max_int, np.int64), np.full(hold, f.min_int, np.int64),
                 np.repeat(corner_codes(f), 16), self.nominal_stimulus(rng, n)["temp"]]
        return {"temp": np.concatenate(parts)}

    def parameters(self) -> dict:
        return {"temp_format": str(self.temp_format), "tau_s": self.tau_s, "rate_hz": self.rate_hz,
                "alpha": self.alpha, **({"decimation": self.decimation} if self.decimation > 1 else {}),
                "alpha_mantissa": self.m, "alpha_shift": self.s, "alpha_bits": self.alpha_bits,
                "state_guard_bits": self.g, "state_format": str(self.state_format),
                "rounding": self.rules.rounding, "overflow": self.rules.overflow}
