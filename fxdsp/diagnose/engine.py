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
   and the rest are tried again on top, up to MAX_CAUSES; the same forward selection also starts
   from the best pair of causes (two causes can hide each other) and the better model is kept, and
   when no single cause passes on top of the ones in, the best pair on top of them may join (on
   top of at most PAIR_ON_TOP_OF causes).
   Then time-like causes (aging, warm-up, hysteresis, quadrature) are re-tested against a random-
   walk bias if the residual without them wanders (the places that frees are filled again by the
   forward selection, from the causes it did not remove); every cause on the output against draws of the
   residual's own noise (white, a flicker band, random walk no smaller than a short log's variogram can
   miss: noise.py), which must not give the best of the causes the log could show as much (a short
   log cannot show a slight wander in its variogram, and flicker makes lags and ramp-rate terms
   too), a time constant searched on every draw; and every cause must still pass when it is the
   last one added, a time-like one with a held-out rms ratio >= WANDER_GAIN (a line fitted to an
   unseen bias random walk reaches 1.05 easily). The last two run until neither removes a cause.
   A cause whose parameters the log does not determine (identify.py) is set aside, not named, and
   reported as unidentified. Nothing left means `none`; `causes` are ordered by held-out gain.
4. Calibration and numbers (results.py): the orders of B and S (0..3) are chosen by held-out
   error with the causes in place; parameters come from the full-data fit by generalised least
   squares (whitening.py: rows whitened by the innovations of the residual's own noise, white,
   a flicker band and a random walk; nonlinear ones refined on those rows by Brent's method; a channel with
   a cause whose column is not known row by row keeps ordinary least squares); each uncertainty (at
   least the ordinary fit's) is the larger of a delete-one-group jackknife standard deviation (20
   contiguous groups: noise correlated over minutes to an hour; the interleaved folds for a transient
   or a column one group holds most of, results.CONCENTRATED) and the spread over refits to draws
   of the residual's own noise (uncertainty.py: a walk or a flicker that tilts the whole log), and
   the gain is the held-out rms of the cause's channel without and with the causes.

