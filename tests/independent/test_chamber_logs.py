"""The independent chamber-log generator honours the contract (shared/spec/measured-data.md).

These check the generator itself, not ``fxdsp``: columns and units, time stamps, noise, the
hysteresis state, the lag integration against analytic and ODE-solver responses, programme limits,
effect sizes, and that the truth parameters reproduce each cause in the contract's units.
"""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from .chamber_logs import (CAUSES, COLUMNS, PAIRS, PROGRAMME_KINDS, chamber_response, fast_ramp_logs,
                           generate, programme_from_steps)

CONTRACT_PARAMS = {
    "none": set(), "thermal_lag": {"tau_s"}, "ramp_rate": {"k_per_c_per_s"}, "hysteresis": {"h"},
    "warmup": {"a", "tau_s"}, "aging_drift": {"r_per_h"}, "quadrature_leak": {"c"},
    "sf_nonlinearity": {"k3"}, "rtd_nonlinearity": {"b_per_c"},
    "frequency_nonlinearity": {"k2_hz_per_c2"},
}
NEEDS = {"rtd_nonlinearity": "ref_temp_c", "sf_nonlinearity": "rate_dps",
         "frequency_nonlinearity": "freq_hz", "quadrature_leak": "quad"}


def _rms_remaining(v, X):
    coef, *_ = np.linalg.lstsq(X, v, rcond=None)
    r = v - X @ coef
    return float(np.sqrt(np.mean(r ** 2)))


def _output_design(log):
    x = (log.hidden["temp_true"] - 25.0) / 50.0
    X = np.column_stack([np.ones_like(x), x, x ** 2, x ** 3])
    if "rate_dps" in log.columns:
        X = np.column_stack([X, X * log.columns["rate_dps"][:, None]])
    return X


# ------------------------------------------------------------------------------------------- API

def test_causes_and_pairs():
    assert CAUSES[0] == "none" and set(CAUSES) == set(CONTRACT_PARAMS) and len(CAUSES) == 10
    assert len(PAIRS) >= 8 and len(set(map(frozenset, PAIRS))) == len(PAIRS)
    for a, b in PAIRS:
        assert a != b and "none" not in (a, b) and {a, b} <= set(CAUSES)
    assert sum("hysteresis" in p for p in PAIRS) >= 2


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_contract_columns_and_csv(seed):
    log = generate((), seed)
    cols = log.columns
    assert {"time_s", "temp_c", "output"} <= set(cols) <= set(COLUMNS)
    n = len(cols["time_s"])
    assert n > 1000 and all(len(v) == n for v in cols.values())
    assert all(np.all(np.isfinite(v)) for v in cols.values())
    t = cols["time_s"]
    assert np.all(np.diff(t) >= 0.0)
    assert 0.0 <= t[0] <= min(log.description["sampling"]["dt_s"], 10.0) + 1e-9   # power-on near 0
    assert -45.0 < cols["temp_c"].min() and cols["temp_c"].max() < 90.0
    assert log.truth == {}
    for key in ("te", "chamber", "hyst_state"):
        assert log.hidden[key].shape == (n,)
    json.dumps(log.description)
    # the CSV round-trips exactly (repr precision), header first, contract names
    rows = list(csv.reader(io.StringIO(log.csv_text())))
    header, body = rows[0], rows[1:]
    assert set(header) == set(cols) and len(body) == n
    back = np.array(body, float)
    for j, name in enumerate(header):
        assert np.array_equal(back[:, j], cols[name]), name


def test_determinism():
    a, b = generate(("hysteresis", "aging_drift"), 11), generate(("hysteresis", "aging_drift"), 11)
    assert a.csv_text() == b.csv_text() and a.truth == b.truth
    assert json.dumps(a.description) == json.dumps(b.description)
    assert generate(("hysteresis", "aging_drift"), 12).csv_text() != a.csv_text()


def test_optional_columns_sometimes_absent_and_present_when_needed():
    seen = {c: set() for c in COLUMNS[3:]}
    for seed in range(12):
        log = generate((), seed, rows=600)
        for c in seen:
            seen[c].add(c in log.columns)
    assert all(v == {True, False} for v in seen.values()), seen
    for cause, col in NEEDS.items():
        for seed in range(3):
            assert col in generate((cause,), seed, rows=600).columns


