"""Mutation proof: every single-point RTL mutation is caught, the unmutated RTL is not."""

import pytest

from hdl_util import require_iverilog
from mutation import run, table


@pytest.mark.hdl
def test_every_mutation_is_caught():
    require_iverilog()
    rows = run()
    print("\n" + table(rows))
    assert not rows[0]["caught"], f"unmutated RTL fails: {rows[0]['evidence']}"
    survivors = [r["mutation"] for r in rows[1:] if not r["caught"]]
    assert not survivors, f"mutations not caught: {survivors}\n{table(rows)}"
