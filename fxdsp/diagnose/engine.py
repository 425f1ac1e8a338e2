"""Diagnosis: calibrate the baseline, then add the causes that held-out data support.

Selection rule (greedy forward selection on held-out evidence):

1. The search runs with cubic B(Te) and S(Te), so that a missing polynomial term is never taken
   for a cause; the orders (0..3) of the final model are chosen by blocked cross-validation with
   the accepted causes in place (calibration, not discovery).
2. Each candidate cause is fitted on the training folds (its nonlinear parameter picked on the
   training folds only, so the held-out score is honest) and scored on the held-out folds of the
   channels it affects. Evidence = drop of the held-out sum of squares, in units of each channel's
   white-noise variance (estimated from first differences), summed over those channels: thermal
   lag must explain the resonator frequency too, a ramp-rate term or hysteresis must not.
3. The best candidate is accepted when the held-out rms of its channel falls by at least
   MIN_GAIN and the evidence exceeds MIN_EVIDENCE noise variances; it joins the model and the
   remaining candidates are tried again on top of it. Nothing accepted means `none`.

Uncertainties are delete-one-group jackknife standard deviations (20 groups, each a contiguous
twentieth of the log, so noise correlated over minutes to an hour is accounted for).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.signal import lfilter

from fxdsp import mechanisms as mech
from fxdsp.diagnose import model as M
from fxdsp.diagnose.blockfit import Blocks, SegmentNormals, jackknife_sd, parabolic_argmin

MIN_GAIN = 1.05  # held-out rms ratio below which a cause is not worth naming
MIN_EVIDENCE = 30.0  # held-out SSE drop, in noise variances, that noise alone does not produce
MAX_CAUSES = 3
MAX_SEARCH_ROWS = 100_000
TIME_TIED = ("aging_drift", "warmup", "hysteresis")  # causes a bias random walk can imitate
ORDER_CHOICES = (0, 1, 2, 3)


@dataclass
class Candidate:
    cause: str
    channel: str
    evidence: float
    ratio: float
    rms_before: float
    rms_after: float
    nonlinear: dict = field(default_factory=dict)  # the state entry (e.g. {"tau_s": 3000.0})
    nonlinear_sd: dict = field(default_factory=dict)
    ratios: dict = field(default_factory=dict)  # per affected channel

    @property
    def accepted_by_rule(self) -> bool:
        return self.ratio >= MIN_GAIN and self.evidence >= MIN_EVIDENCE


@dataclass
class Diagnosis:
    causes: list[str]
    parameters: dict[str, dict[str, float]]
    uncertainty: dict[str, dict[str, float]]
    gain: dict
    candidates: list[Candidate]
    orders: tuple
    baseline: dict
    context: "Context"
    state: dict
    residuals: dict = field(default_factory=dict)


class Context:
    """Everything fixed during a diagnosis: data, blocks, scalings, channel standardisation."""

    def __init__(self, series: M.Series, n_segments: int = 200, n_folds: int = 5):
        self.series = series
        self.blocks = Blocks.contiguous(series.n, n_segments, n_folds)
        self.scales = {"output": M.Scaling.of(series.temp)}
        if series.freq is not None:
            self.scales["freq_hz"] = M.Scaling.of(series.freq_thermometer)
        if series.ref is not None:
            self.scales["temp_c"] = M.Scaling.of(series.ref)
        self.norm = {}
        for ch in series.channels():
            y = series.target(ch)
            sd = float(np.std(y)) or 1.0
            self.norm[ch] = (float(np.mean(y)), sd)
        self.orders: tuple[int, int | None] = (3, 3 if self.has_rate else None)
        self.weights = {ch: 1.0 for ch in series.channels()}
        # > 0 when the channel's noise wanders (random walk): fits then use one-step innovations
        self.innovation_gain: dict[str, float] = {}

    @property
    def has_rate(self) -> bool:
        r = self.series.rate
        return r is not None and float(np.ptp(r)) > 0

    def target(self, channel: str) -> np.ndarray:
        mu, sd = self.norm[channel]
        return (self.series.target(channel) - mu) / sd

    def design(self, channel: str, state: dict, orders=None):
        if channel == "output":
            return M.output_design(self.series, state, orders or self.orders, self.scales["output"])
        if channel == "freq_hz":
            return M.freq_design(self.series, state, self.scales["freq_hz"])
        return M.temp_design(self.series, state, self.scales["temp_c"])

    def normals(self, channel: str, state: dict, orders=None) -> tuple[SegmentNormals, list[str]]:
        x, names = self.design(channel, state, orders)
        y = self.target(channel)
        gain = self.innovation_gain.get(channel, 0.0)
        if gain > 0:
            x, y = innovations(x, gain), innovations(y, gain)
        return SegmentNormals(x, y, self.blocks, self.weights[channel]), names


# -- calibration of the baseline -----------------------------------------------------------------
def choose_orders(ctx: Context, state: dict) -> tuple[int, int | None]:
    """Orders of B and S with the least held-out error, with the causes of ``state`` in place
    (calibration, not discovery: an unexplained drift can make a cubic look useless)."""
    best, best_sse = None, np.inf
    s_choices = ORDER_CHOICES if ctx.has_rate else (None,)
    for pb in ORDER_CHOICES:
        for ps in s_choices:
            normals, _ = ctx.normals("output", state, (pb, ps))
            held = normals.folds()[1].sum()
            if held < best_sse * (1 - 1e-3):  # a higher order must earn its keep
                best, best_sse = (pb, ps), held
    return best


def sf_estimate(ctx: Context) -> np.ndarray | None:
    """S(Te) of the baseline fit, in output units per rate unit (None without a rate column)."""
    pb, ps = ctx.orders
    if ps is None or not ctx.has_rate:
        return None
    normals, names = ctx.normals("output", {})
    coef, _ = normals.fit_all()
    x = ctx.scales["output"](ctx.series.temp)
    sd = ctx.norm["output"][1]
    return sd * np.polynomial.polynomial.polyval(x, [coef[names.index(f"s{j}")] for j in range(ps + 1)])


def white_noise_variance(residual: np.ndarray) -> float:
    """Variance of the white part of a residual, from first differences (robust to slow effects)."""
    d = np.diff(residual)
    if d.size < 2:
        return float(np.var(residual)) or 1.0
    mad = 1.4826 * np.median(np.abs(d - np.median(d)))
    var = 0.5 * mad * mad
    if not var > 0:
        var = 0.5 * float(np.var(d))
    return var if var > 0 else 1e-30


def set_noise_weights(ctx: Context, state: dict | None = None) -> dict[str, float]:
    """1/white-noise variance per channel, from the residual of ``state``: a large unexplained
    effect changes fast during ramps and would inflate a first-difference estimate."""
    sigma2 = {}
    for ch in ctx.series.channels():
        x, _ = ctx.design(ch, state or {})
        y = ctx.target(ch)
        beta = np.linalg.lstsq(x, y, rcond=None)[0]
        sigma2[ch] = white_noise_variance(y - x @ beta)
        ctx.weights[ch] = 1.0 / sigma2[ch]
    return sigma2


# -- candidates ------------------------------------------------------------------------------------
def affected_channels(ctx: Context, cause: str) -> list[str]:
    if cause == "thermal_lag":
        return ["output"] + (["freq_hz"] if ctx.series.freq is not None else [])
    if cause == "frequency_nonlinearity":
        return ["freq_hz"]
    if cause == "rtd_nonlinearity":
        return ["temp_c"]
    return ["output"]


def available(ctx: Context, cause: str) -> bool:
    s = ctx.series
    if cause == "none":
        return False
    if cause == "quadrature_leak":
        return s.quad is not None and float(np.ptp(s.quad)) > 0
    if cause == "sf_nonlinearity":
        # rate^3 must not be a multiple of rate (a tumble's cos(theta) in {1, 0, -1} is)
        r = s.rate
        return (ctx.has_rate and ctx.orders[1] is not None and s.sf_estimate is not None
                and np.linalg.matrix_rank(np.column_stack([r, r ** 3]) / max(np.max(np.abs(r)), 1e-300) ** np.array([1, 3]), tol=1e-6) == 2)
    if cause == "rtd_nonlinearity":
        return s.ref is not None
    if cause == "frequency_nonlinearity":
        return s.freq is not None
    if cause == "hysteresis":
        return bool(np.any(s.hyst != 0))
    if cause in ("thermal_lag", "ramp_rate"):
        return float(np.ptp(s.temp)) > 0
    return True


def grid(ctx: Context, cause: str) -> np.ndarray:
    s = ctx.series
    dt = float(np.median(np.diff(s.t))) if s.n > 1 else 1.0
    lo = max(2.0 * dt, 5.0)
    if cause == "thermal_lag":
        return np.geomspace(lo, max(s.duration, 4 * lo), 36)
    if cause == "warmup":
        return np.geomspace(lo, max(0.5 * s.duration, 4 * lo), 30)
    raise KeyError(cause)


def _log_axis(cause: str) -> bool:
    return cause in ("thermal_lag", "warmup")


def _evaluate_state(ctx: Context, state: dict, channels: list[str]):
    """Per channel: (train SSE per fold, held SSE per fold, full SSE, jackknife SSE per group)."""
    out = {}
    for ch in channels:
        normals, _ = ctx.normals(ch, state)
        train, held = normals.folds()
        _, full = normals.fit_all()
        out[ch] = (train, held, full * normals.weight, normals.jackknife()[1])
    return out


def evaluate(ctx: Context, state: dict, cause: str, base_held: dict) -> Candidate:
    """Fit one candidate on top of ``state``; score it on held-out folds against ``state``."""
    channels = affected_channels(ctx, cause)
    if cause not in M.NONLINEAR:
        res = _evaluate_state(ctx, {**state, cause: {}}, channels)
        held = {ch: res[ch][1] for ch in channels}
        nonlinear, nonlinear_sd = {}, {}
    else:
        pname = M.NONLINEAR[cause]
        values = grid(ctx, cause)
        train = np.zeros((values.size, ctx.blocks.n_folds))
        full = np.zeros(values.size)
        jk = np.zeros((values.size, ctx.blocks.n_groups))
        held_g = {ch: np.zeros((values.size, ctx.blocks.n_folds)) for ch in channels}
        for i, v in enumerate(values):
            res = _evaluate_state(ctx, {**state, cause: {pname: float(v)}}, channels)
            for ch in channels:
                train[i] += res[ch][0]
                held_g[ch][i] = res[ch][1]
                full[i] += res[ch][2]
                jk[i] += res[ch][3]
        # nested: each fold's parameter is the one its own training data prefer
        pick = np.argmin(train, axis=0)
        held = {ch: held_g[ch][pick, np.arange(pick.size)] for ch in channels}
        axis = np.log(values) if _log_axis(cause) else values
        best = _refine(ctx, state, cause, channels, values, full, axis)
        per_segment = np.array([parabolic_argmin(axis, jk[:, k]) for k in range(jk.shape[1])])
        if _log_axis(cause):
            per_segment = np.exp(per_segment)
        nonlinear = {pname: best}
        nonlinear_sd = {pname: jackknife_sd(per_segment)}
    evidence = 0.0
    ratios, before_after = {}, {}
    for ch in channels:
        w = ctx.weights[ch]
        b, a = float(base_held[ch].sum()), float(held[ch].sum())
        evidence += b - a
        sd = ctx.norm[ch][1]
        rms_b = np.sqrt(b / w / ctx.series.n) * sd
        rms_a = np.sqrt(a / w / ctx.series.n) * sd
        ratios[ch] = rms_b / rms_a if rms_a > 0 else np.inf
        before_after[ch] = (rms_b, rms_a)
    main = max(channels, key=lambda ch: ratios[ch])
    if cause == "thermal_lag" and ratios["output"] >= MIN_GAIN:
        main = "output"  # the contract's channel for a lag, whenever it shows there
    return Candidate(cause=cause, channel=main, evidence=float(evidence), ratio=float(ratios[main]),
                     rms_before=float(before_after[main][0]), rms_after=float(before_after[main][1]),
                     nonlinear=nonlinear, nonlinear_sd=nonlinear_sd, ratios=ratios)


def _refine(ctx, state, cause, channels, values, full, axis) -> float:
    """Full-data minimum of the weighted SSE between the grid neighbours of the grid minimum."""
    pname = M.NONLINEAR[cause]
    i = int(np.argmin(full))
    lo, hi = axis[max(i - 1, 0)], axis[min(i + 1, values.size - 1)]
    if lo == hi:
        return float(values[i])

    def sse(a):
        v = float(np.exp(a)) if _log_axis(cause) else float(a)
        total = 0.0
        for ch in channels:
            normals, _ = ctx.normals(ch, {**state, cause: {pname: v}})
            total += normals.fit_all()[1] * normals.weight
        return total

    # a lag 1000 x above the noise needs tau to 1e-4 or its misfit looks like another cause
    res = minimize_scalar(sse, bounds=(lo, hi), method="bounded", options={"xatol": 1e-7, "maxiter": 200})
    a = res.x if res.fun <= full[i] else axis[i]
    return float(np.exp(a)) if _log_axis(cause) else float(a)


# -- parameters of the final model -------------------------------------------------------------
def _linear_parameters(ctx: Context, state: dict):
    """Linear parameters of every cause in ``state`` (contract units) and their jackknife sds."""
    params, sds = {}, {}
    for ch in ctx.series.channels():
        normals, names = ctx.normals(ch, state)
        coef, _ = normals.fit_all()
        jk, _ = normals.jackknife()
        sd_y = ctx.norm[ch][1]
        for cause in state:
            conv = _converter(ctx, ch, cause, names)
            if conv is None:
                continue
            pname, fn = conv
            params.setdefault(cause, {})[pname] = fn(coef) * 1.0
            sds.setdefault(cause, {})[pname] = jackknife_sd(np.array([fn(c) for c in jk]))
    return params, sds


def _converter(ctx: Context, channel: str, cause: str, names: list[str]):
    """(parameter name, coefficients -> value in contract units) of a cause's linear parameter."""
    sd_y = ctx.norm[channel][1]
    if channel == "output" and cause in M.OUTPUT_COLUMN:
        j = names.index(cause)
        return M.OUTPUT_COLUMN[cause], lambda c: float(c[j] * sd_y)
    if channel == "freq_hz" and cause == "frequency_nonlinearity":
        j, half = names.index(cause), ctx.scales["freq_hz"].half
        return "k2_hz_per_c2", lambda c: float(c[j] * sd_y / half ** 2)
    if channel == "temp_c" and cause == "rtd_nonlinearity":
        sc = ctx.scales["temp_c"]

        def b_per_c(c):
            quad = c[2] / sc.half ** 2  # coefficient of ref^2
            slope = c[1] / sc.half + 2.0 * c[2] * (mech.T_CURVE_C - sc.mid) / sc.half ** 2
            return float(quad / slope) if slope != 0 else float("nan")

        return "b_per_c", b_per_c
    return None