# ---------------------------------------------------------------------------------- time stamps

def test_missing_rows_and_repeated_stamps():
    checked = bursts = 0
    for seed in range(25):
        log = generate((), seed, rows=800)
        s = log.description["sampling"]
        t = log.columns["time_s"]
        d = np.diff(t)
        assert np.count_nonzero(d == 0.0) == s["n_duplicated"]
        # a duplicated stamp is a fresh sample: its output noise differs
        same = np.flatnonzero(d == 0.0)
        assert np.all(log.columns["output"][same] != log.columns["output"][same + 1])
        assert np.all(log.columns["temp_c"][same + 1] - log.columns["temp_c"][same] <= 0.5)
        # gaps: jitter <= 15 % and stamp rounding <= 10 % of dt, so round(gap/dt) - 1 counts lost rows
        pos = d[d > 0] / s["dt_s"]
        assert np.all(pos > 0.5)
        assert int(np.sum(np.round(pos) - 1)) == s["n_dropped"]
        assert s["n_dropped"] <= 0.025 * s["rows_nominal"] + 1
        if s["n_dropped"] and s["n_duplicated"]:
            checked += 1
            bursts += int(np.max(np.round(pos)) >= 3)   # at least two consecutive rows lost
    assert checked >= 5 and bursts >= 2


def test_sampling_interval_range():
    dts = [generate((), seed).description["sampling"]["dt_s"] for seed in range(20)]
    assert min(dts) >= 1.0 and max(dts) <= 60.0 and max(dts) / min(dts) > 5.0


# ----------------------------------------------------------------------------------- thermometer

@pytest.mark.parametrize("seed", [0, 5, 9])
def test_temp_quantisation_visible(seed):
    log = generate(("rtd_nonlinearity",), seed)
    q = log.description["noise"]["temp_quant_c"]
    sig = log.description["noise"]["temp_white_sigma_c"]
    assert 0.01 <= q <= 0.1 and 0.005 <= sig <= 0.05
    tc = log.columns["temp_c"]
    k = tc / q
    assert np.max(np.abs(k - np.round(k))) < 1e-6                   # on the quantiser's grid
    steps = np.diff(np.unique(np.round(k)))
    assert np.min(steps) == 1                                        # and the single step is used
    assert np.max(np.abs(tc - log.hidden["temp_true"])) <= q / 2 + 6 * sig


# ----------------------------------------------------------------------------- hysteresis state

def test_hyst_state_semantics_on_handmade_programme():
    steps = [(1800, 25), (600, 45), (1800, 45), (120, 42), (600, 60), (1200, 60), (900, 30), (1200, 30)]
    prog = programme_from_steps(25.0, steps, air_tau_s=30.0, dt_s=5.0)
    log = generate(("hysteresis",), 3, programme=prog)
    t, s = log.columns["time_s"], log.hidden["hyst_state"]
    expect = np.select(
        [t < 1800, t < 4200, t < 4320, t < 6120],   # before 1st ramp / heating+dwell / short cooling /
        [0.0, 1.0, -1.0, 1.0], -1.0)                # reversal straight into heating + dwell / cooling on
    assert np.array_equal(s, expect)
    # the sign is taken from the ramp's first instant, while the thermometer has hardly moved yet
    early = (t >= 1800) & (t < 1830)
    assert early.any() and np.all(s[early] == 1.0)
    assert np.all(log.hidden["chamber"][early] < 25.0 + 2.0 / 60.0 * 30.0)
    # the 2-minute cooling ramp flips it from its start; it persists through the long dwells
    assert np.all(s[(t >= 4200) & (t < 4320)] == -1.0) and np.all(s[(t > 7100)] == -1.0)
    h = log.truth["hysteresis"]["h"]
    assert np.allclose(log.hidden["output_clean"] - log.hidden["output_base"], h * s, atol=1e-9 * abs(h))


# --------------------------------------------------------------------------------------------- lags

