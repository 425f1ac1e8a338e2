// chain_paper001: the paper 001 frequency path (fxdsp.chains.Paper001Chain), top level.
//   f -> freq2temp -> temp -> piecewise_bias001 -> q(T) ; rate_in - q(T) -> bias_subtract001 -> rate
// Parameters from the generated headers (`fxdsp hdl-gen`); roundings (floor / half_up / half_even /
// toward_zero) and overflows (wrap / saturate) are those of each block.
// ovf = {bias_subtract001, piecewise_bias001, freq2temp}, valid with out_valid. Both
// architectures give the same outputs for every input.
// ARCH = 0: fully pipelined, one sample per cycle (gaps allowed); in_ready is tied high.
//   Latency: 3 cycles.
// ARCH = 1: serial, one sample in flight: freq2temp and piecewise_bias001 in their ARCH = 1
//   variants (one fx_mac_serial, one SB_MAC16, each), bias_subtract001 as one pipeline stage.
//   Interface: in_valid / in_ready / out_valid; in_ready is high when idle and in the cycle of
//   out_valid. Schedule: freq2temp (N1 + 7 cycles, 13 at the default), then piecewise
//   (ORDER (N2 + 10) + 7, 35), then the subtraction (1 cycle): 49 cycles per sample at the default
//   config (416 at 40 MHz and 96 kS/s). temp and the flags of the first two stages hold from their stage to out_valid.
`default_nettype none

module chain_paper001 #(
`include "chain_paper001_params.vh"
    ,
    parameter integer ARCH = 0   // 0: one sample per cycle; 1: serial, one sample in flight
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
    output wire              in_ready,  // ARCH = 1: low while a sample is in flight
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
    wire               b_v;
    wire [BIAS_W-1:0]  b_w;
    wire [B_OVF_W-1:0] ovf_b;
    wire ovf_s;
    wire accept;   // a sample enters freq2temp

    freq2temp #(
`include "freq2temp_params.vh"
        , .ARCH(ARCH)
    ) u_f2t (.clk(clk), .rst(rst), .in_valid(accept), .in_ready(), .f(f), .out_valid(t_v), .temp(t_w),
             .ovf(ovf_t));

    piecewise #(
`include "piecewise_bias001_params.vh"
        , .ARCH(ARCH), .MAC_A_W(2), .MAC_B_W(2)   // its own multiplier (EXT_MAC = 0): the bundle unused
    ) u_bias (.clk(clk), .rst(rst), .in_valid(t_v), .in_ready(), .temp(t_w), .out_valid(b_v), .y(b_w),
              .out_valid_1(), .y_1(), .ovf_1(),
              .ovf(ovf_b), .mac_in_valid(), .mac_in_ready(1'b0), .mac_a(), .mac_b(), .mac_na(), .mac_nb(),
              .mac_out_valid(1'b0), .mac_p(4'd0));

    generate
        if (ARCH == 0) begin : g_par
            assign in_ready = 1'b1;
            assign accept = in_valid;
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
            bias_subtract #(
`include "bias_subtract001_params.vh"
            ) u_sub (.clk(clk), .rst(rst), .in_valid(b_v), .x(rate_d2), .bias(b_w), .out_valid(out_valid),
                     .y(rate), .ovf(ovf_s));
            assign temp = temp_d3;
            assign ovf  = {ovf_s, ovf_b_d3, ovf_t_d3};
        end else begin : g_ser
            // one sample in flight: the stages' registered outputs hold until the next sample
            reg              busy;
            reg [RATE_W-1:0] rate_q;
            assign in_ready = ~busy | out_valid;   // the next sample may enter as this one leaves
            assign accept   = in_valid & in_ready;
            always @(posedge clk) begin
                if (rst) busy <= 1'b0;
                else if (accept) busy <= 1'b1;
                else if (out_valid) busy <= 1'b0;
                if (accept) rate_q <= rate_in;
            end
            bias_subtract #(
`include "bias_subtract001_params.vh"
            ) u_sub (.clk(clk), .rst(rst), .in_valid(b_v), .x(rate_q), .bias(b_w), .out_valid(out_valid),
                     .y(rate), .ovf(ovf_s));
            assign temp = t_w;
            assign ovf  = {ovf_s, ovf_b, ovf_t};
        end
    endgenerate
endmodule

`default_nettype wire
