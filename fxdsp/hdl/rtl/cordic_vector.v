// cordic_vector: CORDIC vectoring of one (x, y), unrolled and combinational
// (fxdsp.blocks.demod.cordic_one), read by the one-sample-per-clock demodulator and drive loop.
// Pre-rotation by +-90 deg (HALF_PI) into the right half plane, then ITERATIONS shift-and-add steps
// with arithmetic right shifts (floor, the model's >>) in DATA_W + 3 bits (two guard bits, which
// the model proves suffice: |x_K| <= K sqrt(2) 2**(DATA_W-1), and one spare), the angle accumulated
// from ATAN_FILE (arctan 2**-j, ANGLE_W bits) in ANGLE_W + 2 bits: |z| <= pi/2 + sum atan < 3.4 rad
// never leaves them. Outputs: xk = K |(x, y)| (WW bits), z (the angle, AW bits). No rounding mode
// (no half_up / half_even / toward_zero: the micro-rotations' shifts are floor by the algorithm's
// definition) and no overflow (no wrap / saturate): the widths hold every value.
// Latency: combinational.
`default_nettype none

module cordic_vector #(
    parameter integer DATA_W     = 24,
    parameter integer ITERATIONS = 16,
    parameter integer ANGLE_W    = 20,
    parameter [63:0]  HALF_PI    = 64'd205887,
    parameter         ATAN_FILE  = "demod_atan.hex"
) (
    input  wire [DATA_W-1:0]    x,
    input  wire [DATA_W-1:0]    y,
    output wire [DATA_W+2:0]    xk,      // WW = DATA_W + 3 bits, signed
    output wire [ANGLE_W+1:0]   z        // AW = ANGLE_W + 2 bits, signed
);
    localparam integer WW = DATA_W + 3;
    localparam integer AW = ANGLE_W + 2;
    genvar k;

    reg [ANGLE_W-1:0] atan [0:ITERATIONS-1];
    initial $readmemh(ATAN_FILE, atan);
    localparam [ANGLE_W-1:0] HALF_PI_C = HALF_PI[ANGLE_W-1:0];
    wire signed [AW-1:0] hpi = {{2{HALF_PI_C[ANGLE_W-1]}}, HALF_PI_C};

    wire signed [WW-1:0] xi = {{(WW-DATA_W){x[DATA_W-1]}}, x};
    wire signed [WW-1:0] yi = {{(WW-DATA_W){y[DATA_W-1]}}, y};
    wire signed [WW-1:0] x0 = ~xi[WW-1] ? xi : (~yi[WW-1] ? yi : -yi);
    wire signed [WW-1:0] y0 = ~xi[WW-1] ? yi : (~yi[WW-1] ? -xi : xi);
    wire signed [AW-1:0] z0 = ~xi[WW-1] ? {AW{1'b0}} : (~yi[WW-1] ? hpi : -hpi);
    // the arctan table as one flat vector (a procedural loop then reads it without an array)
    wire [ANGLE_W*ITERATIONS-1:0] atan_flat;
    generate
        for (k = 0; k < ITERATIONS; k = k + 1) begin : g_atan
            assign atan_flat[ANGLE_W*k +: ANGLE_W] = atan[k];
        end
    endgenerate

    // the ITERATIONS shift-and-add steps, unrolled by the loop (one evaluation per new x, y)
    reg signed [WW-1:0]  cx, cy, tx;
    reg signed [AW-1:0]  cz, at;
    reg [ANGLE_W-1:0]    atv;
    integer j;
    always @* begin
        cx = x0; cy = y0; cz = z0;
        tx = {WW{1'b0}}; at = {AW{1'b0}}; atv = {ANGLE_W{1'b0}};
        for (j = 0; j < ITERATIONS; j = j + 1) begin
            atv = atan_flat[ANGLE_W*j +: ANGLE_W];
            at  = {{2{atv[ANGLE_W-1]}}, atv};
            if (!cy[WW-1]) begin
                tx = cx + (cy >>> j);
                cy = cy - (cx >>> j);
                cz = cz + at;
            end else begin
                tx = cx - (cy >>> j);
                cy = cy + (cx >>> j);
                cz = cz - at;
            end
            cx = tx;
        end
    end
    assign xk = cx;
    assign z  = cz;
endmodule

`default_nettype wire
