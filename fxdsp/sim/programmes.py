"""Chamber programmes: what the climatic chamber, the rate table and the tumble fixture do over time.

A programme is a list of :class:`Segment`. Each segment moves the chamber air linearly from the
previous setpoint to ``end_c`` over ``duration_s`` (a dwell keeps it), while the rate table holds
``rate_dps`` and the tumble fixture holds ``angle_deg``. The air temperature is therefore
piecewise-linear, which is exactly what :func:`fxdsp.mechanisms.first_order_lag` integrates without
discretisation error.

Chosen numbers (and why):

* chamber ramp rate 1 C/min between setpoints: a typical climatic-chamber slew that a dwell of an
  hour or more then lets settle; the "ramp" scenario uses 0.5 C/min so that a lag shows as a clear
  heating/cooling split;
* room temperature 23 C at power-on (paper 002's bridge balances at about 22.9 C);
* paper 002: room -> 60 C, then 40, 20, 0, -20 C; at each point 1.5 h dwell "to stability", 1 h
  zero-rate log, then a rate-table sequence of +-{10, 50, 100, 200} deg/s for 2 min each;
* paper 001: room -> -10 C, then up in 10 C steps to 50 C with 1.5 h dwells, back to 25 C and a 6 h
  static run;
* paper 000: six temperatures 20 C apart, -40 .. 60 C (the paper's full operating range), 1 h dwell,
  then the four-position tumble 0/90/180/270 deg for 10 min each; the whole sequence is run twice;
* ramp: dwell at 25 C, heat to 60 C, dwell, cool to -20 C, dwell, heat back to 25 C, dwell;
* random: 6..10 segments drawn from the seed: fast steps (3 C/min), slow ramps (0.1..1 C/min) and
  dwells (0.5..3 h) between -30 and 70 C, some dwells followed by a rate-table sequence;
* power_on: one minute at 50 C (the top of paper 001's chamber range, its resonance 1.3 Hz above
  the 25 C one) from the instrument's power-on: with ``--drive-loop`` the loop is switched on at the
  first row (``loop_warmup_s`` 0; every other scenario's loop has run ``LOOP_WARMUP_S`` before its
  log starts), so the log shows the acquisition (paper 001's resonator; a time step of 10 ms shows
  it row by row).

``duration_scale`` scales the holds (dwells, logs, rate steps, tumble positions) but not the chamber
ramp rates, so a shortened test still ramps at physical speed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from fxdsp.errors import InputError

ROOM_C = 23.0
CHAMBER_RAMP_C_PER_MIN = 1.0
FAST_STEP_C_PER_MIN = 3.0
RATE_TABLE_DPS = (10.0, -10.0, 50.0, -50.0, 100.0, -100.0, 200.0, -200.0)
RATE_STEP_S = 120.0
LOOP_WARMUP_S = 5.0   # a drive loop runs this long before a log starts (a settled instrument), unless power_on


@dataclass(frozen=True)
class Segment:
    duration_s: float
    end_c: float
    rate_dps: float = 0.0
    angle_deg: float = 0.0
    phase: str = "dwell"  # "ramp", "dwell", "log", "rate", "tumble", "static"


class _Builder:
    """Accumulates segments; knows the current setpoint so ramps are given by their rate."""

    def __init__(self, start_c: float, scale: float):
        self.segments: list[Segment] = []
        self.start_c = start_c
        self.temp_c = start_c
        self.scale = scale
        self.loop_warmup_s = LOOP_WARMUP_S

    def ramp(self, to_c: float, c_per_min: float = CHAMBER_RAMP_C_PER_MIN) -> None:
        if to_c == self.temp_c:
            return
        duration = abs(to_c - self.temp_c) / c_per_min * 60.0  # ramps keep their physical rate
        self.segments.append(Segment(duration, to_c, phase="ramp"))
        self.temp_c = to_c

    def hold(self, duration_s: float, phase: str = "dwell", rate_dps: float = 0.0,
             angle_deg: float = 0.0) -> None:
        self.segments.append(Segment(duration_s * self.scale, self.temp_c, rate_dps, angle_deg, phase))

    def rate_table(self) -> None:
        for rate in RATE_TABLE_DPS:
            self.hold(RATE_STEP_S, "rate", rate_dps=rate)


def paper002(scale: float, rng: np.random.Generator | None = None) -> _Builder:
    b = _Builder(ROOM_C, scale)
    b.hold(600.0, "dwell")  # power-on at room temperature
    for setpoint in (60.0, 40.0, 20.0, 0.0, -20.0):
        b.ramp(setpoint)
        b.hold(1.5 * 3600.0, "dwell")
        b.hold(3600.0, "log")
        b.rate_table()
    return b


def paper001(scale: float, rng: np.random.Generator | None = None) -> _Builder:
    b = _Builder(ROOM_C, scale)
    b.hold(600.0, "dwell")
    for setpoint in range(-10, 51, 10):
        b.ramp(float(setpoint))
        b.hold(1.5 * 3600.0, "log")
    b.ramp(25.0)
    b.hold(3600.0, "dwell")
    b.hold(6 * 3600.0, "static")
    return b


PAPER000_TEMPS_C = (-40.0, -20.0, 0.0, 20.0, 40.0, 60.0)
TUMBLE_ANGLES_DEG = (0.0, 90.0, 180.0, 270.0)


def paper000(scale: float, rng: np.random.Generator | None = None) -> _Builder:
    b = _Builder(ROOM_C, scale)
    b.hold(600.0, "dwell")
    for _run in range(2):
        for setpoint in PAPER000_TEMPS_C:
            b.ramp(setpoint)
            b.hold(3600.0, "dwell")
            for angle in TUMBLE_ANGLES_DEG:
                b.hold(600.0, "tumble", angle_deg=angle)
    b.ramp(ROOM_C)
    return b


def ramp(scale: float, rng: np.random.Generator | None = None) -> _Builder:
    b = _Builder(25.0, scale)
    b.hold(3600.0, "dwell")
    for setpoint in (60.0, -20.0, 25.0):
        b.ramp(setpoint, 0.5)
        b.hold(2 * 3600.0, "dwell")
    return b


def power_on(scale: float, rng: np.random.Generator | None = None) -> _Builder:
    b = _Builder(50.0, scale)
    b.loop_warmup_s = 0.0
    b.hold(60.0, "dwell")
    return b


def random_programme(scale: float, rng: np.random.Generator) -> _Builder:
    b = _Builder(float(rng.uniform(15.0, 30.0)), scale)
    b.hold(float(rng.uniform(600.0, 3600.0)), "dwell")
    for _ in range(int(rng.integers(6, 11))):
        target = float(np.round(rng.uniform(-30.0, 70.0), 1))
        if rng.random() < 0.4:
            b.ramp(target, FAST_STEP_C_PER_MIN)
        else:
            b.ramp(target, float(rng.uniform(0.1, 1.0)))
        b.hold(float(rng.uniform(0.5, 3.0)) * 3600.0, "dwell")
        if rng.random() < 0.4:
            b.rate_table()
    return b


PROGRAMMES = {
    "paper002": paper002,
    "paper001": paper001,
    "paper000": paper000,
    "ramp": ramp,
    "random": random_programme,
    "power_on": power_on,
}


@dataclass
class Sampled:
    """A programme sampled on the log's time grid."""

    time_s: np.ndarray
    air_c: np.ndarray
    rate_dps: np.ndarray
    angle_deg: np.ndarray
    setpoint_c: np.ndarray
    phase: np.ndarray  # segment phase name per sample
    segment: np.ndarray  # segment index per sample


