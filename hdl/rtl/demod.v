// demod: synchronous demodulator (fxdsp.blocks.demod): nco (quarter-wave table with first-order
// interpolation, NCO_W-bit cos / -sin), two mixers, two iir low-pass filters, CORDIC vectoring
// for amplitude and phase.
//   mixers: i = fit(round(x * cos >> MIX_SHIFT)), q = fit(round(x * msin >> MIX_SHIFT)) into
//     DATA_W bits (the factor 2 is in MIX_SHIFT: the product read one fraction bit coarser);
//   low-pass: iir with the LPF_* parameters, one per channel;
//   CORDIC (ITERATIONS steps, combinational): pre-rotation by +-90 deg (HALF_PI) into the right
//     half plane, then shift-and-add with arithmetic right shifts (floor) in DATA_W + 2 guard
//     bits, the angle accumulated from ATAN_FILE (ANGLE_W bits);
//   amp = fit(round(x_K * INV_K >> AMP_SHIFT)) into DATA_W bits; phase = the angle accumulator.
// Every rounding by ROUNDING (floor / half_up / half_even / toward_zero), every fit by OVERFLOW
// (wrap / saturate), flagged in ovf = {amp, lpf_q[LPF_SECTIONS], lpf_i[LPF_SECTIONS], mix_q, mix_i}.
// PHASE_TRIM: the NCO reference's rotation (nco.v), 0 = none.
// Interface: in_valid / out_valid, one sample per cycle; the NCO and filter states advance only on
// in_valid, rst returns them to reset. Latency: 2 cycles (i, q delayed to align with amp, phase).
`default_nettype none

module demod #(
    parameter integer IN_W          = 24,
    parameter integer DATA_W        = 24,
    parameter integer PHASE_BITS    = 48,
    parameter integer LUT_BITS      = 12,
    parameter integer LUT_W         = 22,
    parameter integer INTERP_BITS   = 12,
    parameter [63:0]  TWO_PI        = 64'd25736,
    parameter integer TWO_PI_W      = 16,
    parameter integer CORR_SHIFT    = 37,
    parameter integer NCO_W         = 23,
    parameter [63:0]  FTW           = 64'd23456248059221,
    parameter [63:0]  PHASE0        = 64'd0,
    parameter [63:0]  PHASE_TRIM    = 64'd0,
    parameter integer MIX_SHIFT     = 14,
    parameter integer ROUNDING      = 1,
    parameter integer OVERFLOW      = 1,
    parameter integer LPF_SECTIONS  = 1,
    parameter integer LPF_COEF_W    = 28,
    parameter integer LPF_SHIFT_B   = 0,
    parameter integer LPF_SHIFT_A   = 4,
    parameter integer LPF_OUT_SHIFT = 30,
    parameter integer LPF_ACC_W     = 57,
    parameter integer LPF_ROUNDING  = 1,
    parameter integer LPF_OVERFLOW  = 1,
    parameter integer ITERATIONS    = 16,
    parameter integer ANGLE_W       = 20,
    parameter [63:0]  HALF_PI       = 64'd205887,
    parameter [63:0]  INV_K         = 64'd79594,
    parameter integer INV_K_W       = 18,
    parameter integer AMP_SHIFT     = 17,
    parameter         QSIN_FILE     = "demod_qsin.hex",
    parameter         LPF_COEF_FILE = "demod_lpf_coef.hex",
    parameter         ATAN_FILE     = "demod_atan.hex"
) (
    input  wire                      clk,
    input  wire                      rst,
    input  wire                      in_valid,
    input  wire [IN_W-1:0]           x,
    output reg                       out_valid,
    output reg  [DATA_W-1:0]         i,
    output reg  [DATA_W-1:0]         q,
    output reg  [DATA_W-1:0]         amp,
    output reg  [ANGLE_W-1:0]        phase,
    output reg  [2*LPF_SECTIONS+2:0] ovf
);
    localparam integer MW = IN_W + NCO_W;
    localparam integer WW = DATA_W + 3;        // CORDIC work: DATA_W + 2 guard bits, + 1 spare
    localparam integer AW = ANGLE_W + 2;       // angle accumulator, never overflows the port
    localparam integer PW = WW + INV_K_W;

    // ---- NCO and mixers ----
    wire [NCO_W-1:0] cos_w, msin_w;
    nco #(.PHASE_BITS(PHASE_BITS), .LUT_BITS(LUT_BITS), .LUT_W(LUT_W), .INTERP_BITS(INTERP_BITS),
          .TWO_PI(TWO_PI), .TWO_PI_W(TWO_PI_W), .CORR_SHIFT(CORR_SHIFT), .NCO_W(NCO_W), .FTW(FTW),
          .PHASE0(PHASE0), .PHASE_TRIM(PHASE_TRIM), .ROUNDING(ROUNDING), .QSIN_FILE(QSIN_FILE)) u_nco
        (.clk(clk), .rst(rst), .step(in_valid), .cos_o(cos_w), .msin_o(msin_w));

    wire signed [MW-1:0] pi_ = $signed(x) * $signed(cos_w);
    wire signed [MW-1:0] pq_ = $signed(x) * $signed(msin_w);
    wire [DATA_W-1:0] mi, mq;
    wire ovf_mi, ovf_mq;
    fx_convert #(.IN_W(MW), .SHIFT(MIX_SHIFT), .ROUNDING(ROUNDING), .OUT_W(DATA_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_mix_i (.x(pi_), .y(mi), .ovf(ovf_mi));
    fx_convert #(.IN_W(MW), .SHIFT(MIX_SHIFT), .ROUNDING(ROUNDING), .OUT_W(DATA_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_mix_q (.x(pq_), .y(mq), .ovf(ovf_mq));
    reg [1:0] ovf_mix_d;
    always @(posedge clk) if (in_valid) ovf_mix_d <= {ovf_mq, ovf_mi};

    // ---- low-pass filters ----
    wire [DATA_W-1:0] li, lq;
    wire [LPF_SECTIONS-1:0] ovf_li, ovf_lq;
    wire lv, lv_q;
    iir #(.DATA_W(DATA_W), .SECTIONS(LPF_SECTIONS), .COEF_W(LPF_COEF_W), .SHIFT_B(LPF_SHIFT_B),
          .SHIFT_A(LPF_SHIFT_A), .OUT_SHIFT(LPF_OUT_SHIFT), .ACC_W(LPF_ACC_W), .ROUNDING(LPF_ROUNDING),
          .OVERFLOW(LPF_OVERFLOW), .COEF_FILE(LPF_COEF_FILE)) u_lpf_i
        (.clk(clk), .rst(rst), .in_valid(in_valid), .in_ready(), .x(mi), .out_valid(lv), .y(li), .ovf(ovf_li));
    iir #(.DATA_W(DATA_W), .SECTIONS(LPF_SECTIONS), .COEF_W(LPF_COEF_W), .SHIFT_B(LPF_SHIFT_B),
          .SHIFT_A(LPF_SHIFT_A), .OUT_SHIFT(LPF_OUT_SHIFT), .ACC_W(LPF_ACC_W), .ROUNDING(LPF_ROUNDING),
          .OVERFLOW(LPF_OVERFLOW), .COEF_FILE(LPF_COEF_FILE)) u_lpf_q
        (.clk(clk), .rst(rst), .in_valid(in_valid), .in_ready(), .x(mq), .out_valid(lv_q), .y(lq), .ovf(ovf_lq));

    // ---- CORDIC vectoring (combinational on the filter outputs) ----
    reg [ANGLE_W-1:0] atan [0:ITERATIONS-1];
    initial $readmemh(ATAN_FILE, atan);
    localparam [ANGLE_W-1:0] HALF_PI_C = HALF_PI[ANGLE_W-1:0];
    wire signed [AW-1:0] hpi = {{2{HALF_PI_C[ANGLE_W-1]}}, HALF_PI_C};

    wire signed [WW-1:0] xi = {{(WW-DATA_W){li[DATA_W-1]}}, li};
    wire signed [WW-1:0] yi = {{(WW-DATA_W){lq[DATA_W-1]}}, lq};
    wire signed [WW-1:0] x0 = ~xi[WW-1] ? xi : (~yi[WW-1] ? yi : -yi);
    wire signed [WW-1:0] y0 = ~xi[WW-1] ? yi : (~yi[WW-1] ? -xi : xi);
    wire signed [AW-1:0] z0 = ~xi[WW-1] ? {AW{1'b0}} : (~yi[WW-1] ? hpi : -hpi);
    // the arctan table as one flat vector (a procedural loop then reads it without an array)
    wire [ANGLE_W*ITERATIONS-1:0] atan_flat;
    genvar k;
    generate
        for (k = 0; k < ITERATIONS; k = k + 1) begin : g_atan
            assign atan_flat[ANGLE_W*k +: ANGLE_W] = atan[k];
        end
    endgenerate

    // the ITERATIONS shift-and-add steps, unrolled by the loop (one evaluation per new I/Q)
    reg signed [WW-1:0]  cx, cy, tx;
    reg signed [AW-1:0]  cz, at;
    reg [ANGLE_W-1:0]    atv;
    integer j;
    always @* begin
        cx = x0; cy = y0; cz = z0;
        tx = {WW{1'b0}}; at = {AW{1'b0}}; atv = {ANGLE_W{1'b0}};
        for (j = 0; j < ITERATIONS; j = j + 1) begin
            atv = atan_flat[ANGLE_W*j +: ANGLE_W];
            at  = {{2{atv[ANGLE_W-1]}}, atv};
            if (!cy[WW-1]) begin
                tx = cx + (cy >>> j);
                cy = cy - (cx >>> j);
                cz = cz + at;
            end else begin
                tx = cx - (cy >>> j);
                cy = cy + (cx >>> j);
                cz = cz - at;
            end
            cx = tx;
        end
    end

    localparam [INV_K_W-1:0] INV_K_C = INV_K[INV_K_W-1:0];
    wire signed [INV_K_W-1:0] invk = INV_K_C;
    wire signed [WW-1:0] xfin = cx;
    wire signed [PW-1:0] ap = xfin * invk;
    wire [DATA_W-1:0] amp_c;
    wire ovf_amp;
    fx_convert #(.IN_W(PW), .SHIFT(AMP_SHIFT), .ROUNDING(ROUNDING), .OUT_W(DATA_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_amp (.x(ap), .y(amp_c), .ovf(ovf_amp));
    /* verilator lint_off UNUSEDSIGNAL */
    wire signed [AW-1:0] zfin = cz;
    /* verilator lint_on UNUSEDSIGNAL */

    always @(posedge clk) begin
        if (rst) begin
            out_valid <= 1'b0;
            i <= {DATA_W{1'b0}}; q <= {DATA_W{1'b0}};
            amp <= {DATA_W{1'b0}}; phase <= {ANGLE_W{1'b0}};
            ovf <= {(2*LPF_SECTIONS+3){1'b0}};
        end else begin
            out_valid <= lv;
            if (lv) begin
                i <= li;
                q <= lq;
                amp <= amp_c;
                phase <= zfin[ANGLE_W-1:0];
                ovf <= {ovf_amp, ovf_lq, ovf_li, ovf_mix_d};
            end
        end
    end
    /* verilator lint_off UNUSEDSIGNAL */
    wire unused_ok = lv_q;
    /* verilator lint_on UNUSEDSIGNAL */
endmodule

`default_nettype wire