def channel_gain(ctx: Context, state: dict, channel: str) -> dict:
    """Held-out rms of the baseline and of the extended model in one channel."""
    n = ctx.series.n
    sd = ctx.norm[channel][1]
    before = ctx.normals(channel, {})[0]
    after = ctx.normals(channel, state)[0]
    b = np.sqrt(before.folds()[1].sum() / before.weight / n) * sd
    a = np.sqrt(after.folds()[1].sum() / after.weight / n) * sd
    return {"channel": channel, "rms_before": float(b), "rms_after": float(a),
            "ratio": float(b / a) if a > 0 else float("inf"), "heldout": True}


def heldout_residuals(ctx: Context, state: dict, channel: str) -> np.ndarray:
    x, _ = ctx.design(channel, state)
    normals = SegmentNormals(x, ctx.target(channel), ctx.blocks)
    return normals.heldout_rows(x, ctx.target(channel)) * ctx.norm[channel][1]


def baseline_coefficients(ctx: Context, state: dict) -> dict:
    """Fitted baseline in the replay format (polynomials ascending in T - 25 C)."""
    out: dict = {"t_ref_c": mech.T_CURVE_C}
    normals, names = ctx.normals("output", state)
    coef, _ = normals.fit_all()
    mu, sd = ctx.norm["output"]
    sc = ctx.scales["output"]
    pb, ps = ctx.orders
    # x = (T - mid)/half = (u + 25 - mid)/half with u = T - 25: re-expand each polynomial in u
    shift = np.polynomial.Polynomial([(mech.T_CURVE_C - sc.mid) / sc.half, 1.0 / sc.half])
    def in_u(cs):
        p = np.polynomial.Polynomial([0.0])
        for j, cj in enumerate(cs):
            p = p + cj * shift ** j
        return [float(v) for v in p.coef]
    bias = [coef[names.index(f"b{j}")] * sd for j in range(pb + 1)]
    bias[0] += mu
    out["bias_poly"] = in_u(bias)
    if ps is not None and ctx.series.rate is not None:
        out["sf_poly"] = in_u([coef[names.index(f"s{j}")] * sd for j in range(ps + 1)])
    if ctx.series.freq is not None:
        # fitted as a polynomial in x = (Te - mid)/half; the contract writes it as
        # f0 + k Te + k2 (Te - 25)^2 with f0 the value at Te = 0 C
        normals, names = ctx.normals("freq_hz", state)
        coef, _ = normals.fit_all()
        mu, sd = ctx.norm["freq_hz"]
        sc = ctx.scales["freq_hz"]
        x_of_te = np.polynomial.Polynomial([-sc.mid / sc.half, 1.0 / sc.half])
        q = np.polynomial.Polynomial([mu])
        powers = {"f0": 0, "k": 1, "frequency_nonlinearity": 2}
        for name, cj in zip(names, coef):
            if name in powers:  # not the lag's start-value column
                q = q + sd * cj * x_of_te ** powers[name]
        a = list(q.coef) + [0.0] * 3
        k2 = a[2] if "frequency_nonlinearity" in state else 0.0
        out["f0_hz"] = float(a[0] - mech.T_CURVE_C ** 2 * k2)
        out["k_hz_per_c"] = float(a[1] + 2 * mech.T_CURVE_C * k2)
    if ctx.series.ref is not None:
        # temp_c = offset + gain * (ref + b (ref - 25)^2): expand and read offset and gain off
        normals, names = ctx.normals("temp_c", state)
        coef, _ = normals.fit_all()
        mu, sd = ctx.norm["temp_c"]
        sc = ctx.scales["temp_c"]
        x_of_ref = np.polynomial.Polynomial([-sc.mid / sc.half, 1.0 / sc.half])
        q = np.polynomial.Polynomial([mu])
        powers = {"t0": 0, "t1": 1, "rtd_nonlinearity": 2}
        for name, cj in zip(names, coef):
            q = q + sd * cj * x_of_ref ** powers[name]
        p = list(q.coef) + [0.0] * 3
        gain = p[1] + 2 * mech.T_CURVE_C * p[2]
        out["rtd_offset_c"] = float(p[0] - mech.T_CURVE_C ** 2 * p[2])
        out["rtd_gain"] = float(gain)
    return out


