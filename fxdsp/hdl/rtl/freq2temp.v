// freq2temp: resonator frequency word -> temperature (fxdsp.blocks.freq2temp).
//   d = f - F0 (exact, FREQ_W + 1 bits); T = fit(round(d * KINV)) with one rounding by ROUNDING
//   (floor / half_up / half_even / toward_zero) over SHIFT bits and one fit by OVERFLOW
//   (wrap / saturate) into TEMP_W bits; ovf flags the fit.
// F0 and KINV are 64-bit two's-complement constants (low FREQ_W / KINV_W bits used).
// Both architectures give the same temp / ovf for every input.
// ARCH = 0: one sample per cycle, one multiplier. Interface: in_valid / out_valid (in_ready tied
//   high). Latency: 1 cycle.
// ARCH = 1: serial. d * KINV on ONE fx_mac_serial (one 16 x 16 multiplier: one SB_MAC16, N =
//   ceil((FREQ_W+1)/16) * ceil(KINV_W/16) multiplier cycles), the rounding and the fit in a
//   cycle each (fx_convert_pipe). Interface: in_valid / in_ready / out_valid; in_ready is high
//   when idle and in the cycle of out_valid. Schedule, in edges after the one that takes f (d = f - F0 registered):
//   1: d issued to the MAC; N + 4: product registered; N + 5: rounded; N + 6: fitted, out_valid.
//   Cycles per sample: N + 7 (13 at the default: 33 x 24 bits, N = 6). Latency: N + 6.
`default_nettype none

module freq2temp #(
    parameter integer FREQ_W   = 32,
    parameter integer KINV_W   = 24,
    parameter integer TEMP_W   = 24,
    parameter [63:0]  F0       = 64'd1005969998,
    parameter [63:0]  KINV     = 64'd4890746,
    parameter integer SHIFT    = 21,
    parameter integer ROUNDING = 1,
    parameter integer OVERFLOW = 1,
    parameter integer ARCH     = 0        // 0: one sample per cycle; 1: serial, one shared multiplier
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
    output wire              in_ready,  // ARCH = 1: low while a sample is being computed
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

    generate
        if (ARCH == 0) begin : g_par
            assign in_ready = 1'b1;
            wire signed [PW-1:0] p = d * kinv;
            fx_convert_reg #(.IN_W(PW), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(TEMP_W), .OUT_SIGNED(1),
                             .OVERFLOW(OVERFLOW)) u_out (.clk(clk), .rst(rst), .in_valid(in_valid), .x(p),
                                                         .out_valid(out_valid), .y(temp), .ovf(ovf));
        end else begin : g_ser
            reg                  busy;      // a sample taken and not yet out
            reg                  issue;     // d_q goes to the MAC this cycle
            reg signed [DW-1:0]  d_q;
            wire                 mac_ready, mac_valid;
            wire signed [PW-1:0] p;
            assign in_ready = ~busy | out_valid;   // the next sample may enter as this one leaves
            fx_mac_serial #(.A_W(DW), .B_W(KINV_W)) u_mac (.clk(clk), .rst(rst), .in_valid(issue),
                .in_ready(mac_ready), .a(d_q), .b(kinv), .na(4'd0), .nb(4'd0), .out_valid(mac_valid), .p(p));
            fx_convert_pipe #(.IN_W(PW), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(TEMP_W), .OUT_SIGNED(1),
                              .OVERFLOW(OVERFLOW)) u_out (.clk(clk), .rst(rst), .in_valid(mac_valid), .x(p), .cin(1'b0),
                                                          .out_valid(out_valid), .y(temp), .ovf(ovf));
            always @(posedge clk) begin
                if (rst) begin
                    busy <= 1'b0; issue <= 1'b0;
                end else begin
                    if (in_valid && in_ready) begin
                        d_q <= d; busy <= 1'b1; issue <= 1'b1;
                    end else begin
                        if (issue && mac_ready) issue <= 1'b0;
                        if (out_valid) busy <= 1'b0;
                    end
                end
            end
        end
    endgenerate
endmodule

`default_nettype wire
