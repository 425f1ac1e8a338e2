"""The Verilog top of a chain, generated from its netlist: ``<chain>.v`` beside the parameter headers.

The top runs one sample in flight through any feed-forward netlist of blocks:

* a sample is accepted on ``in_valid && in_ready`` (``in_ready`` is high while the chain is idle,
  which includes the cycle of ``out_valid``); the chain inputs are registered then;
* a member starts as soon as everything that drives it is ready: the chain inputs, and the captured
  outputs of the members wired to it (and its own ``in_ready``); its ``in_valid`` pulse is that
  decision registered (a cycle later), so the decision logic ends in a register;
* each member's outputs and overflow flags are captured on its ``out_valid``, so a member's result
  holds for whatever reads it later, whatever the member does with its output registers meanwhile;
* ``out_valid`` pulses one cycle after the last member's result is captured, with the chain's
  outputs and ``ovf`` = every member's flags, first instance at bit 0 (the model's order).

``ARCH`` selects every member's variant (0: one sample per clock; 1: the serial variant). In the
serial variant every member with a multiplier bundle (:class:`~fxdsp.blocks.datapath.RtlPorts`) issues
on ONE shared ``fx_mac_serial``, sized here from the members' operands; a member on it starts only
when no other works on it (the earlier in the execution order first), so at most one requests at a
time, and two members that can share an engine do (:mod:`fxdsp.hdl.sharing`); a member the chain
lists in ``own_multiplier`` keeps one of its own and runs beside them. A wire from an output the
member's interface holds ahead (``RtlPorts.ahead``: a loop's phase word, known before its sample) is
read from that port as the chain accepts the sample, so its reader does not wait for the pass. The schedule that
results is :func:`fxdsp.hdl.schedule.chain_schedule`, stated as numbers in the header. Members are
independent blocks with fixed per-block behaviour, so the generator needs only each module's ports,
its RTL interface and its parameters.
"""

from __future__ import annotations

import re

from fxdsp.chains import Chain, Design
from fxdsp.errors import InputError
from fxdsp.netlist import Endpoint

# The reserved words of Verilog-2005 (IEEE 1364-2005 annex B) and SystemVerilog-2012 (the simulators
# compile the tops with -g2012): a chain port of that name cannot be a port of its generated top.
RESERVED_WORDS = frozenset("""
always and assign automatic begin buf bufif0 bufif1 case casex casez cell cmos config deassign default defparam
design disable edge else end endcase endconfig endfunction endgenerate endmodule endprimitive endspecify endtable
endtask event for force forever fork function generate genvar highz0 highz1 if ifnone incdir include initial inout
input instance integer join large liblist library localparam macromodule medium module nand negedge nmos nor
noshowcancelled not notif0 notif1 or output parameter pmos posedge primitive pull0 pull1 pulldown pullup
pulsestyle_ondetect pulsestyle_onevent rcmos real realtime reg release repeat rnmos rpmos rtran rtranif0 rtranif1
scalared showcancelled signed small specify specparam strong0 strong1 supply0 supply1 table task time tran tranif0
tranif1 tri tri0 tri1 triand trior trireg unsigned use uwire vectored wait wand weak0 weak1 while wire wor xnor xor
accept_on alias always_comb always_ff always_latch assert assume before bind bins binsof bit break byte chandle
checker class clocking const constraint context continue cover covergroup coverpoint cross dist do endchecker
endclass endclocking endgroup endinterface endpackage endprogram endproperty endsequence enum eventually expect
export extends extern final first_match foreach forkjoin global iff ignore_bins illegal_bins implements implies
import inside int interconnect interface intersect join_any join_none let local logic longint matches modport
nettype new nexttime null package packed priority program property protected pure rand randc randcase randsequence
ref reject_on restrict return s_always s_eventually s_nexttime s_until s_until_with sequence shortint shortreal
soft solve static string strong struct super sync_accept_on sync_reject_on tagged this throughout timeprecision
timeunit type typedef union unique unique0 until until_with untyped var virtual void wait_order weak wildcard with
within""".split())
_DECLARATION = re.compile(r"^\s*(?:wire|reg|integer|genvar|localparam|parameter)\b([^;]*)", re.M)
_INSTANCE = re.compile(r"\b(u_\w+)\s*\(")
_FIXED_PORTS = ("clk", "rst", "in_valid", "in_ready", "out_valid", "ovf")


def _v(name: str) -> str:
    return name.replace(".", "_")


def _vec(w: int) -> str:
    return f"[{w - 1}:0] " if w > 1 else ""


