// drive_pi: one PI controller update of the drive loop (fxdsp.blocks.drive._pi_update), on the
// products pe = KP e and ie = KI e (the caller's multipliers: drive.v ARCH = 0 its own, ARCH = 1
// the shared one), e for its sign:
//   integ' = integ + KI e;  out = R((KP e + integ') >> SHIFT)
//   conditional integration: when out > HI with e > 0, or out < LO with e < 0, the integrator holds
//     (integ' = integ, out = R((KP e + integ) >> SHIFT)): no wind-up while the output is limited;
//   the integrator is then limited to LO << SHIFT .. HI << SHIFT (integ_lim) and the output to
//     LO .. HI (out_lim): the control law's designed clamps, always saturating (not overflows).
// R rounds by ROUNDING (0 floor, 1 half_up, 2 half_even, 3 toward_zero). The sums are exact in 64
// bits: the model proves |KP e| + |KI e| + |HI| << SHIFT < 2**62 (fxdsp.blocks.drive.Drive), so no
// overflow (no wrap / saturate) occurs inside. LO, HI: 64-bit two's-complement constants.
// PIPE = 0: combinational. PIPE = 1: a register after each of five steps (the serial drive loop:
// one 64-bit carry chain per step), latency 5 cycles; the inputs (e, pe, ie, integ) must hold for
// the five cycles (the serial loop's registers do), so that only the steps' results are registered.
//   1: i1 = integ + ie, s0 = pe + integ;  2: s1 = s0 + ie (the same sum), R(s0);  3: R(s1);
//   4: the hold decision and the choice of (integ', out);  5: the clamps.
`default_nettype none

module drive_pi #(
    parameter integer E_W      = 26,      // the error e, signed
    parameter integer SHIFT    = 10,
    parameter [63:0]  LO       = 64'd0,   // output limits
    parameter [63:0]  HI       = 64'd0,
    parameter integer ROUNDING = 1,
    parameter integer PIPE     = 0        // 1: five register stages
) (
    input  wire                  clk,       // PIPE = 1
    input  wire signed [E_W-1:0] e,
    input  wire signed [63:0]    pe,        // KP e (output LSBs x 2**SHIFT), exact
    input  wire signed [63:0]    ie,        // KI e
    input  wire signed [63:0]    integ,     // the integrator now
    output wire signed [63:0]    integ_n,   // the integrator after this update
    output wire signed [63:0]    out,       // LO .. HI
    output wire                  integ_lim,
    output wire                  out_lim
);
    // a rounded sum: fx_round's width for a right shift (the sums fit 63 bits, so 64 at SHIFT = 0)
    localparam integer RW = (SHIFT > 0) ? 65 - SHIFT : 64;
    localparam signed [63:0] LO_C = LO;
    localparam signed [63:0] HI_C = HI;
    localparam signed [63:0] LO_I = LO_C <<< SHIFT;     // the integrator's limits
    localparam signed [63:0] HI_I = HI_C <<< SHIFT;
    wire signed [64:0] lo_w = {LO_C[63], LO_C};
    wire signed [64:0] hi_w = {HI_C[63], HI_C};

    // each step's values (_c) and what the next step reads (_p: registered at PIPE = 1)
    wire e_pos = ~e[E_W-1] & (|e);
    wire e_neg = e[E_W-1];
    // 1: the two sums on the integrator
    wire signed [63:0] i1_c = integ + ie;
    wire signed [63:0] s0_c = pe + integ;              // held
    wire signed [63:0] i1_p, s0_p;
    // 2: the sum with the integration, s1 = pe + integ + ie; the held one rounded
    wire signed [63:0] s1_c = s0_p + ie;
    wire signed [RW-1:0] o0_c;
    fx_round #(.IN_W(64), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(RW)) u_r0 (.x(s0_p), .cin(1'b0), .y(o0_c));
    wire signed [63:0] s1_p;
    wire signed [RW-1:0] o0_p;
    // 3: the integrated one rounded
    wire signed [RW-1:0] o1_c;
    fx_round #(.IN_W(64), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(RW)) u_r1 (.x(s1_p), .cin(1'b0), .y(o1_c));
    wire signed [RW-1:0] o1_p;
    // 4: conditional integration: hold when the output is limited in the direction the error pushes
    wire signed [64:0] o1w = {{(65-RW){o1_p[RW-1]}}, o1_p};
    wire signed [64:0] o0w = {{(65-RW){o0_p[RW-1]}}, o0_p};
    wire hold = ((o1w > hi_w) && e_pos) || ((o1w < lo_w) && e_neg);
    wire signed [63:0] ic_c = hold ? integ : i1_p;
    wire signed [64:0] oc_c = hold ? o0w : o1w;
    wire signed [63:0] ic;
    wire signed [64:0] oc;
    // 5: the clamps
    wire signed [63:0] in_c = (ic > HI_I) ? HI_I : (ic < LO_I) ? LO_I : ic;
    wire il_c = (ic > HI_I) || (ic < LO_I);
    wire ol_c = (oc > hi_w) || (oc < lo_w);
    /* verilator lint_off UNUSEDSIGNAL */   // the top bit: within LO .. HI after the clamp
    wire signed [64:0] oo_c = (oc > hi_w) ? hi_w : (oc < lo_w) ? lo_w : oc;
    /* verilator lint_on UNUSEDSIGNAL */

    generate
        if (PIPE != 0) begin : g_pipe
            reg signed [63:0] i1_r, s0_r, s1_r, ic_r, in_r, out_r;
            reg signed [RW-1:0] o0_r, o1_r;
            reg signed [64:0] oc_r;
            reg il_r, ol_r;
            always @(posedge clk) begin
                i1_r <= i1_c; s0_r <= s0_c;
                s1_r <= s1_c; o0_r <= o0_c;
                o1_r <= o1_c;
                ic_r <= ic_c; oc_r <= oc_c;
                in_r <= in_c; out_r <= oo_c[63:0]; il_r <= il_c; ol_r <= ol_c;
            end
            assign {i1_p, s0_p, s1_p, o0_p, o1_p, ic, oc} = {i1_r, s0_r, s1_r, o0_r, o1_r, ic_r, oc_r};
            assign {integ_n, out, integ_lim, out_lim} = {in_r, out_r, il_r, ol_r};
        end else begin : g_comb
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_clk = clk;
            /* verilator lint_on UNUSEDSIGNAL */
            assign {i1_p, s0_p, s1_p, o0_p, o1_p, ic, oc} = {i1_c, s0_c, s1_c, o0_c, o1_c, ic_c, oc_c};
            assign {integ_n, out, integ_lim, out_lim} = {in_c, oo_c[63:0], il_c, ol_c};
        end
    endgenerate
endmodule

`default_nettype wire
