// iir: cascade of SECTIONS direct-form-I biquads with second-order error feedback
// (fxdsp.blocks.iir). Per section, from its input v (the previous section's output):
//   acc = ((b0 v + b1 x1 + b2 x2) << SHIFT_B) - ((a1 y1 + a2 y2) << SHIFT_A) + c1 e1 + c2 e2
//   r   = round(acc >> OUT_SHIFT) by ROUNDING (floor / half_up / half_even / toward_zero)
//   y   = fit(r) into DATA_W bits by OVERFLOW (wrap / saturate), ovf[s] flagged
//   e   = acc - (r << OUT_SHIFT), 0 after an overflow
// exact in ACC_W bits. Coefficients from COEF_FILE: 7 words per section (b0 b1 b2 a1 a2 c1 c2),
// COEF_W bits each, sign-extended. State (x1 x2 y1 y2 e1 e2) advances only on in_valid; rst
// clears it (the model's reset()).
// Interface: in_valid / out_valid, one sample per cycle (the cascade is combinational).
// Latency: 1 cycle.
`default_nettype none

module iir #(
    parameter integer DATA_W    = 24,
    parameter integer SECTIONS  = 1,
    parameter integer COEF_W    = 28,
    parameter integer SHIFT_B   = 0,
    parameter integer SHIFT_A   = 6,
    parameter integer OUT_SHIFT = 32,
    parameter integer ACC_W     = 59,
    parameter integer ROUNDING  = 1,
    parameter integer OVERFLOW  = 1,
    parameter         COEF_FILE = "iir_coef.hex"
) (
    input  wire                clk,
    input  wire                rst,
    input  wire                in_valid,
    input  wire [DATA_W-1:0]   x,
    output reg                 out_valid,
    output reg  [DATA_W-1:0]   y,
    output reg  [SECTIONS-1:0] ovf
);
    localparam integer E_W = OUT_SHIFT + 2;
    localparam integer C_W = 4;                  // |c| <= 2 (checked by the generator)
    localparam integer PW  = COEF_W + DATA_W;    // exact coefficient x data product
    localparam integer CE_W = C_W + E_W;
    // accumulator: ACC_W from the model's bound, at least as wide as one product
    localparam integer AW0 = (ACC_W > PW) ? ACC_W : PW;
    localparam integer AW  = (AW0 > CE_W) ? AW0 : CE_W;
    localparam integer RW  = AW - OUT_SHIFT + 1;

    reg [COEF_W-1:0] coef [0:7*SECTIONS-1];
    initial $readmemh(COEF_FILE, coef);

    wire [SECTIONS-1:0] ovf_c;
    genvar s;
    generate
        for (s = 0; s < SECTIONS; s = s + 1) begin : g_sec
            wire signed [COEF_W-1:0] b0 = coef[7*s+0];
            wire signed [COEF_W-1:0] b1 = coef[7*s+1];
            wire signed [COEF_W-1:0] b2 = coef[7*s+2];
            wire signed [COEF_W-1:0] a1 = coef[7*s+3];
            wire signed [COEF_W-1:0] a2 = coef[7*s+4];
            // error-feedback weights are tiny integers (-nearest(a)): C_W bits of their ROM words
            /* verilator lint_off UNUSEDSIGNAL */
            wire [COEF_W-1:0] c1w = coef[7*s+5];
            wire [COEF_W-1:0] c2w = coef[7*s+6];
            /* verilator lint_on UNUSEDSIGNAL */
            wire signed [C_W-1:0] c1 = c1w[C_W-1:0];
            wire signed [C_W-1:0] c2 = c2w[C_W-1:0];
            reg signed [DATA_W-1:0] x1, x2, y1, y2;
            reg signed [E_W-1:0]    e1, e2;
            wire signed [DATA_W-1:0] v;
            if (s == 0) begin : g_in
                assign v = x;
            end else begin : g_chain
                assign v = g_sec[s-1].out;
            end
            // exact products at their own width (COEF_W x DATA_W, not AW x AW), summed in AW
            wire signed [PW-1:0]    pb0 = b0 * v;
            wire signed [PW-1:0]    pb1 = b1 * x1;
            wire signed [PW-1:0]    pb2 = b2 * x2;
            wire signed [PW-1:0]    pa1 = a1 * y1;
            wire signed [PW-1:0]    pa2 = a2 * y2;
            wire signed [CE_W-1:0]  pc1 = c1 * e1;
            wire signed [CE_W-1:0]  pc2 = c2 * e2;
            wire signed [AW-1:0] num = {{(AW-PW){pb0[PW-1]}}, pb0} + {{(AW-PW){pb1[PW-1]}}, pb1}
                                        + {{(AW-PW){pb2[PW-1]}}, pb2};
            wire signed [AW-1:0] den = {{(AW-PW){pa1[PW-1]}}, pa1} + {{(AW-PW){pa2[PW-1]}}, pa2};
            wire signed [AW-1:0] efb = {{(AW-CE_W){pc1[CE_W-1]}}, pc1} + {{(AW-CE_W){pc2[CE_W-1]}}, pc2};
            wire signed [AW-1:0] acc = (num <<< SHIFT_B) - (den <<< SHIFT_A) + efb;
            wire signed [RW-1:0] r;
            fx_round #(.IN_W(AW), .SHIFT(OUT_SHIFT), .ROUNDING(ROUNDING), .OUT_W(RW)) u_round (.x(acc), .y(r));
            wire [DATA_W-1:0] out;
            fx_fit #(.IN_W(RW), .OUT_W(DATA_W), .OUT_SIGNED(1), .OVERFLOW(OVERFLOW)) u_fit
                (.x(r), .y(out), .ovf(ovf_c[s]));
            wire signed [AW-1:0] re  = {{(AW-RW){r[RW-1]}}, r};
            /* verilator lint_off UNUSEDSIGNAL */
            wire signed [AW-1:0] err = acc - (re <<< OUT_SHIFT);
            /* verilator lint_on UNUSEDSIGNAL */
            wire signed [E_W-1:0] e = ovf_c[s] ? {E_W{1'b0}} : err[E_W-1:0];
            always @(posedge clk) begin
                if (rst) begin
                    x1 <= {DATA_W{1'b0}}; x2 <= {DATA_W{1'b0}};
                    y1 <= {DATA_W{1'b0}}; y2 <= {DATA_W{1'b0}};
                    e1 <= {E_W{1'b0}};    e2 <= {E_W{1'b0}};
                end else if (in_valid) begin
                    x1 <= v;  x2 <= x1;
                    y1 <= out; y2 <= y1;
                    e1 <= e;  e2 <= e1;
                end
            end
        end
    endgenerate

    always @(posedge clk) begin
        if (rst) begin
            out_valid <= 1'b0;
            y         <= {DATA_W{1'b0}};
            ovf       <= {SECTIONS{1'b0}};
        end else begin
            out_valid <= in_valid;
            if (in_valid) begin
                y   <= g_sec[SECTIONS-1].out;
                ovf <= ovf_c;
            end
        end
    end
endmodule

`default_nettype wire
