"""Formal proofs of the serial interface (fxdsp.hdl.formal: yosys-smtbmc + yices for the inductions,
abc bmc3 for the bounded proofs): every block but the demodulator is proven here, by induction at
the shortest length that closes and bounded from reset to that length (together: every cycle; reset
and gaps free at every cycle); each property fails on an RTL bug injected into a copy of the
sources, named by its label, with a counterexample trace. Every block's miter (serial = one-sample-
per-clock, at the narrow widths of configs/formal_narrow.toml) passes and fails on a bug in one
variant; the miters' multiplier keeps fx_mac_serial's timing. The demodulator's proof (induction
77 s, bounded 69 s) runs in `make formal`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fxdsp.cli import main
from fxdsp.hdl import formal
from conftest import tiered
from hdl_util import design_of, distinct_duts, mutated_rtl, mutated_top, one_per_module

pytestmark = pytest.mark.skipif(formal.tools_missing() is not None, reason=str(formal.tools_missing()))


@pytest.fixture(scope="module")
def design():
    return design_of()


# the modules whose proof takes minutes: `make formal` (demod: induction 77 s, bounded 69 s, at 208
# cycles; drive: its 409-cycle schedule with the demodulator inside)
LONG = {"demod", "drive"}


def _blocks():
    d = design_of()
    return distinct_duts(d, [n for n in formal.serial_duts(d) if not d.instances[n].members
                             and d.instances[n].module not in LONG])


# one instance of each module in make test (hdl_util.one_per_module: piecewise_k0 for the cubic); the
# other instances' proofs, at their own parameters and schedules, are the slow tier
@pytest.mark.parametrize("name", tiered(_blocks(), lambda name: name in one_per_module(design_of())))
def test_the_serial_contract_is_proven_for_every_cycle(design, name, tmp_path):
    """Every serial block of the default config but those in LONG: k-induction at the shortest
    length that closes and the bounded proof from reset of that length (its base case)."""
    bmc, ind = formal.prove_every_cycle(design, name, tmp_path)
    assert bmc.passed and ind.passed, (bmc.detail, ind.detail)
    assert bmc.depth == ind.depth >= formal.cycles_per_sample(design, name, arch=1) + 2


# (name, what the bug is, the DUT, the RTL file, (old, new), the assertion that must fail, BMC depth)
MUTANTS = [
    ("sample_taken_in_flight", "freq2temp: in_ready high while a sample is computed (the one in flight is lost)",
     "freq2temp", "freq2temp.v", ("assign in_ready = ~busy | out_valid;", "assign in_ready = 1'b1;"),
     "in_ready_when_idle_or_leaving", None),
    ("never_ready_again", "freq2temp: busy never clears (the next sample is never taken)",
     "freq2temp", "freq2temp.v", ("if (out_valid) busy <= 1'b0;", "if (out_valid) busy <= 1'b1;"),
     "in_ready_when_idle_or_leaving", None),
    ("request_while_idle", "rtd: the multiplier requested while idle (another block's product disturbed)",
     "rtd", "rtd.v", (".in_valid(st == S_MAC)", ".in_valid((st == S_MAC) | (st == S_IDLE))"),
     "mac_request_only_in_a_sample", None),
    ("product_left_behind", "rtd: one more product requested as the sample leaves (the multiplier still busy "
     "with it when the next block's request comes)",
     "rtd", "rtd.v", (".in_valid(st == S_MAC)", ".in_valid((st == S_MAC) | out_valid)"),
     "products_all_back_when_idle", None),
    ("product_counted_before_taken", "iir: a product counted as issued while the multiplier is still busy "
     "(its bookkeeping no longer the multiplier's)",
     "iir", "iir.v", ("wire issue = mac_req && mac_ready;", "wire issue = mac_req;"),
     "the_block_accounts_for_every_product", 40),
]


@pytest.mark.parametrize("key, what, name, file, edit, label, depth", MUTANTS, ids=[m[0] for m in MUTANTS])
def test_each_property_fails_on_an_injected_bug(design, tmp_path, key, what, name, file, edit, label, depth):
    rtl = mutated_rtl(tmp_path / "rtl", file, [edit])
    p = formal.prove(design, name, tmp_path / "proof", depth=depth, rtl=rtl)
    assert not p.passed and label in p.detail, (what, p.detail)
    assert p.trace is not None and p.trace.stat().st_size > 0


@pytest.mark.parametrize("name", ["chain_paper001", "chain_paper000", "chain_paper002"])
def test_every_top_is_proven_with_its_members_cut(design, name, tmp_path):
    """Bounded and by induction, the members replaced by their contracts; the cover inside shows the
    assumptions still let a sample through (a vacuous proof fails)."""
    for induction in (False, True):
        p = formal.prove(design, name, tmp_path / str(induction), induction=induction, cut=True)
        assert p.passed, (p.mode, p.detail)


@pytest.mark.parametrize("cut", [True, False], ids=["members_cut", "members_in_place"])
def test_a_double_multiplier_request_in_a_top_fails_its_proof(design, tmp_path, cut):
    """chain_paper000's K0 and K1 engines share the multiplier; without the arbitration both start at
    once and the top's own assertion (at most one request per cycle) fails, with the members cut to
    their contracts as with the real ones (which request as soon as they start)."""
    with mutated_top("chain_paper000", [("(~mac_busy & ~ask_piecewise_k0)", "(1'b1)")]):
        p = formal.prove(design, "chain_paper000", tmp_path, depth=12, cut=cut)
    # the request itself, or (members cut, free to wait) the two engines working at once that lets it
    assert not p.passed and ("one_request" in p.detail or "one_member_on_the_multiplier" in p.detail), p.detail


def test_a_top_that_loses_a_sample_fails_its_proof(design, tmp_path):
    """chain_paper001 taking a new sample while one is in flight (in_ready held high): the first lost."""
    with mutated_top("chain_paper001", [("assign in_ready = ~busy;", "assign in_ready = 1'b1;")]):
        p = formal.prove(design, "chain_paper001", tmp_path, cut=True)
    assert not p.passed and "in_ready_when_idle_or_leaving" in p.detail, p.detail


def test_contracts_that_admit_no_sample_are_reported_vacuous(design, tmp_path):
    """A top whose members' contracts would let no sample through proves nothing: the proof fails."""
    with mutated_top("chain_paper001", [("assume(!freq2temp_out_valid || fv_pend_freq2temp);",
                                         "assume(!freq2temp_out_valid);")]):
        p = formal.prove(design, "chain_paper001", tmp_path, cut=True)
    assert not p.passed and "vacuous" in p.detail, p.detail


