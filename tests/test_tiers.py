"""The slow tier (tests/conftest.py): make test skips exactly what is marked slow, FXDSP_SLOW runs
it, and a parameter filter cannot silently take a whole check out of make test."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from conftest import slow_wanted, tiered


def test_tiered_marks_exactly_the_rejected_cases_and_keeps_ids_and_marks():
    params = tiered([("a", 1), pytest.param("b", 2, id="bee", marks=pytest.mark.hdl), ("c", 3)],
                    lambda case: case[1] != 2)
    assert [p.values for p in params] == [("a", 1), ("b", 2), ("c", 3)]
    assert [p.id for p in params] == [None, "bee", None]
    assert [sorted(m.name for m in p.marks) for p in params] == [[], ["hdl", "slow"], []]
    assert [bool(p.marks) for p in tiered(["x", "y"], lambda name: name == "x")] == [False, True]


def test_a_filter_that_keeps_no_case_is_an_error():
    with pytest.raises(ValueError, match="every one of 2 cases"):
        tiered(["x", "y"], lambda name: False)


@pytest.mark.parametrize("value, wanted", [(None, False), ("", False), ("0", False), (" 0 ", False), ("1", True),
                                           ("yes", True)])
def test_fxdsp_slow_is_on_when_set_and_not_0(value, wanted):
    assert slow_wanted(value) is wanted


def test_make_test_skips_the_slow_cases_alone_and_the_slow_tier_runs_them(monkeypatch):
    import conftest

    def items():
        out = []
        for slow in (True, False):
            marker = pytest.mark.slow.mark if slow else None
            it = SimpleNamespace(added=[], get_closest_marker=lambda n, m=marker: m if n == "slow" else None)
            it.add_marker = it.added.append
            out.append(it)
        return out

    for slow_env, want in ((False, [["skip"], []]), (True, [[], []])):
        monkeypatch.setattr(conftest, "SLOW", slow_env)
        got = items()
        conftest._skip_the_slow_tier(got)
        assert [[m.name for m in it.added] for it in got] == want
