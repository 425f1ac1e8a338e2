"""The slow tier (tests/conftest.py): make test skips exactly what is marked slow, and a parameter
filter cannot silently take a whole check out of make test."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from conftest import tier_gaps, tiered


def _item(path, name, slow_param=False, slow_function=False):
    def function():
        pass
    if slow_function:
        function.pytestmark = [pytest.mark.slow.mark]
    marker = pytest.mark.slow.mark if slow_param or slow_function else None
    return SimpleNamespace(function=function, path=path, originalname=name,
                           get_closest_marker=lambda n: marker if n == "slow" else None)


def test_tiered_marks_exactly_the_rejected_cases_and_keeps_ids_and_marks():
    params = tiered([("a", 1), pytest.param("b", 2, id="bee", marks=pytest.mark.hdl), ("c", 3)],
                    lambda case: case[1] != 2)
    assert [p.values for p in params] == [("a", 1), ("b", 2), ("c", 3)]
    assert [p.id for p in params] == [None, "bee", None]
    assert [sorted(m.name for m in p.marks) for p in params] == [[], ["hdl", "slow"], []]
    assert [bool(p.marks) for p in tiered(["x", "y"], lambda name: name == "x")] == [False, True]


def test_a_check_whose_every_case_is_slow_is_a_gap_unless_the_test_is_marked_slow():
    items = [_item("/t/test_a.py", "test_one", slow_param=True), _item("/t/test_a.py", "test_one"),
             _item("/t/test_a.py", "test_two", slow_param=True), _item("/t/test_a.py", "test_two", slow_param=True),
             _item("/t/test_b.py", "test_rate", slow_function=True)]
    assert tier_gaps(items) == ["test_a.py::test_two"]


def test_make_test_skips_the_slow_cases_alone_the_slow_tier_runs_them_and_a_gap_stops_the_run(monkeypatch):
    import conftest

    def items():
        out = [_item("/t/test_a.py", "test_one", slow_param=True), _item("/t/test_a.py", "test_one")]
        for it in out:
            it.added = []
            it.add_marker = it.added.append
        return out

    for slow_env, want in ((False, [["skip"], []]), (True, [[], []])):
        monkeypatch.setattr(conftest, "SLOW", slow_env)
        got = items()
        conftest._skip_the_slow_tier(got)
        assert [[m.name for m in it.added] for it in got] == want
    gap = items()[:1]
    with pytest.raises(pytest.UsageError, match="test_a.py::test_one"):
        conftest._skip_the_slow_tier(gap)
