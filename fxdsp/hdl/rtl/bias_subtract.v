// bias_subtract: y = fit(round(x - bias)) (fxdsp.blocks.bias_subtract).
// The difference is exact (x << X_ALIGN, bias << B_ALIGN: aligned to the finer fraction length,
// one carry bit), then one rounding by ROUNDING (floor / half_up / half_even / toward_zero) over
// SHIFT bits and one fit by OVERFLOW (wrap / saturate) into OUT_W bits; ovf flags the fit.
// Interface: in_valid / out_valid, one sample per cycle. Latency: 2 cycles: the difference is
// registered before the rounding and the fit, so the subtractor's carry chain and the rounding
// adder's are not one path (together with the saturation they would set a generated top's Fmax).
`default_nettype none

module bias_subtract #(
    parameter integer IN_W     = 24,
    parameter integer BIAS_W   = 28,
    parameter integer OUT_W    = 24,
    parameter integer X_ALIGN  = 4,
    parameter integer B_ALIGN  = 0,
    parameter integer SHIFT    = 4,
    parameter integer ROUNDING = 1,
    parameter integer OVERFLOW = 1
) (
    input  wire             clk,
    input  wire             rst,
    input  wire             in_valid,
    input  wire [IN_W-1:0]  x,
    input  wire [BIAS_W-1:0] bias,
    output wire             out_valid,
    output wire [OUT_W-1:0] y,
    output wire             ovf
);
    localparam integer XW = IN_W + X_ALIGN;
    localparam integer BW = BIAS_W + B_ALIGN;
    localparam integer DW = ((XW > BW) ? XW : BW) + 1;

    wire signed [DW-1:0] xe = {{(DW-IN_W){x[IN_W-1]}}, x};
    wire signed [DW-1:0] be = {{(DW-BIAS_W){bias[BIAS_W-1]}}, bias};
    wire signed [DW-1:0] d  = (xe <<< X_ALIGN) - (be <<< B_ALIGN);

    // stage 1: the exact difference
    reg signed [DW-1:0] d_q;
    reg                 d_v;
    always @(posedge clk) begin
        if (rst) d_v <= 1'b0;
        else     d_v <= in_valid;
        if (in_valid) d_q <= d;
    end

    // stage 2: rounded and fitted into the output register
    fx_convert_reg #(.IN_W(DW), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(OUT_W), .OUT_SIGNED(1),
                     .OVERFLOW(OVERFLOW)) u_out (.clk(clk), .rst(rst), .in_valid(d_v), .x(d_q),
                                                 .out_valid(out_valid), .y(y), .ovf(ovf));
endmodule

`default_nettype wire