def test_lag_matches_analytic_ramp_response():
    prog = programme_from_steps(20.0, [(7200, 20), (3600, 80), (3600, 80)], air_tau_s=0.0, dt_s=10.0)
    log = generate(("thermal_lag",), 4, programme=prog)
    tau = log.truth["thermal_lag"]["tau_s"]
    t, te, T = log.columns["time_s"], log.hidden["te"], log.hidden["chamber"]
    rate = 60.0 / 3600.0
    assert np.allclose(T, np.clip(20.0 + rate * (t - 7200.0), 20.0, 80.0), atol=1e-9)
    before, ramp, after = t < 7200, (t >= 7200) & (t <= 10800), t > 10800
    assert np.allclose(te[before], 20.0, atol=1e-12)
    u = t[ramp] - 7200.0
    assert np.allclose(te[ramp], T[ramp] - rate * tau * (1 - np.exp(-u / tau)), atol=1e-9)
    te_end = 80.0 - rate * tau * (1 - np.exp(-3600.0 / tau))
    assert np.allclose(te[after], 80.0 - (80.0 - te_end) * np.exp(-(t[after] - 10800.0) / tau), atol=1e-9)
    # and the element lag is really there: Te trails T by about rate*tau late in the ramp
    late = ramp & (t > 7200 + 5 * tau)
    if late.any():
        assert np.allclose(T[late] - te[late], rate * tau, rtol=0.01)


def test_lag_cascade_matches_ode_solver():
    steps = [(1800, 22), (900, 47), (1200, 47), (400, 40), (1500, 10), (2400, 10), (700, 31)]
    prog = programme_from_steps(22.0, steps, air_tau_s=40.0, dt_s=20.0)
    log = generate(("thermal_lag",), 8, programme=prog)
    tau = log.truth["thermal_lag"]["tau_s"]
    t = log.columns["time_s"]
    tu = np.unique(t)

    def rhs(time, y):
        sp = float(prog.extended_to(2e4).setpoint([time])[0])
        return [(sp - y[0]) / 40.0, (y[0] - y[1]) / tau]

    sol = solve_ivp(rhs, (0.0, tu[-1]), [22.0, 22.0], t_eval=tu, rtol=1e-9, atol=1e-9, max_step=5.0)
    idx = np.searchsorted(tu, t)
    assert np.max(np.abs(sol.y[0][idx] - log.hidden["chamber"])) < 2e-4
    assert np.max(np.abs(sol.y[1][idx] - log.hidden["te"])) < 2e-4
    # d chamber/dt is the true rate (checked against the ODE right-hand side)
    sp = prog.extended_to(2e4).setpoint(t)
    assert np.allclose(log.hidden["dtemp_dt"], (sp - log.hidden["chamber"]) / 40.0, atol=1e-9)
    # chamber_response without element lag returns te == chamber
    _, ch, _, te = chamber_response(prog, tu, 40.0, None)
    assert np.array_equal(ch, te)


# ------------------------------------------------------------------------------------- programmes

def test_fast_ramp_logs_have_short_fast_ramps():
    logs = fast_ramp_logs(3, 2024)
    assert len(logs) == 3 and len({lg.csv_text() for lg in logs}) == 3
    for log in logs:
        assert set(log.truth) == {"hysteresis"}, log.brief()
        d = log.description
        assert d["programme"]["kind"] == "fast_short_ramps"
        t, ch = log.columns["time_s"], log.hidden["chamber"]
        air = d["programme"]["air_tau_s"]
        ramps = [leg for leg in d["programme"]["legs"] if leg["T0_c"] != leg["T1_c"] and leg["complete"]]
        assert len(ramps) >= 3 and {np.sign(leg["rate_c_per_min"]) for leg in ramps} == {-1.0, 1.0}
        for leg in ramps:
            dur = leg["t1_s"] - leg["t0_s"]
            assert 300.0 <= dur <= 600.0 and abs(leg["rate_c_per_min"]) >= 2.0 - 1e-4, leg
            # the chamber really ramps at that rate in the second half of the leg ...
            w = (t >= leg["t0_s"] + dur / 2) & (t <= leg["t1_s"])
            if w.sum() >= 3:
                slope = np.polyfit(t[w], ch[w], 1)[0] * 60.0
                assert slope / leg["rate_c_per_min"] > 0.85, (leg, slope)
            # ... and settles at the leg's end temperature in the dwell that follows
            settle = (t > leg["t1_s"] + 6 * air + 1.0) & (t < leg["t1_s"] + 600.0)
            if settle.any():
                assert np.all(np.abs(ch[settle] - leg["T1_c"]) < 0.2), leg
        assert log.description["sampling"]["dt_s"] <= 15.0


