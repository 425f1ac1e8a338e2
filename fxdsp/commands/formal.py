"""``fxdsp formal [--config F] [--only NAMES] [--depth N] [--bounded-only] [--miter] [--rtl DIR] --out DIR``

Formal proofs (yosys-smtbmc with the yices solver, abc bmc3 for the bounded ones) of the serial variant of every block and chain top of
F (or those named), :mod:`fxdsp.hdl.formal`: a block's one sample in flight, out_valid exactly the
stated cycles per sample after the accepting edge, in_ready back when the sample leaves and never
while one is in flight, multiplier requests only inside a sample; a chain top with its members cut
to their contracts: at most one multiplier request per cycle, its handshake, its bookkeeping, and a
sample able to go through. A k-induction of length N and the bounded proof to N cycles from reset
(its base case): a pass of both holds for every cycle. Without ``--depth``, N is the shortest of
:func:`fxdsp.hdl.formal.lengths` at which the induction closes (a block's C + 2, else 2 C + 4; a
top's 24 cycles). ``--bounded-only``: the bounded proof alone (default N: a block's two samples back
to back, 2 C + 4; a top's 24).

``--miter``: equivalence of each smaller block's serial variant (sf_divide, piecewise, lag) with its
one-sample-per-clock variant, bounded over two samples from reset with every input free, word for
word and flag for flag (:func:`fxdsp.hdl.formal.miter`); on the narrow word lengths of the
package's ``configs/formal_narrow.toml`` unless ``--config`` names another.

``DIR/report.json`` and ``DIR/report.md``: per DUT and mode the verdict, the depth, the seconds and,
for a failure, the failing assertions and the counterexample's waveform (``DIR/traces/*.vcd``).
Exit status: 0 when every proof passes, 1 when any fails or is undecided (no answer within
``--timeout`` seconds), 2 on bad input or a missing tool.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from fxdsp.commands.options import POSITIVE, count
from fxdsp.outputs import IN, IN_DIR, OUT_DIR

PATHS = {"--config": IN, "--rtl": IN_DIR, "--out": OUT_DIR}


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--only", default=None, metavar="NAMES",
                        help="comma-separated blocks or chains (default: every one with a serial variant)")
    parser.add_argument("--depth", type=count(2), default=None, metavar="N",
                        help="length of the proofs (default: the shortest at which the induction closes, C + 2 or 2 C + 4 for a "
                             "block of C cycles per sample, 24 for a top; --bounded-only: 2 C + 4)")
    parser.add_argument("--bounded-only", action="store_true",
                        help="the bounded proof from reset only (no induction: not every cycle)")
    parser.add_argument("--timeout", type=POSITIVE, default=3600, metavar="S",
                        help="seconds per solver run; a proof without an answer by then is undecided (default 3600)")
    parser.add_argument("--miter", action="store_true",
                        help="prove each smaller block's serial variant equal to its one-sample-per-clock one "
                             "(bounded, two samples; default config: the package's narrow formal_narrow.toml)")
    parser.add_argument("--rtl", default=None, metavar="DIR", help="Verilog sources (default: the RTL in the package)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder: report and traces")


def _verdict(r: dict) -> str:
    return "proven" if r["passed"] else "undecided" if r["failing"].startswith("undecided") else "FAILS"


def markdown(report: dict) -> str:
    lines = ["# Formal proofs (fxdsp formal)", "",
             "Properties: " + report["properties"], "",
             "| DUT | mode | depth (cycles) | cycles per sample | verdict | seconds | failing |",
             "|---|---|---:|---:|---|---:|---|"]
    for r in report["proofs"]:
        lines.append(f"| {r['dut']} | {r['mode']} | {r['depth']} | {r['cycles_per_sample'] or '-'} | "
                     f"{_verdict(r)} | {r['seconds']} | {r['failing'] or ''} |")
    return "\n".join(lines) + "\n"


def run(args) -> int:
    from tqdm import tqdm

    from fxdsp.chains import build
    from fxdsp.errors import InputError
    from fxdsp.outputs import json_text, staged
    from fxdsp.hdl import formal
    from fxdsp.hdl.schedule import cycles_per_sample

    if args.rtl is not None and not sorted(Path(args.rtl).glob("*.v")):
        raise InputError(f"--rtl: no Verilog sources (*.v) in {args.rtl}")
    config = args.config or (formal.MITER_CONFIG if args.miter else None)
    design = build(config)
    design.with_rtl()
    duts = formal.miter_duts(design) if args.miter else formal.serial_duts(design)
    where = (f"--config {args.config}" if args.config else
             f"the miters' config {config}" if args.miter else "the built-in config")
    if args.miter and not duts:   # the multiplier-timing proofs alone would pass and prove no miter
        raise InputError(f"--miter: {where} has no {', '.join(formal.MITER_BLOCKS)} block with a serial variant to "
                         "compare with its one-sample-per-clock variant")
    if args.only is not None:
        only = [n.strip() for n in args.only.split(",") if n.strip()]
        if not only:
            raise InputError("--only: no block or chain named")
        for n in only:
            if n not in design.hardware:
                raise InputError(f"--only: {n!r} is not a block or chain with RTL of {where} "
                                 f"({', '.join(design.hardware)})")
            if n not in duts:
                raise InputError(f"--only: {n!r} has no {'miter' if args.miter else 'serial variant'} to prove "
                                 f"(those with one: {', '.join(duts) or 'none'})")
        duts = [n for n in duts if n in only]
    formal.require_tools()
    proofs = []
    modes = (False,) if args.bounded_only or args.miter else (False, True)
    every_cycle = len(modes) == 2 and args.depth is None   # the length the induction needs (formal.lengths)
    try:
        with staged() as stage, tempfile.TemporaryDirectory(prefix="fxdsp_formal_") as tmp:
            out = stage.dir(args.out)
            rtl = Path(args.rtl) if args.rtl else None
            for name in tqdm(duts, desc="formal", unit="DUT", disable=None):
                cut = bool(design.instances[name].members)
                if every_cycle:
                    done = formal.prove_every_cycle(design, name, Path(tmp) / name, rtl=rtl, cut=cut, timeout=args.timeout)
                else:
                    done = [formal.prove(design, name, Path(tmp) / name / str(ind), depth=args.depth, induction=ind, rtl=rtl,
                                         cut=cut, timeout=args.timeout, equivalence=args.miter) for ind in modes]
                for p in done:
                    trace = None
                    if p.trace is not None:
                        trace = f"traces/{name}_{p.mode}.vcd"
                        (out / "traces").mkdir(exist_ok=True)
                        (out / trace).write_bytes(p.trace.read_bytes())
                    proofs.append({"dut": name, "mode": p.mode, "depth": p.depth,
                                   "cycles_per_sample": cycles_per_sample(design, name, arch=1),
                                   "passed": p.passed, "seconds": round(p.seconds, 1), "failing": p.detail,
                                   "trace": trace})
            if args.miter and args.only is None:   # the miters' multiplier keeps fx_mac_serial's timing
                for a_w, b_w in formal.MAC_TIMING_WIDTHS:
                    for ind in (False, True):
                        p = formal.mac_timing(a_w, b_w, Path(tmp) / f"mac{a_w}x{b_w}_{ind}", induction=ind,
                                              rtl=rtl, timeout=args.timeout)
                        proofs.append({"dut": p.name, "mode": p.mode, "depth": p.depth, "cycles_per_sample": None,
                                       "passed": p.passed, "seconds": round(p.seconds, 1), "failing": p.detail,
                                       "trace": None})
            report = {"config": str(config or "built-in"), "proofs": proofs,
                      "properties": formal.MITER_PROPERTIES if args.miter else formal.PROPERTIES}
            (out / "report.json").write_text(json_text(report, "report.json", indent=1), encoding="utf-8")
            (out / "report.md").write_text(markdown(report), encoding="utf-8")
    except formal.RtlRejected as exc:
        if args.rtl is None:   # the package's own RTL refused: a bug, with its traceback
            raise
        raise InputError(f"--rtl {args.rtl}: yosys rejects it: {exc}") from None
    bad = [p for p in proofs if not p["passed"]]
    for p in bad:
        sys.stdout.write(f"formal: {_verdict(p).upper()} {p['dut']} ({p['mode']}, {p['depth']} cycles): {p['failing']}"
                         + (f"; trace {Path(args.out) / p['trace']}" if p["trace"] else "") + "\n")
    sys.stdout.write(f"formal: {len(proofs) - len(bad)} of {len(proofs)} proofs pass; report "
                     f"{Path(args.out) / 'report.md'}\n")
    return 1 if bad else 0
