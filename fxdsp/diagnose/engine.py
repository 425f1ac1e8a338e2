"""Diagnosis: calibrate the baseline, then name the causes that held-out data support.

1. Search baseline: cubic B(Te) and S(Te) (context.py), so that a polynomial term the data need is
   never taken for a cause. Channels: output; freq_hz against the reference thermometer (mapped
   onto temp_c's linear scale) when both are logged, else against temp_c; temp_c against
   ref_temp_c.
2. Candidates (candidates.py): each cause is fitted on the training folds of a blocked
   cross-validation (5 folds of interleaved contiguous segments; a nonlinear parameter such as
   tau_s is picked on a grid by each fold's training data only) and scored on the held-out folds
   of the channels it affects. Evidence = drop of the held-out sum of squares in units of each
   channel's white-noise variance, summed over channels: a lag must also explain the resonator
   frequency when it is logged, a ramp-rate term or hysteresis must not touch it.
3. Selection (selection.py): the best candidate with a held-out rms ratio >= MIN_GAIN and an
   evidence >= MIN_EVIDENCE joins the model (earlier nonlinear parameters are re-fitted with it),
   and the rest are tried again on top, up to MAX_CAUSES. Then time-like causes (aging, warm-up,
   hysteresis) are re-tested on random-walk innovations if the final residual still wanders, and
   every cause must still pass when it is the last one added. Nothing left means `none`.
4. Calibration and numbers (results.py): the orders of B and S (0..3) are chosen by held-out
   error with the causes in place; parameters come from the full-data fit (nonlinear ones refined
   by Brent's method), uncertainties are delete-one-group jackknife standard deviations (20
   contiguous groups, so noise correlated over minutes to an hour is accounted for), and the gain
   is the held-out rms of the cause's channel without and with the causes.

Logs above MAX_SEARCH_ROWS rows are searched on every k-th row (derivatives, ramp states and
lags computed on the full log first); the final fit uses every row.
"""

from __future__ import annotations

import numpy as np

from fxdsp import mechanisms as mech
from fxdsp.diagnose import model as M
from fxdsp.diagnose.candidates import affected_channels, refit_nonlinear
from fxdsp.diagnose.context import ORDER_CHOICES, Context, Diagnosis, choose_orders, set_noise_weights, sf_estimate
from fxdsp.diagnose.results import baseline_coefficients, channel_gain, linear_parameters
from fxdsp.diagnose.selection import check_against_wander, greedy_search, prune

MAX_SEARCH_ROWS = 100_000


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
    refit_nonlinear(search, state, accepted)  # the causes that were removed may have biased them

    ctx.orders = choose_orders(search, state)
    linear, linear_sd = linear_parameters(ctx, state)
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