@pytest.mark.parametrize("kind", PROGRAMME_KINDS)
def test_programme_kinds_respect_limits(kind):
    for seed in range(3):
        log = generate(("hysteresis",), seed, programme=kind, rows=2000)
        legs = log.description["programme"]["legs"]
        for a, b in zip(legs, legs[1:]):
            assert a["t1_s"] == b["t0_s"] and a["T1_c"] == b["T0_c"]
        for leg in legs:
            assert -40.0 <= leg["T1_c"] <= 85.0
            dur = leg["t1_s"] - leg["t0_s"]
            if not leg["complete"] or leg["tag"] == "preroll":
                continue
            if leg["T0_c"] != leg["T1_c"]:
                assert 0.2 - 1e-6 <= abs(leg["rate_c_per_min"]) <= 5.0 + 1e-6 and dur >= 300.0, leg
            else:
                assert 600.0 <= dur <= 10800.0, leg
        tags = [leg["tag"] for leg in legs]
        if kind == "reversal":
            for i, leg in enumerate(legs[:-1]):
                if leg["tag"] == "reversal":
                    nxt = legs[i + 1]
                    assert np.sign(nxt["rate_c_per_min"]) == -np.sign(leg["rate_c_per_min"])
                    between = sorted([leg["T0_c"], leg["planned_T1_c"]])
                    assert between[0] < leg["T1_c"] < between[1]      # turned back before its target
            assert "reversal" in tags
        if kind == "clipped":
            assert {"clipped_limit", "early_stop"} & set(tags)
            for leg in legs:
                if leg["tag"] == "clipped_limit":
                    assert abs(leg["planned_T1_c"] - leg["T0_c"]) > abs(leg["T1_c"] - leg["T0_c"])


def test_rate_table_levels_held_for_minutes():
    log = generate(("sf_nonlinearity",), 6)
    r, t = log.columns["rate_dps"], log.columns["time_s"]
    levels = np.unique(r)
    assert len(levels) >= 7 and 0.0 in levels and np.max(np.abs(r)) <= 500.0
    change = np.flatnonzero(np.diff(r) != 0)
    holds = np.diff(t[change + 1])
    assert np.median(holds) >= 120.0


# -------------------------------------------------------------------------- noise and effect size

@pytest.mark.parametrize("seed", [1, 4])
def test_output_noise(seed):
    log = generate((), seed)
    nz = log.description["noise"]
    sig = nz["output_white_sigma"]
    assert 0.1 <= nz["output_flicker_bias_instability"] / sig <= 0.3
    assert 0.5 <= nz["output_random_walk_end_std"] / sig <= 3.0
    resid = log.columns["output"] - log.hidden["output_clean"]
    d = np.diff(resid)
    assert 0.95 <= np.std(d) / np.sqrt(2) / sig <= 1.1          # white noise dominates differences
    col = log.hidden["output_coloured_noise"]
    assert 0.02 * sig < np.std(col) < 4.0 * sig                 # noise, not a drift cause
    same = np.flatnonzero(np.diff(log.columns["time_s"]) == 0)
    assert np.array_equal(col[same], col[same + 1])             # repeated stamp: same slow noise


