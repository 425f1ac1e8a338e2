#!/usr/bin/env python3
"""Mutation proof of the HDL regressions: apply each single-point RTL mutation to a copy of
hdl/rtl, run the file-driven check that should notice it, print a Markdown table.
Exit status 1 if any mutation survives or the unmutated RTL fails; 2 if a mutant (or the unmutated
copy) does not compile: a broken mutant is an error of the mutation list, never a kill.
Usage: python scripts/mutate_rtl.py"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "hdl"))

from mutation import MutantBroken, run, table  # noqa: E402


def main() -> int:
    try:
        rows = run()
    except MutantBroken as exc:
        print(f"mutation harness error: {exc}", file=sys.stderr)
        return 2
    print(table(rows))
    base, muts = rows[0], rows[1:]
    ok = not base["caught"] and all(r["caught"] for r in muts)
    print(f"\n{sum(r['caught'] for r in muts)}/{len(muts)} mutations caught; baseline "
          f"{'passes' if not base['caught'] else 'FAILS'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