def test_the_stated_latency_is_exact(design, tmp_path, monkeypatch):
    """A schedule stated one cycle long or short fails: the latency is proven equal, not bounded."""
    real = formal.cycles_per_sample
    for off in (-1, 1):
        monkeypatch.setattr(formal, "cycles_per_sample", lambda *a, off=off, **k: real(*a, **k) + off)
        p = formal.prove(design, "freq2temp", tmp_path / str(off))
        assert not p.passed and "out_valid_for_the_sample_at_its_cycle" in p.detail, (off, p.detail)


@pytest.fixture(scope="module")
def narrow():
    from fxdsp.chains import build

    return build(formal.MITER_CONFIG)


# (the DUT, a bug in its serial variant only: (old, new) in its RTL file, the assertion that must fail)
MITER_MUTANTS = {"lag": ("lag.v", (".ROUNDING(ROUNDING), .SHIFT(ALPHA_S), .OUT_W(RW)) u_step_s",
                                   ".ROUNDING(0), .SHIFT(ALPHA_S), .OUT_W(RW)) u_step_s"), "same_te"),
                 "sf_divide": ("sf_divide.v", ("neg_r <= neg;", "neg_r <= 1'b0;"), "same_y")}


def test_every_miter_passes(narrow, tmp_path):
    """Each block's miter (two samples from reset, every input free: equal word for word and flag for
    flag, a second answer compared, else vacuous) at the narrow widths of formal_narrow.toml."""
    names = formal.miter_duts(narrow)
    assert {narrow.instances[n].module for n in names} == set(formal.MITER_BLOCKS)
    for name in names:
        p = formal.prove(narrow, name, tmp_path / name, equivalence=True)
        assert p.passed, (name, p.mode, p.detail)