# -- wandering noise: bias random walk ------------------------------------------------------------
def innovations(values: np.ndarray, gain: float) -> np.ndarray:
    """One-step prediction errors of the steady-state Kalman filter of a local-level model (white
    noise plus a random walk): e_t = y_t - y_(t-1) + (1 - gain) e_(t-1). Least squares on
    innovations is generalised least squares for that noise; gain 0 leaves the data as they are
    (up to a constant), gain 1 differences them."""
    return lfilter([1.0, -1.0], [1.0, -(1.0 - gain)], values, axis=0)


def variogram(residual: np.ndarray, lag: int) -> float:
    """Robust variogram: median of squared lag differences, scaled to a variance for Gaussian noise
    (a few samples of model mismatch at a ramp corner must not look like a wandering bias)."""
    d = residual[lag:] - residual[:-lag]
    return float(np.median(d * d)) / 0.4549


def wander(residual: np.ndarray) -> tuple[float, float, float]:
    """(variogram ratio gamma(M)/gamma(1), the ratio white noise stays below, Kalman gain).

    White noise has a flat variogram; a random walk's grows linearly with the lag. M is a fifth of
    the log; the threshold is 1 + 4 standard deviations of the ratio for white noise, which is
    3.2 / sqrt(n) (simulated for n = 1e3 .. 1e5)."""
    n = residual.size
    m = max(2, n // 5)
    if n < 50:
        return 1.0, np.inf, 0.0
    g1, gm = variogram(residual, 1), variogram(residual, m)
    ratio = gm / g1 if g1 > 0 else 1.0
    threshold = 1.0 + 4.0 * 3.2 / np.sqrt(n)
    q = max((gm - g1) / (m - 1), 0.0)
    white = max((g1 - q) / 2.0, 1e-300)
    lam = q / white
    p = 0.5 * (lam + np.sqrt(lam * lam + 4.0 * lam))
    return float(ratio), float(threshold), float(p / (p + 1.0))


def residual(ctx: Context, state: dict, channel: str) -> np.ndarray:
    x, _ = ctx.design(channel, state)
    y = ctx.target(channel)
    normals = SegmentNormals(x, y, ctx.blocks)
    coef, _ = normals.fit_all()
    return y - x @ coef


def check_against_wander(ctx: Context, state: dict, accepted: list[Candidate]):
    """Re-test the accepted time-like causes when the final residual still wanders.

    A bias random walk drifts; over one run it can look like an aging slope, a warm-up or a
    hysteresis step (a level that changes a few times), and the white-noise held-out test cannot
    tell. Causes tied to the temperature ramps themselves (lag, ramp rate) or to other channels
    are not time-like: a random walk does not repeat with the programme. If the residual of the
    final model is not white, each time-like cause is tested again (dropped from the final model,
    held-out folds) on innovations of the white-plus-random-walk noise that the residual shows,
    and the weakest cause that no longer passes is removed, until all pass or the residual is
    white.
    """
    ch = "output"
    while True:
        out_causes = [c for c in accepted if c.cause in TIME_TIED]
        if not out_causes:
            return state, accepted
        ratio, threshold, gain = wander(residual(ctx, state, ch))
        if ratio <= threshold:
            return state, accepted
        ctx.innovation_gain[ch] = gain
        e = innovations(residual(ctx, state, ch), gain)
        saved_weight = ctx.weights[ch]
        ctx.weights[ch] = 1.0 / white_noise_variance(e)
        try:
            full = ctx.normals(ch, state)[0].folds()[1].sum()
            verdicts = []
            for cand in out_causes:
                without = {k: v for k, v in state.items() if k != cand.cause}
                held = ctx.normals(ch, without)[0].folds()[1].sum()
                evidence = held - full
                rms_ratio = float(np.sqrt(held / full)) if full > 0 else np.inf
                verdicts.append((evidence, rms_ratio, cand))
        finally:
            ctx.innovation_gain.pop(ch, None)
            ctx.weights[ch] = saved_weight
        failing = [v for v in verdicts if v[1] < MIN_GAIN or v[0] < MIN_EVIDENCE]
        if not failing:
            return state, accepted
        weakest = min(failing, key=lambda v: v[0])[2]
        accepted = [c for c in accepted if c is not weakest]
        state = {k: v for k, v in state.items() if k != weakest.cause}


def prune(ctx: Context, state: dict, accepted: list[Candidate]):
    """Backward check of the final model: every cause must still pass the acceptance rule when it
    is the last one added (a cause accepted early can become redundant after a later one, or after
    a time-like cause was removed by the wander check). The weakest failure goes first."""
    while accepted:
        verdicts = []
        for cand in accepted:
            without = {k: v for k, v in state.items() if k != cand.cause}
            evidence, ratio = 0.0, 0.0
            for ch in affected_channels(ctx, cand.cause):
                full = ctx.normals(ch, state)[0].folds()[1].sum()
                held = ctx.normals(ch, without)[0].folds()[1].sum()
                evidence += held - full
                ratio = max(ratio, float(np.sqrt(held / full)) if full > 0 else np.inf)
            verdicts.append((evidence, ratio, cand))
        failing = [v for v in verdicts if v[1] < MIN_GAIN or v[0] < MIN_EVIDENCE]
        if not failing:
            break
        weakest = min(failing, key=lambda v: v[0])[2]
        accepted = [c for c in accepted if c is not weakest]
        state = {k: v for k, v in state.items() if k != weakest.cause}
    return state, accepted


# -- the whole diagnosis -----------------------------------------------------------------------------
def greedy_search(ctx: Context) -> tuple[dict, list[Candidate], list[Candidate]]:
    """Forward selection on held-out evidence: (state, accepted candidates, first-round candidates)."""
    series = ctx.series
    state: dict = {}
    accepted: list[Candidate] = []
    first_round: list[Candidate] = []
    causes = [c for c in mech.CAUSES if available(ctx, c)]
    for _ in range(MAX_CAUSES):
        set_noise_weights(ctx, state)
        base_held = {ch: ctx.normals(ch, state)[0].folds()[1] for ch in series.channels()}
        results = [evaluate(ctx, state, c, base_held) for c in causes if c not in state]
        if not first_round:
            first_round = sorted(results, key=lambda c: -c.evidence)
        good = [c for c in results if c.accepted_by_rule]
        if not good:
            break
        best = max(good, key=lambda c: c.evidence)
        accepted.append(best)
        state[best.cause] = dict(best.nonlinear)
        if len(accepted) > 1:
            refit_nonlinear(ctx, state, accepted)
    return state, accepted, first_round


def refit_nonlinear(ctx: Context, state: dict, accepted: list[Candidate]) -> None:
    """Re-estimate the nonlinear parameters of earlier causes with the later ones in the model:
    a lag time constant fitted while a quadrature leak was still unexplained is biased."""
    for cand in accepted:
        if cand.cause not in M.NONLINEAR:
            continue
        pname = M.NONLINEAR[cand.cause]
        channels = affected_channels(ctx, cand.cause)
        others = {k: v for k, v in state.items() if k != cand.cause}

        def sse(a, cause=cand.cause, pname=pname, channels=channels, others=others):
            total = 0.0
            for ch in channels:
                normals, _ = ctx.normals(ch, {**others, cause: {pname: float(np.exp(a))}})
                total += normals.fit_all()[1] * normals.weight
            return total

        a0 = np.log(state[cand.cause][pname])
        res = minimize_scalar(sse, bounds=(a0 - 0.3, a0 + 0.3), method="bounded",
                              options={"xatol": 1e-7, "maxiter": 200})
        if res.fun <= sse(a0):
            state[cand.cause][pname] = float(np.exp(res.x))
            cand.nonlinear = dict(state[cand.cause])


def diagnose_series(series: M.Series, n_segments: int = 200, n_folds: int = 5) -> Diagnosis:
    ctx = Context(series, n_segments, n_folds)
    # the search runs on the most flexible baseline, so that a polynomial term the data need is
    # never mistaken for a cause; the orders are then re-chosen with the causes in place
    ctx.orders = (max(ORDER_CHOICES), max(ORDER_CHOICES) if ctx.has_rate else None)
    set_noise_weights(ctx)
    series.sf_estimate = sf_estimate(ctx)
    if series.n > MAX_SEARCH_ROWS:
        # a million rows carry no more shape information than a hundred thousand: search on every
        # k-th row (lags and derivatives were computed on the full log), then fit the found
        # model on all rows
        search = Context(series.decimated(-(-series.n // MAX_SEARCH_ROWS)), n_segments, n_folds)
        search.orders = ctx.orders
        set_noise_weights(search)
    else:
        search = ctx
    state, accepted, first_round = greedy_search(search)
    set_noise_weights(search, state)
    state, accepted = check_against_wander(search, state, accepted)
    state, accepted = prune(search, state, accepted)

    ctx.orders = choose_orders(search, state)
    linear, linear_sd = _linear_parameters(ctx, state)
    parameters, uncertainty = {}, {}
    for cand in accepted:
        p = {**linear.get(cand.cause, {}), **cand.nonlinear}
        u = {**linear_sd.get(cand.cause, {}), **cand.nonlinear_sd}
        names = mech.CAUSES[cand.cause]
        parameters[cand.cause] = {k: float(p[k]) for k in names}
        uncertainty[cand.cause] = {k: float(u[k]) for k in names if np.isfinite(u.get(k, np.nan))}
    if accepted:
        primary = accepted[0]
        channel_state = {c: state[c] for c in state if primary.channel in affected_channels(ctx, c)}
        gain = channel_gain(ctx, channel_state, primary.channel)
    else:
        gain = channel_gain(ctx, {}, "output")
    diag = Diagnosis(causes=[c.cause for c in accepted], parameters=parameters, uncertainty=uncertainty,
                     gain=gain, candidates=first_round, orders=ctx.orders,
                     baseline=baseline_coefficients(ctx, state), context=ctx, state=state)
    return diag
