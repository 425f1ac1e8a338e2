"""Chamber ramps read off a thermometer log: its noise, the ramps' starts and signs, and the
smoothing a derivative of it needs. No fixed rates, durations or windows: every rule scales with
the log's own sampling interval, noise and quantisation step, and the rules are reported
(`RampReading.describe`) so a user can see why a ramp was, or was not, counted.

Rules
-----
* Noise. The white noise sigma of the reading comes from its second differences (a ramp's slope
  cancels in them, so ramps do not inflate it): sigma = 1.4826 MAD(d2) / sqrt(6). The quantisation
  step q is the most common non-zero step between consecutive distinct readings. The reading's
  resolution is sigma_eff = sqrt(sigma^2 + q^2 / 12).
* Ramp threshold. A move counts as a ramp once the reading has left its last extreme by more than
  delta = max(NOISE_MULTIPLE x sigma_eff + q, SPAN_FRACTION x span of the log): far beyond what the
  noise does over a whole log (the largest excursion of white noise over 1e6 samples is ~5 sigma),
  and above a chamber's control wobble during a dwell, which scales with the programme (a few
  tenths of a degree in a 100 C programme).
* Ramp start. Once confirmed, a ramp is dated back to its start: the knee of the best hinge (a
  level, then a straight ramp) fitted by least squares to the readings between the extreme the
  move left and the confirmation. So the hysteresis state of the contract (``s``) takes the ramp's
  sign from its start, however short or fast the ramp, a reversal mid-ramp flips it where the
  temperature turned, and a dwell's wobble before the ramp does not pull the start back.
* Derivative smoothing. A first d(temp_c)/dt is taken on a moving average of W seconds; its noise
  is then sigma_eff / (sqrt(2) W). W is the shortest window (from one sample up) for which that
  noise is at most DERIVATIVE_NOISE_FRACTION of the median |dT/dt| of the ramp rows. It dates the
  phases (heating, cooling, dwell) and so the corners: where a ramp starts, ends or turns.
* Corner rounding. A chamber's air lags its setpoint, so a corner of the reading is rounded over
  a few time constants, and where the ramp "really" turned (the setpoint's corner, or the knee of
  the rounded reading) is uncertain by about one. The rounding's time constant is fitted to all the
  corners at once: each corner's readings (out to half the way to its neighbours) against a
  first-order lag of a sharp corner (a line, and from an instant ts on a change of slope through the
  lag), ts free per corner, one time constant for the log (least squares; 0: sharp corners).
* Corner-aware derivative. The d(temp_c)/dt the model uses is the slope of a straight line fitted
  to the readings within +-h of each row, h the distance to the nearest corner (at least W / 2, at
  most MAX_HALF_WINDOWS x W / 2): inside a ramp the line takes in far more readings than W (its
  slope's noise falls as h^-1.5), and no window reaches across a corner. A regressor as noisy as the
  output itself would bias a ramp-rate term low by its noise share (errors in variables) and leave
  that share in the residual, on every ramp.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numba import njit
from fxdsp.errors import InputError
from fxdsp.numeric import parabolic_argmin

# a move this many noise sigmas (plus a quantisation step) beyond the last extreme is a ramp
NOISE_MULTIPLE = 10.0
# ... and it must exceed this fraction of the log's temperature span (chamber wobble in a dwell)
SPAN_FRACTION = 0.01
# noise of the derivative allowed, as a fraction of the typical ramp rate
DERIVATIVE_NOISE_FRACTION = 0.1
# the longest line a row's slope is fitted over, in half-windows W / 2 of the first derivative
MAX_HALF_WINDOWS = 10.0
# a corner is unresolved for this many rounding time constants either side of its knee (the knee
# of a rounded reading is dated about one after the chamber turned, and the lag settles to 14 % of a
# change of slope in two more; three either side set aside most of a five-minute ramp, and what is
# left of a log of short ramps is its dwells, where a temperature shape is a dwell's level)
ROUNDING_SPANS = 2.0
# the rounding's time constants tried (between half a sampling interval and a third of the typical
# corner's half-window), the instants tried for each corner's sharp corner, and the rows a corner's
# fit reads at most (a longer window is read every k-th row)
ROUNDING_TAUS = 24
ROUNDING_STARTS = 48
ROUNDING_ROWS = 600


def _distinct_steps(t: np.ndarray) -> np.ndarray:
    steps = np.diff(t)
    return steps[steps > 0]


def sample_interval(time_s) -> float:
    """Median step between distinct time stamps (repeated stamps would make a plain median 0)."""
    steps = _distinct_steps(np.asarray(time_s, float))
    if steps.size == 0:
        raise InputError("time_s: the log has no two distinct time stamps")
    return float(np.median(steps))


def white_sigma(values) -> float:
    """White-noise sigma of a reading from its second differences (insensitive to ramps)."""
    y = np.asarray(values, float)
    if y.size < 5:
        return 0.0
    d2 = y[2:] - 2.0 * y[1:-1] + y[:-2]
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def quantisation_step(values) -> float:
    """Most common non-zero step between consecutive readings, when the readings sit on a grid
    (0 when they do not: a float reading has no common step)."""
    d = np.abs(np.diff(np.asarray(values, float)))
    d = d[d > 0]
    if d.size < 10:
        return 0.0
    q = float(np.min(d))
    # on a grid every step is a multiple of the smallest one
    multiples = d / q
    on_grid = np.abs(multiples - np.round(multiples)) < 1e-6 * np.maximum(multiples, 1.0)
    return q if on_grid.mean() > 0.99 else 0.0


def moving_average(t: np.ndarray, values: np.ndarray, window_s: float) -> tuple[np.ndarray, int]:
    """Centred moving average over about ``window_s`` (2 k + 1 rows; ends shrink) and k."""
    values = np.asarray(values, float)
    dt = sample_interval(t) if np.ptp(t) > 0 else window_s
    k = int(window_s / dt) // 2 if dt > 0 else 0
    if k < 1 or values.size < 2 * k + 1:
        return values.copy(), 0
    c = np.concatenate([[0.0], np.cumsum(values - values[0])])
    i = np.arange(values.size)
    lo, hi = np.maximum(i - k, 0), np.minimum(i + k + 1, values.size)
    return values[0] + (c[hi] - c[lo]) / (hi - lo), k


def derivative(t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """dy/dt by central differences on a possibly irregular grid; rows with a repeated stamp share
    the derivative of the mean reading at that stamp."""
    t = np.asarray(t, float)
    u = np.asarray(values, float)
    if u.size < 2:
        return np.zeros_like(u)
    if np.all(np.diff(t) > 0):
        return np.gradient(u, t)
    tu, inverse = np.unique(t, return_inverse=True)
    if tu.size < 2:
        return np.zeros_like(u)
    uu = np.bincount(inverse, weights=u) / np.bincount(inverse)
    return np.gradient(uu, tu)[inverse]


@dataclass
class RampReading:
    """What the ramp rules found in one thermometer log (see the module docstring)."""

    sigma: float  # white noise of the reading, C
    quant_step: float  # quantisation step, C (0: none found)
    threshold: float  # delta: the move that makes a ramp, C
    starts: np.ndarray  # row index where each ramp starts
    signs: np.ndarray  # +1 heating, -1 cooling
    window_s: float  # the first derivative's smoothing window W
    dtdt_window: np.ndarray  # the first derivative (on the W moving average), C/s: dates the phases
    dtdt: np.ndarray  # corner-aware d(temp)/dt per row, C/s (what the model uses)
    state: np.ndarray  # the contract's hysteresis s per row
    # the log the reading was taken from (the corners' rounding is fitted to it when asked for)
    times: np.ndarray = field(repr=False)
    readings: np.ndarray = field(repr=False)

    @cached_property
    def rounding_s(self) -> float:
        """Time constant of the corners' rounding (module docstring), s."""
        return corner_rounding(self.times, self.readings, self.corners(self.times))

    @property
    def sigma_eff(self) -> float:
        return float(np.hypot(self.sigma, self.quant_step / np.sqrt(12.0)))

    def phase(self) -> np.ndarray:
        """+1 heating, -1 cooling, 0 dwell per row: |dT/dt| above 5 sigmas of its own noise."""
        noise = self.sigma_eff / (np.sqrt(2.0) * self.window_s)
        d = self.dtdt_window
        return np.where(d > 5 * noise, 1, np.where(d < -5 * noise, -1, 0))

    def corners(self, t) -> np.ndarray:
        """Rows where a ramp starts (its knee) or the heating / cooling / dwell phase changes and then
        holds for at least two windows W over the stamps ``t`` (a phase flickering about its threshold
        on a slow ramp or in a dwell's noise is not a corner)."""
        phase = self.phase()
        change = np.flatnonzero(np.diff(phase) != 0) + 1
        if change.size:
            t = np.asarray(t, float)
            bounds = np.concatenate([[0], change, [phase.size]])
            lasting = t[np.minimum(bounds[1:], phase.size - 1)] - t[bounds[:-1]] >= 2.0 * self.window_s
            # a run too short to be a phase takes its predecessor's value: a change is kept where
            # the lasting phases on its two sides differ
            value, kept, last = phase[bounds[:-1]], [], None
            for b, v, ok in zip(bounds[:-1], value, lasting):
                if ok:
                    if last is not None and v != last:
                        kept.append(b)
                    last = v
            change = np.array(kept, dtype=np.int64)
        return np.union1d(self.starts, change).astype(np.int64)

    def unresolved(self, t) -> np.ndarray:
        """Rows too near a corner for the reading to say what the temperature did there: within half
        the derivative's window (the smoothed dT/dt turns over that span, the true one at an instant)
        plus two sampling intervals (a knee dated to a row: the true start lies between two rows) and
        ROUNDING_SPANS of the corners' rounding time constant (a chamber's air lag: the ramp turned
        somewhere in the rounded stretch) of a ramp's start or end. Bool per row of ``t``: the
        reading's own stamps or any others over the same log (every few rows of it: the corners are
        found on the reading's own rows, and set aside by time)."""
        t = np.asarray(t, float)
        corners = self.corners(self.times)
        out = np.zeros(t.size, dtype=bool)
        if corners.size == 0 or t.size < 2:
            return out
        reach = 0.5 * self.window_s + 2.0 * sample_interval(self.times) + ROUNDING_SPANS * self.rounding_s
        at = self.times[corners]
        lo = np.searchsorted(t, at - reach, side="left")
        hi = np.searchsorted(t, at + reach, side="right")
        cover = np.zeros(t.size + 1, dtype=np.int64)
        np.add.at(cover, lo, 1)
        np.add.at(cover, hi, -1)
        return np.cumsum(cover[:-1]) > 0

    def describe(self) -> str:
        q = f"{self.quant_step:.3g} C" if self.quant_step > 0 else "none found"
        heat, cool = int(np.sum(self.signs > 0)), int(np.sum(self.signs < 0))  # changes of direction
        return (f"ramps read off temp_c: white noise {self.sigma:.3g} C (second differences), quantisation "
                f"step {q}; a ramp is a move of more than {self.threshold:.3g} C from the last extreme "
                f"(max of {NOISE_MULTIPLE:g} noise sigmas + one step, and {100 * SPAN_FRACTION:g} % of the "
                f"span), dated back to its knee (hinge fit): the state turned to heating {heat} and to "
                f"cooling {cool} times; phases from d(temp_c)/dt on a {self.window_s:.3g} s moving average (its noise "
                f"at most {100 * DERIVATIVE_NOISE_FRACTION:g} % of the median ramp rate); the model's d(temp_c)/dt is "
                f"the slope of a line over +-{0.5 * self.window_s:.3g} to {0.5 * MAX_HALF_WINDOWS * self.window_s:.3g} s, "
                f"as far as the nearest corner; the corners are rounded as by a lag of {self.rounding_s:.3g} s (a "
                "first-order lag of a sharp corner fitted to all of them)")


