"""Shared helpers of the HDL regressions: build a design from a (modified) config, generate its
Verilog headers and ROMs into a private build directory, run a cocotb stream test through
``cocotb_tools.runner`` on Icarus, and run the file-driven long-stream harness.

Every test gets its own build directory under ``tests/hdl/sim_build/<test id>``, so
``pytest -n 2 --dist loadfile`` never shares a directory between processes.
"""

from __future__ import annotations

import copy
import json
import os
import re
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fxdsp.chains import build
from fxdsp.config import Config, default_config_text
from fxdsp.hdl import params as hp

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RTL = ROOT / "hdl" / "rtl"
VECTORS = ROOT / "vectors"
SIM_BUILD = HERE / "sim_build"



def ports_of(design, name: str) -> tuple[str, list[str], list[str], bool]:
    """(RTL module, input ports, output ports, has in_ready) of an instance, from the design's table."""
    inst = design.instances[name]
    return inst.module, [p.name for p in inst.inputs], [p.name for p in inst.outputs], inst.has_ready


def require_iverilog() -> None:
    if shutil.which("iverilog") is None or shutil.which("vvp") is None:
        pytest.skip("iverilog (Icarus Verilog) is not installed: `make hdl-tools` or apt-get install iverilog")


def rtl_sources(rtl: Path | None = None) -> list[Path]:
    return sorted((rtl or RTL).glob("*.v"))


def build_dir(name: str) -> Path:
    d = SIM_BUILD / re.sub(r"[^A-Za-z0-9_.-]+", "_", name)
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    return d


# ---- designs ----------------------------------------------------------------------------------
def default_data() -> dict:
    return tomllib.loads(default_config_text())


def merged(overrides: dict | None) -> dict:
    data = default_data()

    def merge(dst, src):
        for k, v in src.items():
            if isinstance(v, dict) and isinstance(dst.get(k), dict):
                merge(dst[k], v)
            else:
                dst[k] = copy.deepcopy(v)

    merge(data, overrides or {})
    return data


def design_of(overrides: dict | None = None):
    return build(Config(merged(overrides), source="<test>"))


def generate_into(design, d: Path) -> None:
    for rel, text in hp.generate(design).items():
        (d / rel).write_text(text, encoding="ascii")


def dut_parameters(design, name: str, extra: dict | None = None) -> dict[str, str]:
    """Command-line parameters of a block DUT (chains take theirs from the headers)."""
    if design.instances[name].members:
        return dict(extra or {})
    p = hp.iverilog_params(hp.instance(design, name))
    p.update(extra or {})
    return p


def to_unsigned(values, wl: int) -> list[int]:
    mask = (1 << wl) - 1
    return [int(v) & mask for v in np.asarray(values, dtype=np.int64)]


def ovf_ignore(design, name: str) -> int:
    """Overflow flags the RTL raises but the model does not count: the demod's amp fit inside the
    paper 002 chain (the chain uses I only; the model never computes amp there)."""
    if name != "chain_paper002":
        return 0
    return 1 << design.ovf_bit(name, "demod.amp")


def model_run(design, name: str, inputs: dict[str, np.ndarray]):
    res = design.all[name].run(**inputs)  # from reset, as the RTL after rst
    return res.outputs, res.overflows.total


def segment(design, name, inputs, outputs=None, ovf_total=None, abort_after=None, gap=None):
    """One stream between resets, as the cocotb test reads it."""
    block = design.all[name]
    if outputs is None:
        outputs, ovf_total = model_run(design, name, inputs)
    seg = {"inputs": {p: to_unsigned(inputs[p], block.inputs[p].wl) for p in block.inputs},
           "outputs": {p: to_unsigned(outputs[p], block.outputs[p].wl) for p in block.outputs},
           "ovf_total": None if ovf_total is None else int(ovf_total)}
    if abort_after is not None:
        seg["abort_after"] = int(abort_after)
    if gap is not None:
        seg["gap"] = float(gap)
    return seg


