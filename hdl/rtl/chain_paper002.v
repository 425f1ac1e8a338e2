// chain_paper002: the paper 002 RTD path (fxdsp.chains.Paper002Chain), top level.
//   rtd_code -> rtd -> temp -> piecewise_sf -> SF ; vsa / SF -> sf_divide -> demod (I)
//   temp -> piecewise_bias -> bias ; I - bias -> bias_subtract -> iir -> rate
// Optional stages, chosen by the config through the generated header (absent = the above, and the
// disabled stage is not elaborated): LAG_EN = 1 puts lag (lag_params.vh) between rtd and the two
// coefficient engines (SF and bias see the die-temperature estimate te; the temp output stays the
// thermometer's); the NCO reference's phase trim is demod's PHASE_TRIM (demod_params.vh, 0 = none).
// Every block's parameters come from the generated headers (`fxdsp hdl-gen`), i.e. from the one
// config; roundings (floor / half_up / half_even / toward_zero) and overflows (wrap / saturate)
// are those of each block. The demodulator's Q channel runs as in the model (its filter state is
// part of the reference) but only I is used; amp and phase are left unconnected.
// Interface: valid/ready with one sample in flight: in_ready is high when the chain is idle; a
// sample is accepted on in_valid && in_ready and leaves (temp, rate) with out_valid
// ceil((VSA_W + sf.fl + guard_bits) / DIV_UNROLL) + 7 + LAG_EN cycles later (55 at DIV_UNROLL = 1
// on the default config: 16 + 22 + 10 = 48 divider steps); in_ready is high again from the cycle
// after out_valid, so one sample takes latency + 1 cycles.
// ovf: every block's overflow flags of the sample, valid with out_valid:
// {iir, bias_subtract, demod, sf_divide (zero, out), piecewise_bias, piecewise_sf, [lag,] rtd}.
`default_nettype none

module chain_paper002 #(
`include "chain_paper002_params.vh"
    , parameter integer DIV_UNROLL = 1
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
    output wire              in_ready,
    input  wire [VSA_W-1:0]  vsa,
    input  wire [CODE_W-1:0] rtd_code,
    output reg               out_valid,
    output reg  [TEMP_W-1:0] temp,
    output reg  [RATE_W-1:0] rate,
    output reg  [N_OVF-1:0]  ovf
);
    reg busy;
    assign in_ready = ~busy;
    wire accept = in_valid & ~busy;

    reg [VSA_W-1:0] vsa_r;

    // ---- temperature ----
    wire              t_v;
    wire [TEMP_W-1:0] t_w;
    wire              ovf_rtd;
    rtd #(
`include "rtd_params.vh"
    ) u_rtd (.clk(clk), .rst(rst), .in_valid(accept), .in_ready(), .code(rtd_code), .out_valid(t_v), .temp(t_w),
             .ovf(ovf_rtd));

    // ---- the temperature the coefficient engines see: t_w, or the lag's te (generate below) ----
    wire              ce_v;
    wire [TEMP_W-1:0] ce_w;

    // ---- SF(T) and bias(T) ----
    wire                sf_v, b_v;
    wire [SF_W-1:0]     sf_w;
    wire [BIAS_W-1:0]   b_w;
    wire [SF_OVF_W-1:0] ovf_sf;
    wire [B_OVF_W-1:0]  ovf_b;
    piecewise #(
`include "piecewise_sf_params.vh"
    ) u_sf (.clk(clk), .rst(rst), .in_valid(ce_v), .in_ready(), .temp(ce_w), .out_valid(sf_v), .y(sf_w), .ovf(ovf_sf));
    piecewise #(
`include "piecewise_bias_params.vh"
    ) u_bias (.clk(clk), .rst(rst), .in_valid(ce_v), .in_ready(), .temp(ce_w), .out_valid(b_v), .y(b_w), .ovf(ovf_b));

    // ---- sense / SF ----
    wire             d_v;
    wire [DIV_W-1:0] d_w;
    wire [1:0]       ovf_div;
    /* verilator lint_off UNUSEDSIGNAL */
    wire             div_ready;
    /* verilator lint_on UNUSEDSIGNAL */
    sf_divide #(
`include "sf_divide_params.vh"
        , .UNROLL(DIV_UNROLL)
    ) u_div (.clk(clk), .rst(rst), .in_valid(sf_v), .in_ready(div_ready), .x(vsa_r), .sf(sf_w),
             .out_valid(d_v), .y(d_w), .ovf(ovf_div));

    // ---- demodulator (I) ----
    wire                   i_v;
    wire [DATA_W-1:0]      i_w;
    wire [DEMOD_OVF_W-1:0] ovf_dm;
    /* verilator lint_off UNUSEDSIGNAL */
    wire [DATA_W-1:0]      q_w, amp_w;
    wire [ANGLE_W-1:0]     ph_w;
    /* verilator lint_on UNUSEDSIGNAL */
    demod #(
