"""`fxdsp hw-report`: synthesise every RTL block instance and both tops for the iCE40UP5K
(yosys ``synth_ice40 -dsp``, nextpnr-ice40 ``--up5k``) and write a Markdown table of LUTs,
SB_MAC16, flip-flops, block RAMs and Fmax to ``hdl/HW_REPORT.md``, and the same rows as data to
``hdl/HW_REPORT.json`` beside it (:mod:`fxdsp.hdl.hwreport`).

A second column set estimates the cost on a larger part users also target, a Xilinx 7-series
(Artix-7): yosys ``synth_xilinx -family xc7 -flatten -noiopad`` on the same bare module with the
same parameters, synthesis only (no vendor tools, no place and route, no timing): LUT1..LUT6,
DSP48E1, FDRE/FDSE/FDCE/FDPE and RAMB36E1/RAMB18E1 counts (distributed-RAM and SRL cells are in the
JSON only). These are yosys estimates, not Vivado results.

Resources are those of the bare module (its parameters from the same config as the models).
Fmax comes from placing and routing the module inside a serial wrapper (one input pin, one
output pin, shift registers around the module's ports) because the tops have more port bits than
the UP5K has pins; the wrapper's shift registers add flip-flops and LUTs to the routed design but
not to the table's resource columns.

Besides the instances, the resource-shared variants of blocks (:func:`variants`, e.g. the serial iir
``iir (ARCH=1)``) get a row each: the same module and config parameters plus the variant's own.

A serial row that does not place on the UP5K is also placed on the smallest ECP5 (:data:`ECP5`,
:func:`place_ecp5`: yosys ``synth_ecp5`` on the same wrapper, the YoWASP nextpnr-ecp5, the row's
seeds), against the clock its cycles per sample need; a row taken from a previous report keeps its
placement (``--fresh`` with ``--only`` places it again).

A row whose hash (:func:`fxdsp.hdl.hwreport.row_hash`: its module's RTL closure, the generated
files, its parameters, the tool commands and wrapper) and tool versions match a row of the report
at ``--out`` is taken from it instead of synthesised again (``--fresh`` re-runs every row): after a
change to one block only the rows that read it are re-run.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fxdsp.commands.options import POSITIVE, count
from fxdsp.chains import build
from fxdsp.errors import InputError
from fxdsp.outputs import IN, OUT_FILE, check_output, staged
from fxdsp.hdl.hwreport import load_hw_report, report_json, source_hash
from fxdsp.hdl.params import generate
from fxdsp.hdl.synthesis import ECP5, UP5K, XC7A35T, chparam_command, failure_text, place_ecp5, place_route, synth, synth_xc7, tool_versions
from fxdsp.hdl.hwplan import row_digest, planned_rows, reusable_rows, seeds_of, too_big
from fxdsp.hdl.hwreport_md import schedule_fields, markdown


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--out", required=True, metavar="REPORT.md",
                        help="Markdown report to write (its JSON twin goes beside it, suffix .json); "
                             "the project's own is hdl/HW_REPORT.md (`make hw-report`)")
    parser.add_argument("--only", nargs="*", help="re-run only these instances' rows (default: every block and chain); "
                        "the report's other rows are kept while they are current")
    parser.add_argument("--freq", type=POSITIVE, default=40.0, help="nextpnr target clock in MHz (default 40)")
    parser.add_argument("--timeout", type=count(), default=1200, help="seconds per tool run")
    parser.add_argument("--xc7-timeout", type=count(), default=900,
                        help="seconds for the xc7 (synth_xilinx) synthesis of one block (default 900)")
    parser.add_argument("--no-xc7", action="store_true", help="skip the xc7 (synth_xilinx) columns")
    parser.add_argument("--fresh", action="store_true",
                        help="synthesise every row (default: take the rows whose sources, parameters and tools "
                             "are unchanged from the report at --out)")


PATHS = {"--config": IN, "--out": OUT_FILE}
# the xc7 synthesis' time limit means nothing on a run that skips it (fxdsp.cli checks)
ONLY_WITH = {"--xc7-timeout": ("not --no-xc7",)}


def run(args) -> int:
    for option, value in (("--freq", args.freq), ("--timeout", args.timeout), ("--xc7-timeout", args.xc7_timeout)):
        if not (math.isfinite(value) and value > 0):   # before any synthesis: nan, inf and <= 0 alike
            raise InputError(f"{option}: need a positive, finite number, got {value}")
    check_output(Path(args.out).with_suffix(".json"), OUT_FILE, "--out (its .json twin)")
    for tool in ("yosys", "nextpnr-ice40"):
        if shutil.which(tool) is None:
            print(f"fxdsp hw-report: {tool} not found (apt-get install yosys nextpnr-ice40)", file=sys.stderr)
            return 2
    design = build(args.config)
    design.with_rtl()
    tools = tool_versions()
    previous = load_hw_report(Path(args.out).with_suffix(".json"))
    current = reusable_rows(previous, tools, args.freq, not args.no_xc7)  # rows still valid as they are
    reuse = {} if args.fresh else current
    targets = args.only or list(design.hardware)
    unknown = [t for t in targets if t not in design.hardware]
    if unknown:
        raise InputError(f"--only: {unknown[0]!r} is not an instance of the design with RTL ({', '.join(design.hardware)})")
    rows = []
    with tempfile.TemporaryDirectory(prefix="fxdsp_hw_") as tmp:
        work = Path(tmp)
        files = generate(design)
        for rel, text in files.items():
            (work / rel).write_text(text)
        digest = source_hash(design, files)  # what is synthesised: the RTL and these files, as read now
        chosen = planned_rows(design, targets)
        for row_name, plan in planned_rows(design, list(design.hardware)).items():
            name, module, params, extra = plan
            tag = re.sub(r"\W+", "_", row_name).strip("_")
            t0 = time.perf_counter()
            chparam = chparam_command(module, params)
            digest_row = row_digest(design, files, plan, args.freq, seeds_of(row_name))
            sched = schedule_fields(design, name, extra)
            if row_name not in chosen:  # --only: the report's other rows stay while they are current
                if digest_row in current:
                    rows.append({**current[digest_row], "name": row_name, "module": module, **sched})
                else:
                    print(f"{row_name}: not in --only and stale or absent in the previous report: left out",
                          file=sys.stderr)
                continue
            if digest_row in reuse:
                rows.append({**reuse[digest_row], "name": row_name, "module": module, **sched})
                print(f"{row_name}: unchanged, taken from the previous report", file=sys.stderr)
                continue
            row = {"name": row_name, "module": module, "sha256": digest_row, **sched}
            try:
                row.update(synth(design, name, work, args.timeout, chparam, tag))
                row["fmax"], row["note"] = None, too_big(row)
                if not row["note"]:  # placing what cannot fit would only spend minutes to say so
                    seeds = seeds_of(row_name)
                    row["fmax"], row["note"], sweep, worst = place_route(design, name, work, args.freq, args.timeout,
                                                                         params, bool(extra), tag, seeds)
                    row.update({k: worst.get(k) for k in ("LC", "GB", "critical_path")})
                    row["warnings"] = row.get("warnings", []) + [w for w in worst.get("warnings", [])
                                                                 if w not in row.get("warnings", [])]
                    if len(seeds) > 1:
                        row["fmax_seeds"] = {str(s): f for s, f in sweep.items()}
                        row["critical_seed"] = worst.get("seed")
                if row["fmax"] is None and "no BELs remaining" in row["note"] and "DSP" in row["note"]:
                    row["note"] = f"does not place: {row['MAC16']} SB_MAC16 > {UP5K['MAC16']} on the device"
                elif row["fmax"] is None and "ICESTORM_LC" in row["note"] and (
                        "no BELs remaining" in row["note"] or "Failed to expand region" in row["note"]):
                    cells = re.search(r"of (\d+) ICESTORM_LCs", row["note"])  # the packer's count, when given
                    need = f"{cells.group(1)} logic cells (packed)" if cells else "more logic cells"
                    row["note"] = (f"does not place: {row['LUT']} LUT4 and {row['FF']} FF need {need}, the device "
                                   f"has {UP5K['LUT']}")
            except subprocess.TimeoutExpired:
                row["note"] = f"timed out after {args.timeout} s"
            except subprocess.CalledProcessError as exc:
                row["note"] = failure_text(exc)
            if extra and row.get("fmax") is None and row.get("note", "").startswith("does not place"):
                try:   # a serial row the UP5K cannot hold: where it does fit
                    row["ecp5"] = place_ecp5(design, name, work, args.freq, args.timeout, params, bool(extra), tag,
                                             seeds_of(row_name))
                except subprocess.TimeoutExpired:
                    row["ecp5"] = {"device": ECP5["name"], "note": f"timed out after {args.timeout} s"}
                except subprocess.CalledProcessError as exc:
                    row["ecp5"] = {"device": ECP5["name"], "note": "ecp5 " + failure_text(exc)}
            row["seconds"] = round(time.perf_counter() - t0, 1)
            t1 = time.perf_counter()
            xc7: dict = {}
            if args.no_xc7:
                xc7["note"] = "not run (--no-xc7)"
            else:
                try:
                    xc7.update(synth_xc7(design, name, work, args.xc7_timeout, chparam, tag))
                except subprocess.TimeoutExpired:
                    xc7["note"] = f"xc7 synthesis timed out after {args.xc7_timeout} s"
                except subprocess.CalledProcessError as exc:
                    xc7["note"] = "xc7 " + failure_text(exc)
            xc7["seconds"] = round(time.perf_counter() - t1, 1)
            row["xc7"] = xc7
            rows.append(row)
            print(f"{row_name}: {row}", file=sys.stderr)
    out = Path(args.out)
    with staged() as stage:  # the Markdown table and its JSON twin land together
        stage.write_text(out, markdown(rows, args.freq, digest))
        stage.write_text(out.with_suffix(".json"), report_json(rows, args.freq, UP5K, digest, XC7A35T, tools))
    print(f"wrote {out} and {out.with_suffix('.json')}")
    return 0
