"""(a) The committed golden vectors, bit for bit, through every RTL block and every chain top, with
the model's overflow count matched by the RTL's overflow flags; the serial (resource-shared) variants
likewise. Every DUT through cocotb (Python-driven) on Icarus; the chain tops, the serial variants and
the blocks Icarus simulates slowly (WHOLE_ON_VERILATOR) on Verilator as well, whole, through the
file-driven harness (inputs by $readmemh, no Python in the per-cycle loop: paper 002's serial top
streams its 8.7k golden samples, 3 M cycles, in a few seconds where cocotb's clock callbacks took
18 s). Icarus, 4-state, still sees an x on a port in every DUT's first samples. A top holds every block of its chain, with the same
parameters, in the same variant, so a block's own Verilator run would repeat a C++ model build for
RTL that Verilator already compiles and runs in the top; cocotb on Verilator runs the serial
variants' corner streams (gaps and resets anywhere, test_hdl_corners)."""

from __future__ import annotations

import json

import pytest

from conftest import tiered
from fxdsp.hdl.chain_top import has_divider
from fxdsp.vectors import load
from hdl_util import SERIAL, SIMULATORS, VECTORS, design_of, distinct_duts, icarus_samples, icarus_window, \
    record_throughput, run_cocotb, segment, verilator_runs
from long_common import file_stream

# every instance of the design with an RTL module; the manifest lists them all (and the others)
# (an instance that is another's DUT under the same parameters, a copy such as iir02, once: distinct_duts)
NAMES = distinct_duts(design_of(), sorted(set(json.loads((VECTORS / "manifest.json").read_text())["blocks"])
                                          & set(design_of().hardware)))
_TOPS = {n for n, inst in design_of().instances.items() if inst.members}
# blocks whose whole golden set Icarus simulates slowly (a drive loop's 6.8k samples: 7-10 s of vvp; a
# demodulator's 5 s, the low-pass's 2-3 s) streamed whole on Verilator instead, file-driven, a window on
# Icarus. drive, demod and iir by the very model their long stream builds (test_hdl_long_blocks,
# test_hdl_long_chains: the same harness text); the other drive and demodulator instances (drive001,
# demod002, demod02) by a model of their own (~2 s of C++ each, where Icarus took 5-10 s): each
# instance's whole golden set, its corner codes and overflow counts, runs in make test once
WHOLE_ON_VERILATOR = {"iir"} | {n for n in NAMES if design_of().instances[n].module in ("drive", "demod")}


def cases(names, whole=frozenset()) -> list:
    """(name, simulator): every DUT on Icarus, the chain tops (and ``whole``) on every simulator."""
    return [pytest.param(n, s, id=f"{n}-{s}") for n in names for s in SIMULATORS
            if s == "icarus" or n in _TOPS or n in whole]
# the sequential divider one quotient bit per cycle is the hardware setting; the Python-driven runs
# of the dividers and the chains with one take 7 bits per cycle to stay fast (at 1 bit, 100k cycles
# of Icarus for each divider's golden set: 4-5 s); the file-driven runs on Verilator (here, and the
# long streams) run 1 bit per cycle
DIV7 = {"DIV_UNROLL": 7}
# samples of a chain top's golden window on Icarus (one sample per clock; the whole set on Verilator)
ICARUS_TOP_WINDOW = 500


def _extra(design, name: str) -> dict | None:
    if design.instances[name].members:
        return DIV7 if has_divider(design, name) else None
    return {"UNROLL": 7} if design.instances[name].module == "sf_divide" else None


@pytest.fixture(scope="module")
def design():
    return design_of()


@pytest.mark.hdl
@pytest.mark.parametrize("name, sim", cases(NAMES, WHOLE_ON_VERILATOR))
def test_golden_vectors(design, name, sim):
    ins, outs, entry = load(VECTORS, name)
    total = sum(entry["overflows"].values())
    if sim == "verilator":   # the whole set, file-driven, at the hardware divider setting
        cycles, seconds = file_stream(design, name, ins, outs, total, f"golden_{name}", sim)
        record_throughput("file", name, cycles, seconds, sim=sim)
        return
    if (name in _TOPS or name in WHOLE_ON_VERILATOR) and verilator_runs():
        # a chain top (and WHOLE_ON_VERILATOR) streams every golden sample on Verilator (above); on
        # Icarus (~30 s for paper 002's whole set) a window of them, the model run on it. Where
        # Verilator cannot run, its case is skipped and this one streams the whole set
        seg = segment(design, name, icarus_window(ins, ICARUS_TOP_WINDOW))
    else:
        # the committed vectors are the model's: the design built here must reproduce them
        seg = segment(design, name, ins, outs, total)
    summary = run_cocotb(design, name, [seg], f"golden_{name}", extra_params=_extra(design, name), sim=sim)
    record_throughput("cocotb", name, summary["cycles"], summary["seconds"], sim=sim)


@pytest.mark.hdl
# the serial variants whole on Verilator are the slow tier: test_hdl_long_blocks streams each of them
# on Verilator, back to back at its schedule's cycles (drive's as it stands inside paper 002's loop
# top); here a window of each on Icarus
@pytest.mark.parametrize("name, sim", tiered(cases(sorted(SERIAL)), lambda case: case[1] == "icarus"))
def test_golden_vectors_serial(design, name, sim):
    """The same vectors through the serial variant (valid/ready, many cycles per sample)."""
    ins, outs, entry = load(VECTORS, name)
    if sim == "verilator":   # the whole set, file-driven
        cycles, seconds = file_stream(design, name, ins, outs, sum(entry["overflows"].values()),
                                      f"golden_{name}_serial", sim, extra=SERIAL[name])
        record_throughput("file", f"{name} (serial)", cycles, seconds, sim=sim)
        return
    # on Icarus a window, the model run on it (hdl_util.ICARUS_SERIAL_SAMPLES)
    seg = segment(design, name, icarus_window(ins, icarus_samples(design, name)))
    summary = run_cocotb(design, name, [seg], f"golden_{name}_serial", extra_params={**(_extra(design, name) or {}),
                                                                                    **SERIAL[name]}, sim=sim)
    record_throughput("cocotb", f"{name} (serial)", summary["cycles"], summary["seconds"], sim=sim)
