// fx_fit: the ONE range-fit primitive of the fxdsp RTL (mirrors fxdsp.fixed.kernels.fit).
// Brings a signed value into an OUT_W-bit format, signed (OUT_SIGNED = 1) or unsigned.
// OVERFLOW codes (same words as the config): 0 wrap (keep the low OUT_W bits, two's
// complement), 1 saturate (clamp to the format's min/max). Either way ovf = 1 when the
// value was outside the format: overflow is never silent.
// The range test looks at the bits above the format only (all equal to the sign for a signed
// format, all zero for an unsigned one): a wide OR/AND instead of two magnitude comparators, which
// synthesis builds as carry chains (the critical path of the serial iir at 40 MHz).
// Latency: combinational.
`default_nettype none

module fx_fit #(
    parameter integer IN_W       = 33,
    parameter integer OUT_W      = 32,
    parameter integer OUT_SIGNED = 1,
    parameter integer OVERFLOW   = 1
) (
    input  wire signed [IN_W-1:0]  x,
    output wire        [OUT_W-1:0] y,
    output wire                    ovf
);
    localparam integer W = ((IN_W > OUT_W + 1) ? IN_W : OUT_W + 1) + 1;

    /* verilator lint_off UNUSEDSIGNAL */
    wire signed [W-1:0] xe  = {{(W-IN_W){x[IN_W-1]}}, x};
    wire signed [W-1:0] one = {{(W-1){1'b0}}, 1'b1};
    wire signed [W-1:0] hi  = (OUT_SIGNED != 0) ? (one <<< (OUT_W - 1)) - one : (one <<< OUT_W) - one;
    wire signed [W-1:0] lo  = (OUT_SIGNED != 0) ? -(one <<< (OUT_W - 1)) : {W{1'b0}};
    /* verilator lint_on UNUSEDSIGNAL */

    wire neg = xe[W-1];
    // the bits that must copy the sign: xe[W-2:OUT_W-1] (signed) or xe[W-2:OUT_W] (unsigned) and
    // the sign itself; W >= OUT_W + 2, so the range is never empty
    localparam integer TOP = (OUT_SIGNED != 0) ? OUT_W - 1 : OUT_W;
    wire [W-2-TOP:0] upper = xe[W-2:TOP];
    wire above = ~neg & (|upper);                                  // x > hi
    wire below = (OUT_SIGNED != 0) ? (neg & ~(&upper)) : neg;      // x < lo
    assign ovf = above | below;
    assign y = (OVERFLOW == 1 && above) ? hi[OUT_W-1:0] :
               (OVERFLOW == 1 && below) ? lo[OUT_W-1:0] : xe[OUT_W-1:0];
endmodule

`default_nettype wire
