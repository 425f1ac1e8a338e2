// nco: numerically controlled oscillator of the demodulator (fxdsp.blocks.demod.Nco).
// phase[n] = (PHASE0 + PHASE_TRIM + n FTW) mod 2**PHASE_BITS: the model's accumulator
// (PHASE0 + n FTW) plus the phase trim, which rotates the reference by PHASE_TRIM / 2**PHASE_BITS
// turns without touching the frequency. Adding a constant commutes with the accumulation modulo
// 2**PHASE_BITS, so the trim is folded into the reset value (a constant: no adder; PHASE_TRIM = 0
// is the untrimmed NCO). cos and -sin of the phase come from nco_wave (quarter-wave table and
// first-order interpolation, the correction rounded by ROUNDING: 0 floor, 1 half_up, 2 half_even,
// 3 toward_zero; NCO_W = LUT_W + 1 bits, no overflow: no wrap / saturate and no fit point).
// cos_o / msin_o show the current phase (combinational); the phase advances by FTW on each `step`;
// rst returns it to PHASE0 + PHASE_TRIM. FTW, PHASE0, PHASE_TRIM, TWO_PI: 64-bit constants. Latency:
// combinational read.
`default_nettype none

module nco #(
    parameter integer PHASE_BITS  = 48,   // phase accumulator (turns * 2**PHASE_BITS)
    parameter integer LUT_BITS    = 12,   // bins per turn = 2**LUT_BITS (2 quadrant bits + index)
    parameter integer LUT_W       = 22,   // quarter-table word
    parameter integer INTERP_BITS = 12,   // phase bits below the bin that drive the interpolation
    parameter [63:0]  TWO_PI      = 64'd25736,
    parameter integer TWO_PI_W    = 16,
    parameter integer CORR_SHIFT  = 37,   // qsin * delta * TWO_PI -> table LSBs
    parameter integer NCO_W       = 23,   // output word: LUT_W + 1
    parameter [63:0]  FTW         = 64'd23456248059221,
    parameter [63:0]  PHASE0      = 64'd0,
    parameter [63:0]  PHASE_TRIM  = 64'd0,  // reference rotation (turns * 2**PHASE_BITS)
    parameter integer ROUNDING    = 1,    // of the correction: 0 floor, 1 half_up, 2 half_even, 3 toward_zero
    parameter         QSIN_FILE   = "demod_qsin.hex"
) (
    input  wire             clk,
    input  wire             rst,
    input  wire             step,
    output wire [NCO_W-1:0] cos_o,
    output wire [NCO_W-1:0] msin_o
);
    localparam [PHASE_BITS-1:0] FTW_C    = FTW[PHASE_BITS-1:0];
    localparam [PHASE_BITS-1:0] PHASE0_C = PHASE0[PHASE_BITS-1:0];
    localparam [PHASE_BITS-1:0] TRIM_C   = PHASE_TRIM[PHASE_BITS-1:0];
    localparam [PHASE_BITS-1:0] START_C  = PHASE0_C + TRIM_C;   // modulo 2**PHASE_BITS

    reg [PHASE_BITS-1:0] phase;
    always @(posedge clk) begin
        if (rst) phase <= START_C;
        else if (step) phase <= phase + FTW_C;
    end

    // the table, its interpolation and rounding: one description, shared with the drive loop
    nco_wave #(.PHASE_BITS(PHASE_BITS), .LUT_BITS(LUT_BITS), .LUT_W(LUT_W), .INTERP_BITS(INTERP_BITS),
               .TWO_PI(TWO_PI), .TWO_PI_W(TWO_PI_W), .CORR_SHIFT(CORR_SHIFT), .NCO_W(NCO_W), .ROUNDING(ROUNDING),
               .QSIN_FILE(QSIN_FILE)) u_wave (.phase(phase), .cos_o(cos_o), .msin_o(msin_o));
endmodule

`default_nettype wire
