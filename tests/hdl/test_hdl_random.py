"""(b) Randomised stimuli computed on the fly by the fxdsp model, on three parameter sets that
change word lengths, rounding modes, overflow modes and filter orders; gapped valid.
On Icarus only: 42 DUT builds of ~3-5 s of C++ each would exceed the test-time budget on Verilator,
whose models the golden and corner tests already cover."""

from __future__ import annotations

import zlib

import pytest

from conftest import tiered
from hdl_util import COPIES, SERIAL, covering_tops, design_of, dut_key, icarus_samples, icarus_window, merged, run_cocotb, \
    segment, with_copies

from fxdsp.hdl.stimuli import random_stimulus  # fxdsp rtl and the sweep's RTL shards draw the same way
from fxdsp.sweep.rtl import unroll_params

# every block instance of the design with RTL; a chain top's text (its wires, their widths, its
# scheduler) is the same in both variants, so its random parameter sets run on the serial one, where
# the schedule also moves with them (its members' one-per-clock variants are each in this list)
# A copy whose config section is its original's word for word (iir02, bias_subtract02) is the same
# module under the same parameters in every set (with_copies): its draws would test nothing new.
_DEFAULT = merged(None)
BLOCKS = sorted(n for n, inst in design_of().hardware.items()
                if not inst.members and not (n in COPIES and _DEFAULT.get(n) == _DEFAULT.get(COPIES[n])))

PARAM_SETS = {
    # every rounding floor, every overflow wrap, default word lengths
    "floor_wrap": {
        sec: {"rounding": "floor", "overflow": "wrap"}
        for sec in ("rtd", "sf_divide", "demod", "bias_subtract", "iir", "freq2temp", "bias_subtract001", "lag")
    } | {"piecewise": {k: {"rounding": "floor", "overflow": "wrap"}
                       for k in ("sf", "bias", "bias001", "k0", "k1")},
         "demod": {"rounding": "floor", "overflow": "wrap", "lpf": {"rounding": "floor", "overflow": "wrap"}}},
    # half_even, narrower words everywhere, 4th-order filters (two biquads), smaller NCO/CORDIC
    "half_even_narrow": {
        "rtd": {"temp_format": "s16.7", "lut_index_bits": 4, "lut_format": "s24.14", "rounding": "half_even"},
        "piecewise": {"sf": {"acc_format": "s30.26", "rounding": "half_even"},
                      "bias": {"out_format": "s20.18", "rounding": "half_even", "overflow": "wrap"},
                      "bias001": {"out_format": "s20.4", "rounding": "half_even"},
                      "k0": {"rounding": "half_even"}, "k1": {"rounding": "half_even"}},
        "sf_divide": {"out_format": "s20.18", "guard_bits": 6, "rounding": "half_even"},
        "demod": {"data_format": "s20.18", "lut_bits": 8, "lut_format": "s12.11", "phase_bits": 24,
                  "cordic_iterations": 12, "angle_format": "s16.13", "rounding": "half_even",
                  "lpf": {"data_format": "s20.18", "num_format": "s22.28", "den_format": "s26.24",
                          "order": 4, "rounding": "half_even"}},
        "bias_subtract": {"out_format": "s20.18", "rounding": "half_even"},
        "iir": {"data_format": "s20.18", "num_format": "s22.30", "den_format": "s26.24", "order": 4,
                "rounding": "half_even"},
        "freq2temp": {"temp_format": "s16.7", "rounding": "half_even"},
        "bias_subtract001": {"in_format": "s20.4", "out_format": "s20.4", "rounding": "half_even"},
        # lag on the s16.7 code: a short time constant, a 12-bit alpha, 8 guard bits
        "lag": {"temp_format": "s16.7", "tau_s": 2.0, "alpha_bits": 12, "state_guard_bits": 8, "rounding": "half_even"},
    },
    # toward_zero, wider words, output fraction dropped in the subtractions (rounding ties there)
    "toward_zero_wide": {
        "rtd": {"adc_format": "s18.17", "temp_format": "s20.11", "lut_index_bits": 6, "rounding": "toward_zero"},
        "piecewise": {"sf": {"rounding": "toward_zero"},
                      "bias": {"out_format": "s26.24", "rounding": "toward_zero"},
                      "bias001": {"rounding": "toward_zero", "out_format": "s26.8"},
                      "k0": {"rounding": "toward_zero", "overflow": "wrap"}, "k1": {"rounding": "toward_zero"}},
        "sf_divide": {"in_format": "s18.17", "guard_bits": 12, "out_format": "s26.24", "rounding": "toward_zero"},
        "demod": {"data_format": "s26.24", "rounding": "toward_zero", "phase_offset_turns": 0.3,
                  "lpf": {"data_format": "s26.24", "num_format": "s26.32", "den_format": "s30.28",
                          "rounding": "toward_zero", "design": "bessel"}},
        "bias_subtract": {"out_format": "s24.22", "rounding": "toward_zero"},
        "iir": {"data_format": "s24.22", "num_format": "s26.34", "rounding": "toward_zero", "design": "cheby1"},
        "freq2temp": {"temp_format": "s20.11", "rounding": "toward_zero", "overflow": "wrap"},
        "bias_subtract001": {"in_format": "s24.9", "out_format": "s24.6", "rounding": "toward_zero"},
        # lag on the s20.11 code: an hour's time constant (alpha 2.8e-5), 20-bit alpha, 20 guard bits
        "lag": {"temp_format": "s20.11", "tau_s": 3600.0, "alpha_bits": 20, "state_guard_bits": 20, "rounding": "toward_zero",
                "overflow": "wrap"},
    },
}
PARAM_SETS = {k: with_copies(v) for k, v in PARAM_SETS.items()}
_designs: dict = {}


