// nco: numerically controlled oscillator of the demodulator (fxdsp.blocks.demod.Nco).
// phase[n] = (PHASE0 + n FTW) mod 2**PHASE_BITS; the LUT address is the top LUT_BITS bits of the
// phase (truncation); cos / -sin at the bin centres (COS_FILE, MSIN_FILE: 2**LUT_BITS words of
// LUT_W bits, quantised half_up / saturate by the generator). cos/msin show the current phase
// (combinational); the phase advances by FTW on each `step`; rst returns it to PHASE0.
// FTW, PHASE0: 64-bit constants, low PHASE_BITS bits used. Latency: combinational read.
`default_nettype none

module nco #(
    parameter integer PHASE_BITS = 32,
    parameter integer LUT_BITS   = 12,
    parameter integer LUT_W      = 16,
    parameter [63:0]  FTW        = 64'd357913941,
    parameter [63:0]  PHASE0     = 64'd0,
    parameter         COS_FILE   = "demod_cos.hex",
    parameter         MSIN_FILE  = "demod_msin.hex"
) (
    input  wire             clk,
    input  wire             rst,
    input  wire             step,
    output wire [LUT_W-1:0] cos_o,
    output wire [LUT_W-1:0] msin_o
);
    localparam [PHASE_BITS-1:0] FTW_C    = FTW[PHASE_BITS-1:0];
    localparam [PHASE_BITS-1:0] PHASE0_C = PHASE0[PHASE_BITS-1:0];

    reg [LUT_W-1:0] cos_lut  [0:(1<<LUT_BITS)-1];
    reg [LUT_W-1:0] msin_lut [0:(1<<LUT_BITS)-1];
    initial $readmemh(COS_FILE, cos_lut);
    initial $readmemh(MSIN_FILE, msin_lut);

    reg [PHASE_BITS-1:0] phase;
    wire [LUT_BITS-1:0] addr = phase[PHASE_BITS-1 -: LUT_BITS];
    assign cos_o  = cos_lut[addr];
    assign msin_o = msin_lut[addr];

    always @(posedge clk) begin
        if (rst) phase <= PHASE0_C;
        else if (step) phase <= phase + FTW_C;
    end
endmodule

`default_nettype wire