def _check_effects(log):
    """Truth parameters (contract units) reproduce the effects; SNR within 5..20 as documented."""
    cols, hid, tr = log.columns, log.hidden, log.truth
    t = cols["time_s"]
    assert set(tr) == set(log.description["causes"]) - {"none"}
    for cause, params in tr.items():
        assert set(params) == CONTRACT_PARAMS[cause], (cause, params)
        assert all(np.isfinite(v) and v != 0 for v in params.values())
        if cause in NEEDS:
            assert NEEDS[cause] in cols
    sig_w = log.description["noise"]["output_white_sigma"]
    X = _output_design(log)
    add = {
        "hysteresis": lambda p: p["h"] * hid["hyst_state"],
        "aging_drift": lambda p: p["r_per_h"] * t / 3600.0,
        "warmup": lambda p: p["a"] * np.exp(-t / p["tau_s"]),
        "ramp_rate": lambda p: p["k_per_c_per_s"] * hid["dtemp_dt"],
        "quadrature_leak": lambda p: p["c"] * hid["quad_true"],
    }
    for cause, p in tr.items():
        snr = None
        if cause in add:
            v = add[cause](p)
            assert np.allclose(hid[f"effect:{cause}"], v, rtol=1e-9, atol=1e-12 * sig_w), cause
            snr = _rms_remaining(v, X) / sig_w
        elif cause == "sf_nonlinearity":
            v, r = hid["effect:sf_nonlinearity"], cols["rate_dps"]
            assert np.all(v[r == 0] == 0)
            ratio = v[r != 0] / (p["k3"] * r[r != 0] ** 3)              # = S(Te): a few % variation
            assert np.ptp(ratio) < 0.5 * np.abs(ratio).mean()
            snr = _rms_remaining(v, X) / sig_w
        elif cause == "thermal_lag":
            snr = _rms_remaining(hid["effect:thermal_lag"], X) / sig_w
            assert np.max(np.abs(hid["te"] - hid["chamber"])) > 0
        elif cause == "rtd_nonlinearity":
            ch = hid["chamber"]
            A = np.column_stack([np.ones_like(ch), ch, (ch - 25.0) ** 2])
            coef, *_ = np.linalg.lstsq(A, hid["temp_true"], rcond=None)
            assert coef[2] == pytest.approx(p["b_per_c"], rel=1e-6)
            nz = log.description["noise"]
            sig = np.hypot(nz["temp_white_sigma_c"], nz["temp_quant_c"] / np.sqrt(12))
            snr = _rms_remaining(p["b_per_c"] * (ch - 25.0) ** 2, A[:, :2]) / sig
        elif cause == "frequency_nonlinearity":
            te = hid["te"]
            A = np.column_stack([np.ones_like(te), te, (te - 25.0) ** 2])
            coef, *_ = np.linalg.lstsq(A, cols["freq_hz"], rcond=None)   # noisy column
            assert coef[2] == pytest.approx(p["k2_hz_per_c2"], rel=0.1)
            assert -0.5 - 1e-3 <= coef[1] <= -0.1 + 1e-3                  # k in -0.5..-0.1 Hz/C
            assert 3000.0 - 60.0 < np.median(cols["freq_hz"]) < 9000.0 + 30.0   # f0 at kHz scale
            Xf = np.column_stack([np.ones_like(te), hid["temp_true"]])
            snr = _rms_remaining(p["k2_hz_per_c2"] * (te - 25.0) ** 2, Xf) / log.description["noise"][
                "freq_sigma_hz"]
        assert 5.0 * 0.98 <= snr <= 20.0 * 1.05, (cause, snr, log.brief())
    # the noise-free output is the baseline plus the additive and multiplicative effects
    total = sum(hid[k] for k in hid if k.startswith("effect:") and k not in (
        "effect:rtd_nonlinearity", "effect:frequency_nonlinearity"))
    assert np.allclose(hid["output_clean"] - hid["output_base"], total, atol=1e-9 * np.abs(hid["output_clean"]).max())


@pytest.mark.parametrize("cause", CAUSES)
def test_every_cause_generates_with_its_truth(cause):
    log = generate((cause,), 21)
    assert log.description["causes"] == [cause]
    _check_effects(log)
    if cause == "none":
        assert log.truth == {} and not log.description["effects"]


@pytest.mark.parametrize("pair", PAIRS)
def test_every_pair_generates(pair):
    log = generate(pair, 33, rows=3000)
    assert set(log.truth) == set(pair)
    _check_effects(log)


def test_unknown_input_rejected():
    with pytest.raises(ValueError):
        generate(("no_such_cause",), 0)
    with pytest.raises(ValueError):
        generate((), 0, programme="no_such_programme")
