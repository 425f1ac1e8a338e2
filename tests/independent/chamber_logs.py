"""Independent generator of simulated chamber logs for testing ``fxdsp diagnose``.

Written from the contract (shared/spec/measured-data.md) and the domain brief only; it imports nothing
from ``fxdsp`` and shares no code with it (numpy/scipy only). Everything is drawn from
``numpy.random.default_rng(seed)``, so a log is a pure function of (causes, seed, programme, rows).

Physics
-------
* Chamber programme: piecewise-linear setpoint legs (dwells and ramps), temperatures in -40..85 C.
  Ramps 0.2..5 C/min lasting at least 5 min, dwells 10 min..3 h (capped at a quarter of the log for
  short logs, never below 10 min), both directions. Programme kinds: ``fast_short_ramps`` (ramps
  2..5 C/min lasting 5..10 min, mostly alternating direction, dwells 10..60 min between), ``slow``
  (0.2..1 C/min, dwells 30 min..3 h), ``reversal`` (ramps that turn back part-way, 25..75 % of the
  planned span, straight into a ramp the other way), ``clipped`` (ramps clipped at a chamber limit
  drawn in [-40,-10] / [50,85], ramps stopped early then held, possibly power-on in the middle of a
  ramp that began before power-on, and the log ending inside a ramp), ``mixed`` (all of it).
* Air lag: the thermometer's true temperature ``chamber`` follows the setpoint through a first-order
  lag ``air_tau_s`` (0 with probability 0.2, else 10..60 s), which rounds the corners. The hysteresis
  state is taken from the *setpoint* programme (the true programme), not from the rounded curve.
* Element temperature ``te`` = ``chamber``; with ``thermal_lag`` dTe/dt = (chamber - Te)/tau_s. Both
  lags are evaluated in closed form (exact response of a one- and two-pole cascade to a
  piecewise-linear input), no time stepping. All lags start in equilibrium at the programme start.
* ``temp_c`` = offset + gain*chamber [+ b*(chamber-25)^2 for rtd_nonlinearity] + white noise
  (0.005..0.05 C) then quantised (step 0.01..0.1 C). offset (+-0.5 C) and gain (1+-1 %) are applied
  only when ``ref_temp_c`` is logged (otherwise temp_c is on the true scale); ``ref_temp_c`` =
  chamber + white noise 0.002..0.01 C, rounded to 0.001 C. ``b_per_c`` is therefore exactly the
  quadratic coefficient of temp_c in ref_temp_c.
* ``output`` = B(Te) + S(Te)*(rate + k3*rate^3) + additive causes + noise, with x = (Te-25)/50,
  B = b0 + g*(c1 x + c2 x^2 + c3 x^3) (peak-to-peak over the visited range 20..80 sigma_w unless
  thermal_lag sets g), S = S0*(1 + s1 x + s2 x^2 + s3 x^3) (|S0| = 0.5..5 sigma_w per deg/s, a few %
  over the range). sigma_w (white output noise) = 10**U(-1, 1) sensor units.
* Output noise: white sigma_w (fresh on every row, also on repeated stamps); flicker = sum of AR(1)
  processes with correlation times 5*dt .. duration spaced by sqrt(10), equal variances, giving a
  1/f spectrum whose Allan-deviation floor (the "bias instability" here, not divided by 0.664) is
  0.1..0.3 sigma_w; random walk whose std at the end of the log is 0.5..3 sigma_w, starting at 0 at
  power-on. Flicker and random walk are functions of the sample slot (a repeated stamp shares them).
* ``quad`` = q0 + slow independent variation (random steps + sinusoid + slow AR(1), rms
  50..200 sigma_q) + white sigma_q (0.5..2 sigma_w); quadrature_leak leaks c * (noise-free quad).
* ``freq_hz`` = f0 (3..9 kHz) + k*Te (k = -0.5..-0.1 Hz/C) [+ k2*(Te-25)^2] + white sigma_f
  (0.002..0.05 Hz; with thermal_lag sigma_f is set so that the lag's effect on freq_hz also has
  SNR 5..20, see below).
* ``rate_dps`` (rate table): levels 0, +-R/8, +-R/4, +-R/2, +-R (R in 100..500 deg/s), each held
  2..15 min, visited in shuffled rounds so that every level appears.
* Sampling: dt 1..60 s (log-uniform; at most 15 s for fast_short_ramps; raised so that a log lasts at
  least 2 h fast / 3 h reversal / 4 h clipped, mixed / 10 h slow), jitter uniform +-0..15 % of dt (or
  none), time stamps rounded to 0.001/0.01/0.1/1 s (at most dt/10); 0..2 % of rows dropped
  (about half in 1..4 bursts), 0..10 rows repeated with the same time_s and fresh white noise.
  time_s starts within min(dt, 10) s of power-on (t = 0).
* Causes follow the contract table; parameters in the contract's names and units (``truth``).
  ``hysteresis`` s: 0 before the first ramp, the ramp's sign from the ramp's first instant (however
  short), kept through dwells, flipped at a reversal. ``ramp_rate`` uses the true rate of the
  noise-free temp_c. ``warmup`` tau_s in [10 min, duration/5]; ``thermal_lag`` tau_s in
  [max(120 s, 4 dt), max(that, min(2 h, duration/10))].

Effects outside the contract's list (``outside=``), each from its own random stream (the in-contract
part of a log is the same with or without them), sized like a cause (SNR 5..20 after the baseline's
projection) on the output:

* ``step``: the output's level changes once, at a time drawn in the middle 60 % of the log (a mode
  hop, a moved connector).
* ``periodic``: a sinusoid of 3..12 periods per log and random phase, unrelated to the chamber (the
  lab's air conditioning, a supply's cycle).
* ``two_lags``: part of the output follows the chamber through a second, slower path: B of a
  temperature lagged by 5..20 % of the log (with ``thermal_lag``, a lag with two time constants).
* ``sloped_hysteresis``: a heating/cooling difference proportional to (T - 25)/50: the hysteresis
  state times temperature (the contract's hysteresis is a constant offset).

``noise="flicker"`` makes the output's flicker the dominant coloured noise: its Allan-deviation floor
1..3 sigma_w instead of 0.1..0.3 (the same draws, scaled by ten).

Effect size (SNR) definition
----------------------------
For each cause its contribution v to its channel is evaluated noise-free at the logged rows and
projected by least squares onto that channel's baseline regressors evaluated on noise-free inputs:
output -> cubic in temp_c (plus rate_dps times a cubic in temp_c when rate_dps is logged);
temp_c -> [1, ref_temp_c]; freq_hz -> [1, temp_c]. SNR = rms(v - projection) / sigma, with sigma the
channel's white noise: sigma_w for output, sqrt(sigma_T^2 + q^2/12) for temp_c, sigma_f for freq_hz.
The SNR is drawn log-uniform in [5, 20] and the cause's linear parameter (h, k, a, r, c, k3, b, k2)
scaled to it, sign random. For thermal_lag (tau is not a linear parameter) the temperature slope
g of B is scaled instead (exact quadratic solve including the S(Te) part), and on freq_hz sigma_f
is chosen. ``description['effects']`` records target, raw rms, remaining rms and SNR per channel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

CAUSES: tuple[str, ...] = (
    "none", "thermal_lag", "ramp_rate", "hysteresis", "warmup", "aging_drift", "quadrature_leak",
    "sf_nonlinearity", "rtd_nonlinearity", "frequency_nonlinearity",
)

PAIRS: tuple[tuple[str, str], ...] = (
    ("thermal_lag", "quadrature_leak"),
    ("hysteresis", "aging_drift"),
    ("hysteresis", "ramp_rate"),
    ("warmup", "sf_nonlinearity"),
    ("hysteresis", "quadrature_leak"),
    ("thermal_lag", "frequency_nonlinearity"),
    ("rtd_nonlinearity", "aging_drift"),
    ("ramp_rate", "warmup"),
    ("hysteresis", "warmup"),
    ("quadrature_leak", "aging_drift"),
    ("hysteresis", "frequency_nonlinearity"),
    ("rtd_nonlinearity", "quadrature_leak"),
)

# three causes at once (the contract allows any number)
TRIPLES: tuple[tuple[str, str, str], ...] = (
    ("thermal_lag", "hysteresis", "quadrature_leak"),
    ("hysteresis", "aging_drift", "ramp_rate"),
    ("warmup", "sf_nonlinearity", "aging_drift"),
    ("rtd_nonlinearity", "hysteresis", "frequency_nonlinearity"),
    ("thermal_lag", "frequency_nonlinearity", "quadrature_leak"),
)

OUTSIDE: tuple[str, ...] = ("step", "periodic", "two_lags", "sloped_hysteresis")
NOISE_KINDS: tuple[str, ...] = ("default", "flicker")

PROGRAMME_KINDS: tuple[str, ...] = ("fast_short_ramps", "slow", "reversal", "clipped", "mixed")

COLUMNS: tuple[str, ...] = ("time_s", "temp_c", "output", "ref_temp_c", "rate_dps", "freq_hz", "quad")

PARAMETERS: dict[str, tuple[str, ...]] = {
    "none": (), "thermal_lag": ("tau_s",), "ramp_rate": ("k_per_c_per_s",), "hysteresis": ("h",),
    "warmup": ("a", "tau_s"), "aging_drift": ("r_per_h",), "quadrature_leak": ("c",),
    "sf_nonlinearity": ("k3",), "rtd_nonlinearity": ("b_per_c",),
    "frequency_nonlinearity": ("k2_hz_per_c2",),
}

T_LIMITS = (-40.0, 85.0)
MIN_RAMP_S = 300.0
MIN_DWELL_S = 600.0
MAX_DWELL_S = 10800.0
SNR_RANGE = (5.0, 20.0)

_DURATION_MIN_S = {"fast_short_ramps": 7200.0, "slow": 36000.0, "reversal": 10800.0,
                   "clipped": 14400.0, "mixed": 14400.0, "custom": 0.0}
_DT_MAX_S = {"fast_short_ramps": 15.0}


# ---------------------------------------------------------------------------------------- programme

@dataclass(frozen=True)
class Leg:
    """One piecewise-linear setpoint leg from (t0, T0) to (t1, T1); T0 == T1 is a dwell."""
    t0: float
    t1: float
    T0: float
    T1: float
    tag: str = "dwell"              # dwell, ramp, reversal, clipped_limit, early_stop, preroll, ...
    planned_T1: float | None = None  # the target the leg was heading for (reversal, clipped, early stop)

    @property
    def duration(self) -> float:
        return self.t1 - self.t0

    @property
    def slope(self) -> float:
        """C/s."""
        return (self.T1 - self.T0) / (self.t1 - self.t0)

    @property
    def is_ramp(self) -> bool:
        return self.T1 != self.T0


@dataclass
class Programme:
    """A chamber programme. ``air_tau_s``/``dt_s`` None = drawn from the seed by ``generate``."""
    legs: list[Leg]
    kind: str = "custom"
    air_tau_s: float | None = None
    dt_s: float | None = None

    def __post_init__(self):
        if not self.legs:
            raise ValueError("a programme needs at least one leg")
        for a, b in zip(self.legs, self.legs[1:]):
            if b.t0 != a.t1 or b.T0 != a.T1:
                raise ValueError(f"legs not contiguous: {a} -> {b}")
        for leg in self.legs:
            if not leg.t1 > leg.t0:
                raise ValueError(f"leg of non-positive duration: {leg}")

    @property
    def t_start(self) -> float:
        return self.legs[0].t0

    @property
    def t_end(self) -> float:
        return self.legs[-1].t1

    def leg_index(self, t) -> np.ndarray:
        t0s = np.array([leg.t0 for leg in self.legs])
        return np.clip(np.searchsorted(t0s, np.asarray(t, float), side="right") - 1, 0, len(self.legs) - 1)

    def setpoint(self, t) -> np.ndarray:
        t = np.asarray(t, float)
        i = self.leg_index(t)
        t0 = np.array([leg.t0 for leg in self.legs])[i]
        T0 = np.array([leg.T0 for leg in self.legs])[i]
        m = np.array([leg.slope for leg in self.legs])[i]
        t1 = np.array([leg.t1 for leg in self.legs])[i]
        return T0 + m * (np.minimum(t, t1) - t0)

    def leg_states(self) -> np.ndarray:
        """Hysteresis state s at each leg: sign of the leg if it is a ramp, else the previous state."""
        s, out = 0.0, []
        for leg in self.legs:
            if leg.is_ramp:
                s = float(np.sign(leg.T1 - leg.T0))
            out.append(s)
        return np.array(out)

    def hyst_state(self, t) -> np.ndarray:
        return self.leg_states()[self.leg_index(t)]

    def extended_to(self, t_end: float) -> "Programme":
        """The same programme with a final dwell appended so that it covers ``t_end``."""
        if self.t_end >= t_end:
            return self
        last = self.legs[-1]
        legs = list(self.legs) + [Leg(last.t1, float(math.ceil(t_end)) + 1.0, last.T1, last.T1, "dwell")]
        return Programme(legs, self.kind, self.air_tau_s, self.dt_s)


def programme_from_steps(T_start: float, steps, *, t_start: float = 0.0, air_tau_s: float | None = None,
                         dt_s: float | None = None) -> Programme:
    """A hand-made programme: ``steps`` = [(duration_s, target_c), ...]; a target equal to the current
    temperature is a dwell, anything else a ramp reaching the target at the end of the step."""
    legs, t, T = [], float(t_start), float(T_start)
    for dur, target in steps:
        target = float(target)
        tag = "dwell" if target == T else "ramp"
        legs.append(Leg(t, t + float(dur), T, target, tag))
        t, T = t + float(dur), target
    return Programme(legs, "custom", air_tau_s, dt_s)


def chamber_response(prog: Programme, t, air_tau_s: float, elem_tau_s: float | None = None):
    """Exact responses at times ``t`` (>= programme start) of the setpoint programme.

    Returns (setpoint, chamber, d chamber/dt, te): chamber = first-order lag ``air_tau_s`` of the
    setpoint (0 = none), te = first-order lag ``elem_tau_s`` of chamber (None = te is chamber).
    Both start in equilibrium at the programme's first setpoint. Closed form per leg:
    chamber(u) = P + m u - m ta + A e^{-u/ta};  te(u) = P - m ta + m (u - tau) + C e^{-u/ta} + D e^{-u/tau}
    with A = chamber0 - P + m ta, C = A ta/(ta - tau), D fixed by te(0).
    """
    ta = float(air_tau_s)
    tau = None if elem_tau_s is None else float(elem_tau_s)
    if tau is not None and ta > 0 and abs(ta - tau) < 1e-6 * tau:
        ta *= 1.001  # the degenerate double pole; a 0.1 % change of the air lag is immaterial
    legs = prog.legs
    n = len(legs)
    P = np.array([leg.T0 for leg in legs])
    m = np.array([leg.slope for leg in legs])
    h = np.array([leg.duration for leg in legs])
    th0 = np.empty(n)
    te0 = np.empty(n)
    th, te = legs[0].T0, legs[0].T0
    for i in range(n):
        th0[i], te0[i] = th, te
        a, _, b = _leg_eval(P[i], m[i], th, te, h[i], ta, tau)
        th, te = float(a), float(b)
    t = np.asarray(t, float)
    i = prog.leg_index(t)
    u = t - np.array([leg.t0 for leg in legs])[i]
    if np.any(u > h[i] + 1e-9):
        raise ValueError("times beyond the programme's end")
    if np.any(u < -1e-9):
        raise ValueError("times before the programme's start")
    chamber, dchamber, elem = _leg_eval(P[i], m[i], th0[i], te0[i], u, ta, tau)
    return P[i] + m[i] * u, chamber, dchamber, elem


def _leg_eval(P, m, th0, te0, u, ta, tau):
    u = np.asarray(u, float)
    if ta > 0:
        A = th0 - P + m * ta
        ea = np.exp(-u / ta)
        th = P + m * u - m * ta + A * ea
        dth = m - A / ta * ea
    else:
        A, ea = 0.0 * P, 0.0 * u
        th = P + m * u
        dth = m + 0.0 * u
    if tau is None:
        return th, dth, th
    a0 = P - m * ta
    C = A * ta / (ta - tau) if ta > 0 else 0.0 * P
    D = te0 - (a0 - m * tau + C)
    te = a0 + m * (u - tau) + C * ea + D * np.exp(-u / tau)
    return th, dth, te


def _logu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


class _Builder:
    def __init__(self, rng, t, T, lo, hi, duration):
        self.rng, self.t, self.T, self.lo, self.hi = rng, float(t), float(T), lo, hi
        self.legs: list[Leg] = []
        self.duration = duration
        self.up = bool(rng.random() < 0.5)

    def room(self, up):
        return self.hi - self.T if up else self.T - self.lo

    def dwell(self, dur, tag="dwell"):
        dur = float(max(1, round(dur)))
        self.legs.append(Leg(self.t, self.t + dur, self.T, self.T, tag))
        self.t += dur

    def dwell_drawn(self, lo=MIN_DWELL_S, hi=MAX_DWELL_S):
        hi = min(hi, max(lo, self.duration / 4))
        self.dwell(_logu(self.rng, lo, hi) if hi > lo else lo)

    def ramp(self, dur, T1, tag="ramp", planned=None):
        dur = float(max(1, round(dur)))
        T1 = float(round(T1, 6))
        self.legs.append(Leg(self.t, self.t + dur, self.T, T1, tag, planned))
        self.t += dur
        self.T = T1

    def direction(self, p_alternate=0.75, need=1.0):
        up = (not self.up) if self.rng.random() < p_alternate else bool(self.rng.random() < 0.5)
        if self.room(up) < need:
            up = not up
        self.up = up
        return up

    def ramp_span(self, up, span, rate_cpm, tag="ramp", planned=None):
        """Ramp by ``span`` (clipped to the room) at ``rate_cpm``; at least MIN_RAMP_S long (a short
        span is then run more slowly)."""
        span = min(span, self.room(up))
        dur = max(MIN_RAMP_S, span / rate_cpm * 60.0)
        self.ramp(dur, self.T + (span if up else -span), tag, planned)

    def plain_ramp(self, need, rate_lo, rate_hi):
        """A ramp of at least ``need`` C (as far as the room allows) at a log-uniform rate."""
        up = self.direction(need=need)
        self.ramp_span(up, self.rng.uniform(need, max(need, self.room(up))), _logu(self.rng, rate_lo, rate_hi))

    def _cut_leg(self, rate_lo, rate_hi, frac_lo, frac_hi):
        """A planned ramp and the part of it that will be run: (up, room, planned span, rate,
        planned duration, run duration)."""
        rng = self.rng
        up = self.direction(need=15.0)
        room = self.room(up)
        span_plan = rng.uniform(15.0, max(15.0, room))
        rate = _logu(rng, rate_lo, rate_hi)
        dur_full = span_plan / rate * 60.0
        return up, room, span_plan, rate, dur_full, max(MIN_RAMP_S, rng.uniform(frac_lo, frac_hi) * dur_full)

    def reversal_group(self, rate_lo, rate_hi):
        """A ramp that turns back part-way and goes straight into a ramp the other way."""
        rng = self.rng
        up, room, span_plan, rate1, dur_full, dur1 = self._cut_leg(rate_lo, rate_hi, 0.25, 0.75)
        turn = rate1 * dur1 / 60.0
        if dur1 > 0.85 * dur_full or span_plan > room or self.room(not up) + turn < 10.0:
            self.ramp_span(up, span_plan, rate1)
            return False
        target = self.T + (span_plan if up else -span_plan)
        self.ramp(dur1, self.T + (turn if up else -turn), "reversal", target)
        self.up = not up
        back = self.room(self.up)
        self.ramp_span(self.up, rng.uniform(min(10.0, back), back), _logu(rng, rate_lo, rate_hi))
        return True

    def early_stop(self, rate_lo, rate_hi):
        up, room, span_plan, rate, dur_full, dur1 = self._cut_leg(rate_lo, rate_hi, 0.3, 0.8)
        if dur1 > 0.85 * dur_full or span_plan > room:
            self.ramp_span(up, span_plan, rate)
            return False
        target = self.T + (span_plan if up else -span_plan)
        self.ramp(dur1, self.T + (1 if up else -1) * rate * dur1 / 60.0, "early_stop", target)
        return True

    def limit_clip(self, rate_lo, rate_hi):
        rng = self.rng
        rate = _logu(rng, rate_lo, rate_hi)
        need = rate * MIN_RAMP_S / 60.0
        up = self.direction(p_alternate=0.5, need=max(need, 5.0))
        room = self.room(up)
        if room < need:  # too close to both limits for a ramp at this rate: slower
            rate = room * 60.0 / MIN_RAMP_S
        limit = self.hi if up else self.lo
        planned = limit + (1 if up else -1) * rng.uniform(5.0, 25.0)
        self.ramp(max(MIN_RAMP_S, room / rate * 60.0), limit, "clipped_limit", planned)


def _build_programme(kind: str, rng, t_cover: float, duration: float) -> Programme:
    lo_lim, hi_lim = T_LIMITS
    if kind == "clipped":
        lo, hi = rng.uniform(-40.0, -10.0), rng.uniform(50.0, 85.0)
    else:
        lo = rng.uniform(-40.0, 5.0)
        hi = rng.uniform(max(lo + 40.0, 45.0), hi_lim)
    T_room = rng.uniform(18.0, 28.0)
    b = _Builder(rng, 0.0, T_room, lo, hi, duration)
    first_dwell = (MIN_DWELL_S, min(3600.0, max(MIN_DWELL_S, duration / 6)))

    if kind == "clipped" and rng.random() < 0.5:
        # power-on in the middle of a ramp that began before power-on
        rate = _logu(rng, 0.5, 3.0)
        up = b.room(True) > b.room(False)
        span = rng.uniform(min(15.0, b.room(up)), b.room(up))
        dur = max(MIN_RAMP_S * 2, span / rate * 60.0)
        pre = float(round(rng.uniform(0.2, 0.8) * dur))
        b.t = -pre - 3600.0
        b.dwell(3600.0, "preroll")
        b.ramp(dur, b.T + (span if up else -span), "ramp")
        b.up = up
    else:
        b.dwell(_logu(rng, *first_dwell) if first_dwell[1] > first_dwell[0] else first_dwell[0])

    n = 0
    while b.t < t_cover:
        n += 1
        if kind == "fast_short_ramps":
            up = b.direction(p_alternate=0.7, need=20.0)
            room = b.room(up)
            dur = rng.uniform(300.0, 600.0)
            rate = rng.uniform(2.0, 5.0)
            if rate * dur / 60.0 > room:
                rate = max(2.0, room * 60.0 / dur)
            dur = float(round(dur))
            b.ramp(dur, b.T + (1 if up else -1) * rate * dur / 60.0)
            b.dwell_drawn(MIN_DWELL_S, 3600.0)
        elif kind == "slow":
            b.plain_ramp(10.0, 0.2, 1.0)
            b.dwell_drawn(1800.0, MAX_DWELL_S)
        elif kind == "reversal":
            if n <= 2 or rng.random() < 0.5:
                b.reversal_group(0.5, 5.0)
            else:
                b.plain_ramp(10.0, 0.5, 5.0)
            b.dwell_drawn()
        elif kind == "clipped":
            r = rng.random()
            if n == 1 or (n > 2 and r < 0.35):
                b.limit_clip(0.5, 5.0)
            elif n == 2 or r < 0.7:
                b.early_stop(0.5, 5.0)
            else:
                b.plain_ramp(10.0, 0.5, 5.0)
            b.dwell_drawn()
        elif kind == "mixed":
            r = rng.random()
            if r < 0.55:
                b.plain_ramp(5.0, 0.2, 5.0)
            elif r < 0.75:
                b.reversal_group(0.2, 5.0)
            elif r < 0.9:
                b.early_stop(0.2, 5.0)
            else:
                b.limit_clip(0.2, 5.0)
            if rng.random() < 0.8:
                b.dwell_drawn()
        else:
            raise ValueError(f"unknown programme kind {kind!r}")

    legs = b.legs
    if kind == "clipped":
        legs = _end_inside_ramp(legs, rng, t_cover, lo, hi)
    return Programme(legs, kind)


def _end_inside_ramp(legs, rng, t_last, lo, hi):
    """Make the log end inside a ramp when the leg holding the last row is a long enough dwell."""
    i = next(k for k, leg in enumerate(legs) if leg.t1 >= t_last)
    leg = legs[i]
    if leg.is_ramp:
        return legs
    new_end = float(round(t_last - rng.uniform(300.0, 1200.0)))
    if new_end - leg.t0 < MIN_DWELL_S:
        return legs
    T = leg.T0
    up = (hi - T) > (T - lo)
    room = (hi - T) if up else (T - lo)
    dur = float(round(t_last - new_end + 900.0))
    rate = min(rng.uniform(0.5, 3.0), room * 60.0 / dur)
    T1 = round(T + (1 if up else -1) * rate * dur / 60.0, 6)
    out = legs[:i] + [Leg(leg.t0, new_end, T, T, "dwell"), Leg(new_end, new_end + dur, T, T1, "ramp")]
    return out + [Leg(new_end + dur, new_end + dur + 3600.0, T1, T1, "dwell")]


# ------------------------------------------------------------------------------------------ the log

@dataclass
class IndependentLog:
    columns: dict[str, np.ndarray]
    truth: dict[str, dict[str, float]]
    hidden: dict[str, np.ndarray]
    description: dict = field(default_factory=dict)

    def csv_text(self) -> str:
        names = [c for c in COLUMNS if c in self.columns]
        cols = [np.asarray(self.columns[c], float).tolist() for c in names]
        lines = [",".join(names)]
        lines.extend(",".join(map(repr, row)) for row in zip(*cols))
        return "\n".join(lines) + "\n"

    def brief(self) -> str:
        """One line for failure messages."""
        d = self.description
        snr = {c: round(v[ch]["snr"], 1) for c, v in d["effects"].items() for ch in v}
        extra = f" outside={d['outside']}" if d.get("outside") else ""
        extra += " noise=flicker" if d.get("noise_kind") == "flicker" else ""
        return (f"seed={d['seed']} causes={d['causes']}{extra} programme={d['programme']['kind']} "
                f"dt={d['sampling']['dt_s']:.2f}s rows={d['sampling']['rows']} snr={snr}")


def _norm_causes(causes) -> tuple[str, ...]:
    if isinstance(causes, str):
        causes = (causes,)
    out = tuple(c for c in causes if c != "none")
    for c in out:
        if c not in CAUSES:
            raise ValueError(f"unknown cause {c!r}; known: {CAUSES}")
    if len(set(out)) != len(out):
        raise ValueError(f"repeated cause in {causes}")
    if len(out) > 3:
        raise ValueError("one cause, a pair or a triple at a time")
    return out


def _rms(v):
    v = np.asarray(v, float)
    return float(np.sqrt(np.mean(v ** 2)))


def _remaining(v, X):
    coef, *_ = np.linalg.lstsq(X, v, rcond=None)
    return v - X @ coef


def _ar1(rng, n, phi, sigma):
    """Stationary AR(1) with marginal std ``sigma`` on ``n`` samples."""
    e = rng.standard_normal(n) * sigma * math.sqrt(max(0.0, 1.0 - phi * phi))
    x0 = rng.standard_normal() * sigma
    return lfilter([1.0], [1.0, -phi], e, zi=[phi * x0])[0]


def generate(causes: tuple[str, ...] = (), seed: int = 0, *, programme: str | Programme | None = None,
             rows: int | None = None, outside: tuple[str, ...] = (), noise: str = "default") -> IndependentLog:
    """One simulated chamber log with ``causes`` (none, one, a pair or a triple), deterministic in
    ``seed``; ``outside``: effects outside the contract's list (OUTSIDE); ``noise``: NOISE_KINDS.

    ``programme``: None (kind drawn from the seed), a kind from PROGRAMME_KINDS, or a ``Programme``
    (e.g. from ``programme_from_steps``; it is extended with a dwell if the log outlasts it).
    ``rows``: target row count (default drawn in 4000..8000). For a named kind the sampling interval
    is raised (up to its cap) so that the log lasts the kind's minimum duration, so a small ``rows``
    gives a coarse dt. With a ``Programme`` the log spans the programme and ``Programme.dt_s`` (or
    programme length / ``rows``, clipped to 1..60 s) sets dt.
    """
    causes = _norm_causes(causes)
    outside = tuple(outside)
    unknown = [o for o in outside if o not in OUTSIDE]
    if unknown or noise not in NOISE_KINDS:
        raise ValueError(f"outside must be among {OUTSIDE} and noise one of {NOISE_KINDS}")
    rng = np.random.default_rng(seed)
    custom = isinstance(programme, Programme)
    if custom:
        kind = "custom"
    elif programme is None:
        kind = str(PROGRAMME_KINDS[int(rng.integers(len(PROGRAMME_KINDS)))])
    elif programme in PROGRAMME_KINDS:
        kind = programme
    else:
        raise ValueError(f"programme must be None, a Programme or one of {PROGRAMME_KINDS}")

    # ---- sampling
    n_target = int(rows) if rows is not None else int(rng.integers(4000, 8001))
    if n_target < 20:
        raise ValueError("rows must be >= 20")
    p_drop = 0.0 if rng.random() < 0.15 else rng.uniform(0.002, 0.02)
    n_dup = 0 if rng.random() < 0.2 else int(rng.integers(1, 11))
    n_dup = min(n_dup, n_target // 10)
    n0 = int(round((n_target - n_dup) / (1.0 - p_drop)))
    if custom:
        span = programme.t_end
        dt = float(programme.dt_s) if programme.dt_s else float(np.clip(span / n0, 1.0, 60.0))
        n0 = max(20, int(span / dt) - 1)
        n_dup = min(n_dup, n0 // 10)
    else:
        dt = _logu(rng, 1.0, 60.0)
        dt = float(np.clip(max(dt, _DURATION_MIN_S[kind] / n0), 1.0, _DT_MAX_S.get(kind, 60.0)))
    jitter = 0.0 if rng.random() < 0.4 else rng.uniform(0.0, 0.15)
    resolutions = [r for r in (0.001, 0.01, 0.1, 1.0) if r <= 0.1 * dt + 1e-12]
    res = float(resolutions[int(rng.integers(len(resolutions)))])
    t_first = rng.uniform(0.0, 1.0) * min(dt, 10.0)
    tn = t_first + np.arange(n0) * dt + jitter * dt * rng.uniform(-1.0, 1.0, n0)
    tn = np.maximum(np.round(np.round(tn / res) * res, 3), 0.0)
    keep = np.ones(n0, bool)
    n_bursts = 0
    n_drop_target = int(round(p_drop * n0))
    if n_drop_target:
        n_bursts = int(rng.integers(1, 5))
        in_bursts = int(round(rng.uniform(0.3, 0.7) * n_drop_target))
        lengths = rng.multinomial(in_bursts, np.ones(n_bursts) / n_bursts) if in_bursts else []
        for ln in lengths:
            if ln:
                s = int(rng.integers(1, max(2, n0 - ln - 1)))
                keep[s:s + ln] = False
        singles = n_drop_target - int(np.count_nonzero(~keep))
        if singles > 0:
            cand = np.flatnonzero(keep[1:-1]) + 1
            keep[rng.choice(cand, size=min(singles, cand.size), replace=False)] = False
    keep[0] = keep[-1] = True
    slots = np.flatnonzero(keep)
    counts = np.ones(slots.size, int)
    if n_dup:
        counts[rng.choice(slots.size, size=n_dup, replace=False)] += 1
    slot = np.repeat(slots, counts)          # nominal sample slot of each row
    t = tn[slot]
    n = t.size
    duration = float(t[-1])

    # ---- programme and temperatures
    if custom:
        prog = programme.extended_to(duration + dt)
    else:
        prog = _build_programme(kind, rng, duration + dt, duration)
    if prog.air_tau_s is not None:
        air_tau = float(prog.air_tau_s)
    else:
        air_tau = 0.0 if rng.random() < 0.2 else rng.uniform(10.0, 60.0)
    truth: dict[str, dict[str, float]] = {c: {} for c in causes}
    tau = None
    if "thermal_lag" in causes:
        lo_tau = max(120.0, 4.0 * dt)
        tau = _logu(rng, lo_tau, max(lo_tau * 1.0001, min(7200.0, duration / 10.0)))
        truth["thermal_lag"]["tau_s"] = tau
    setpoint, chamber, dchamber, te = chamber_response(prog, t, air_tau, tau)
    s_state = prog.hyst_state(t)

    # ---- optional columns
    has_ref = "rtd_nonlinearity" in causes or rng.random() < 0.4
    has_rate = "sf_nonlinearity" in causes or rng.random() < 0.3
    has_freq = "frequency_nonlinearity" in causes or rng.random() < (0.6 if "thermal_lag" in causes else 0.35)
    has_quad = "quadrature_leak" in causes or rng.random() < 0.35

    # ---- thermometers
    sig_t = _logu(rng, 0.005, 0.05)
    if rng.random() < 0.5:
        q = float(rng.choice([0.01, 0.02, 0.025, 0.05, 0.0625, 0.1]))
    else:
        q = float(f"{_logu(rng, 0.01, 0.1):.4g}")
    sig_temp = math.sqrt(sig_t ** 2 + q ** 2 / 12.0)
    off, gain = (rng.uniform(-0.5, 0.5), 1.0 + rng.uniform(-0.01, 0.01)) if has_ref else (0.0, 1.0)
    effects: dict[str, dict] = {}

    def record(cause, channel, v, X, sigma, target):
        r = _remaining(v, X)
        effects.setdefault(cause, {})[channel] = {
            "sigma": float(sigma), "target_snr": float(target), "rms_raw": float(np.std(v)),
            "rms_remaining": _rms(r), "snr": _rms(r) / float(sigma)}

    def scaled(cause, channel, shape, X, sigma):
        """Linear parameter that gives ``shape`` a drawn SNR on ``channel`` (random sign)."""
        target = _logu(rng, *SNR_RANGE)
        rr = _rms(_remaining(shape, X))
        if not rr > 1e-12 * max(1.0, _rms(shape)):
            raise ValueError(f"{cause}: this programme gives the cause no effect the baseline cannot "
                             "absorb (e.g. no ramps)")
        p = float(target * sigma / rr * (1 if rng.random() < 0.5 else -1))
        record(cause, channel, p * shape, X, sigma, target)
        return p

    b_rtd = 0.0
    if "rtd_nonlinearity" in causes:
        Xr = np.column_stack([np.ones(n), chamber])
        b_rtd = scaled("rtd_nonlinearity", "temp_c", (chamber - 25.0) ** 2, Xr, sig_temp)
        truth["rtd_nonlinearity"]["b_per_c"] = b_rtd
    temp_true = off + gain * chamber + b_rtd * (chamber - 25.0) ** 2
    dtemp = (gain + 2.0 * b_rtd * (chamber - 25.0)) * dchamber
    temp_c = np.round(q * np.round((temp_true + sig_t * rng.standard_normal(n)) / q), 10)
    sig_ref = _logu(rng, 0.002, 0.01)
    ref = np.round(chamber + sig_ref * rng.standard_normal(n), 3)

    # ---- rate table
    rate = np.zeros(n)
    rate_info = None
    if has_rate:
        R = float(rng.choice([100.0, 200.0, 300.0, 400.0, 500.0]))
        mags = R * np.array([0.125, 0.25, 0.5, 1.0])
        levels = np.concatenate([[0.0], mags, -mags])
        edges, vals, tt = [], [], prog.t_start
        while tt <= duration + dt:
            for lv in rng.permutation(levels):
                edges.append(tt)
                vals.append(lv)
                tt += _logu(rng, 120.0, 900.0)
        rate = np.array(vals)[np.searchsorted(np.array(edges), t, side="right") - 1]
        rate_info = {"max_dps": R, "levels_dps": sorted(float(v) for v in levels), "hold_s": [120.0, 900.0]}

    # ---- output baseline
    sig_w = 10.0 ** rng.uniform(-1.0, 1.0)
    cB = np.array([rng.normal(0, 1.0), rng.normal(0, 0.6), rng.normal(0, 0.4)])
    b0 = sig_w * rng.uniform(-200.0, 200.0)
    S0 = sig_w * _logu(rng, 0.5, 5.0) * (1 if rng.random() < 0.5 else -1)
    cS = np.array([rng.normal(0, 0.02), rng.normal(0, 0.01), rng.normal(0, 0.005)])

    def bshape(T):
        x = (T - 25.0) / 50.0
        return cB[0] * x + cB[1] * x ** 2 + cB[2] * x ** 3

    def sfun(T):
        x = (T - 25.0) / 50.0
        return S0 * (1.0 + cS[0] * x + cS[1] * x ** 2 + cS[2] * x ** 3)

    xt = (temp_true - 25.0) / 50.0
    Xo = np.column_stack([xt ** 0, xt, xt ** 2, xt ** 3])
    if has_rate:
        Xo = np.column_stack([Xo, Xo * (rate / 400.0)[:, None]])

    if "thermal_lag" in causes:
        target = _logu(rng, *SNR_RANGE)
        RB = _remaining(bshape(te) - bshape(chamber), Xo)
        RS = _remaining((sfun(te) - sfun(chamber)) * rate, Xo)
        qa, qb, qc = np.mean(RB ** 2), 2 * np.mean(RB * RS), np.mean(RS ** 2) - (target * sig_w) ** 2
        if not qa > 0:
            raise ValueError("thermal_lag: no temperature change in this programme")
        g = float((-qb + math.sqrt(max(qb * qb - 4 * qa * qc, 0.0))) / (2 * qa))
        g = max(g, 1e-9)
        lag_out = g * (bshape(te) - bshape(chamber)) + (sfun(te) - sfun(chamber)) * rate
        record("thermal_lag", "output", lag_out, Xo, sig_w, target)
    else:
        span_b = np.ptp(bshape(np.linspace(chamber.min(), chamber.max(), 200)))
        g = rng.uniform(20.0, 80.0) * sig_w / max(span_b, 1e-9)

    def bfun(T):
        return b0 + g * bshape(T)

    k3 = 0.0
    if "sf_nonlinearity" in causes:
        k3 = scaled("sf_nonlinearity", "output", sfun(te) * rate ** 3, Xo, sig_w)
        truth["sf_nonlinearity"]["k3"] = k3
    base_clean = bfun(chamber) + sfun(chamber) * rate      # the baseline's view: Te = chamber, k3 = 0
    out_clean = bfun(te) + sfun(te) * (rate + k3 * rate ** 3)
    hidden_effects: dict[str, np.ndarray] = {}
    if "sf_nonlinearity" in causes:
        hidden_effects["sf_nonlinearity"] = sfun(te) * k3 * rate ** 3
    if "thermal_lag" in causes:
        hidden_effects["thermal_lag"] = bfun(te) - bfun(chamber) + (sfun(te) - sfun(chamber)) * rate

    # ---- quadrature channel
    sig_q = sig_w * rng.uniform(0.5, 2.0)
    q_steps_t = np.sort(rng.uniform(0.0, duration, int(rng.poisson(max(duration / 7200.0, 1.0))) + 2))
    q_steps = np.concatenate([[0.0], np.cumsum(rng.standard_normal(q_steps_t.size))])
    qv = q_steps[np.searchsorted(q_steps_t, t, side="right")]
    period = _logu(rng, duration / 6.0, duration)
    qv = qv + rng.uniform(0.5, 1.5) * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
    qv = qv + _ar1(rng, n0, math.exp(-dt / max(duration / 20.0, dt)), rng.uniform(0.2, 0.6))[slot]
    qv = (qv - qv.mean()) / max(np.std(qv), 1e-12)
    quad_sig = sig_w * rng.uniform(-50.0, 50.0) + qv * sig_q * rng.uniform(50.0, 200.0)
    quad = quad_sig + sig_q * rng.standard_normal(n)

    # ---- additive output causes
    shapes = {
        "hysteresis": ("h", s_state),
        "ramp_rate": ("k_per_c_per_s", dtemp),
        "aging_drift": ("r_per_h", t / 3600.0),
        "quadrature_leak": ("c", quad_sig),
    }
    if "warmup" in causes:
        lo_w = 600.0
        tau_w = _logu(rng, lo_w, max(lo_w * 1.0001, duration / 5.0))
        truth["warmup"]["tau_s"] = tau_w
        shapes["warmup"] = ("a", np.exp(-t / tau_w))
    for cause in causes:
        if cause in shapes:
            pname, shape = shapes[cause]
            p = scaled(cause, "output", shape, Xo, sig_w)
            truth[cause][pname] = p
            hidden_effects[cause] = p * shape
            out_clean = out_clean + p * shape

    # ---- effects outside the contract's list, each from its own stream
    for i, name in enumerate(outside):
        orng = np.random.default_rng([int(seed) if isinstance(seed, (int, np.integer)) else 0, 7919, i,
                                      OUTSIDE.index(name)])
        if name == "step":
            shape = (t >= t[0] + orng.uniform(0.2, 0.8) * (duration - t[0])).astype(float)
        elif name == "periodic":
            shape = np.sin(2 * np.pi * orng.uniform(3.0, 12.0) * t / duration + orng.uniform(0, 2 * np.pi))
        elif name == "two_lags":
            te2 = chamber_response(prog, t, air_tau, orng.uniform(0.05, 0.2) * duration)[3]
            shape = bshape(te2) - bshape(chamber)
        else:  # sloped_hysteresis
            shape = s_state * (chamber - 25.0) / 50.0
        target = orng.uniform(0.0, 1.0)
        target = SNR_RANGE[0] * (SNR_RANGE[1] / SNR_RANGE[0]) ** target
        rr = _rms(_remaining(shape, Xo))
        if not rr > 1e-12 * max(1.0, _rms(shape)):
            raise ValueError(f"{name}: this programme gives the effect nothing the baseline cannot absorb")
        v = shape * (target * sig_w / rr) * (1 if orng.random() < 0.5 else -1)
        record(f"outside:{name}", "output", v, Xo, sig_w, target)
        hidden_effects[f"outside:{name}"] = v
        out_clean = out_clean + v

    # ---- frequency channel
    f0 = rng.uniform(3000.0, 9000.0)
    kf = -rng.uniform(0.1, 0.5)
    sig_f = _logu(rng, 0.002, 0.05)
    Xf = np.column_stack([np.ones(n), temp_true])
    if "thermal_lag" in causes and has_freq:
        target = _logu(rng, *SNR_RANGE)
        sig_f = _rms(_remaining(kf * (te - chamber), Xf)) / target
        record("thermal_lag", "freq_hz", kf * (te - chamber), Xf, sig_f, target)
    k2 = 0.0
    if "frequency_nonlinearity" in causes:
        k2 = scaled("frequency_nonlinearity", "freq_hz", (te - 25.0) ** 2, Xf, sig_f)
        truth["frequency_nonlinearity"]["k2_hz_per_c2"] = k2
    freq_clean = f0 + kf * te + k2 * (te - 25.0) ** 2
    freq = freq_clean + sig_f * rng.standard_normal(n)

    # ---- output noise
    bi = rng.uniform(0.1, 0.3) * sig_w * (10.0 if noise == "flicker" else 1.0)
    ratio = math.sqrt(10.0)
    n_fl = max(1, int(math.floor(math.log(max(duration, 10 * dt) / (5 * dt)) / math.log(ratio))) + 1)
    fl_taus = [5 * dt * ratio ** i for i in range(n_fl)]
    sig_i = bi * math.sqrt(math.log(ratio) / (2 * math.log(2.0)))
    flicker = np.zeros(n0)
    for ft in fl_taus:
        flicker += _ar1(rng, n0, math.exp(-dt / ft), sig_i)
    rw_end = rng.uniform(0.5, 3.0) * sig_w
    walk = np.cumsum(rng.standard_normal(n0)) * rw_end / math.sqrt(n0)
    walk -= walk[0]
    coloured = (flicker + walk)[slot]
    output = out_clean + coloured + sig_w * rng.standard_normal(n)

    # ---- assemble
    columns = {"time_s": t.astype(float), "temp_c": temp_c, "output": output}
    if has_ref:
        columns["ref_temp_c"] = ref
    if has_rate:
        columns["rate_dps"] = rate.astype(float)
    if has_freq:
        columns["freq_hz"] = freq
    if has_quad:
        columns["quad"] = quad
    hidden = {
        "te": te, "chamber": chamber, "hyst_state": s_state.astype(float), "setpoint": setpoint,
        "temp_true": temp_true, "dtemp_dt": dtemp, "output_clean": out_clean,
        "output_base": base_clean, "output_coloured_noise": coloured, "freq_clean": freq_clean,
        "quad_true": quad_sig, "slot": slot.astype(float),
    }
    for cause, v in hidden_effects.items():
        hidden[f"effect:{cause}"] = v
    if "rtd_nonlinearity" in causes:
        hidden["effect:rtd_nonlinearity"] = b_rtd * (chamber - 25.0) ** 2
    if "frequency_nonlinearity" in causes:
        hidden["effect:frequency_nonlinearity"] = k2 * (te - 25.0) ** 2

    legs_desc = []
    for leg in prog.legs:
        if leg.t0 > duration:
            break
        d = {"t0_s": leg.t0, "t1_s": leg.t1, "T0_c": leg.T0, "T1_c": leg.T1,
             "rate_c_per_min": leg.slope * 60.0, "tag": leg.tag,
             "complete": bool(leg.t0 >= 0.0 and leg.t1 <= duration)}
        if leg.planned_T1 is not None:
            d["planned_T1_c"] = leg.planned_T1
        legs_desc.append(d)
    n_dropped = int(n0 - slots.size)
    description = {
        "seed": int(seed) if isinstance(seed, (int, np.integer)) else repr(seed),
        "causes": list(causes) or ["none"],
        "outside": list(outside), "noise_kind": noise,
        "columns": [c for c in COLUMNS if c in columns],
        "programme": {"kind": kind, "air_tau_s": air_tau, "n_legs": len(legs_desc),
                      "n_ramps": sum(1 for d in legs_desc if d["T0_c"] != d["T1_c"]),
                      "temp_range_c": [float(chamber.min()), float(chamber.max())], "legs": legs_desc},
        "sampling": {"dt_s": dt, "jitter_frac": float(jitter), "time_resolution_s": res,
                     "rows": int(n), "rows_nominal": int(n0), "n_dropped": n_dropped,
                     "n_drop_bursts": int(n_bursts), "n_duplicated": int(n_dup), "duration_s": duration},
        "noise": {"output_white_sigma": sig_w, "output_flicker_bias_instability": bi,
                  "output_flicker_taus_s": fl_taus, "output_flicker_component_sigma": sig_i,
                  "output_random_walk_end_std": rw_end,
                  "temp_white_sigma_c": sig_t, "temp_quant_c": q, "temp_effective_sigma_c": sig_temp,
                  "ref_sigma_c": sig_ref, "freq_sigma_hz": sig_f, "quad_sigma": sig_q},
        "baseline": {"x": "(T-25)/50", "B_const": b0, "B_coeffs_x123": (g * cB).tolist(),
                     "S0": S0, "S_rel_coeffs_x123": cS.tolist(), "thermometer_offset_c": off,
                     "thermometer_gain": gain, "f0_hz": f0, "k_hz_per_c": kf},
        "rate_table": rate_info,
        "effects": effects,
    }
    description = _jsonable(description)
    return IndependentLog(columns, truth, hidden, description)


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x)
    return x


def fast_ramp_logs(n: int, seed: int) -> list[IndependentLog]:
    """``n`` hysteresis-only logs on 'fast_short_ramps' programmes; log i uses the seed
    SeedSequence([seed, i]) -> 32 bits, recorded in its description (reproduce with ``generate``)."""
    out = []
    for i in range(n):
        s = int(np.random.SeedSequence([int(seed), i]).generate_state(1)[0])
        out.append(generate(("hysteresis",), s, programme="fast_short_ramps"))
    return out