def _schedule_lines(design: Design, name: str) -> list[str]:
    """Both variants' schedules as numbers for this config (:func:`fxdsp.hdl.schedule.chain_schedule`)."""
    from fxdsp.hdl.schedule import chain_schedule

    fs = design.chains[name].fs_hz
    budget = int(40e6 // fs)
    out = []
    for arch in (1, 0):
        try:
            per, start = chain_schedule(design, name, arch)
        except ValueError as e:   # a member without a constant schedule (a decimating lag)
            out.append(f"// ARCH = {arch} schedule: not constant ({e}).")
            continue
        steps = ", ".join(f"{m} at {b} for {c}" for m, (b, c) in start.items())
        out += [f"// ARCH = {arch} schedule at DIV_UNROLL = 1 (each member's in_valid cycle, counted from the cycle after "
                f"the chain's accepting edge, and its cycles): {steps};",
                f"//   {per} cycles per sample at this config, against {budget} at 40 MHz and {fs:g} S/s."]
    return out


# the shared multiplier bundle of a block (fx_mac_port): request, operands, limb counts
MAC_PORTS = (("mac_in_valid", "req", ""), ("mac_a", "a", "[MAC_A_W-1:0] "), ("mac_b", "b", "[MAC_B_W-1:0] "),
             ("mac_na", "na", "[3:0] "), ("mac_nb", "nb", "[3:0] "))


class _Top:
    """The text of one generated top, built member by member."""

    def __init__(self, design: Design, name: str):
        from fxdsp.hdl.sharing import engine_sharing

        self.design, self.name = design, name
        self.chain: Chain = design.chains[name]
        self.net = self.chain.netlist
        self.inst = design.instances
        self.members = list(self.net.instances)
        self.order = list(self.net.order)       # priority on the shared multiplier: the execution order
        self.shares = engine_sharing(design, name)
        self.hosted = {s.host: s for s in self.shares.values()}
        from fxdsp.hdl.schedule import ahead_source, on_shared_multiplier

        for m in self.net.own_multiplier:
            if not self.inst[_v(m)].rtl.mac_bundle:
                raise InputError(f"{self.net.name}.own_multiplier: {m!r} has no shared-multiplier bundle "
                                 f"({self.inst[_v(m)].module}.v): it never takes turns on the top's multiplier")
        self.on_mac = on_shared_multiplier(design, name)
        self.bundles = list(self.on_mac)   # every member on the multiplier has a bundle (a guest's tied off when shared)
        # the words read ahead (member output -> its RTL port): taken when the chain accepts a sample
        self.ahead = {src: port for src in set(self.net.drivers.values()) if (port := ahead_source(design, src))}

    # ---- helpers ----
    def src(self, m: str, port: str) -> str:
        s = self.net.driver(m, port)
        if isinstance(s, str):
            return f"in_{s}_q"
        return f"{_v(s.instance)}_{s.port}_" + ("ahead_q" if s in self.ahead else "q")

    def deps(self, m: str) -> list[str]:
        from fxdsp.hdl.schedule import waits_on

        return sorted(waits_on(self.design, self.name, m))

    def ready(self, m: str) -> bool:
        return self.inst[_v(m)].rtl.ready

    def mac_width(self) -> tuple[int, int]:
        from fxdsp.blocks.datapath import whole_limbs
        from fxdsp.hdl.schedule import mac_operands

        ops = [mac_operands(self.design, _v(m)) for m in self.on_mac]
        return whole_limbs(max(a for a, _ in ops)), whole_limbs(max(b for _, b in ops))

    def instance_text(self, m: str, extra: list[str], conns_extra: list[str], outs: dict[str, str],
                      label: str = "") -> list[str]:
        """One member's module instance: its header's parameters, ``extra`` overrides, data and bundle
        connections; ``outs`` names the wire of each of its outputs (port -> wire or '' unconnected)."""
        v = _v(m)
        inst = self.inst[v]
        rtl = inst.rtl
        block = self.chain.members[m]
        over = []
        if rtl.serial:
            over.append(", .ARCH(ARCH)")
        if inst.module == "sf_divide":
            over.append(", .UNROLL(DIV_UNROLL)")
        over += extra
        conns = [".clk(clk)", ".rst(rst)", f".in_valid(go_{v}_q)"]
        if rtl.ready:
            conns.append(f".in_ready({v}_in_ready)")
        conns += [f".{inst.rtl_port(p)}({self.src(m, p)})" for p in block.inputs]
        conns.append(f".out_valid({v}_out_valid)")
        conns += [f".{inst.rtl_port(p)}({outs.get(p, '')})" for p in block.outputs]
        conns += [f".{port}({v}_{p}_next)" if Endpoint(m, p) in self.ahead else f".{port}()" for p, port in rtl.ahead]
        conns.append(f".ovf({v}_ovf)")
        if m in self.on_mac:
            conns += [f".{port}({v}_mac_{sig})" for port, sig, _ in MAC_PORTS]
            conns += [".mac_in_ready(sh_ready)", f".mac_out_valid(sh_valid & own[{self.bundles.index(m)}])",
                      ".mac_p(sh_p)"]
            over.insert(1 if rtl.serial else 0, ", .EXT_MAC(ARCH), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)")
        elif rtl.mac_bundle:   # own_multiplier: its own (EXT_MAC = 0), the bundle tied off at 2 x 2 bits
            conns += list(MAC_TIE_OFFS)
            over.append(", .MAC_A_W(2), .MAC_B_W(2)")
        conns += [c for c in conns_extra]
        ind = "    " + label
        return [f"{ind}{inst.module} #(", f'`include "{v}_params.vh"', *(f"{ind}    {o}" for o in over),
                f"{ind}) u_{v} (", f"{ind}    " + f",\n{ind}    ".join(conns), f"{ind});"]

    def outs(self, m: str) -> dict[str, str]:
        """The member's outputs something reads after its result: not those read only ahead."""
        v = _v(m)
        return {p: f"{v}_{p}" for p in self.captured(m)}

    def captured(self, m: str) -> set[str]:
        """The member's outputs the top captures on its out_valid: read by a wire that waits for the
        result, or a chain output."""
        waited = {src.port for src in self.net.drivers.values()
                  if not isinstance(src, str) and src.instance == m and src not in self.ahead}
        return waited | {src.port for src in self.net.outputs.values() if src.instance == m}

    def mac_tie(self, m: str, ind: str) -> list[str]:
        """A guest's bundle when its engine is the host's: no request, zero operands."""
        zero = {"req": "1'b0", "a": "{MAC_A_W{1'b0}}", "b": "{MAC_B_W{1'b0}}", "na": "4'd0", "nb": "4'd0"}
        return [f"{ind}assign {_v(m)}_mac_{sig} = {zero[sig]};" for _, sig, _ in MAC_PORTS]

    # ---- the members ----
    def member_decls(self, m: str) -> list[str]:
        v = _v(m)
        block = self.chain.members[m]
        w_ovf = self.design.ovf_width(v)
        out = [f"    // ---- {m} ----", f"    reg started_{v}, done_{v};", f"    wire {v}_out_valid;",
               f"    wire [{w_ovf - 1}:0] {v}_ovf;", f"    reg  [{w_ovf - 1}:0] {v}_ovf_q;"]
        for p in sorted(self.captured(m)):
            w = block.outputs[p].wl
            out += [f"    wire {_vec(w)}{v}_{p};", f"    reg  {_vec(w)}{v}_{p}_q;"]
        for src in self.ahead:   # read ahead: the word taken as the chain accepts the sample
            if src.instance == m:
                w = block.outputs[src.port].wl
                out += [f"    wire {_vec(w)}{v}_{src.port}_next;", f"    reg  {_vec(w)}{v}_{src.port}_ahead_q;",
                        f"    always @(posedge clk) if (accept) {v}_{src.port}_ahead_q <= {v}_{src.port}_next;"]
        if self.ready(m):
            out.append(f"    wire {v}_in_ready;")
        if m in self.on_mac:
            out += [f"    wire {w}{v}_mac_{sig};" for _, sig, w in MAC_PORTS]
        deps = [f"done_{_v(s)}" for s in self.deps(m)] + ([f"{v}_in_ready"] if self.ready(m) else [])
        out.append(f"    wire want_{v} = " + " & ".join(["busy", f"~started_{v}"] + deps) + ";")
        out.append(f"    always @(posedge clk) if ({v}_out_valid) begin")
        out += [f"        {v}_{p}_q <= {v}_{p};" for p in sorted(self.captured(m))]
        out += [f"        {v}_ovf_q <= {v}_ovf;", "    end"]
        return out

    def go_lines(self) -> list[str]:
        """Each member's start: it wants to (what drives it is ready, and its in_ready), and on the
        shared multiplier (ARCH = 1) no other member works on it and none earlier in the order wants to;
        a shared set's guest starts with its host (the engine runs its pass after the host's)."""
        out = ["    // ---- starts: what drives a member is ready; ARCH = 1: one member at a time on the shared",
               "    // multiplier (the earlier in the execution order first); a shared set's guest with its host;",
               "    // the member's in_valid is its start registered (go_*_q) ----"]
        set_guest = {s.guest: s.host for s in self.shares.values() if s.kind == "set"}
        if self.on_mac:
            out.append("    wire mac_busy = " + " | ".join(f"on_mac_{_v(u)}" for u in self.on_mac) + ";")
        ahead: list[str] = []
        for m in self.order:
            v = _v(m)
            if m in self.on_mac:
                asks = f"want_{v}" if m not in set_guest else f"(want_{v} & (SHARE == 0))"
                cond = f"want_{v} & ((ARCH == 0) | (~mac_busy" + "".join(f" & ~{a}" for a in ahead) + "))"
                if m in set_guest:
                    cond = f"(SHARE != 0) ? go_{_v(set_guest[m])} : ({cond})"
                if m != self.on_mac[-1]:   # a later member on the multiplier waits for it
                    out.append(f"    wire ask_{v} = {asks};")
                    ahead.append(f"ask_{v}")
            else:
                cond = f"want_{v}"
            out.append(f"    wire go_{v} = {cond};")
        # the in_valid pulses registered: the arbitration above is one path to a register, not into each
        # block's first stage (a cycle per member, paid for 40 MHz)
        out.append("    reg " + ", ".join(f"go_{_v(m)}_q" for m in self.order) + ";")
        out.append("    always @(posedge clk) begin")
        out += [f"        go_{_v(m)}_q <= ~rst & go_{_v(m)};" for m in self.order]
        out.append("    end")
        return out

    def unused_ties(self, m: str) -> list[str]:
        """The connections tying off a member's auxiliary channel and second set (not shared here)."""
        return tie_offs(self.inst[_v(m)], mac=False, used=("ahead",))   # instance_text connects those

    def member_body(self, m: str) -> list[str]:
        """The instance of a member that is neither a host nor a guest of a shared engine."""
        return self.instance_text(m, [], self.unused_ties(m), self.outs(m))

    def shared_body(self, share) -> list[str]:
        """A host and its guest: in the serial variant (SHARE) one engine, the guest's outputs the
        host's second set (``set``) or auxiliary channel (``aux``); else two instances."""
        from fxdsp.hdl.params import instance, literal
        from fxdsp.hdl.sharing import set_parameters

        h, g = share.host, share.guest
        hv, gv = _v(h), _v(g)
        if share.kind == "set":
            hinst = instance(self.design, hv)
            extra = [", .SETS(2), .SETS_FILE(\"" + share.file + "\")",
                     ", " + ", ".join(f".{k}({literal(hinst, k[:-2], val)})"
                                      for k, val in set_parameters(self.design, share).items())]
            ties = [f".out_valid_1({gv}_out_valid)", f".y_1({self.outs(g).get('y', '')})", f".ovf_1({gv}_ovf)",
                    *tie_offs(self.inst[hv], mac=False, used=("second_set", "ahead"))]
            unused = (f"go_{gv}_q ^ own[{self.bundles.index(g)}];   // the guest's pass is the host's (its start, "
                      "its products on the host's bundle)")
            what = "its second coefficient set"
        else:
            extra = [", .AUX_LPF(SHARE), .AUX_COEF_FILE(\"" + share.file + "\")"]
            ties = [f".aux_in_valid(go_{gv}_q)", f".aux_x({self.src(g, 'x')})", f".aux_out_valid({gv}_out_valid)",
                    f".aux_y({self.outs(g).get('y', '')})", f".aux_ovf({gv}_ovf)",
                    *tie_offs(self.inst[hv], mac=False, used=("aux", "ahead"))]
            unused = f"own[{self.bundles.index(g)}];   // the channel's products are the host's (its bundle)"
            what = "the filter engine's third channel"
        shared = [f"    // ---- {g} on {h}'s engine in the serial variant ({what}, coefficient sets in {share.file}) ----",
                  "    generate", f"    if (SHARE != 0) begin : g_{hv}_shared"]
        shared += self.instance_text(h, extra, ties, self.outs(h), "    ")
        if self.ready(g):
            shared.append(f"        assign {gv}_in_ready = {hv}_in_ready;")
        shared += self.mac_tie(g, "        ")
        shared += ["        /* verilator lint_off UNUSEDSIGNAL */", f"        wire unused_{gv} = {unused}",
                   "        /* verilator lint_on UNUSEDSIGNAL */"]
        apart = [f"    end else begin : g_{hv}_apart"]
        apart += self.instance_text(h, [], self.unused_ties(h), self.outs(h), "    ")
        apart += self.member_body(g)
        return shared + apart + ["    end", "    endgenerate"]

    def mac_lines(self) -> list[str]:
        """The one multiplier of the serial members (ARCH = 1): the request selects the operands (at most
        one at a time: the starts above), out_valid goes to the member that works on the multiplier
        (``own``: started and its result not yet captured, or its guest's pass: registers only, so the
        product's route back does not hang on the request path); each member keeps its own limb
        counts (VAR_N = 1), so its schedule is that of a multiplier of its own."""
        if not self.on_mac:
            return []
        n = len(self.bundles)
        vs = [_v(m) for m in self.bundles]
        a_w, b_w = self.mac_width()
        guests = {m: [s.guest for s in self.shares.values() if s.host == m] for m in self.bundles}

        def owner(m: str) -> str:
            return " | ".join([f"on_mac_{_v(m)}"] + [f"((SHARE != 0) & on_mac_{_v(g)})" for g in guests[m]])
        def sel(sig: str, w: str) -> str:
            return " | ".join(f"({{{w}{{{v}_mac_req}}}} & {v}_mac_{sig})" for v in vs)
        out = ["    // ---- the one multiplier of the serial members (ARCH = 1): the request selects the operands,",
               "    // out_valid goes to the member working on it (own: started, result not yet captured; a host",
               "    // also for its guest's pass); each keeps its own limb counts (VAR_N = 1). Users, bit i of own: "
               + ", ".join(f"{i} {m}" for i, m in enumerate(self.bundles)) + " ----",
               f"    localparam integer MAC_A_W = {a_w};   // the members' widest operands, in whole 16-bit limbs",
               f"    localparam integer MAC_B_W = {b_w};",
               "    wire sh_ready, sh_valid;", "    wire [MAC_A_W+MAC_B_W-1:0] sh_p;",
               *(f"    wire on_mac_{v} = started_{v} & ~done_{v};" for v in vs),
               f"    wire [{n - 1}:0] own = {{" + ", ".join(owner(m) for m in reversed(self.bundles)) + "};",
               "    generate", "        if (ARCH != 0) begin : g_mac",
               f"            wire [{n - 1}:0] req = {{" + ", ".join(f"{v}_mac_req" for v in reversed(vs)) + "};",
               f"            wire [MAC_A_W-1:0] sh_a = {sel('a', 'MAC_A_W')};",
               f"            wire [MAC_B_W-1:0] sh_b = {sel('b', 'MAC_B_W')};",
               f"            wire [3:0] sh_na = {sel('na', '4')};",
               f"            wire [3:0] sh_nb = {sel('nb', '4')};",
               "            fx_mac_serial #(.A_W(MAC_A_W), .B_W(MAC_B_W), .VAR_N(1)) u_mac (.clk(clk), .rst(rst),",
               "                .in_valid(|req), .in_ready(sh_ready), .a(sh_a), .b(sh_b), .na(sh_na), .nb(sh_nb),",
               "                .out_valid(sh_valid), .p(sh_p));",
               "            // two requests at once would be a scheduling error (one product lost): proven never to",
               "            // happen (fxdsp.hdl.formal, make formal); a simulation stops on it",
               "`ifdef FORMAL",
               f"            always @* if (!rst) one_request: assert((req & (req - {n}'d1)) == {n}'d0);",
               "`else",
               "`ifndef SYNTHESIS",
               "            always @(posedge clk) begin",
               f"                if (!rst && (req & (req - {n}'d1)) != {n}'d0) begin",
               f'                    $display("{self.name}: members %b request the shared multiplier at once", req);',
               "                    $finish;", "                end", "            end",
               "`endif",
               "`endif",
               "        end else begin : g_no_mac",
               "            // one-sample-per-clock members: no shared multiplier, the bundles are idle",
               "            assign sh_ready = 1'b0;", "            assign sh_valid = 1'b0;",
               "            assign sh_p = {(MAC_A_W+MAC_B_W){1'b0}};",
               "            /* verilator lint_off UNUSEDSIGNAL */",
               "            wire unused_mac = " + " ^ ".join(f"(^{{{v}_mac_req, {v}_mac_a, {v}_mac_b, {v}_mac_na, "
                                                          f"{v}_mac_nb}})" for v in vs) + ";",
               "            /* verilator lint_on UNUSEDSIGNAL */",
               "        end", "    endgenerate"]
        return out


    def formal_lines(self) -> list[str]:
        """The members' contracts for the formal proofs (:mod:`fxdsp.hdl.formal`), read only under
        FORMAL: each member answers only a sample it took (out_valid only while one is in flight)
        and requests the multiplier only while it, or the guest on its engine, has one in flight.
        Each is proven of the block on its own; the top's proof with its members cut
        (FXDSP_CUT_MEMBERS) assumes them, a proof with the members in place asserts them."""
        vs = [_v(m) for m in self.members]
        guest_of = {s.host: s.guest for s in self.shares.values()}

        def take(m: str) -> str:
            return f"go_{_v(m)}_q" + (f" & {_v(m)}_in_ready" if self.ready(m) else "")

        rules = []
        for m in self.members:
            v = _v(m)
            rules.append(f"{{kind}}(!{v}_out_valid || fv_pend_{v});")
            if m in self.on_mac and m not in self.shares:   # a guest's bundle is tied off when shared
                also = f" || ((SHARE != 0) & fv_pend_{_v(guest_of[m])})" if m in guest_of else ""
                rules.append(f"{{kind}}(!{v}_mac_req || fv_pend_{v}{also});")
        out = ["`ifdef FORMAL",
               "    // ---- the members' contracts (fxdsp.hdl.formal): out_valid only for a sample the member took, a",
               "    // multiplier request only while it (or the guest on its engine) has one in flight; proven of each",
               "    // block on its own, assumed of cut members (FXDSP_CUT_MEMBERS), asserted of members in place ----",
               "    reg " + ", ".join(f"fv_pend_{v}" for v in vs) + ";",
               "    always @(posedge clk) begin",
               "        if (rst) begin",
               *(f"            fv_pend_{v} <= 1'b0;" for v in vs),
               "        end else begin",
               *(f"            if ({take(m)}) fv_pend_{_v(m)} <= 1'b1; else if ({_v(m)}_out_valid) fv_pend_{_v(m)} <= 1'b0;"
                 for m in self.members),
               "        end",
               "    end",
               *self._formal_invariants(),
               "`ifdef FXDSP_CUT_MEMBERS",
               "    always @* if (!rst) begin",
               *(f"        {r.format(kind='assume')}" for r in rules),
               "    end",
               "`else",
               "    always @* if (!rst) begin",
               *(f"        {r.format(kind='assert')}" for r in rules),
               "    end",
               "`endif",
               "`endif"]
        return out


    def _formal_invariants(self) -> list[str]:
        """The top's own bookkeeping, asserted in every proof (an induction proof needs them: they rule
        out states no reset reaches): idle, nothing is started or done; a member's registered start
        goes to a member started, not done, not yet in flight; a member in flight was started and is
        not done; at most one engine works on the multiplier (a guest's pass is its host's)."""
        vs = [_v(m) for m in self.members]
        # an engine's use: ``own`` of mac_lines (a member's, and in the serial variant its guest's pass),
        # but a guest's own bit not when its pass is its host's
        users = [f"own[{i}]" + (" & (SHARE == 0)" if m in self.shares else "") for i, m in enumerate(self.bundles)]
        n = len(users)
        out = [f"    wire [{n - 1}:0] fv_users = {{" + ", ".join(f"({u})" for u in reversed(users)) + "};"] if n > 1 else []
        out += ["    always @* if (!rst) begin",
               "        idle_means_nothing_started: assert(busy || !(" + " | ".join(f"started_{v} | done_{v}" for v in vs) + "));"]
        for v in vs:
            out.append(f"        {v}_in_flight_was_started: assert(!fv_pend_{v} || (started_{v} & ~done_{v}));")
            out.append(f"        {v}_done_was_started: assert(!done_{v} || started_{v});")
            out.append(f"        {v}_start_on_its_way: assert(!go_{v}_q || (started_{v} & ~done_{v} & ~fv_pend_{v}));")
        for sh in self.shares.values():   # a second coefficient set starts with its host
            if sh.kind == "set":
                g, h = _v(sh.guest), _v(sh.host)
                out.append(f"        {g}_starts_with_{h}: assert((SHARE == 0) || (started_{g} == started_{h}));")
        if n > 1:
            out.append(f"        one_member_on_the_multiplier: assert((fv_users & (fv_users - {n}'d1)) == {n}'d0);")
        return out + ["    end"]


def chain_top(design: Design, name: str) -> str:
    """The Verilog-2005 text of chain ``name``'s generated top."""
    t = _Top(design, name)
    net, chain, members = t.net, t.chain, t.members
    n_ovf = design.ovf_width(name)
    has_div = has_divider(design, name)
    share_words = "; ".join(f"{s.guest} on {s.host}'s engine ({'second coefficient set' if s.kind == 'set' else 'third filter channel'})"
                            for s in t.shares.values()) or "none"
    lines = [f"// {name}: generated by fxdsp hdl-gen from the config's [{net.name}]; do not edit.",
             "//   " + "; ".join(f"{net.drivers[d] if isinstance(net.drivers[d], Endpoint) else 'in ' + net.drivers[d]}"
                                 f" -> {d}" for d in net.drivers),
             "//   outputs: " + ", ".join(f"{e} -> {o}" for o, e in net.outputs.items()),
             "// One sample in flight: accepted on in_valid && in_ready (in_ready high while idle, also in the",
             "// cycle of out_valid); each member starts (its in_valid a cycle later, registered) when what drives",
             "// it is ready and its result is captured on its out_valid; out_valid one cycle after the last result. Roundings and",
             "// overflows (floor / half_up / half_even / toward_zero; wrap / saturate) are each block's,",
             "// from its header. ovf = {" + ", ".join(_v(m) for m in reversed(members)) + "} (bit 0 first: "
             + _v(members[0]) + f"), {n_ovf} flags, valid with out_valid.",
             "// ARCH = 0: every member in its one-sample-per-clock variant. ARCH = 1: its serial variant, every",
             "// member with a multiplier bundle on ONE shared fx_mac_serial (one SB_MAC16), one at a time;",
             f"// shared engines (ARCH = 1): {share_words}.",
             *([f"// own multipliers (own_multiplier: beside the shared one, not taking turns): {', '.join(net.own_multiplier)}."]
               if net.own_multiplier else []),
             *(["// read ahead (taken as the chain accepts the sample, not waiting for the member's pass): "
                + ", ".join(f"{src} (port {port})" for src, port in t.ahead.items()) + "."] if t.ahead else []),
             *_schedule_lines(design, name),
             "`default_nettype none", "", f"module {name} #(",
             "    parameter integer ARCH = 0" + ("," if has_div else "")
             + "   // 0: one-sample-per-clock members; 1: their serial variants, one multiplier"]
    if has_div:
        lines.append("    parameter integer DIV_UNROLL = 1   // quotient bits per cycle of every sf_divide member")
    lines += [") (", "    input  wire clk,", "    input  wire rst,", "    input  wire in_valid,",
              "    output wire in_ready,"]
    ports = [f"    input  wire {_vec(f.wl)}{p}," for p, f in chain.inputs.items()]
    ports += ["    output reg  out_valid,"]
    ports += [f"    output wire {_vec(f.wl)}{p}," for p, f in chain.outputs.items()]
    ports += [f"    output wire [{n_ovf - 1}:0] ovf"]
    lines += ports + [");"]
    body = (["    // the serial variant's shared engines (fxdsp.hdl.sharing)",
             "    localparam integer SHARE = (ARCH != 0) ? 1 : 0;"] if t.shares else [])
    body += ["    reg busy;", "    assign in_ready = ~busy;", "    wire accept = in_valid & ~busy;"]
    for p, f in chain.inputs.items():
        body.append(f"    reg {_vec(f.wl)}in_{p}_q;")
    body.append("    always @(posedge clk) if (accept) begin")
    body += [f"        in_{p}_q <= {p};" for p in chain.inputs]
    body.append("    end")
    for m in members:
        body += t.member_decls(m)
    body += t.mac_lines()
    body += t.go_lines()
    for m in members:
        if m in t.shares:
            continue
        if m in t.hosted:
            body += t.shared_body(t.hosted[m])
        else:
            body += t.member_body(m)

    all_done = " & ".join(f"done_{_v(m)}" for m in members)
    body += ["    // ---- the sample's progress: started / done per member, cleared as the sample leaves ----",
             f"    wire all_done = {all_done};",
             "    always @(posedge clk) begin",
             "        if (rst) begin",
             "            busy <= 1'b0;", "            out_valid <= 1'b0;"]
    body += [f"            started_{_v(m)} <= 1'b0; done_{_v(m)} <= 1'b0;" for m in members]
    body += ["        end else begin", "            out_valid <= 1'b0;",
             "            if (accept) busy <= 1'b1;",
             "            if (busy && all_done) begin",
             "                out_valid <= 1'b1;", "                busy <= 1'b0;"]
    body += [f"                started_{_v(m)} <= 1'b0; done_{_v(m)} <= 1'b0;" for m in members]
    body += ["            end else begin"]
    body += [f"                if (go_{_v(m)}) started_{_v(m)} <= 1'b1;\n"
             f"                if ({_v(m)}_out_valid) done_{_v(m)} <= 1'b1;" for m in members]
    body += ["            end", "        end", "    end"]
    for p, e in net.outputs.items():
        body.append(f"    assign {p} = {_v(e.instance)}_{e.port}_q;")
    body.append("    assign ovf = {" + ", ".join(f"{_v(m)}_ovf_q" for m in reversed(members)) + "};")
    body += t.formal_lines()
    text = "\n".join(lines + body + ["endmodule", "", "`default_nettype wire", ""])
    _check_port_names(net, text)
    return text


def _check_port_names(net, text: str) -> None:
    """Every chain port must be free to be a port of the top: not a reserved word, not one of the
    top's own ports or of the names it declares (``busy``, ``go_<member>``, ``u_<member>`` ...);
    otherwise an InputError naming the chain's line (the model runs any name, the RTL cannot)."""
    declared = set(_FIXED_PORTS) | set(_INSTANCE.findall(text))
    for rest in _DECLARATION.findall(text):   # "reg [3:0] a, b" / "wire x = ..." / "parameter integer N = 1"
        head = re.sub(r"\[[^\]]*\]|\b(?:signed|integer)\b", " ", rest.split("=")[0])
        declared |= {n.strip() for n in head.split(",") if n.strip().isidentifier()}
    for field, names in (("inputs", net.inputs), ("outputs", net.outputs)):
        for p in names:
            why = ("a Verilog / SystemVerilog reserved word" if p in RESERVED_WORDS else
                   "a name the generated top uses itself" if p in declared else None)
            if why:
                raise InputError(f"{net.name}.{field}: chain {field[:-1]} {p!r} is {why}: its generated top "
                                 f"cannot have a port of that name; rename it")


# an unused multiplier bundle (a block on a multiplier of its own; MAC_A_W = MAC_B_W = 2: mac_p 4 bits)
MAC_TIE_OFFS = (".mac_in_valid()", ".mac_in_ready(1'b0)", ".mac_a()", ".mac_b()", ".mac_na()", ".mac_nb()",
                ".mac_out_valid(1'b0)", ".mac_p(4'd0)")


def tie_offs(inst, mac: bool = True, used: tuple[str, ...] = ()) -> list[str]:
    """The connections that tie off an instance's unused bundles (:class:`RtlPorts`), as a harness and
    a generated top write them (``mac``: the multiplier bundle too, for a block on a multiplier of its
    own; ``used``: the bundles the caller connects itself, "aux", "second_set" or "ahead")."""
    rtl, out = inst.rtl, []
    if mac and rtl.mac_bundle:
        out += list(MAC_TIE_OFFS)
    if rtl.aux and "aux" not in used:
        w = inst.ports["i"].format.wl
        out += [".aux_in_valid(1'b0)", f".aux_x({w}'d0)", ".aux_out_valid()", ".aux_y()", ".aux_ovf()"]
    if rtl.second_set and "second_set" not in used:
        out += [".out_valid_1()", ".y_1()", ".ovf_1()"]
    if rtl.reference:
        mapped = {rtl.port(p.name) for p in inst.inputs}
        out += [f".ref_phase({inst.block.datapath.phase_bits}'d0)"] if "ref_phase" not in mapped else []
        out += [".wave_in_valid(1'b0)", ".wave_out_valid()", ".wave_msin()"]
    if "ahead" not in used:
        out += [f".{port}()" for _, port in rtl.ahead]
    return out


def has_divider(design, name: str) -> bool:
    """Whether chain ``name``'s generated top has the DIV_UNROLL parameter (an sf_divide member)."""
    return any(design.instances[_v(m)].module == "sf_divide" for m in design.chains[name].netlist.instances)


def top_file(name: str) -> str:
    """The file of chain ``name``'s generated top."""
    return f"{name}.v"


def _top_chains(design: Design) -> list[str]:
    """The chains of the design whose members all have RTL (``design.hardware``): each has a top."""
    return [name for name in design.chains if design.instances[name].hardware]


def generated_top_files(design: Design) -> list[str]:
    """The generated tops' files, without their text (what a simulator's source list needs)."""
    return [top_file(name) for name in _top_chains(design)]


def generated_tops(design: Design) -> dict[str, str]:
    """``<chain>.v`` of every chain whose members all have RTL, with its text."""
    return {top_file(name): chain_top(design, name) for name in _top_chains(design)}