def design(pset):
    if pset not in _designs:
        _designs[pset] = design_of(PARAM_SETS[pset])
    return _designs[pset]


def distinct_sets(names, extra=lambda d, n: None) -> list[tuple[str, str]]:
    """(set, name) for each name under each set that gives it a DUT (hdl_util.dut_key) no earlier set
    gave it: a set that leaves an instance as another left it (drive and drive001: no set touches the
    loop's sections) would only stream other draws through the same DUT, which is not what a
    parameter set is for. Chain tops run under every set."""
    out, seen = [], set()
    for pset in sorted(PARAM_SETS):
        d = design(pset)
        for name in names:
            key = dut_key(d, name, extra(d, name))
            if key is None or (name, key) not in seen:
                seen.add((name, key))
                out.append((pset, name))
    return sorted(out, key=lambda pn: (pn[1], pn[0]))


def one_set_each(cases: list[tuple[str, str]]) -> list:
    """make test runs each name under one of its sets, the sets taken in turn down the sorted names,
    so every set's rules reach the RTL; the name's other sets are the slow tier (conftest.tiered):
    its rounding and overflow rules are each one shared fx_round / fx_sat (test_hdl_lint holds every
    rounding to it), and each block's wrap and half_even are also the corner streams'."""
    sets: dict[str, list[str]] = {}
    for pset, name in cases:
        sets.setdefault(name, []).append(pset)
    chosen = {name: s[i % len(s)] for i, (name, s) in enumerate(sorted(sets.items()))}
    missing = {pset for pset, _ in cases} - set(chosen.values())
    if missing:   # the turn fell so that a set reaches no DUT: a name's set must be moved
        raise ValueError(f"one_set_each: the sets {sorted(missing)} run on no name in make test")
    return tiered(cases, lambda case: chosen[case[1]] == case[0])


@pytest.mark.hdl
@pytest.mark.parametrize("pset, name", one_set_each(distinct_sets(BLOCKS, unroll_params)))
def test_random_parameter_set(pset, name):
    d = design(pset)
    stim = random_stimulus(d, name, seed=zlib.crc32(f"{pset}:{name}".encode()))
    run_cocotb(d, name, [segment(d, name, stim)], f"random_{pset}_{name}", gap=0.25, seed=7,
               extra_params=unroll_params(d, name))


# the serial variants: every serial block module's, and the chain tops that hold every module between
# them (hdl_util.covering_tops: a top's wiring at each set's widths; each top's own schedule is its
# golden vectors', long stream's and serial corners')
_D = design_of()
SERIAL_NAMES = sorted(n for n in SERIAL if not _D.instances[n].members or n in covering_tops(_D))


@pytest.mark.hdl
@pytest.mark.parametrize("pset, name", one_set_each(distinct_sets(SERIAL_NAMES, lambda d, n: {
    **(unroll_params(d, n) or {}), **SERIAL[n]})))
def test_random_parameter_set_serial(pset, name):
    """The serial variants on the same draws (half_even_narrow: two sections in the schedule)."""
    d = design(pset)
    stim = random_stimulus(d, name, seed=zlib.crc32(f"{pset}:{name}".encode()))
    stim = icarus_window(stim, icarus_samples(d, name))  # on Icarus (hdl_util.ICARUS_SERIAL_SAMPLES); the model runs on it
    run_cocotb(d, name, [segment(d, name, stim)], f"random_{pset}_{name}_serial", gap=0.25, seed=7,
               extra_params={**(unroll_params(d, name) or {}), **SERIAL[name]})