def read_ramps(time_s, temp_c) -> RampReading:
    """Noise, ramps, hysteresis state and smoothed derivative of a thermometer log."""
    t = np.asarray(time_s, float)
    y = np.asarray(temp_c, float)
    if t.shape != y.shape or t.ndim != 1:
        raise InputError("time_s and temp_c must be 1-D arrays of the same length")
    sigma = white_sigma(y)
    q = quantisation_step(y)
    sigma_eff = float(np.hypot(sigma, q / np.sqrt(12.0)))
    span = float(np.ptp(y)) if y.size else 0.0
    threshold = max(NOISE_MULTIPLE * sigma_eff + q, SPAN_FRACTION * span)
    dt = sample_interval(t) if y.size > 1 and np.ptp(t) > 0 else 1.0
    window = _derivative_window(t, y, dt, sigma_eff)
    smooth, k = moving_average(t, y, window)
    dtdt = derivative(t, smooth)
    if threshold > 0 and y.size > 1:
        left, confirmed, signs = _zigzag(smooth, threshold)
        # date each ramp back to its knee between the extreme it left and its confirmation
        starts = np.array([_knee(t, y, a, b) for a, b in zip(left, confirmed)], dtype=np.int64)
    else:
        starts, signs = np.zeros(0, np.int64), np.zeros(0, np.int64)
    state = np.zeros(y.size)
    for start, sign in zip(starts, signs):
        state[start:] = sign
    reading = RampReading(sigma=sigma, quant_step=q, threshold=threshold, starts=starts, signs=signs,
                          window_s=float((2 * k + 1) * dt), dtdt_window=dtdt, dtdt=dtdt, state=state,
                          times=t, readings=y)
    if y.size > 2 and np.ptp(t) > 0:
        reading.dtdt = corner_aware_derivative(t, y, t[reading.corners(t)], 0.5 * reading.window_s,
                                               0.5 * MAX_HALF_WINDOWS * reading.window_s)
    return reading


