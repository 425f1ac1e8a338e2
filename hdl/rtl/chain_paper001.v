// chain_paper001: the paper 001 frequency path (fxdsp.chains.Paper001Chain), top level.
//   f -> freq2temp -> temp -> piecewise_bias001 -> q(T) ; rate_in - q(T) -> bias_subtract001 -> rate
// Parameters from the generated headers (`fxdsp hdl-gen`); roundings (floor / half_up / half_even /
// toward_zero) and overflows (wrap / saturate) are those of each block.
// Interface: in_valid / out_valid, fully pipelined (one sample per cycle, gaps allowed).
// Latency: 3 cycles. ovf = {bias_subtract001, piecewise_bias001, freq2temp}, valid with out_valid.
`default_nettype none

module chain_paper001 #(
`include "chain_paper001_params.vh"
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
    input  wire [FREQ_W-1:0] f,
    input  wire [RATE_W-1:0] rate_in,
    output wire              out_valid,
    output wire [TEMP_W-1:0] temp,
    output wire [OUT_W-1:0]  rate,
    output wire [N_OVF-1:0]  ovf
);
    wire              t_v;
    wire [TEMP_W-1:0] t_w;
    wire              ovf_t;
    freq2temp #(
`include "freq2temp_params.vh"
    ) u_f2t (.clk(clk), .rst(rst), .in_valid(in_valid), .f(f), .out_valid(t_v), .temp(t_w), .ovf(ovf_t));

    wire               b_v;
    wire [BIAS_W-1:0]  b_w;
    wire [B_OVF_W-1:0] ovf_b;
    piecewise #(
`include "piecewise_bias001_params.vh"
    ) u_bias (.clk(clk), .rst(rst), .in_valid(t_v), .temp(t_w), .out_valid(b_v), .y(b_w), .ovf(ovf_b));

    // rate_in, temp and the flags travel alongside the pipeline
    reg [RATE_W-1:0] rate_d1, rate_d2;
    reg [TEMP_W-1:0] temp_d2, temp_d3;
    reg              ovf_t_d2, ovf_t_d3;
    reg [B_OVF_W-1:0] ovf_b_d3;
    always @(posedge clk) begin
        if (in_valid) rate_d1 <= rate_in;
        if (t_v) begin rate_d2 <= rate_d1; temp_d2 <= t_w; ovf_t_d2 <= ovf_t; end
        if (b_v) begin temp_d3 <= temp_d2; ovf_t_d3 <= ovf_t_d2; ovf_b_d3 <= ovf_b; end
    end

    wire ovf_s;
    bias_subtract #(
`include "bias_subtract001_params.vh"
    ) u_sub (.clk(clk), .rst(rst), .in_valid(b_v), .x(rate_d2), .bias(b_w), .out_valid(out_valid), .y(rate),
             .ovf(ovf_s));
    assign temp = temp_d3;
    assign ovf  = {ovf_s, ovf_b_d3, ovf_t_d3};
endmodule

`default_nettype wire
