"""Mutation proof: every single-point RTL mutation is caught, the unmutated RTL is not; a mutant
that does not compile is an error of the harness, not a kill."""

import pytest

from hdl_util import require_iverilog
from mutation import MUTATIONS, PER_CLOCK_MUTATIONS, MutantBroken, Mutation, run, table


@pytest.mark.hdl
def test_every_mutation_is_caught():
    """The one-sample-per-clock RTL's mutants (test_mutation_serial.py runs the serial schedulers')."""
    require_iverilog()
    rows = run(PER_CLOCK_MUTATIONS)
    print("\n" + table(rows))
    assert not rows[0]["caught"], f"unmutated RTL fails: {rows[0]['evidence']}"
    survivors = [r["mutation"] for r in rows[1:] if not r["caught"]]
    assert not survivors, f"mutations not caught: {survivors}\n{table(rows)}"


@pytest.mark.hdl
def test_a_mutant_that_does_not_compile_is_an_error_not_a_kill():
    """A syntax error in a mutant must stop the harness: counted as "caught" it would prove nothing."""
    require_iverilog()
    broken = Mutation("missing_semicolon", "fx_round.v", "assign c = half;", "assign c = half",
                      "does not compile", ((None, "rtd", False),))
    with pytest.raises(MutantBroken, match="missing_semicolon: does not compile"):
        run([MUTATIONS[0], broken], baseline=False)


@pytest.mark.hdl
def test_a_mutant_whose_check_harness_does_not_compile_is_an_error():
    """The same for a mutant that compiles at the defaults (where no module rounds half_even, so the
    branch is not elaborated) but not in the check's harness, which elaborates it."""
    require_iverilog()
    from mutation import HALF_EVEN

    broken = Mutation("undeclared_in_half_even", "fx_round.v",
                      "assign c = half - one + {{(W-1){1'b0}}, xe[RSH]};",
                      "assign c = half - one + {{(W-1){1'b0}}, xq[RSH]};",
                      "does not compile where half_even is used", ((HALF_EVEN, "bias_subtract", False),))
    with pytest.raises(MutantBroken, match="harness does not compile"):
        run([broken], baseline=False)