def corner_rounding(t, y, corner_rows) -> float:
    """The time constant of a first-order lag that rounds every corner of the reading ``y`` (rows
    ``corner_rows``), by least squares over all corners at once (module docstring), s."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    at = np.unique(np.asarray(corner_rows, np.int64))
    if at.size == 0 or t.size < 8:
        return 0.0
    dt = sample_interval(t)
    # each corner's half-window: half the way to its neighbours (the log's ends count as neighbours)
    edges = np.concatenate([[t[0]], t[at], [t[-1]]])
    half = 0.5 * np.minimum(edges[1:-1] - edges[:-2], edges[2:] - edges[1:-1])
    usable = half >= 4.0 * dt
    if not usable.any():
        return 0.0
    longest = np.median(half[usable]) / 3.0
    if not longest > 0.5 * dt:
        return 0.0
    taus = np.concatenate([[0.0], np.geomspace(0.5 * dt, longest, ROUNDING_TAUS)])
    total = np.zeros(taus.size)
    for row, h in zip(at[usable], half[usable]):
        tc = t[row]
        inside = np.flatnonzero((t >= tc - h) & (t <= tc + h))
        inside = inside[::max(1, -(-inside.size // ROUNDING_ROWS))]
        u, v = t[inside] - tc, y[inside]
        # the readings and every lagged corner less their straight line (what [1, t] absorbs)
        base = np.column_stack([np.ones_like(u), u])
        proj = np.linalg.pinv(base)
        rv = v - base @ (proj @ v)
        coarse = np.linspace(-min(3.0 * longest, 0.8 * h), min(dt, 0.2 * h), ROUNDING_STARTS)
        step = coarse[1] - coarse[0]
        best = np.full(taus.size, np.sum(rv * rv))
        for i, tau in enumerate(taus):
            # the corner's instant on the coarse grid, then on a grid twelve times finer around it
            drop, at_start = _best_lagged_corner(u, rv, base, proj, coarse, tau)
            fine = np.linspace(at_start - step, at_start + step, 25)
            drop = max(drop, _best_lagged_corner(u, rv, base, proj, fine, tau)[0])
            best[i] -= drop
        total += best
    if int(np.argmin(total)) == 0:
        return 0.0
    # between grid points: the minimum refined on the grid's own axis, log tau
    return float(np.exp(parabolic_argmin(np.log(taus[1:]), total[1:])))


def _best_lagged_corner(u, rv, base, proj, starts, tau) -> tuple[float, float]:
    """The largest drop of the sum of squares ``rv`` (readings less their line) that a lagged change
    of slope from one of ``starts`` gives, and that start."""
    w = np.maximum(u[None, :] - starts[:, None], 0.0)
    bend = w - tau * -np.expm1(-w / tau) if tau > 0 else w
    rb = bend - (bend @ proj.T) @ base.T
    norm = np.einsum("ij,ij->i", rb, rb)
    ok = norm > 1e-12 * max(float(np.max(norm)), 1e-300)
    if not ok.any():
        return 0.0, float(starts[0])
    dot = rb @ rv
    drops = np.where(ok, dot * dot / np.where(ok, norm, 1.0), 0.0)
    k = int(np.argmax(drops))
    return float(drops[k]), float(starts[k])


def corner_aware_derivative(t, y, corners_t, shortest: float, longest: float) -> np.ndarray:
    """Per row, the slope of the least-squares line through the readings within +-h of it, h its
    distance to the nearest of ``corners_t`` clipped to [shortest, longest] (seconds): running sums,
    one pass. A window with fewer than two distinct stamps has slope 0."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    c = np.sort(np.asarray(corners_t, float))
    if c.size:
        k = np.clip(np.searchsorted(c, t), 1, c.size)
        dist = np.minimum(np.abs(t - c[k - 1]), np.abs(c[np.minimum(k, c.size - 1)] - t))
    else:
        dist = np.full(t.size, np.inf)
    h = np.clip(dist, shortest, longest)
    lo = np.searchsorted(t, t - h, side="left")
    hi = np.searchsorted(t, t + h, side="right")
    # centred on each window's own row (sums of (t - t0) powers from running sums, t0 the log's mean
    # time: the differences keep ~1e-8 relative precision over a week of seconds)
    u = t - t.mean()
    v = y - y.mean()
    run = [np.concatenate([[0.0], np.cumsum(a)]) for a in (np.ones_like(u), u, v, u * u, u * v)]
    n, su, sv, suu, suv = (r[hi] - r[lo] for r in run)
    sxx = suu - su * su / np.maximum(n, 1)
    sxy = suv - su * sv / np.maximum(n, 1)
    ok = (n >= 2) & (sxx > 1e-12 * np.maximum(suu, 1e-300))
    return np.where(ok, sxy / np.where(ok, sxx, 1.0), 0.0)


