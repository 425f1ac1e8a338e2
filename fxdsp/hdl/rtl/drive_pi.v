// drive_pi: one PI controller update of the drive loop (fxdsp.blocks.drive._pi_update), combinational.
//   integ' = integ + KI e;  out = R((KP e + integ') >> SHIFT)
//   conditional integration: when out > HI with e > 0, or out < LO with e < 0, the integrator holds
//     (integ' = integ, out = R((KP e + integ) >> SHIFT)): no wind-up while the output is limited;
//   the integrator is then limited to LO << SHIFT .. HI << SHIFT (integ_lim) and the output to
//     LO .. HI (out_lim): the control law's designed clamps, always saturating (not overflows).
// R rounds by ROUNDING (0 floor, 1 half_up, 2 half_even, 3 toward_zero). The sums are exact in 64
// bits: the model proves |KP e| + |KI e| + |HI| << SHIFT < 2**62 (fxdsp.blocks.drive.Drive), so no
// overflow (no wrap / saturate) occurs inside. KP, KI, LO, HI: 64-bit two's-complement constants.
// Latency: combinational.
`default_nettype none

module drive_pi #(
    parameter integer E_W      = 26,      // the error e, signed
    parameter [63:0]  KP       = 64'd0,   // output LSBs per error LSB, x 2**SHIFT
    parameter [63:0]  KI       = 64'd0,
    parameter integer SHIFT    = 10,
    parameter [63:0]  LO       = 64'd0,   // output limits
    parameter [63:0]  HI       = 64'd0,
    parameter integer ROUNDING = 1
) (
    input  wire signed [E_W-1:0] e,
    input  wire signed [63:0]    integ,     // the integrator now
    output wire signed [63:0]    integ_n,   // the integrator after this update
    output wire signed [63:0]    out,       // LO .. HI
    output wire                  integ_lim,
    output wire                  out_lim
);
    // a rounded sum: fx_round's width for a right shift (the sums fit 63 bits, so 64 at SHIFT = 0)
    localparam integer RW = (SHIFT > 0) ? 65 - SHIFT : 64;
    localparam signed [63:0] KP_C = KP;
    localparam signed [63:0] KI_C = KI;
    localparam signed [63:0] LO_C = LO;
    localparam signed [63:0] HI_C = HI;
    localparam signed [63:0] LO_I = LO_C <<< SHIFT;     // the integrator's limits
    localparam signed [63:0] HI_I = HI_C <<< SHIFT;

    wire signed [63:0] ew = {{(64-E_W){e[E_W-1]}}, e};
    wire signed [63:0] pe = KP_C * ew;              // exact: the model's 63-bit proof
    wire signed [63:0] ie = KI_C * ew;
    wire signed [63:0] i1 = integ + ie;
    wire signed [63:0] s1 = pe + i1;                // with the integration
    wire signed [63:0] s0 = pe + integ;             // held
    wire signed [RW-1:0] o1, o0;
    fx_round #(.IN_W(64), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(RW)) u_r1 (.x(s1), .cin(1'b0), .y(o1));
    fx_round #(.IN_W(64), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(RW)) u_r0 (.x(s0), .cin(1'b0), .y(o0));
    wire signed [64:0] o1w = {{(65-RW){o1[RW-1]}}, o1};
    wire signed [64:0] o0w = {{(65-RW){o0[RW-1]}}, o0};
    wire signed [64:0] lo_w = {LO_C[63], LO_C};
    wire signed [64:0] hi_w = {HI_C[63], HI_C};
    wire e_pos = ~e[E_W-1] & (|e);
    wire e_neg = e[E_W-1];
    wire hold = ((o1w > hi_w) && e_pos) || ((o1w < lo_w) && e_neg);
    wire signed [63:0] ic = hold ? integ : i1;
    wire signed [64:0] oc = hold ? o0w : o1w;
    assign integ_lim = (ic > HI_I) || (ic < LO_I);
    assign integ_n = (ic > HI_I) ? HI_I : (ic < LO_I) ? LO_I : ic;
    assign out_lim = (oc > hi_w) || (oc < lo_w);
    /* verilator lint_off UNUSEDSIGNAL */   // the top bit: within LO .. HI after the clamp
    wire signed [64:0] oo = (oc > hi_w) ? hi_w : (oc < lo_w) ? lo_w : oc;
    /* verilator lint_on UNUSEDSIGNAL */
    assign out = oo[63:0];
endmodule

`default_nettype wire