# ---- cocotb -----------------------------------------------------------------------------------
def run_cocotb(design, name: str, segments: list[dict], tag: str, gap: float = 0.0, seed: int = 1,
               extra_params: dict | None = None, in_ready_check: bool = True) -> dict:
    """Build the DUT of ``name`` (block or chain) in its own directory and stream ``segments``
    through it with the generic cocotb driver; returns the driver's summary (cycles, timing)."""
    require_iverilog()
    from cocotb_tools.runner import get_runner

    module, ins, outs, ready = ports_of(design, name)
    d = build_dir(f"{tag}")
    generate_into(design, d)
    spec = {"segments": segments, "inputs": ins, "outputs": outs, "ready": ready, "gap": gap, "seed": seed,
            "ovf_ignore": ovf_ignore(design, name), "summary": str(d / "summary.json")}
    (d / "spec.json").write_text(json.dumps(spec))
    runner = get_runner("icarus")
    runner.build(sources=rtl_sources(), hdl_toplevel=module, includes=[d], build_dir=d,
                 parameters=dut_parameters(design, name, extra_params), always=True,
                 build_args=["-Wall"], timescale=("1ns", "1ps"), log_file=d / "build.log")
    # COCOTB_REWRITE_ASSERTION_FILES="": no pytest assertion rewriting inside the simulator (it
    # costs ~7 s of start-up per run; the driver reports its own mismatches)
    env = {"FXDSP_SPEC": str(d / "spec.json"), "COCOTB_REWRITE_ASSERTION_FILES": "",
           "PYTHONPATH": os.pathsep.join([str(HERE), str(ROOT), os.environ.get("PYTHONPATH", "")])}
    results = runner.test(test_module="cocotb_stream", hdl_toplevel=module, build_dir=d, test_dir=d,
                          extra_env=env, log_file=d / "sim.log")
    text = Path(results).read_text()
    if "<failure" in text or "<error" in text or 'tests="0"' in text:
        log = (d / "sim.log").read_text(errors="replace") if (d / "sim.log").exists() else ""
        tail = "\n".join(l for l in log.splitlines() if "Error" in l or "FAIL" in l or "mismatch" in l)[-4000:]
        pytest.fail(f"cocotb {name} [{tag}] failed; see {d}/sim.log\n{tail}")
    return json.loads((d / "summary.json").read_text())


# ---- file-driven harness ----------------------------------------------------------------------
def harness_text(design, name: str, n: int, unroll: int | None = None, gap: bool = False) -> str:
    """A self-checking-free Verilog testbench: $readmemh the inputs, drive back to back (honouring
    in_ready), $writememh every output after n samples, print the cycle count and overflow flags."""
    module, ins, outs, ready = ports_of(design, name)
    block = design.all[name]
    n_ovf = design.ovf_width(name)
    if design.instances[name].members:
        pov = f"#(.DIV_UNROLL({unroll or 1}))" if name == "chain_paper002" else ""
    else:
        inst = hp.instance(design, name)
        plist = dict(inst.params)
        if module == "sf_divide" and unroll:
            plist["UNROLL"] = unroll
        pov = "#(" + ", ".join(f".{k}({hp.literal(inst, k, v)})" for k, v in plist.items()) + ")"
    L = ["`timescale 1ns/1ps", "`default_nettype none", "module tb;", "    reg clk = 1'b0;", "    reg rst = 1'b1;",
         f"    localparam integer N = {n};", "    integer idx, oidx, cycles, ovf_total, b;"]
    conns = [".clk(clk)", ".rst(rst)", ".in_valid(in_valid)"]
    for p in ins:
        w = block.inputs[p].wl
        L += [f"    reg [{w - 1}:0] mem_{p} [0:N-1];", f"    wire [{w - 1}:0] {p} = mem_{p}[idx];"]
        conns.append(f".{p}({p})")
    for p in outs:
        w = block.outputs[p].wl
        L += [f"    reg [{w - 1}:0] res_{p} [0:N-1];", f"    wire [{w - 1}:0] {p};"]
        conns.append(f".{p}({p})")
    # gapped valid: a 16-bit LFSR idles about one cycle in four
    L += ["    wire out_valid;", f"    wire [{n_ovf - 1}:0] ovf;", "    reg [15:0] lfsr = 16'hace1;",
          "    always @(posedge clk) lfsr <= {lfsr[14:0], lfsr[15] ^ lfsr[13] ^ lfsr[12] ^ lfsr[10]};",
          f"    wire gate = {'|lfsr[1:0]' if gap else '1' + chr(39) + 'b1'};",
          "    wire in_valid = !rst && idx < N && gate;"]
    conns += [".out_valid(out_valid)", ".ovf(ovf)"]
    if ready:
        L.append("    wire in_ready;")
        conns.append(".in_ready(in_ready)")
    else:
        L.append("    wire in_ready = 1'b1;")
    L.append(f"    wire [{n_ovf - 1}:0] ign = {n_ovf}'d{ovf_ignore(design, name)};")
    L.append(f"    {module} {pov} dut ({', '.join(conns)});")
    L.append("    always #5 clk = ~clk;")
    L.append("    initial begin")
    L.append("        idx = 0; oidx = 0; cycles = 0; ovf_total = 0;")
    for p in ins:
        L.append(f'        $readmemh("in_{p}.hex", mem_{p});')
    L += ["        repeat (3) @(posedge clk);", "        rst <= 1'b0;", "    end",
          "    always @(posedge clk) if (!rst) begin",
          "        cycles = cycles + 1;",
          "        if (in_valid && in_ready) idx <= idx + 1;",
          "        if (out_valid) begin"]
    for p in outs:
        L.append(f"            res_{p}[oidx] = {p};")
    L += [f"            for (b = 0; b < {n_ovf}; b = b + 1) ovf_total = ovf_total + (ovf[b] & ~ign[b]);",
          "            oidx = oidx + 1;",
          "            if (oidx == N) begin"]
    for p in outs:
        L.append(f'                $writememh("out_{p}.hex", res_{p});')
    L += ['                $display("HARNESS cycles=%0d ovf=%0d", cycles, ovf_total);', "                $finish;",
          "            end", "        end",
          "        if (cycles > N * 200 + 1000) begin $display(\"HARNESS timeout\"); $finish; end",
          "    end", "endmodule", "`default_nettype wire", ""]
    return "\n".join(L)