5. What remains (remaining.py): the final model's residual in every channel, tested against shapes
   no named cause has (a step, a periodic term, a curved drift, temperature, dT/dt, rate and
   quadrature terms) at the 1 % level of the log's own noise (white plus a random walk). A named
   cause whose claimed signature (its record's ``signature``) still shows there is re-tested with
   that structure in the model: one that then fails only absorbed part of it and is not named.

Logs above MAX_SEARCH_ROWS rows are searched on every k-th row (derivatives, ramp states and
lags computed on the full log first); the final fit uses every row.
"""

from __future__ import annotations

import numpy as np

from fxdsp.causes import PARAMETERS
from fxdsp.diagnose import model as M
from fxdsp.diagnose.candidates import affected_channels, final_jackknife_sd, refit_nonlinear, tried
from fxdsp.diagnose.context import MAX_CAUSES, MIN_EVIDENCE, MIN_GAIN, ORDER_CHOICES, Context, Diagnosis, choose_orders, set_noise_weights, sf_estimate
from fxdsp.diagnose.identify import described, judge, reasons
from fxdsp.diagnose.remaining import absorbing_only, remaining
from fxdsp.diagnose.results import baseline_coefficients, channel_gain, linear_parameters
from fxdsp.diagnose.selection import check_against_wander, check_final, forward, greedy_search, order_by_gain
from fxdsp.diagnose.uncertainty import noise_sds
from fxdsp.diagnose.whitening import prewhitened

MAX_SEARCH_ROWS = 100_000


def diagnose_series(series: M.Series, n_segments: int = 200, n_folds: int = 5) -> Diagnosis:
    ctx = Context(series, n_segments, n_folds)
    # the search runs on the most flexible baseline, so that a polynomial term the data need is
    # never mistaken for a cause; the orders are then re-chosen with the causes in place
    ctx.orders = (max(ORDER_CHOICES), max(ORDER_CHOICES) if ctx.has_rate else None)
    set_noise_weights(ctx)
    series.sf_estimate = sf_estimate(ctx)
    step = -(-series.n // MAX_SEARCH_ROWS)
    if step > 1:
        # a million rows carry no more shape information than a hundred thousand: search on every
        # k-th row (lags and derivatives were computed on the full log), then fit the found
        # model on all rows
        search = Context(series.decimated(step), n_segments, n_folds)
        search.orders = ctx.orders
        set_noise_weights(search)
    else:
        search = ctx
    state, accepted, first_round = greedy_search(search)
    set_noise_weights(search, state)
    state, accepted, wandering = check_against_wander(search, state, accepted)
    state, accepted, wandering = _refill(search, state, accepted, wandering)
    state, accepted = check_final(search, state, accepted)
    refit_nonlinear(search, state, accepted)  # the causes that were removed may have biased them
    if "sf_nonlinearity" in state:
        _converge_scale_factor(ctx, search, state, step)

    unidentified: dict = {}
    notes: list[str] = [f"{cause} passed the first tests (held-out rms ratio on the output {ratio:.3g}) but is not "
                        "named: the residual without it wanders, and a random walk of the bias at that level gives "
                        "as much, for the wander it leaves"
                        for cause, ratio in wandering.items()]
    while True:
        diag = _conclude(ctx, search, state, accepted, first_round, unidentified, notes)
        diag.wandering = list(wandering)
        # a cause is named only when it removes the signature it claims: one that passes its test
        # only by absorbing part of a structure the list does not explain (a linear drift taking
        # part of a step) is not named
        absorbing = absorbing_only(ctx, diag.state, [c for c in accepted if c.cause in diag.causes],
                                   diag.structures)
        if not absorbing:
            return diag
        for cause, what in absorbing.items():
            notes.append(f"{cause} lowered the held-out error but is not named: it only absorbs part of {what}, "
                         "and once that is modelled it no longer passes")
        accepted = [c for c in accepted if c.cause in diag.causes and c.cause not in absorbing]
        state = {k: v for k, v in diag.state.items() if k not in absorbing}
        refit_nonlinear(search, state, accepted)


def _refill(ctx: Context, state: dict, accepted: list, wandering: dict):
    """Forward selection again into the places the wander re-test freed, from the causes it did not
    remove, and that re-test again, until nothing changes. A drift that took part of a slowly
    varying quadrature leak filled the last of MAX_CAUSES places before the leak could join; once
    the drift went, the leak's structure, unexplained, made the noise re-test's null so wide that
    it removed a lag and a hysteresis of known-noise z 90 to 130 (issue 32 notes)."""
    while wandering and len(accepted) < MAX_CAUSES:
        causes = [c for c in tried(ctx) if c not in wandering and c not in state]
        before = set(state)
        state, accepted, _ = forward(ctx, causes, state, accepted)
        if set(state) == before:
            break
        set_noise_weights(ctx, state)
        state, accepted, removed = check_against_wander(ctx, state, accepted)
        wandering = {**wandering, **removed}
    return state, accepted, wandering


def _conclude(ctx: Context, search: Context, state: dict, accepted: list, first_round: list, unidentified: dict,
              notes: list) -> Diagnosis:
    """The final model of ``accepted``: orders, parameters (setting aside what the log does not
    determine), causes in order of gain, the gain, and what remains."""
    while True:
        ctx.orders = choose_orders(search, state)
        parameters, uncertainty = _final_parameters(ctx, state, accepted)
        with prewhitened(ctx, state) as filters:
            if filters:
                # the numbers by generalised least squares (fxdsp.diagnose.whitening): the searched
                # values found again on the whitened rows, then every parameter and its sds; the
                # ordinary fit's sd bounds each (the whitening's noise model is estimated from the
                # same log, and the noise draws of the sds take a flicker from one row on)
                refit_nonlinear(ctx, state, accepted)
                parameters, whitened_sds = _final_parameters(ctx, state, accepted)
                uncertainty = {c: {k: max(v, uncertainty[c].get(k, 0.0)) for k, v in u.items()}
                               for c, u in whitened_sds.items()}
            baseline = baseline_coefficients(ctx, state)
        verdicts = _verdicts(ctx, accepted, parameters, uncertainty)
        doubtful = [c for c in accepted if not all(v.identified for v in verdicts[c.cause].values())]
        if not doubtful:
            break
        # a cause whose numbers the log cannot determine is not named: set it aside, say why,
        # and fit the rest again without it
        for cand in doubtful:
            _set_aside(unidentified, notes, cand.cause,
                       {k: described(parameters[cand.cause][k], uncertainty[cand.cause].get(k), verdicts[cand.cause][k])
                        for k in PARAMETERS[cand.cause]})
        accepted = [c for c in accepted if c not in doubtful]
        state = {k: v for k, v in state.items() if k in {c.cause for c in accepted}}
        refit_nonlinear(search, state, accepted)
    named = {c.cause for c in accepted}
    for cand in first_round:
        # a candidate that passed the evidence rule on its numbers alone but was never accepted
        # because its parameter is not determined: say so rather than stay silent (unless it was
        # named after all, its parameter determined once the other causes were in the model)
        if (not cand.identified and cand.cause not in (set(unidentified) | named) and cand.ratio >= MIN_GAIN
                and cand.evidence >= MIN_EVIDENCE):
            _set_aside(unidentified, notes, cand.cause,
                       {k: described(cand.nonlinear[k], cand.nonlinear_sd.get(k), v) for k, v in cand.verdicts.items()})
    accepted = order_by_gain(search, state, accepted)  # `causes` in order of held-out gain
    parameters = {c.cause: parameters[c.cause] for c in accepted}
    if accepted:
        primary = accepted[0]
        channel_state = {c: state[c] for c in state if primary.channel in affected_channels(ctx, c)}
        gain = channel_gain(ctx, channel_state, primary.channel)
    else:
        gain = channel_gain(ctx, {}, "output")
    diag = Diagnosis(causes=[c.cause for c in accepted], parameters=parameters, uncertainty=uncertainty,
                     gain=gain, candidates=first_round, orders=ctx.orders,
                     baseline=baseline, context=ctx, state=state,
                     unidentified=unidentified, notes=notes)
    # what the named causes leave (the contract's section 5), on the full log
    diag.remaining, diag.structures = remaining(ctx, state, gain, diag.causes)
    return diag


def _set_aside(unidentified: dict, notes: list, cause: str, params: dict) -> None:
    """Record a cause that is not named because the log does not determine its parameters."""
    unidentified[cause] = params
    notes.append(f"{cause} lowered the held-out error but is not named: {reasons(params)}")


def _converge_scale_factor(ctx: Context, search: Context, state: dict, step: int) -> None:
    """S k3 rate^3 is bilinear: the rate^3 column is built on an estimate of S, and the baseline's
    estimate has absorbed part of k3 rate^3 (rate^3 correlates with rate), which biases k3 by
    1/(1 + k3 E[rate^4]/E[rate^2]). Re-estimate S with the cubic term in the model until it
    settles (alternating least squares)."""
    for _ in range(20):
        new = sf_estimate(ctx, state)
        settled = np.allclose(new, ctx.series.sf_estimate, rtol=1e-9, atol=0.0)
        ctx.series.sf_estimate = new
        if search is not ctx:
            search.series.sf_estimate = np.ascontiguousarray(new[::step])
        if settled:
            return


def _final_parameters(ctx: Context, state: dict, accepted: list):
    """Parameters (contract units) and sds of the named causes: each sd the larger of the
    jackknife's in this final model and the one the log's own noise gives (fxdsp.diagnose.uncertainty)."""
    linear, linear_sd = linear_parameters(ctx, state)
    from_noise = noise_sds(ctx, state)
    parameters, uncertainty = {}, {}
    for cand in accepted:
        p = {**linear.get(cand.cause, {}), **cand.nonlinear}
        u = {**linear_sd.get(cand.cause, {}),
             **{k: final_jackknife_sd(ctx, state, cand.cause) for k in cand.nonlinear}}
        u = {k: max(v, from_noise.get(cand.cause, {}).get(k, 0.0)) for k, v in u.items()}
        names = PARAMETERS[cand.cause]
        parameters[cand.cause] = {k: float(p[k]) for k in names}
        uncertainty[cand.cause] = {k: float(u[k]) for k in names if np.isfinite(u.get(k, np.nan))}
    return parameters, uncertainty


def _verdicts(ctx: Context, accepted: list, parameters: dict, uncertainty: dict) -> dict:
    """Per named cause, per parameter: whether the log determines it (fxdsp.diagnose.identify)."""
    return {cand.cause: {k: judge(k, parameters[cand.cause][k], uncertainty[cand.cause].get(k), ctx.series.duration,
                                  cand.at_bound and k in cand.nonlinear)
                         for k in PARAMETERS[cand.cause]}
            for cand in accepted}
