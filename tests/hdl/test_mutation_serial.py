"""Mutation proof, second half: every mutant of the serial variants' schedulers and shared
multipliers (wrong slot, stale operand, missed stall, ...) is caught. A file of its own so that
pytest-xdist (--dist loadfile) runs it beside test_mutation.py; same harness, same rules."""

import pytest

from hdl_util import require_iverilog
from mutation import MUTATIONS, PER_CLOCK_MUTATIONS, SERIAL_MUTATIONS, run, table


def test_the_two_halves_are_every_mutant_once():
    assert sorted(m.key for m in SERIAL_MUTATIONS + PER_CLOCK_MUTATIONS) == sorted(m.key for m in MUTATIONS)
    assert SERIAL_MUTATIONS and PER_CLOCK_MUTATIONS


@pytest.mark.hdl
def test_every_serial_mutation_is_caught():
    require_iverilog()
    rows = run(SERIAL_MUTATIONS, baseline=False, tag="mut_serial")
    print("\n" + table(rows))
    survivors = [r["mutation"] for r in rows if not r["caught"]]
    assert not survivors, f"mutations not caught: {survivors}\n{table(rows)}"
