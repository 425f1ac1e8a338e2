"""The demodulator's NCO has no phase bias at any drive frequency (the floor issue's requirement),
and the old phase-truncating table, injected, is caught by the same check."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import OLD_NCO, design_with
from fxdsp.fixed import Format

# requirement, not a reading of the code: a reference phase bias phi turns the quadrature (here 5 %
# of full scale, as in the chain's nominal stimulus) into a rate bias quad * phi; 0.05 deg/h at
# 200 deg/s full scale allows phi <= 0.05 / 720000 / 0.05 rad
MAX_PHASE_BIAS_RAD = 0.05 / (200.0 * 3600.0) / 0.05
N = 1 << 15


def _phase_bias(nco) -> float:
    """Mean of (phase of the NCO's (cos, -sin) words) - (exact phase of the same samples)."""
    cos, msin = nco.wave(nco.phases(N))
    got = np.arctan2(-msin.astype(float), cos.astype(float))
    return float(np.mean(np.angle(np.exp(1j * (got - nco.reference_phase(N))))))


def _frequencies():
    rng = np.random.default_rng(11)
    # the nominal exact ratio 1/12, other simple ratios, and random points in and beyond the drive band
    return [8000.0, 96000.0 / 16, 96000.0 / 10, 96000.0 / 7] + list(rng.uniform(7985.0, 8016.0, 12)) + \
        list(rng.uniform(100.0, 40000.0, 6))


@pytest.mark.parametrize("f_hz", _frequencies())
def test_nco_phase_unbiased_at_any_frequency(f_hz):
    nco = design_with(**{"demod.f_hz": f_hz}).blocks["demod"].nco
    assert abs(_phase_bias(nco)) < MAX_PHASE_BIAS_RAD


def test_old_truncating_nco_is_caught():
    nco = design_with(**OLD_NCO).blocks["demod"].nco
    assert abs(_phase_bias(nco)) > 10 * MAX_PHASE_BIAS_RAD


def test_nco_memory_below_the_old_tables():
    """Memory is the one quarter-wave table; the old design held cos and -sin over a full turn."""
    dp = design_with().blocks["demod"].datapath
    old_bits = 2 * 2 ** OLD_NCO["demod.lut_bits"] * Format.parse(OLD_NCO["demod.lut_format"]).wl  # cos and -sin
    assert dp.qsin.words.size * dp.qsin.width < old_bits


def test_nco_words_fit_their_format_at_every_phase():
    nco = design_with().blocks["demod"].nco
    step = 1 << (nco.phase_bits - nco.lut_bits - nco.interp_bits)  # every bin and sub-bin offset
    phases = np.arange(0, 1 << nco.phase_bits, step, dtype=np.int64)
    for words in nco.wave(phases):
        assert words.min() >= nco.nco_format.min_int and words.max() <= nco.nco_format.max_int
        # and the values are cos / -sin of the phase within a few table LSBs
    cos, msin = nco.wave(phases)
    exact = 2 * np.pi * (phases.astype(float) + step / 2) / 2.0**nco.phase_bits
    assert np.abs(cos * nco.nco_format.lsb - np.cos(exact)).max() < 4 * nco.lut_format.lsb
    assert np.abs(msin * nco.nco_format.lsb + np.sin(exact)).max() < 4 * nco.lut_format.lsb
