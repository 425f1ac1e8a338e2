#!/usr/bin/env python3
"""Confusion matrix of `fxdsp diagnose` on both log generators: the independent one written from the
contract (tests/independent/chamber_logs.py, no fxdsp imports) and the project's own simulator
(fxdsp.diagnose.hidden). Every cause including none, the independent generator's PAIRS and
(--triples) TRIPLES, (--outside) none with each effect outside the contract's list, (--short) the
single causes in logs of 500 rows, (--flicker) the single causes under flicker-dominated noise.

    .venv/bin/python scripts/confusion_matrix.py --per-label 20 [--generator independent|project|both]
        [--triples] [--outside] [--short] [--flicker] [--jsonl LOGS.jsonl]
    .venv/bin/python scripts/confusion_matrix.py --compare OLD.jsonl NEW.jsonl
    .venv/bin/python scripts/confusion_matrix.py --labels RUN.jsonl [RUN.jsonl ...]

--jsonl writes one line per log (independent.confusion.record); --compare prints both files' totals
and every log whose named causes, flag or parameters differ between them (a change to the diagnosis
is judged log by log, on the same seeds); --labels reads the acceptance label by label over the
files' logs pooled (each generator, both, the labels under it marked).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fxdsp.threads import one_blas_thread  # noqa: E402

one_blas_thread()   # as `fxdsp diagnose` runs; before the generators import numpy

from tqdm import tqdm  # noqa: E402

from independent.confusion import compare, label_name, per_label, record, records, score, specs, table  # noqa: E402


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--per-label", type=int, default=20)
    p.add_argument("--first-seed", type=int, default=5000)
    p.add_argument("--generator", choices=("independent", "project", "both"), default="both")
    p.add_argument("--no-pairs", action="store_true")
    for group in ("triples", "outside", "short", "flicker"):
        p.add_argument(f"--{group}", action="store_true")
    p.add_argument("--jsonl", type=Path, help="also write one JSON line per log here")
    p.add_argument("--compare", nargs=2, type=Path, metavar=("OLD", "NEW"),
                   help="compare two --jsonl files log by log and exit")
    p.add_argument("--labels", nargs="+", type=Path, metavar="RUN",
                   help="the acceptance label by label over these --jsonl files, pooled, and exit")
    args = p.parse_args()
    try:
        if args.labels:
            print(per_label([r for path in args.labels for r in records(path)]))
            return 0
        if args.compare:
            print(compare(*(records(path) for path in args.compare)))
            return 0
    except (OSError, ValueError) as exc:   # a file missing or not a --jsonl file: one line, exit 2
        print(f"{'--labels' if args.labels else '--compare'}: {exc}", file=sys.stderr)
        return 2
    try:
        sink = args.jsonl.open("w") if args.jsonl else None
    except OSError as exc:   # a folder, an unwritable place: one line before any log is diagnosed
        print(f"--jsonl: {exc}", file=sys.stderr)
        return 2
    gens = ("independent", "project") if args.generator == "both" else (args.generator,)
    for gen in gens:
        # the project's simulator has no flicker-dominated kind nor a row count of its own
        todo = [(lab, kw) for lab, kw in specs(not args.no_pairs, args.triples, args.outside, args.short and gen == "independent",
                                               args.flicker and gen == "independent")]
        outcomes = []
        with tqdm(total=len(todo) * args.per_label, desc=gen, file=sys.stderr) as bar:
            for lab, kw in todo:
                for k in range(args.per_label):
                    outcomes.append(score(lab, args.first_seed + k, gen, **kw))
                    outcomes[-1].label = label_name(lab, kw)
                    if sink:
                        sink.write(json.dumps(record(outcomes[-1], gen)) + "\n")
                        sink.flush()
                    bar.update()
        print(f"## {gen} generator, {args.per_label} logs per label\n")
        print(table(outcomes))
        misses = [o for o in outcomes if not o.outside and not (o.named_exactly and o.params_ok and o.gain_ok)]
        if misses:
            print("\nMisses:\n")
            for o in misses:
                print(f"- {o.brief}: found {o.found or ['none']}; {'; '.join(o.misses)}; gain {o.gain_ratio:.2f}")
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
