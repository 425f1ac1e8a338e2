"""Numbers of the final model: cause parameters in contract units with jackknife uncertainties (the
diagnosis also takes the log's own noise's: uncertainty.py), held-out gains and residuals, and the
baseline in the simulator's replay format."""

from __future__ import annotations

import numpy as np

from fxdsp import mechanisms as mech
from fxdsp.causes import CAUSES
from fxdsp.diagnose.blockfit import SegmentNormals, jackknife_sd
from fxdsp.diagnose.context import Context, gain_ratio

# The delete-one-group jackknife needs a parameter's information spread over the 20 contiguous groups.
# A transient, or a column one group holds most of (a rate-table session within a twentieth of the
# log), leaves the fit without it when that group is deleted, and the groups' spread is then of fits
# that do not determine it: the project's sf_nonlinearity log 5010 (all of k3's information in one
# group) reported k3 = 3.37e-8 +- 3.2e-8, and +- 1.3e-5 on whitened rows, against a noise sd of
# 1e-10, and the cause was set aside. The interleaved folds each keep part of every stretch.
CONCENTRATED = 0.5   # the largest share of a column's information (given the others) one group may hold


def linear_parameters(ctx: Context, state: dict):
    """Linear parameters of every cause in ``state`` (contract units) and their jackknife sds (by
    contiguous groups, or by interleaved folds where those cannot see the parameter: CONCENTRATED)."""
    params, sds = {}, {}
    for ch in ctx.series.channels():
        normals, names = ctx.normals(ch, state)
        coef, _ = normals.fit_all()
        jk, _ = normals.jackknife()
        by_fold, fitted = None, None
        for cause in state:
            conv = converter(ctx, ch, cause, names)
            if conv is None:
                continue
            pname, fn = conv
            params.setdefault(cause, {})[pname] = fn(coef)
            samples = jk
            if not CAUSES[cause].transient:
                fitted = ctx.whiten(ch, ctx.design(ch, state)[0]) if fitted is None else fitted
            if CAUSES[cause].transient or largest_group_share(fitted, names.index(cause), ctx.blocks) > CONCENTRATED:
                by_fold = normals.jackknife("fold")[0] if by_fold is None else by_fold
                samples = by_fold
            sds.setdefault(cause, {})[pname] = jackknife_sd(np.array([fn(c) for c in samples]))
    return params, sds


def largest_group_share(x: np.ndarray, column: int, blocks) -> float:
    """The largest share of the information on column ``column`` of the design ``x`` (as fitted:
    whitened when a filter is set), given its other columns, that one contiguous jackknife group of
    ``blocks`` holds."""
    others = np.delete(x, column, axis=1)
    left = x[:, column] - others @ np.linalg.lstsq(others, x[:, column], rcond=None)[0]
    total = float(left @ left)
    if not total > 0:
        return 1.0
    return float(np.max(np.bincount(blocks.row_group(), weights=left * left)) / total)


def converter(ctx: Context, channel: str, cause: str, names: list[str]):
    """(parameter name, coefficients -> value in contract units) of a cause's linear parameter."""
    sd_y = ctx.norm[channel][1]
    record = CAUSES[cause]
    if channel != record.channel or cause not in names:
        return None
    j = names.index(cause)
    if record.curvature is not None:
        sc = ctx.scales[channel]
        return record.parameters[0], lambda c: record.curvature(c, j, sd_y, sc)
    if record.linear is not None:
        return record.linear, lambda c: float(c[j] * sd_y)
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
            "ratio": float(gain_ratio(b, a)), "heldout": True}


def heldout_residuals(ctx: Context, state: dict, channel: str) -> np.ndarray:
    x, _ = ctx.design(channel, state)
    normals = SegmentNormals(x, ctx.target(channel), ctx.blocks)
    return normals.heldout_rows(x, ctx.target(channel)) * ctx.norm[channel][1]


def _physical_poly(ctx: Context, channel: str, state: dict, powers: dict[str, int]) -> list[float]:
    """A channel fitted as a polynomial in the scaled thermometer x = (T - mid)/half, re-expressed
    in powers of T itself (coefficients ascending, padded to cubic). ``powers`` maps the fitted
    column names to their power of x; other columns (e.g. a lag's start value) are left out."""
    normals, names = ctx.normals(channel, state)
    coef, _ = normals.fit_all()
    mu, sd = ctx.norm[channel]
    sc = ctx.scales[channel]
    x_of_t = np.polynomial.Polynomial([-sc.mid / sc.half, 1.0 / sc.half])
    q = np.polynomial.Polynomial([mu])
    for name, cj in zip(names, coef):
        if name in powers:
            q = q + sd * cj * x_of_t ** powers[name]
    return list(q.coef) + [0.0] * 3


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
        a = _physical_poly(ctx, "freq_hz", state, {"f0": 0, "k": 1, "frequency_nonlinearity": 2})
        k2 = a[2] if "frequency_nonlinearity" in state else 0.0
        out["f0_hz"] = float(a[0] - mech.T_CURVE_C ** 2 * k2)
        out["k_hz_per_c"] = float(a[1] + 2 * mech.T_CURVE_C * k2)
    if ctx.series.ref is not None:
        # temp_c = offset + gain * (ref + b (ref - 25)^2): expand and read offset and gain off
        p = _physical_poly(ctx, "temp_c", state, {"t0": 0, "t1": 1, "rtd_nonlinearity": 2})
        gain = p[1] + 2 * mech.T_CURVE_C * p[2]
        out["rtd_offset_c"] = float(p[0] - mech.T_CURVE_C ** 2 * p[2])
        out["rtd_gain"] = float(gain)
    return out
