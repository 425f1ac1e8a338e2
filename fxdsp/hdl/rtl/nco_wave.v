// nco_wave: cos and -sin of one NCO phase word (fxdsp.blocks.demod._nco_wave), read by the
// demodulator's NCO (nco.v) and by the drive loop (drive.v), whose accumulator is its own. The top
// LUT_BITS phase bits are the bin (nco_phase): the quadrant (2 bits) and the index k of a
// quarter-wave sine table (QSIN_FILE: 2**(LUT_BITS-2) words of LUT_W bits, sin at the bin centres,
// quantised half_up / saturate by the generator). cos and -sin of the bin centre are +-qsin[k],
// +-qsin[~k] by quadrant (cb, mb). First-order interpolation removes the phase-truncation error: the
// next INTERP_BITS phase bits give the sub-bin centre delta (nco_phase), d = delta * TWO_PI (2 pi,
// TWO_PI_W bits), and
//   cos_o = cb + R(mb * d),   msin_o = mb + R(-cb * d),   R = >> CORR_SHIFT rounded by ROUNDING
// (d cos = -sin d phase, d(-sin) = -cos d phase; 0 floor, 1 half_up, 2 half_even, 3 toward_zero).
// The outputs are NCO_W = LUT_W + 1 bits, which the model proves they never exceed: no overflow
// (no wrap / saturate) and no fit point. INTERP_BITS = 0: the plain truncating table.
// Latency: combinational (the table is read at the phase's address).
`default_nettype none

module nco_wave #(
    parameter integer PHASE_BITS  = 48,   // phase word (turns * 2**PHASE_BITS)
    parameter integer LUT_BITS    = 12,   // bins per turn = 2**LUT_BITS (2 quadrant bits + index)
    parameter integer LUT_W       = 22,   // quarter-table word
    parameter integer INTERP_BITS = 12,   // phase bits below the bin that drive the interpolation
    parameter [63:0]  TWO_PI      = 64'd25736,
    parameter integer TWO_PI_W    = 16,
    parameter integer CORR_SHIFT  = 37,   // qsin * delta * TWO_PI -> table LSBs
    parameter integer NCO_W       = 23,   // output word: LUT_W + 1
    parameter integer ROUNDING    = 1,    // of the correction
    parameter         QSIN_FILE   = "demod_qsin.hex"
) (
    input  wire [PHASE_BITS-1:0] phase,
    output wire [NCO_W-1:0]      cos_o,
    output wire [NCO_W-1:0]      msin_o
);
    localparam integer QBITS = LUT_BITS - 2;
    localparam [TWO_PI_W-1:0] TWO_PI_C = TWO_PI[TWO_PI_W-1:0];
    localparam integer DLW = INTERP_BITS + 2;           // delta: odd, |delta| < 2**INTERP_BITS
    localparam integer DW  = DLW + TWO_PI_W + 1;        // d = delta * TWO_PI (TWO_PI > 0)
    localparam integer PW  = NCO_W + DW;                // correction product
    localparam integer CW  = PW - CORR_SHIFT + 1;       // rounded correction
    localparam integer SW  = ((CW > NCO_W) ? CW : NCO_W) + 1;

    generate
        if (NCO_W != LUT_W + 1) begin : g_bad_nco_w
            initial begin $display("nco_wave: NCO_W must be LUT_W + 1, got %0d, %0d", NCO_W, LUT_W); $finish; end
        end
    endgenerate

    reg [LUT_W-1:0] qsin [0:(1<<QBITS)-1];
    initial $readmemh(QSIN_FILE, qsin);

    // ---- bin centre: quadrant symmetry of the quarter table ----
    wire [1:0]       quad;
    wire [QBITS-1:0] k;
    wire signed [DLW-1:0] delta;          // the sub-bin centre (nco_phase), for the correction below
    nco_phase #(.PHASE_BITS(PHASE_BITS), .LUT_BITS(LUT_BITS), .INTERP_BITS(INTERP_BITS)) u_fields (
        .phase(phase), .quad(quad), .k(k), .delta(delta));
    wire [LUT_W-1:0] s_k  = qsin[k];
    wire [LUT_W-1:0] s_r  = qsin[~k];
    wire signed [NCO_W-1:0] sk = {s_k[LUT_W-1], s_k};
    wire signed [NCO_W-1:0] sr = {s_r[LUT_W-1], s_r};
    // cb: |sr| in even quadrants, |sk| in odd ones, negative in quadrants 1, 2;
    // mb: |sk| in even quadrants, |sr| in odd ones, negative in quadrants 0, 1
    wire signed [NCO_W-1:0] ca = quad[0] ? sk : sr;
    wire signed [NCO_W-1:0] ma = quad[0] ? sr : sk;
    wire signed [NCO_W-1:0] cb = (quad[1] ^ quad[0]) ? -ca : ca;
    wire signed [NCO_W-1:0] mb = quad[1] ? ma : -ma;

    // ---- first-order correction from the sub-bin offset ----
    wire signed [TWO_PI_W:0] twopi = {1'b0, TWO_PI_C};
    wire signed [DW-1:0] d  = delta * twopi;
    wire signed [PW-1:0] pc = mb * d;
    wire signed [NCO_W-1:0] ncb = -cb;                 // cb >= -max: fits
    wire signed [PW-1:0] pm = ncb * d;
    wire signed [CW-1:0] rc, rm;
    fx_round #(.IN_W(PW), .SHIFT(CORR_SHIFT), .ROUNDING(ROUNDING), .OUT_W(CW)) u_rc (.x(pc), .cin(1'b0), .y(rc));
    fx_round #(.IN_W(PW), .SHIFT(CORR_SHIFT), .ROUNDING(ROUNDING), .OUT_W(CW)) u_rm (.x(pm), .cin(1'b0), .y(rm));

    /* verilator lint_off UNUSEDSIGNAL */  // the top bit of the sums: the model proves it is a sign copy
    wire signed [SW-1:0] c_sum = {{(SW-NCO_W){cb[NCO_W-1]}}, cb} + {{(SW-CW){rc[CW-1]}}, rc};
    wire signed [SW-1:0] m_sum = {{(SW-NCO_W){mb[NCO_W-1]}}, mb} + {{(SW-CW){rm[CW-1]}}, rm};
    /* verilator lint_on UNUSEDSIGNAL */
    assign cos_o  = c_sum[NCO_W-1:0];
    assign msin_o = m_sum[NCO_W-1:0];
endmodule

`default_nettype wire
