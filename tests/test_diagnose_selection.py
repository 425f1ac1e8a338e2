"""Pieces of the diagnosis's selection checked on their own: the held-out errors of many targets on
one design (the noise nulls' draws), and the order of the final checks."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from fxdsp.diagnose import selection as S
from fxdsp.diagnose.blockfit import Blocks, SegmentNormals


@pytest.mark.parametrize("n,weight", [(1000, 2.0), (333, 0.5)])
def test_fold_errors_of_many_targets_are_each_targets_own(n, weight):
    """One design, many targets (the draws of a null): each target's column equals SegmentNormals(...)
    .folds() of that target alone, a dead (all-zero) column included."""
    rng = np.random.default_rng(n)
    x = np.column_stack([np.ones(n), np.linspace(-1, 1, n), rng.normal(size=n), np.zeros(n),
                         np.cumsum(rng.normal(size=n))])
    y = rng.normal(size=(7, n)) + np.cumsum(rng.normal(size=(7, n)), axis=1) * 0.1
    blocks = Blocks.contiguous(n)
    train, held = SegmentNormals(x, y.T, blocks, weight).folds()
    assert train.shape == held.shape == (blocks.n_folds, 7)
    for k in range(7):
        t, h = SegmentNormals(x, y[k], blocks, weight).folds()
        np.testing.assert_allclose(train[:, k], t, rtol=1e-9)
        np.testing.assert_allclose(held[:, k], h, rtol=1e-9)


def test_the_noise_check_runs_again_after_prune_removes_a_cause(monkeypatch):
    """A cause that passed the noise re-test only beside another is judged again alone once prune has
    removed the other: here the noise re-test drops 'lag' only when 'warmup' is gone, and prune
    drops 'warmup'; a single pass of each would keep the lag."""
    def noise(ctx, state, accepted):
        keep = [c for c in accepted if not (c.cause == "lag" and "warmup" not in state)]
        return {c.cause: {} for c in keep}, keep

    def prune(ctx, state, accepted):
        keep = [c for c in accepted if c.cause != "warmup"]
        return {c.cause: {} for c in keep}, keep

    monkeypatch.setattr(S, "check_against_noise", noise)
    monkeypatch.setattr(S, "prune", prune)
    accepted = [SimpleNamespace(cause="warmup"), SimpleNamespace(cause="lag"), SimpleNamespace(cause="hyst")]
    state, kept = S.check_final(None, {c.cause: {} for c in accepted}, accepted)
    assert set(state) == {"hyst"} and [c.cause for c in kept] == ["hyst"]