@pytest.mark.parametrize("name", sorted(MITER_MUTANTS))
def test_a_bug_in_one_variant_fails_its_miter(narrow, tmp_path, name):
    """The same generated miter fails on a rounding bug in either block's serial variant alone, with
    a trace."""
    file, edit, label = MITER_MUTANTS[name]
    rtl = mutated_rtl(tmp_path / "rtl", file, [edit])
    p = formal.prove(narrow, name, tmp_path / "bug", equivalence=True, rtl=rtl)
    assert not p.passed and label in p.detail, p.detail
    assert p.trace is not None and p.trace.stat().st_size > 0


def test_the_miters_multiplier_keeps_the_real_ones_timing(tmp_path):
    for induction in (False, True):
        p = formal.mac_timing(16, 16, tmp_path / str(induction), induction=induction)
        assert p.passed, (p.mode, p.detail)
    rtl = mutated_rtl(tmp_path / "rtl", "fx_mac_serial.v", [("assign in_ready = ~busy | last;",
                                                              "assign in_ready = ~busy;")])
    p = formal.mac_timing(16, 16, tmp_path / "bug", rtl=rtl)
    assert not p.passed and "same_in_ready" in p.detail, p.detail


def test_a_proof_out_of_time_leaves_no_solver_running(tmp_path):
    """The solver is yosys-smtbmc's child: at the timeout the whole process group goes (before, a
    killed yosys-smtbmc left yices computing for the rest of the session)."""
    import subprocess
    import time

    with pytest.raises(subprocess.TimeoutExpired):
        formal._run(["sh", "-c", "sleep 60 & echo $! > grandchild; wait"], tmp_path, {}, timeout=1.0)
    pid = int((tmp_path / "grandchild").read_text())
    time.sleep(0.5)
    stat = Path(f"/proc/{pid}/stat")
    assert not stat.exists() or stat.read_text().split()[2] == "Z", "the solver's stand-in still runs"


def test_formal_command(tmp_path, capsys):
    out = tmp_path / "f"
    assert main(["formal", "--only", "rtd", "--bounded-only", "--out", str(out)]) == 0
    text = (out / "report.md").read_text()
    assert "| rtd | bmc |" in text and "proven" in text
    # every cycle: each DUT's induction at the shortest length that closes, the bounded proof at it
    assert main(["formal", "--only", "rtd,freq2temp", "--out", str(tmp_path / "every")]) == 0
    rows = json.loads((tmp_path / "every" / "report.json").read_text())["proofs"]
    assert [(r["dut"], r["mode"]) for r in rows] == [("rtd", "bmc"), ("rtd", "induction"),
                                                     ("freq2temp", "bmc"), ("freq2temp", "induction")]
    for r in rows:
        assert r["passed"] and r["depth"] in formal.lengths(design_of(), r["dut"]), r
    capsys.readouterr()
    # a proof the solver does not finish in time is undecided, not proven: exit 1, said so
    assert main(["formal", "--only", "iir", "--bounded-only", "--timeout", "1", "--out", str(tmp_path / "t")]) == 1
    assert "UNDECIDED iir" in capsys.readouterr().out
    # bad input: one line, exit 2, nothing written
    # a config with no block a miter compares (the multiplier-timing proofs alone would pass)
    plain = tmp_path / "plain.toml"
    plain.write_text('[stimulus]\nseed = 1\nsamples = 64\n[system]\nfs_hz = 1000.0\nrate_full_scale_dps = 1.0\n'
                     '[bias_subtract]\nin_format = "s8.4"\nbias_format = "s8.4"\nout_format = "s9.4"\n'
                     'rounding = "floor"\noverflow = "wrap"\n')
    # a user's RTL folder that yosys rejects: a multiplier that does not state its count of products in
    # flight (an older copy), a syntax error
    older = mutated_rtl(tmp_path / "older", "fx_mac_serial.v", [("output wire [2:0]                f_in_flight",
                                                                 "output wire [2:0]                f_gone")])
    broken = mutated_rtl(tmp_path / "broken", "rtd.v", [("endmodule", "endmodule endmodule")])
    for args in (["--only", "nope"], ["--only", "bias_subtract"], ["--depth", "1"], ["--timeout", "0"],
                 ["--timeout", "inf"], ["--miter", "--only", "rtd"], ["--miter", "--config", str(plain)],
                 ["--only", "rtd", "--rtl", str(older)], ["--only", "rtd", "--rtl", str(broken)]):
        bad = tmp_path / "bad"
        assert main(["formal", *args, "--out", str(bad)]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and not bad.exists(), err

