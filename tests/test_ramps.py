"""Ramp rules (fxdsp.ramps) on hand-made thermometer logs: the contract's hysteresis state takes the
sign of a ramp from its start however short, a reversal flips it where the temperature turns, and
nothing flips on noise, quantisation or a dwell's wobble. The logs are written here from the
contract (piecewise-linear programmes, white noise, a quantiser), not with fxdsp.sim."""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.ramps import quantisation_step, read_ramps, white_sigma


def programme(legs, dt, t0=0.0):
    """Piecewise-linear temperature: legs of (duration_s, end_temp_c) from a start temperature."""
    t_knots, y_knots = [t0], [legs[0][1]]
    for duration, end in legs[1:]:
        t_knots.append(t_knots[-1] + duration)
        y_knots.append(end)
    t = np.arange(t0, t_knots[-1], dt)
    return t, np.interp(t, t_knots, y_knots), np.array(t_knots), np.array(y_knots)


def reading(y, rng, sigma, step):
    noisy = y + rng.normal(0.0, sigma, y.size)
    return np.round(noisy / step) * step if step > 0 else noisy


def true_state(t, t_knots, y_knots):
    """The contract's s from the programme itself: each rising/falling leg sets it from its start."""
    s = np.zeros(t.size)
    for a, b, ya, yb in zip(t_knots[:-1], t_knots[1:], y_knots[:-1], y_knots[1:]):
        if yb != ya:
            s[t >= a] = np.sign(yb - ya)
    return s


@pytest.mark.parametrize("sigma,step,dt", [(0.005, 0.01, 1.0), (0.05, 0.1, 10.0), (0.02, 0.0, 60.0)])
def test_short_fast_ramps_flip_the_state_at_their_start(sigma, step, dt):
    # 20 C steps at 2 C/min (10-minute ramps) and a 5-minute ramp at 4 C/min, dwells of 20 min to 2 h
    legs = [(0, 25.0), (3600, 25.0), (600, 45.0), (1200, 45.0), (600, 25.0), (7200, 25.0), (300, 5.0),
            (3600, 5.0), (600, 25.0), (3600, 25.0)]
    t, y, tk, yk = programme(legs, dt)
    rng = np.random.default_rng(3)
    got = read_ramps(t, reading(y, rng, sigma, step)).state
    want = true_state(t, tk, yk)
    wrong = np.flatnonzero(got != want)
    # three flips (the second cooling ramp keeps s = -1); each may be off by a sample or two, or a
    # minute: never the 10 minutes of a duration rule
    assert wrong.size <= 3 * max(2, int(60 / dt)), (wrong.size, t[wrong][:10])
    assert np.all(got[t < 3600 - 60] == 0)


def test_a_reversal_mid_ramp_flips_where_the_temperature_turns():
    legs = [(0, 20.0), (1800, 20.0), (1200, 40.0), (900, 30.0), (1800, 30.0), (600, 50.0), (1800, 50.0)]
    t, y, tk, yk = programme(legs, 5.0)
    rng = np.random.default_rng(4)
    got = read_ramps(t, reading(y, rng, 0.02, 0.01)).state
    want = true_state(t, tk, yk)
    turn = 1800 + 1200
    assert np.all(got[(t > turn + 120) & (t < turn + 900)] == -1)
    assert np.all(got[(t > turn - 900) & (t < turn - 60)] == 1)
    assert np.mean(got != want) < 0.02


def test_noise_quantisation_and_dwell_wobble_are_not_ramps():
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 20 * 3600.0, 10.0)
    # a chamber dwell: controller wobble of +-0.1 C on a 60 C programme span elsewhere in the log
    wobble = 0.1 * np.sin(2 * np.pi * t / 1800.0)
    y = np.where(t < 10 * 3600, 25.0 + wobble, np.interp(t, [10 * 3600, 11 * 3600], [25.0, 85.0]))
    r = read_ramps(t, reading(y, rng, 0.03, 0.05))
    assert np.all(r.state[t < 10 * 3600] == 0), "a dwell's wobble flipped the state"
    assert r.signs.tolist() == [1]
    flat = read_ramps(t, reading(np.full(t.size, 25.0), rng, 0.05, 0.1))
    assert flat.starts.size == 0 and np.all(flat.state == 0)


def test_noise_and_step_are_read_from_the_log():
    rng = np.random.default_rng(6)
    t, y, _, _ = programme([(0, 0.0), (3600, 0.0), (3600, 60.0), (3600, 60.0)], 2.0)
    assert white_sigma(y + rng.normal(0, 0.03, y.size)) == pytest.approx(0.03, rel=0.1)
    assert quantisation_step(reading(y, rng, 0.01, 0.05)) == pytest.approx(0.05, rel=1e-6)
    assert quantisation_step(y + rng.normal(0, 0.01, y.size)) == 0.0


