"""The confusion matrix's per-log records and their comparison (scripts/confusion_matrix.py --jsonl,
--compare): a change to the diagnosis is judged log by log on the same seeds, so the comparison must
list exactly the logs whose answer changed, and count the totals from the records alone."""

from __future__ import annotations

import json

import pytest

from .confusion import compare, per_label, record, records, score


def _line(label, seed, truth, found, flagged=False, params_ok=True, outside=(), generator="independent"):
    # the fields record() writes, filled in by hand: what a run of the script leaves in its file
    return {"generator": generator, "label": label, "seed": seed, "truth": list(truth), "found": list(found),
            "named_exactly": sorted(found) == sorted(truth), "params_ok": params_ok, "misses": [] if params_ok else
            ["aging_drift.r_per_h 1.5 vs 1"], "noise_misses": [], "outside": list(outside), "flagged": flagged,
            "seconds": 1.0, "sds_off": [0.5]}


def test_the_comparison_lists_the_logs_whose_answer_changed_and_counts_from_the_records():
    old = [_line("none", 5000, (), ()), _line("aging_drift", 5000, ("aging_drift",), ()),
           _line("none + outside:step", 5000, (), (), flagged=True, outside=("step",))]
    new = [_line("none", 5000, (), ()), _line("aging_drift", 5000, ("aging_drift",), ("aging_drift",), params_ok=False),
           _line("none + outside:step", 5000, (), (), flagged=True, outside=("step",))]
    text = compare(old, new)
    changed = [line for line in text.splitlines() if line.startswith("- ")]
    assert len(changed) == 1 and "aging_drift seed 5000" in changed[0] and "1.5 vs 1" in changed[0], text
    assert "old: named exactly 1/2" in text and "new: named exactly 2/2" in text, text
    assert "parameters within 25 % 0/0" in text.splitlines()[0], text   # no log with a cause named
    assert "parameters within 25 % 0/1" in text.splitlines()[1], text   # the drift named, its rate off
    assert "out-of-contract flagged 1/1" in text, text
    assert "no log differs" in compare(old, old)


def test_a_diagnosed_log_is_written_as_a_json_line_the_comparison_reads():
    o = score((), 5000, rows=500)
    o.label = "none (500 rows)"
    line = json.loads(json.dumps(record(o, "independent")))
    assert line["found"] == o.found and line["seed"] == 5000 and line["named_exactly"] == o.named_exactly
    assert "no log differs" in compare([line], [line])
    moved = {**line, "found": ["aging_drift"] if not o.found else []}
    assert "none (500 rows) seed 5000" in compare([line], [moved])


def _logs(label, truth, n, hits, generator="independent", outside=(), params_ok=True):
    """``n`` logs of ``label``, the first ``hits`` of them named exactly (flagged, out of contract)."""
    return [_line(label, 5000 + k, truth, truth if outside or k < hits else (), flagged=bool(outside) and k < hits,
                  outside=outside, generator=generator, params_ok=params_ok or k > 0) for k in range(n)]


def test_the_acceptance_read_label_by_label_marks_the_labels_under_it():
    # issue 32: >= 95 % named exactly on in-contract labels, >= 90 % of out-of-contract logs flagged;
    # the rates here sit on and just under those lines, the two generators pooled
    records = (_logs("thermal_lag", ("thermal_lag",), 20, 20)
               + _logs("thermal_lag", ("thermal_lag",), 20, 18, "project", params_ok=False)         # 38/40
               + _logs("warmup", ("warmup",), 20, 18) + _logs("warmup", ("warmup",), 20, 19, "project")  # 37/40
               + _logs("none + outside:step", (), 20, 18, outside=("step",))                         # 18/20
               + _logs("none + outside:sine", (), 20, 17, outside=("sine",)))                        # 17/20
    rows = {line.split(" | ")[0].strip("| "): line for line in per_label(records).splitlines()[2:]}
    # the project's first lag log has a parameter off: 37 of the 38 exact logs within 25 %
    assert "| 20/20 | 18/20 | 95.0% named exactly | 37/38 |" in rows["thermal_lag"]
    assert "under" not in rows["thermal_lag"]
    assert "18/20 | 19/20 | 92.5% named exactly" in rows["warmup"] and "**under 95%**" in rows["warmup"]
    assert "| 18/20 | - | 90.0% flagged" in rows["none + outside:step"] and "under" not in rows["none + outside:step"]
    assert "85.0% flagged" in rows["none + outside:sine"] and "**under 90%**" in rows["none + outside:sine"]
    # the in-contract labels first, though "none + ..." comes first alphabetically
    assert list(rows) == ["thermal_lag", "warmup", "none + outside:sine", "none + outside:step"]
    # one log twice (two runs of a seed set): refused, not counted twice
    with pytest.raises(ValueError, match="thermal_lag seed 5000: twice"):
        per_label(records + records[:1])


def test_a_file_that_is_no_run_of_the_script_is_refused_with_its_line(tmp_path):
    good = tmp_path / "run.jsonl"
    good.write_text(json.dumps(_line("none", 5000, (), ())) + "\n\n")
    assert [r["seed"] for r in records(good)] == [5000]          # a blank line is no record
    for text, says in (('{"label": "none"}', "no 'generator'"), ("[1, 2]", "no 'generator'"),
                       ('{"generator": "independent", "label', "not JSON")):
        bad = tmp_path / "bad.jsonl"
        bad.write_text(json.dumps(_line("none", 5000, (), ())) + "\n" + text + "\n")
        with pytest.raises(ValueError, match=f"bad.jsonl:2: .*{says}"):
            records(bad)
    binary = tmp_path / "run.jsonl.gz"
    binary.write_bytes(b"\x1f\x8b\x08\x00\xcb\xff")
    with pytest.raises(ValueError, match="run.jsonl.gz: not a text file"):
        records(binary)
