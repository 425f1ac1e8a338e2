// fx_convert_pipe: fx_convert split over two registered stages, for the serial (ARCH = 1)
// datapaths at 40 MHz: the rounding adder (fx_round, by ROUNDING: floor / half_up / half_even /
// toward_zero) in one cycle, the range fit (fx_fit, by OVERFLOW: wrap / saturate, ovf flagged) in
// the next (CIN = 1: x + cin rounded, cin as fx_round's carry in). y and ovf load when the value
// reaches them and hold until the next one; out_valid is a one-cycle pulse. Synchronous reset clears the valid pipeline and the outputs.
// Interface: in_valid / out_valid, one value per cycle. Latency: 2 cycles.
`default_nettype none

module fx_convert_pipe #(
    parameter integer IN_W       = 33,   // bits of the signed input
    parameter integer SHIFT      = 0,    // scale by 2**-SHIFT (rounded if > 0, exact if <= 0)
    parameter integer ROUNDING   = 1,    // 0 floor, 1 half_up, 2 half_even, 3 toward_zero
    parameter integer OUT_W      = 32,   // bits of the output
    parameter integer OUT_SIGNED = 1,    // 1: signed output format, 0: unsigned
    parameter integer OVERFLOW   = 1,    // 0 wrap, 1 saturate
    parameter integer CIN        = 0     // 1: cin added before the rounding (fx_round CIN)
) (
    input  wire                    clk,
    input  wire                    rst,
    input  wire                    in_valid,
    input  wire signed [IN_W-1:0]  x,
    input  wire                    cin,        // CIN = 1: added to x before the rounding (fx_round's carry in)
    output reg                     out_valid,
    output reg         [OUT_W-1:0] y,
    output reg                     ovf
);
    localparam integer RW0 = (SHIFT > 0) ? IN_W - SHIFT + 1 : IN_W - SHIFT;
    localparam integer RW  = (RW0 < 2) ? 2 : RW0;   // fx_convert's width rule
    wire signed [RW-1:0] r_c;
    fx_round #(.IN_W(IN_W), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(RW), .CIN(CIN)) u_round (.x(x), .cin(cin), .y(r_c));
    reg signed [RW-1:0] r_q;
    reg                 r_v;
    wire [OUT_W-1:0] y_c;
    wire             o_c;
    fx_fit #(.IN_W(RW), .OUT_W(OUT_W), .OUT_SIGNED(OUT_SIGNED), .OVERFLOW(OVERFLOW)) u_fit
        (.x(r_q), .y(y_c), .ovf(o_c));

    always @(posedge clk) begin
        if (rst) begin
            r_v <= 1'b0; out_valid <= 1'b0; y <= {OUT_W{1'b0}}; ovf <= 1'b0;
        end else begin
            r_v <= in_valid;
            out_valid <= r_v;
            if (in_valid) r_q <= r_c;
            if (r_v) begin
                y   <= y_c;
                ovf <= o_c;
            end
        end
    end
endmodule

`default_nettype wire
