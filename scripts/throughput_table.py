"""Simulation throughput per DUT from the HDL regressions' records (tests/hdl/sim_build/throughput.jsonl,
written by ``hdl_util.record_throughput`` during `make test`): a Markdown table of cycles/s per DUT,
file-driven (a Verilog testbench reading hex files) and Python-driven (cocotb), on Icarus and
Verilator; the fastest run of each (DUT, kind, simulator) is shown (short runs are dominated by
start-up). Usage: python scripts/throughput_table.py [PATH]"""

from __future__ import annotations

import json
import sys
from pathlib import Path

DEFAULT = Path(__file__).resolve().parents[1] / "tests" / "hdl" / "sim_build" / "throughput.jsonl"
COLUMNS = [("file", "icarus"), ("file", "verilator"), ("cocotb", "icarus"), ("cocotb", "verilator")]


def table(path: Path) -> str:
    best: dict[tuple[str, str, str], dict] = {}
    for line in path.read_text().splitlines():
        row = json.loads(line)
        if row["kind"] not in ("file", "cocotb"):
            continue  # build times
        key = (row["name"], row["kind"], row["sim"])
        if key not in best or row["cycles_per_s"] > best[key]["cycles_per_s"]:
            best[key] = row
    names = sorted({k[0] for k in best})
    out = ["| DUT | " + " | ".join(f"{k} {s} (cycles/s)" for k, s in COLUMNS) + " |",
           "|---|" + "---:|" * len(COLUMNS)]
    for n in names:
        cells = []
        for k, s in COLUMNS:
            r = best.get((n, k, s))
            cells.append("-" if r is None else f"{r['cycles_per_s']:,} ({r['cycles']:,} cycles)")
        out.append(f"| {n} | " + " | ".join(cells) + " |")
    return "\n".join(out)


if __name__ == "__main__":
    print(table(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT))
