// nco_phase: the fields of an NCO phase word (fxdsp.blocks.demod.Nco), read by the NCO (nco.v) and
// by the serial demodulator's own phase accumulator (demod.v, ARCH = 1): the top LUT_BITS bits are
// the bin, i.e. the quadrant (2 bits) and the index k of the quarter-wave table; the next
// INTERP_BITS bits r give the sub-bin centre delta = 2 r + 1 - 2**INTERP_BITS (odd,
// |delta| < 2**INTERP_BITS, DLW = INTERP_BITS + 2 bits), the first-order interpolation's offset.
// INTERP_BITS = 0: delta = 0 (the plain truncating table). The phase bits below are not read: the
// model drops them (phase truncation, whose error the interpolation removes). Combinational, no
// arithmetic rounding (no floor / half_up / half_even / toward_zero) and no overflow (no wrap /
// saturate): bit fields and a constant offset.
`default_nettype none

module nco_phase #(
    parameter integer PHASE_BITS  = 48,   // phase accumulator (turns * 2**PHASE_BITS)
    parameter integer LUT_BITS    = 12,   // bins per turn = 2**LUT_BITS (2 quadrant bits + index)
    parameter integer INTERP_BITS = 12    // phase bits below the bin that drive the interpolation
) (
    /* verilator lint_off UNUSEDSIGNAL */  // the bits below the interpolation's: truncated by the model
    input  wire [PHASE_BITS-1:0]           phase,
    /* verilator lint_on UNUSEDSIGNAL */
    output wire [1:0]                      quad,
    output wire [LUT_BITS-3:0]             k,
    output wire signed [INTERP_BITS+1:0]   delta
);
    localparam integer QBITS = LUT_BITS - 2;
    localparam integer DLW   = INTERP_BITS + 2;

    assign quad = phase[PHASE_BITS-1 -: 2];
    assign k    = phase[PHASE_BITS-3 -: QBITS];
    generate
        if (INTERP_BITS > 0) begin : g_interp
            wire [INTERP_BITS-1:0] r = phase[PHASE_BITS-LUT_BITS-1 -: INTERP_BITS];
            // 2 r + 1 - 2**INTERP_BITS: r with a 1 appended is 2 r + 1; inverting its top bit
            // subtracts 2**INTERP_BITS when the word is read as signed
            wire [INTERP_BITS:0] odd = {r, 1'b1};
            wire signed [INTERP_BITS:0] centred = {~odd[INTERP_BITS], odd[INTERP_BITS-1:0]};
            assign delta = {{(DLW-INTERP_BITS-1){centred[INTERP_BITS]}}, centred};
        end else begin : g_plain
            assign delta = {DLW{1'b0}};
        end
    endgenerate
endmodule

`default_nettype wire
