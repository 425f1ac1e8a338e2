// piecewise: piecewise-polynomial coefficient engine (fxdsp.blocks.piecewise).
// Segment select: seg = number of breakpoints <= temp (SEGMENTS - 1 comparators; a temperature
// exactly on a breakpoint takes the segment above). Horner in fixed point, t = temp - T0 exact:
//   acc = fit(round(c[seg][ORDER] >> TOP_SHIFT))                                   (acc fit)
//   for k = ORDER-1 .. 0:
//     p   = fit(round((acc * t) >> PROD_SHIFT))                                    (product fit)
//     acc = fit(round(((p << ACC_ALIGN[k]) + (c[seg][k] << COEF_ALIGN[k])) >> ACC_ALIGN[k]))  (acc fit)
//   y = fit(round(acc >> OUT_SHIFT)) into OUT_W (OUT_SIGNED) bits                  (out fit)
// every rounding by ROUNDING (floor / half_up / half_even / toward_zero), every fit by OVERFLOW
// (wrap / saturate) into ACC_W bits; negative shifts are exact left shifts.
// ACC_ALIGN / COEF_ALIGN pack one 8-bit shift per power (power k in bits [8k+7:8k]).
// Coefficients: COEF_FILE, entry seg*(ORDER+1)+k, COEF_W bits sign-extended; breakpoints:
// BP_FILE, SEGMENTS-1 entries of T_W bits.
// ovf: one flag per fit, {out, product[ORDER-1..0], acc[ORDER..0]} (2*ORDER+2 bits).
// Interface: in_valid / out_valid, one sample per cycle. Latency: 1 cycle.
`default_nettype none

module piecewise #(
    parameter integer T_W        = 18,
    parameter integer ORDER      = 1,
    parameter integer SEGMENTS   = 4,
    parameter integer COEF_W     = 20,
    parameter integer ACC_W      = 32,
    parameter integer OUT_W      = 18,
    parameter integer OUT_SIGNED = 0,
    parameter [63:0]  T0         = 64'd0,
    parameter integer TOP_SHIFT  = 1,
    parameter integer PROD_SHIFT = 9,
    parameter [63:0]  ACC_ALIGN  = 64'h100,
    parameter [63:0]  COEF_ALIGN = 64'h00a,
    parameter integer OUT_SHIFT  = 12,
    parameter integer ROUNDING   = 1,
    parameter integer OVERFLOW   = 1,
    parameter         COEF_FILE  = "piecewise_sf_coef.hex",
    parameter         BP_FILE    = "piecewise_sf_bp.hex"
) (
    input  wire                  clk,
    input  wire                  rst,
    input  wire                  in_valid,
    input  wire [T_W-1:0]        temp,
    output reg                   out_valid,
    output reg  [OUT_W-1:0]      y,
    output reg  [2*ORDER+1:0]    ovf
);
    localparam integer NC  = ORDER + 1;
    localparam integer NBP = SEGMENTS - 1;
    localparam integer SEG_W = (SEGMENTS > 1) ? $clog2(SEGMENTS) : 1;
    localparam integer TW1 = T_W + 1;
    localparam integer PW  = ACC_W + TW1;
    localparam [T_W-1:0] T0_C = T0[T_W-1:0];

    reg [COEF_W-1:0] coef [0:SEGMENTS*NC-1];
    initial $readmemh(COEF_FILE, coef);

    // ---- segment select: count the breakpoints <= temp ----
    wire [SEG_W-1:0] seg;
    generate
        if (NBP == 0) begin : g_noseg
            assign seg = {SEG_W{1'b0}};
        end else begin : g_seg
            reg [T_W-1:0] bp [0:NBP-1];
            initial $readmemh(BP_FILE, bp);
            wire [NBP-1:0] le;
            genvar b;
            for (b = 0; b < NBP; b = b + 1) begin : g_cmp
                wire [T_W-1:0] bpv = bp[b];
                assign le[b] = $signed(bpv) <= $signed(temp);
            end
            reg [SEG_W-1:0] cnt;
            integer i;
            always @* begin
                cnt = {SEG_W{1'b0}};
                for (i = 0; i < NBP; i = i + 1)
                    cnt = cnt + {{(SEG_W-1){1'b0}}, le[i]};
            end
            assign seg = cnt;
        end
    endgenerate

    wire signed [TW1-1:0] t = {temp[T_W-1], temp} - {T0_C[T_W-1], T0_C};

    // coefficient of power k of the selected segment
    function [COEF_W-1:0] c_of;
        input [SEG_W-1:0] s;
        input integer k;
        begin
            c_of = coef[s * NC + k];
        end
    endfunction

    // ---- top coefficient into the accumulator ----
    wire [ACC_W-1:0] acc_top;
    wire             ovf_top;
    wire signed [COEF_W-1:0] c_top = c_of(seg, ORDER);
    fx_convert #(.IN_W(COEF_W), .SHIFT(TOP_SHIFT), .ROUNDING(ROUNDING), .OUT_W(ACC_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_top (.x(c_top), .y(acc_top), .ovf(ovf_top));

    // ---- Horner stages, j = 0 .. ORDER-1 handles power k = ORDER-1-j ----
    wire [ACC_W-1:0] acc_fin;
    wire [ORDER-1:0] ovf_prod;
    wire [ORDER-1:0] ovf_acc;
    genvar j;
    generate
        for (j = 0; j < ORDER; j = j + 1) begin : g_h
            localparam integer K  = ORDER - 1 - j;
            localparam integer AA = {24'd0, ACC_ALIGN[8*K +: 8]};
            localparam integer CA = {24'd0, COEF_ALIGN[8*K +: 8]};
            localparam integer SW = ((ACC_W + AA > COEF_W + CA) ? ACC_W + AA : COEF_W + CA) + 1;
            wire signed [ACC_W-1:0] acc_in;
            if (j == 0) begin : g_first
                assign acc_in = acc_top;
            end else begin : g_next
                assign acc_in = g_h[j-1].acc_out;
            end
            wire signed [PW-1:0] prod = acc_in * t;
            wire signed [ACC_W-1:0] p;
            fx_convert #(.IN_W(PW), .SHIFT(PROD_SHIFT), .ROUNDING(ROUNDING), .OUT_W(ACC_W), .OUT_SIGNED(1),
                         .OVERFLOW(OVERFLOW)) u_prod (.x(prod), .y(p), .ovf(ovf_prod[j]));
            wire signed [COEF_W-1:0] ck = c_of(seg, K);
            wire signed [SW-1:0] pe  = {{(SW-ACC_W){p[ACC_W-1]}}, p};
            wire signed [SW-1:0] ce  = {{(SW-COEF_W){ck[COEF_W-1]}}, ck};
            wire signed [SW-1:0] sum = (pe <<< AA) + (ce <<< CA);
            wire [ACC_W-1:0] acc_out;
            fx_convert #(.IN_W(SW), .SHIFT(AA), .ROUNDING(ROUNDING), .OUT_W(ACC_W), .OUT_SIGNED(1),
                         .OVERFLOW(OVERFLOW)) u_sum (.x(sum), .y(acc_out), .ovf(ovf_acc[j]));
        end
    endgenerate
    assign acc_fin = g_h[ORDER-1].acc_out;

    wire [OUT_W-1:0] y_c;
    wire             ovf_out;
    fx_convert #(.IN_W(ACC_W), .SHIFT(OUT_SHIFT), .ROUNDING(ROUNDING), .OUT_W(OUT_W), .OUT_SIGNED(OUT_SIGNED),
                 .OVERFLOW(OVERFLOW)) u_out (.x(acc_fin), .y(y_c), .ovf(ovf_out));

    always @(posedge clk) begin
        if (rst) begin
            out_valid <= 1'b0;
            y         <= {OUT_W{1'b0}};
            ovf       <= {(2*ORDER+2){1'b0}};
        end else begin
            out_valid <= in_valid;
            if (in_valid) begin
                y   <= y_c;
                ovf <= {ovf_out, ovf_prod, ovf_acc, ovf_top};
            end
        end
    end
endmodule

`default_nettype wire
