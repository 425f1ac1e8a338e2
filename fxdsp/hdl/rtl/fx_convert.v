// fx_convert: fx_round then fx_fit (mirrors fxdsp.fixed.kernels.convert): scale by
// 2**-SHIFT (rounded by ROUNDING if SHIFT > 0, exact if SHIFT <= 0), then fit into OUT_W
// bits by OVERFLOW (wrap / saturate), ovf flagged; CIN = 1: x + cin rounded (fx_round's carry in). Only a composition of the two shared
// primitives; it has no arithmetic of its own. Latency: combinational.
`default_nettype none

module fx_convert #(
    parameter integer IN_W       = 33,
    parameter integer SHIFT      = 0,
    parameter integer ROUNDING   = 1,
    parameter integer OUT_W      = 32,
    parameter integer OUT_SIGNED = 1,
    parameter integer OVERFLOW   = 1,
    parameter integer CIN        = 0     // 1: cin added before the rounding (fx_round CIN)
) (
    input  wire signed [IN_W-1:0]  x,
    input  wire                    cin,        // CIN = 1: added to x before the rounding
    output wire        [OUT_W-1:0] y,
    output wire                    ovf
);
    localparam integer RW0 = (SHIFT > 0) ? IN_W - SHIFT + 1 : IN_W - SHIFT;
    localparam integer RW  = (RW0 < 2) ? 2 : RW0;
    wire signed [RW-1:0] r;
    fx_round #(.IN_W(IN_W), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(RW), .CIN(CIN)) u_round (.x(x), .cin(cin), .y(r));
    fx_fit #(.IN_W(RW), .OUT_W(OUT_W), .OUT_SIGNED(OUT_SIGNED), .OVERFLOW(OVERFLOW)) u_fit (.x(r), .y(y), .ovf(ovf));
endmodule

`default_nettype wire