MAX_ROWS = 10_000_000   # a 10 M-row CSV is about 1 GB


def sample(segments: list[Segment], start_c: float, time_step_s: float) -> Sampled:
    """Sample a programme every ``time_step_s`` from 0 to its end (inclusive of the last sample)."""
    if not time_step_s > 0:
        raise InputError(f"time_step_s: must be > 0, got {time_step_s}")
    ends = np.cumsum([s.duration_s for s in segments])
    total = float(ends[-1])
    n = int(np.floor(total / time_step_s)) + 1
    if n > MAX_ROWS:   # a memory error (tens of GB) rather than a log, otherwise
        raise InputError(f"time_step_s: {time_step_s:g} s gives {n} rows over the programme's {total:g} s; at most "
                         f"{MAX_ROWS} (a step of {total / (MAX_ROWS - 1):.3g} s or more)")
    t = np.arange(n) * time_step_s
    knots_t = np.concatenate([[0.0], ends])
    knots_c = np.concatenate([[start_c], [s.end_c for s in segments]])
    air = np.interp(t, knots_t, knots_c)
    # a sample at a segment boundary belongs to the segment that starts there
    index = np.minimum(np.searchsorted(ends, t, side="right"), len(segments) - 1)
    rate = np.array([s.rate_dps for s in segments])[index]
    angle = np.array([s.angle_deg for s in segments])[index]
    setpoint = np.array([s.end_c for s in segments])[index]
    phase = np.array([s.phase for s in segments])[index]
    return Sampled(t, air, rate, angle, setpoint, phase, index)


def programme(name: str, scale: float, rng: np.random.Generator) -> tuple[list[Segment], float, float]:
    """Segments of a named scenario, the chamber temperature at power-on and how long a drive loop
    runs before the log starts."""
    if name not in PROGRAMMES:
        raise InputError(f"scenario: unknown name {name!r}; expected one of {', '.join(PROGRAMMES)}")
    if not scale > 0:
        raise InputError(f"duration_scale: must be > 0, got {scale}")
    built = PROGRAMMES[name](scale, rng)
    return built.segments, built.start_c, built.loop_warmup_s