def run_harness(design, name: str, inputs: dict[str, np.ndarray], tag: str, unroll: int | None = None,
                gap: bool = False, rtl: Path | None = None):
    """Compile and run the file-driven harness; returns (outputs by port, flagged overflows,
    cycles, seconds of simulation)."""
    require_iverilog()
    from fxdsp.vectors import from_hex_lines, to_hex_lines

    block = design.all[name]
    d = build_dir(tag)
    generate_into(design, d)
    n = len(next(iter(inputs.values())))
    for p, fmt in block.inputs.items():
        (d / f"in_{p}.hex").write_text(to_hex_lines(inputs[p], fmt))
    (d / "tb.v").write_text(harness_text(design, name, n, unroll, gap))
    cmd = ["iverilog", "-g2005", "-I", str(d), "-o", str(d / "tb.vvp"), "-s", "tb", str(d / "tb.v"),
           *map(str, rtl_sources(rtl))]
    subprocess.run(cmd, check=True, cwd=d, capture_output=True, text=True)
    t0 = time.perf_counter()
    proc = subprocess.run(["vvp", "-n", str(d / "tb.vvp")], cwd=d, capture_output=True, text=True, check=True)
    seconds = time.perf_counter() - t0
    m = re.search(r"HARNESS cycles=(\d+) ovf=(\w+)", proc.stdout)
    assert m, f"harness did not finish: {proc.stdout[-2000:]}"
    outs = {p: from_hex_lines((d / f"out_{p}.hex").read_text(), fmt) for p, fmt in block.outputs.items()}
    ovf = int(m.group(2)) if m.group(2).isdigit() else -1  # -1: unknown (x) flags
    return outs, ovf, int(m.group(1)), seconds


def record_throughput(kind: str, name: str, cycles: int, seconds: float) -> None:
    """Append one throughput measurement to sim_build/throughput.jsonl (read by the report)."""
    SIM_BUILD.mkdir(parents=True, exist_ok=True)
    with open(SIM_BUILD / "throughput.jsonl", "a") as f:
        f.write(json.dumps({"kind": kind, "name": name, "cycles": cycles, "seconds": round(seconds, 3),
                            "cycles_per_s": round(cycles / max(seconds, 1e-9))}) + "\n")
    print(f"{kind} {name}: {cycles} cycles in {seconds:.2f} s = {cycles / max(seconds, 1e-9):,.0f} cycles/s",
          file=sys.stderr)