def _derivative_window(t, y, dt, sigma_eff) -> float:
    """Shortest window whose derivative noise is at most DERIVATIVE_NOISE_FRACTION of the median
    rate of the rows that are clearly ramping at that window."""
    duration = float(np.ptp(t)) if t.size else 0.0
    if sigma_eff <= 0 or duration <= 0:
        return dt
    window = dt
    while window <= duration / 20.0:
        smooth, k = moving_average(t, y, window)
        w = (2 * k + 1) * dt
        noise = sigma_eff / (np.sqrt(2.0) * w)
        rate = np.abs(derivative(t, smooth))
        ramping = rate[rate > 5.0 * noise]
        if ramping.size >= 3 and np.median(ramping) * DERIVATIVE_NOISE_FRACTION >= noise:
            return w
        window = max(w, window) * 1.5
    return window


@njit(cache=True)
def _zigzag(y, threshold):
    """Ramps as (extreme left, row of confirmation, sign): a move of more than ``threshold`` from
    the extreme reached since the last ramp started."""
    n = y.size
    left = np.zeros(n, np.int64)
    confirmed = np.zeros(n, np.int64)
    signs = np.zeros(n, np.int64)
    count = 0
    direction = 0  # 0 before the first ramp, else the sign of the last one
    lo_i, hi_i = 0, 0  # extremes since the last ramp start (both tracked before the first)
    for i in range(1, n):
        if y[i] < y[lo_i]:
            lo_i = i
        if y[i] > y[hi_i]:
            hi_i = i
        if direction <= 0 and y[i] - y[lo_i] > threshold:
            left[count], confirmed[count], signs[count] = lo_i, i, 1
            count += 1
            direction, hi_i = 1, i
        elif direction >= 0 and y[hi_i] - y[i] > threshold:
            left[count], confirmed[count], signs[count] = hi_i, i, -1
            count += 1
            direction, lo_i = -1, i
    return left[:count], confirmed[:count], signs[:count]