def test_derivative_window_grows_with_the_noise_and_keeps_ramp_rates():
    t, y, _, _ = programme([(0, 20.0), (3600, 20.0), (1800, 35.0), (3600, 35.0), (1800, 20.0), (3600, 20.0)], 1.0)
    rng = np.random.default_rng(7)
    quiet = read_ramps(t, reading(y, rng, 0.002, 0.0))
    loud = read_ramps(t, reading(y, rng, 0.05, 0.1))
    assert loud.window_s > 3 * quiet.window_s
    rate = 15.0 / 1800.0
    for r in (quiet, loud):
        mid = (t > 3600 + 300) & (t < 3600 + 1500)
        assert np.median(r.dtdt[mid]) == pytest.approx(rate, rel=0.05)
        assert np.std(r.dtdt[mid]) < 0.15 * rate


@pytest.mark.parametrize("sigma,step,dt", [(0.02, 0.01, 5.0), (0.05, 0.1, 10.0), (0.01, 0.025, 2.0)])
def test_the_models_derivative_is_the_ramps_rate_on_both_sides_of_every_corner(sigma, step, dt):
    """The slope the model regresses on: unbiased and far quieter than the moving-average derivative
    inside each ramp, and no window reaching across a corner (the rows just inside a ramp, a few
    sampling intervals from its start or end, already have the ramp's rate; the first derivative's
    moving average smears the turn over its window there)."""
    legs = [(0, 20.0), (3000, 20.0), (1200, 40.0), (2400, 40.0), (900, 10.0), (600, 25.0), (3000, 25.0)]
    t, y, t_knots, y_knots = programme(legs, dt)
    rng = np.random.default_rng(11)
    r = read_ramps(t, reading(y, rng, sigma, step))
    true = np.zeros(t.size)
    for a, b, ya, yb in zip(t_knots[:-1], t_knots[1:], y_knots[:-1], y_knots[1:]):
        true[(t >= a) & (t < b)] = (yb - ya) / (b - a)
    corner_dist = np.min(np.abs(t[:, None] - t_knots[None, 1:-1]), axis=1)
    inside = corner_dist > 0.5 * r.window_s + 2 * dt        # the rows RampReading.unresolved keeps
    err, err_first = r.dtdt - true, r.dtdt_window - true
    assert abs(np.mean(err[inside])) < 0.01 * np.max(np.abs(true))
    assert np.std(err[inside]) < 0.3 * np.std(err_first[inside])
    # the rows beyond a few windows of any corner: the long line's noise, from the reading's own noise
    deep = corner_dist > 10 * r.window_s
    assert np.std(err[deep]) < 0.1 * np.std(err_first[deep])
    # and no row is taken far from its ramp's rate by a corner (the first derivative is, there)
    assert np.max(np.abs(err[inside])) < 6 * np.std(err_first[inside])
    assert not r.unresolved(t)[inside & (corner_dist > r.window_s + 4 * dt)].any()


def lagged(t, y, tau):
    """The first-order lag of a reading (dT/dt = (y - T)/tau), from rest on its first value: exact
    for a piecewise-linear input between samples (the input is linear over each step)."""
    if tau == 0:
        return y.copy()
    out = np.empty_like(y)
    out[0] = y[0]
    for i in range(1, y.size):
        h = t[i] - t[i - 1]
        a = np.exp(-h / tau)
        slope = (y[i] - y[i - 1]) / h
        # the lag of y[i-1] + slope * s over one step: the exact solution of the ODE
        out[i] = y[i] - slope * tau + (out[i - 1] - y[i - 1] + slope * tau) * a
    return out


@pytest.mark.parametrize("tau", [0.0, 15.0, 45.0])
def test_the_corners_rounding_is_the_chambers_air_lag(tau):
    """A chamber whose air lags its setpoint by tau rounds every corner over a few tau: the
    rounding's time constant is read off the corners, and the rows where the setpoint turned and the
    rounded stretch after it are the ones set aside as unresolved (a hysteresis state dated from the
    setpoint or from the rounded reading differs there by up to two tau)."""
    legs = [(0, 25.0), (3000, 25.0), (900, 55.0), (1200, 55.0), (600, 30.0), (900, 45.0), (2400, 45.0),
            (1500, 5.0), (3000, 5.0)]
    dt = 2.0
    t, setpoint, tk, yk = programme(legs, dt / 20.0)
    air = lagged(t, setpoint, tau)[::20]
    t = t[::20]
    r = read_ramps(t, reading(air, np.random.default_rng(21), 0.01, 0.01))
    assert abs(r.rounding_s - tau) <= max(0.2 * tau, 2 * dt), (r.rounding_s, tau)
    corners = tk[1:-1]
    near = np.min(np.abs(t[:, None] - corners[None, :]), axis=1)
    after = np.any((t[:, None] >= corners[None, :]) & (t[:, None] <= corners[None, :] + 2 * tau), axis=1)
    unresolved = r.unresolved(t)
    assert unresolved[after].all()
    # and no more than the corner's own span (a knee read off the rounded reading is dated up to
    # about 1.5 tau after the setpoint's corner): rows well inside a leg are kept
    assert not unresolved[near > 0.5 * r.window_s + 2 * dt + 5 * max(tau, dt) + 3 * r.window_s].any()
    # asked for every third row (a decimated series), the same rows by time, not rows by index
    np.testing.assert_array_equal(r.unresolved(t[::3]), unresolved[::3])
