// fx_round: the ONE round-by-shift primitive of the fxdsp RTL (mirrors
// fxdsp.fixed.kernels.shift_right_round).
//   y = (x + cin) * 2**-SHIFT rounded to an integer by ROUNDING, when SHIFT > 0;
//   y = (x + cin) * 2**-SHIFT exactly (a left shift), when SHIFT <= 0.
// cin (0 or 1, read when CIN = 1) rides the rounding adder as its carry in: -q = ~q + 1 rounded in
// one adder (sf_divide). CIN = 0: x alone (the extra adder bit costs ~2 LUT4 per instance).
// Every mode's constant below is that of x, and still exact for x + cin: they differ only when cin
// carries through all the dropped bits (x + cin then has none set, and half_even's half - 1 + x[S] <
// 2**S, toward_zero's 2**S - 1 (x = -1) add no carry past them).
// ROUNDING codes (same words as the config): 0 floor (drop bits, toward -inf),
// 1 half_up (ties toward +inf), 2 half_even (ties to even), 3 toward_zero.
// No overflow here: OUT_W must hold the result (IN_W - SHIFT + 1 bits for a right
// shift, IN_W - SHIFT for a left shift); the range is fitted by fx_fit.
// Latency: combinational.
`default_nettype none

module fx_round #(
    parameter integer IN_W     = 32,
    parameter integer SHIFT    = 0,
    parameter integer ROUNDING = 1,
    parameter integer OUT_W    = 33,
    parameter integer CIN      = 0     // 1: cin is added; 0: not read (no adder bit for it)
) (
    input  wire signed [IN_W-1:0]  x,
    /* verilator lint_off UNUSEDSIGNAL */   // CIN = 0: not read
    input  wire                    cin,      // added to x when CIN = 1 (tie to 0 otherwise)
    /* verilator lint_on UNUSEDSIGNAL */
    output wire signed [OUT_W-1:0] y
);
    localparam integer LSH = (SHIFT < 0) ? -SHIFT : 0;
    localparam integer RSH = (SHIFT > 0) ? SHIFT : 0;
    localparam integer W0  = (IN_W + LSH + 1 > OUT_W) ? IN_W + LSH + 1 : OUT_W;
    localparam integer W   = ((W0 > RSH + 1) ? W0 : RSH + 1) + 1;

    wire signed [W-1:0] xe = {{(W-IN_W){x[IN_W-1]}}, x};
    /* verilator lint_off UNUSEDSIGNAL */
    wire signed [W-1:0] s;
    /* verilator lint_on UNUSEDSIGNAL */

    generate
        if (RSH == 0) begin : g_exact
            wire signed [W-1:0] xc = xe + {{(W-1){1'b0}}, cin & (CIN != 0)};
            assign s = xc <<< LSH;
        end else begin : g_round
            /* verilator lint_off UNUSEDSIGNAL */  // not every mode needs both constants
            wire signed [W-1:0] one  = {{(W-1){1'b0}}, 1'b1};
            wire signed [W-1:0] half = one <<< (RSH - 1);
            /* verilator lint_on UNUSEDSIGNAL */
            wire signed [W-1:0] c;
            if (ROUNDING == 0) begin : g_floor
                assign c = {W{1'b0}};
            end else if (ROUNDING == 1) begin : g_half_up
                assign c = half;
            end else if (ROUNDING == 2) begin : g_half_even
                // half - 1, plus 1 more when the kept part is odd: a tie carries only odd -> even
                assign c = half - one + {{(W-1){1'b0}}, xe[RSH]};
            end else begin : g_toward_zero
                // a negative value gets 2**n - 1 added first: floor becomes ceiling
                assign c = xe[W-1] ? ((one <<< RSH) - one) : {W{1'b0}};
            end
            wire signed [W-1:0] sum;
            if (CIN != 0) begin : g_cin
                // xe + c + cin in one adder: cin as the carry in through an extra low bit ({a, 1} +
                // {b, ci} = 2 (a + b + ci) + 1 + ~ci)
                /* verilator lint_off UNUSEDSIGNAL */
                wire sum_ci;
                /* verilator lint_on UNUSEDSIGNAL */
                assign {sum, sum_ci} = {xe, 1'b1} + {c, cin};
            end else begin : g_no_cin
                assign sum = xe + c;
            end
            assign s = sum >>> RSH;
        end
    endgenerate

    assign y = s[OUT_W-1:0];
endmodule

`default_nettype wire
