// freq2temp: resonator frequency word -> temperature (fxdsp.blocks.freq2temp).
//   d = f - F0 (exact, FREQ_W + 1 bits); T = fit(round(d * KINV)) with one rounding by ROUNDING
//   (floor / half_up / half_even / toward_zero) over SHIFT bits and one fit by OVERFLOW
//   (wrap / saturate) into TEMP_W bits; ovf flags the fit.
// F0 and KINV are 64-bit two's-complement constants (low FREQ_W / KINV_W bits used).
// Interface: in_valid / out_valid, one sample per cycle. Latency: 1 cycle.
`default_nettype none

module freq2temp #(
    parameter integer FREQ_W   = 32,
    parameter integer KINV_W   = 24,
    parameter integer TEMP_W   = 18,
    parameter [63:0]  F0       = 64'd1005969998,
    parameter [63:0]  KINV     = 64'd4890746,
    parameter integer SHIFT    = 27,
    parameter integer ROUNDING = 1,
    parameter integer OVERFLOW = 1
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
    input  wire [FREQ_W-1:0] f,
    output wire              out_valid,
    output wire [TEMP_W-1:0] temp,
    output wire              ovf
);
    localparam integer DW = FREQ_W + 1;
    localparam integer PW = DW + KINV_W;
    localparam [FREQ_W-1:0] F0_C   = F0[FREQ_W-1:0];
    localparam [KINV_W-1:0] KINV_C = KINV[KINV_W-1:0];

    wire signed [DW-1:0]     fe = {f[FREQ_W-1], f};
    wire signed [DW-1:0]     f0 = {F0_C[FREQ_W-1], F0_C};
    wire signed [DW-1:0]     d  = fe - f0;
    wire signed [KINV_W-1:0] kinv = KINV_C;
    wire signed [PW-1:0]     p  = d * kinv;

    fx_convert_reg #(.IN_W(PW), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(TEMP_W), .OUT_SIGNED(1),
                     .OVERFLOW(OVERFLOW)) u_out (.clk(clk), .rst(rst), .in_valid(in_valid), .x(p),
                                                 .out_valid(out_valid), .y(temp), .ovf(ovf));
endmodule

`default_nettype wire
