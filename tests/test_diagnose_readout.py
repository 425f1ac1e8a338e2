"""A quantised readout (a thermometer logged to a fixed step) is not a curvature: its error is drawn
(the step is the ramp reader's, tested in test_ramps), and a cause seen only on that channel must
beat it."""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.diagnose.noise import readout_draws

def test_a_readout_error_is_within_half_a_step_and_one_constant_through_a_dwell():
    """Each draw's error is the distance of the read value to the grid: at most half a step; through a
    dwell (one value read again and again) it is one constant; over a slow ramp it is uniform,
    variance step^2/12."""
    step = 0.1
    fitted = np.concatenate([np.full(200, 21.37), np.linspace(21.37, 80.0, 4000), np.full(200, 80.0)])
    e = readout_draws(np.random.default_rng(1), fitted, step, 300)
    assert e.shape == (300, fitted.size)
    assert np.all(np.abs(e) <= step / 2 + 1e-12)
    assert np.all(np.ptp(e[:, :200], axis=1) < 1e-12)
    assert np.var(e[:, 200:4200]) == pytest.approx(step * step / 12.0, rel=0.05)
    assert abs(np.mean(e[:, 0])) < 0.1 * step            # the grid's offset is drawn, not fixed


def test_a_readout_step_through_three_dwells_is_not_named_a_curvature():
    """An independent-generator `none` log of 500 rows (a seed of a 200-seed sweep beyond the
    matrices): temp_c logged to 0.1 C through three dwells, 127, 142 and 83 rows. The white-noise
    test named an RTD curvature of 4.4e-5 /C (4.8 jackknife sigmas) for the three dwells' reading
    errors; the readout's own error gives as much."""
    from independent.confusion import score

    o = score((), 5179, rows=500)
    assert o.found == [], f"{o.brief}: found {o.found}"