@njit(cache=True)
def _knee(t, y, a, b):
    """Row k in [a, b) of the best hinge y ~ c0 + c1 max(0, t - t_k) over rows a..b: where a ramp
    leaves the level it started from. Least squares over every k in one pass of suffix sums."""
    m = b - a + 1
    if m < 3:
        return a
    t0 = t[a]
    ybar = 0.0
    for j in range(a, b + 1):
        ybar += y[j]
    ybar /= m
    # suffix sums over rows j > k of t, t^2, y, t*y
    s1 = 0.0
    s2 = 0.0
    sy = 0.0
    sty = 0.0
    best_k, best_gain = a, -1.0
    for k in range(b - 1, a - 1, -1):
        tj, yj = t[k + 1] - t0, y[k + 1] - ybar
        s1 += tj
        s2 += tj * tj
        sy += yj
        sty += tj * yj
        tk = t[k] - t0
        cnt = b - k
        sx = s1 - tk * cnt
        sxx = s2 - 2.0 * tk * s1 + tk * tk * cnt - sx * sx / m
        sxy = sty - tk * sy  # y is centred, so no mean correction is needed
        if sxx > 0.0:
            gain = sxy * sxy / sxx
            if gain > best_gain:
                best_gain, best_k = gain, k
    return best_k