`include "demod_params.vh"
    ) u_demod (.clk(clk), .rst(rst), .in_valid(d_v), .x(d_w), .out_valid(i_v), .i(i_w), .q(q_w),
               .amp(amp_w), .phase(ph_w), .ovf(ovf_dm));

    // ---- I - bias(T), final low-pass ----
    wire             s_v;
    wire [SUB_W-1:0] s_w;
    wire             ovf_sub;
    bias_subtract #(
`include "bias_subtract_params.vh"
    ) u_sub (.clk(clk), .rst(rst), .in_valid(i_v), .x(i_w), .bias(b_r), .out_valid(s_v), .y(s_w),
             .ovf(ovf_sub));
    wire                 r_v;
    wire [RATE_W-1:0]    r_w;
    wire [IIR_OVF_W-1:0] ovf_iir;
    iir #(
`include "iir_params.vh"
    ) u_iir (.clk(clk), .rst(rst), .in_valid(s_v), .in_ready(), .x(s_w), .out_valid(r_v), .y(r_w), .ovf(ovf_iir));

    // ---- per-sample registers (one sample in flight) ----
    reg [TEMP_W-1:0]   temp_r;
    reg [BIAS_W-1:0]   b_r;
    reg                ovf_rtd_r;
    reg [SF_OVF_W-1:0] ovf_sf_r;
    reg [B_OVF_W-1:0]  ovf_b_r;
    reg [1:0]          ovf_div_r;
    reg [DEMOD_OVF_W-1:0] ovf_dm_r;
    reg                ovf_sub_r;
    always @(posedge clk) begin
        if (accept) vsa_r <= vsa;
        if (t_v) begin temp_r <= t_w; ovf_rtd_r <= ovf_rtd; end
        if (sf_v) ovf_sf_r <= ovf_sf;
        if (b_v) begin b_r <= b_w; ovf_b_r <= ovf_b; end
        if (d_v) ovf_div_r <= ovf_div;
        if (i_v) ovf_dm_r <= ovf_dm;
        if (s_v) ovf_sub_r <= ovf_sub;
    end

    // ---- optional stages and the ovf vector they extend ----
    wire [N_OVF-1:0] ovf_n;
    generate
        if (LAG_EN != 0) begin : g_lag
            wire lag_v, ovf_lag;
            wire [TEMP_W-1:0] te_w;
            lag #(
`include "lag_params.vh"
            ) u_lag (.clk(clk), .rst(rst), .in_valid(t_v), .in_ready(), .temp(t_w), .out_valid(lag_v), .te(te_w),
                     .ovf(ovf_lag));
            reg ovf_lag_r;
            always @(posedge clk) if (lag_v) ovf_lag_r <= ovf_lag;
            assign ce_v  = lag_v;
            assign ce_w  = te_w;
            assign ovf_n = {ovf_iir, ovf_sub_r, ovf_dm_r, ovf_div_r, ovf_b_r, ovf_sf_r, ovf_lag_r, ovf_rtd_r};
        end else begin : g_direct
            assign ce_v  = t_v;
            assign ce_w  = t_w;
            assign ovf_n = {ovf_iir, ovf_sub_r, ovf_dm_r, ovf_div_r, ovf_b_r, ovf_sf_r, ovf_rtd_r};
        end
    endgenerate

    always @(posedge clk) begin
        if (rst) begin
            busy      <= 1'b0;
            out_valid <= 1'b0;
            temp      <= {TEMP_W{1'b0}};
            rate      <= {RATE_W{1'b0}};
            ovf       <= {N_OVF{1'b0}};
        end else begin
            out_valid <= r_v;
            if (accept) busy <= 1'b1;
            if (r_v) begin
                busy <= 1'b0;
                temp <= temp_r;
                rate <= r_w;
                ovf  <= ovf_n;
            end
        end
    end
endmodule

`default_nettype wire
