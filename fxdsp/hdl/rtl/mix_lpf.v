// mix_lpf: the per-sample half of a synchronous detector (fxdsp.blocks.demod's mixers and low-pass
// filters, which the drive loop's phase detector reuses), one sample per cycle: on in_valid,
//   i = fit(R(x cos >> MIX_SHIFT)), q = fit(R(x msin >> MIX_SHIFT)) into DATA_W bits (the factor 2
//   of 2 x cos is in MIX_SHIFT: the product read one fraction bit coarser), R by ROUNDING (0 floor,
//   1 half_up, 2 half_even, 3 toward_zero), the fit by OVERFLOW (0 wrap, 1 saturate);
//   then one iir low-pass per channel (LPF_*: its own LPF_ROUNDING / LPF_OVERFLOW).
// cos and msin are the NCO's words of the sample (NCO_W bits, read combinationally by the caller).
// Outputs with out_valid one cycle after in_valid (the iir's latency): li, lq and
// ovf = {lpf_q[LPF_SECTIONS], lpf_i[LPF_SECTIONS], mix_q, mix_i} of that sample. rst clears the
// filters' state (the model's reset). Latency: 1 cycle.
`default_nettype none

module mix_lpf #(
    parameter integer IN_W          = 24,
    parameter integer NCO_W         = 23,
    parameter integer DATA_W        = 24,
    parameter integer MIX_SHIFT     = 20,   // x * nco -> data, read as 2 x nco
    parameter integer ROUNDING      = 1,
    parameter integer OVERFLOW      = 1,
    parameter integer LPF_SECTIONS  = 1,
    parameter integer LPF_COEF_W    = 35,
    parameter integer LPF_ACOEF_W   = 39,
    parameter integer LPF_SHIFT_B   = 0,
    parameter integer LPF_SHIFT_A   = 4,
    parameter integer LPF_OUT_SHIFT = 37,
    parameter integer LPF_ACC_W     = 64,
    parameter integer LPF_ROUNDING  = 1,
    parameter integer LPF_OVERFLOW  = 1,
    parameter         LPF_COEF_FILE  = "demod_lpf_coef.hex",
    parameter         LPF_ACOEF_FILE = "demod_lpf_acoef.hex"   // the serial iir's words (not read here)
) (
    input  wire                      clk,
    input  wire                      rst,
    input  wire                      in_valid,
    input  wire [IN_W-1:0]           x,
    input  wire [NCO_W-1:0]          cos_i,
    input  wire [NCO_W-1:0]          msin_i,
    output wire                      out_valid,
    output wire [DATA_W-1:0]         li,
    output wire [DATA_W-1:0]         lq,
    output wire [2*LPF_SECTIONS+1:0] ovf
);
    localparam integer MW = IN_W + NCO_W;

    wire signed [MW-1:0] pi_ = $signed(x) * $signed(cos_i);
    wire signed [MW-1:0] pq_ = $signed(x) * $signed(msin_i);
    wire [DATA_W-1:0] mi, mq;
    wire ovf_mi, ovf_mq;
    fx_convert #(.IN_W(MW), .SHIFT(MIX_SHIFT), .ROUNDING(ROUNDING), .OUT_W(DATA_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_mix_i (.x(pi_), .cin(1'b0), .y(mi), .ovf(ovf_mi));
    fx_convert #(.IN_W(MW), .SHIFT(MIX_SHIFT), .ROUNDING(ROUNDING), .OUT_W(DATA_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_mix_q (.x(pq_), .cin(1'b0), .y(mq), .ovf(ovf_mq));
    reg [1:0] ovf_mix_d;                  // the mixers' flags of the sample in the low-pass
    always @(posedge clk) if (in_valid) ovf_mix_d <= {ovf_mq, ovf_mi};

    wire [LPF_SECTIONS-1:0] ovf_li, ovf_lq;
    /* verilator lint_off UNUSEDSIGNAL */
    wire lv_q;                            // the same cycle as out_valid
    /* verilator lint_on UNUSEDSIGNAL */
    iir #(.DATA_W(DATA_W), .SECTIONS(LPF_SECTIONS), .COEF_W(LPF_COEF_W), .ACOEF_W(LPF_ACOEF_W), .SHIFT_B(LPF_SHIFT_B),
          .SHIFT_A(LPF_SHIFT_A), .OUT_SHIFT(LPF_OUT_SHIFT), .ACC_W(LPF_ACC_W), .ROUNDING(LPF_ROUNDING),
          .OVERFLOW(LPF_OVERFLOW), .MAC_A_W(16), .MAC_B_W(16), .COEF_FILE(LPF_COEF_FILE), .ACOEF_FILE(LPF_ACOEF_FILE))
        u_lpf_i (.clk(clk), .rst(rst), .in_valid(in_valid), .in_ready(), .x(mi), .out_valid(out_valid), .y(li),
                 .ovf(ovf_li), .mac_in_valid(), .mac_in_ready(1'b0), .mac_a(), .mac_b(), .mac_na(), .mac_nb(),
                 .mac_out_valid(1'b0), .mac_p(32'd0));
    iir #(.DATA_W(DATA_W), .SECTIONS(LPF_SECTIONS), .COEF_W(LPF_COEF_W), .ACOEF_W(LPF_ACOEF_W), .SHIFT_B(LPF_SHIFT_B),
          .SHIFT_A(LPF_SHIFT_A), .OUT_SHIFT(LPF_OUT_SHIFT), .ACC_W(LPF_ACC_W), .ROUNDING(LPF_ROUNDING),
          .OVERFLOW(LPF_OVERFLOW), .MAC_A_W(16), .MAC_B_W(16), .COEF_FILE(LPF_COEF_FILE), .ACOEF_FILE(LPF_ACOEF_FILE))
        u_lpf_q (.clk(clk), .rst(rst), .in_valid(in_valid), .in_ready(), .x(mq), .out_valid(lv_q), .y(lq),
                 .ovf(ovf_lq), .mac_in_valid(), .mac_in_ready(1'b0), .mac_a(), .mac_b(), .mac_na(), .mac_nb(),
                 .mac_out_valid(1'b0), .mac_p(32'd0));
    assign ovf = {ovf_lq, ovf_li, ovf_mix_d};
endmodule

`default_nettype wire
