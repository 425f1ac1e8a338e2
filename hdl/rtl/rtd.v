// rtd: RTD bridge ADC code -> temperature code (fxdsp.blocks.rtd).
// The code, read as offset binary, splits into a segment index (top LUT_INDEX_BITS bits) and a
// fraction (the low S = ADC_W - LUT_INDEX_BITS bits); the LUT (2**LUT_INDEX_BITS + 1 entries,
// LUT_FILE) gives exact = (L[i] << S) + (L[i+1] - L[i]) * frac, then one rounding by ROUNDING
// (floor / half_up / half_even / toward_zero) over SHIFT bits and one fit by OVERFLOW
// (wrap / saturate) into TEMP_W bits; ovf flags that fit.
// Interface: in_valid / out_valid, one sample per cycle. Latency: 1 cycle.
`default_nettype none

module rtd #(
    parameter integer ADC_W          = 16,
    parameter integer LUT_INDEX_BITS = 5,
    parameter integer LUT_W          = 26,
    parameter integer TEMP_W         = 18,
    parameter integer SHIFT          = 18,
    parameter integer ROUNDING       = 1,
    parameter integer OVERFLOW       = 1,
    parameter         LUT_FILE       = "rtd_lut.hex"
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
    input  wire [ADC_W-1:0]  code,
    output wire              out_valid,
    output wire [TEMP_W-1:0] temp,
    output wire              ovf
);
    localparam integer K  = LUT_INDEX_BITS;
    localparam integer S  = ADC_W - LUT_INDEX_BITS;
    localparam integer EW = LUT_W + S + 2;

    reg [LUT_W-1:0] lut [0:(1<<K)];
    initial $readmemh(LUT_FILE, lut);

    wire [ADC_W-1:0] u    = {~code[ADC_W-1], code[ADC_W-2:0]};   // offset binary
    wire [K-1:0]     idx  = u[ADC_W-1:S];
    wire [S-1:0]     frac = u[S-1:0];
    wire [K:0]       idx1 = {1'b0, idx} + {{K{1'b0}}, 1'b1};
    wire signed [LUT_W-1:0] base = lut[{1'b0, idx}];
    wire signed [LUT_W-1:0] nxt  = lut[idx1];
    wire signed [LUT_W:0]   diff = {nxt[LUT_W-1], nxt} - {base[LUT_W-1], base};
    wire signed [S:0]       fr   = {1'b0, frac};
    wire signed [EW-1:0]    prod = diff * fr;
    wire signed [EW-1:0]    be   = {{(EW-LUT_W){base[LUT_W-1]}}, base};
    wire signed [EW-1:0]    exact = (be <<< S) + prod;

    fx_convert_reg #(.IN_W(EW), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(TEMP_W), .OUT_SIGNED(1),
                     .OVERFLOW(OVERFLOW)) u_out (.clk(clk), .rst(rst), .in_valid(in_valid), .x(exact),
                                                 .out_valid(out_valid), .y(temp), .ovf(ovf));
endmodule

`default_nettype wire
