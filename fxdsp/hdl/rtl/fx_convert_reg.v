// fx_convert_reg: fx_convert (one rounding by ROUNDING: floor / half_up / half_even / toward_zero; one
// fit by OVERFLOW: wrap / saturate, ovf flagged) followed by the output
// register every one-sample-per-cycle block ends with: y and ovf load on in_valid, out_valid
// follows in_valid, synchronous reset clears all three. Latency: 1 cycle.
`default_nettype none

module fx_convert_reg #(
    parameter integer IN_W       = 33,
    parameter integer SHIFT      = 0,
    parameter integer ROUNDING   = 1,
    parameter integer OUT_W      = 32,
    parameter integer OUT_SIGNED = 1,
    parameter integer OVERFLOW   = 1
) (
    input  wire                    clk,
    input  wire                    rst,
    input  wire                    in_valid,
    input  wire signed [IN_W-1:0]  x,
    output reg                     out_valid,
    output reg         [OUT_W-1:0] y,
    output reg                     ovf
);
    wire [OUT_W-1:0] y_c;
    wire             o_c;
    fx_convert #(.IN_W(IN_W), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(OUT_W), .OUT_SIGNED(OUT_SIGNED),
                 .OVERFLOW(OVERFLOW)) u_convert (.x(x), .cin(1'b0), .y(y_c), .ovf(o_c));

    always @(posedge clk) begin
        if (rst) begin
            out_valid <= 1'b0;
            y         <= {OUT_W{1'b0}};
            ovf       <= 1'b0;
        end else begin
            out_valid <= in_valid;
            if (in_valid) begin
                y   <= y_c;
                ovf <= o_c;
            end
        end
    end
endmodule

`default_nettype wire
