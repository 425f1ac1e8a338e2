// fx_mac_serial: the exact signed product p = a * b of an A_W-bit by a B_W-bit two's-complement
// operand, computed on ONE 16 x 16 unsigned multiplier iterated over 16-bit limb pairs, so that
// yosys `synth_ice40 -dsp` maps it to exactly one SB_MAC16 (the resource-shared datapaths of
// issue 12 run all their products through one of these).
// Limbs: a and b are sign-extended to NA = ceil(A_W/16) and NB = ceil(B_W/16) limbs; the top limb
// is signed, the lower ones unsigned. The partial product of limbs (i, j) is exact in 34 bits:
//   a_i * b_j = au * bu - 2**16 * (sb * au + sa * bs)
// au, bu: the limbs read as unsigned; sa, sb: their sign bits when they are top limbs (else 0);
// bs: limb j read with its own signedness. The multiplier sees only unsigned 16 x 16 operands (a
// SB_MAC16 cannot switch its operand signedness per cycle); the correction is a small adder.
// Summation, least significant column first (columns c = i + j = 0 .. NA+NB-2):
//   acc = (first pair ? 0 : new column ? acc >> 16 : acc) + a_i * b_j
// and when a column is complete its low 16 bits are final: they are stored as bits 16c.. of p
// before the shift. The adder is only ACC_W (~38) bits wide whatever A_W and B_W are (a carry
// chain short enough for 40 MHz on an iCE40UP5K); the top column's sum is the top of p. Exact:
// the column sums and the carries never leave ACC_W bits.
// Rounding: none (no floor / half_up / half_even / toward_zero here; the caller rounds with
// fx_round). Overflow: none (P_W = A_W + B_W holds every product).
// Interface: in_valid / in_ready; out_valid is a one-cycle pulse, p is registered and valid in
// that cycle (and until the next product's second limb pair is accumulated).
// Schedule, in edges after the edge that accepts (a, b) (N = NA * NB limb pairs):
//   edge t = 1..N: limb pair t-1 registered (au, bu, signs: the SB_MAC16 input registers)
//   edge t + 1:    32-bit unsigned product registered (the SB_MAC16 output register), correction beside it
//   edge t + 2:    signed 34-bit partial product registered
//   edge t + 3:    accumulated; after edge N + 3 out_valid is high with p
// Latency: N + 3 cycles. Cycles per product: N (in_ready is high when idle and in the cycle of the
// last limb pair, so operands issued back to back keep the multiplier busy every cycle).
`default_nettype none

module fx_mac_serial #(
    parameter integer A_W = 32,    // bits of the signed operand a (>= 2)
    parameter integer B_W = 24     // bits of the signed operand b (>= 2)
) (
    input  wire                      clk,
    input  wire                      rst,        // synchronous; drops a product in flight
    input  wire                      in_valid,   // a, b are taken at an edge with in_valid && in_ready
    output wire                      in_ready,
    input  wire signed [A_W-1:0]     a,
    input  wire signed [B_W-1:0]     b,
    output reg                       out_valid,  // one cycle per product, in the order accepted
    output wire signed [A_W+B_W-1:0] p           // a * b, exact, while out_valid
);
    localparam integer LIMB  = 16;                           // SB_MAC16 operand width
    localparam integer A_UP  = A_W + LIMB - 1;
    localparam integer B_UP  = B_W + LIMB - 1;
    localparam integer NA    = A_UP / LIMB;                  // limbs of a: ceil(A_W / 16)
    localparam integer NB    = B_UP / LIMB;                  // limbs of b
    localparam integer XA    = NA * LIMB;                    // a sign-extended to whole limbs
    localparam integer XB    = NB * LIMB;
    localparam integer P_W   = A_W + B_W;                    // the product, exact
    localparam integer PP_W  = 2 * LIMB + 2;                 // one signed partial product, exact
    localparam integer NC    = NA + NB - 1;                  // columns
    // column sum + carry from the column below: < min(NA, NB) 2**33 + 2**(ACC_W-17), with margin
    localparam integer ACC_W = PP_W + $clog2(NA + NB) + 1;
    localparam integer RES_W = LIMB * (NC - 1);              // p below the top column: stored limbs
    localparam integer TOP_W = P_W - RES_W;                  // p from the top column's sum (<= 32)
    localparam integer IW    = (NA > 1) ? $clog2(NA) : 1;    // limb index widths
    localparam integer JW    = (NB > 1) ? $clog2(NB) : 1;
    localparam integer CW    = $clog2(NA + NB) + 1;          // column number i + j, one spare bit
    localparam integer EW    = (NC > 2) ? $clog2(NC - 1) : 1; // stored-limb index
    localparam integer IA_TOP_I = NA - 1;
    localparam integer JB_TOP_I = NB - 1;
    localparam [IW-1:0] IA_TOP = IA_TOP_I[IW-1:0];
    localparam [JW-1:0] JB_TOP = JB_TOP_I[JW-1:0];
    localparam [CW-1:0] JB_TOP_C = JB_TOP_I[CW-1:0];

    generate
        if (A_W < 2 || B_W < 2) begin : g_bad_width
            initial begin $display("fx_mac_serial: A_W and B_W must be >= 2, got %0d, %0d", A_W, B_W); $finish; end
        end
    endgenerate

    // ---- operands and the limb-pair sequencer ----
    reg  [XA-1:0] a_x;          // operands of the product being sequenced
    reg  [XB-1:0] b_x;
    reg           busy;         // a limb pair is selected this cycle
    reg  [IW-1:0] ia;           // selected pair (ia, jb)
    reg  [JW-1:0] jb;
    reg           first;        // the pair is the product's first ...
    reg           newcol;       // ... starts a new column (the column below is complete)

    wire last = (ia == IA_TOP) && (jb == JB_TOP);             // the top column has one pair: the last
    assign in_ready = ~busy | last;
    wire take = in_valid & in_ready;

    // next pair: along the column (i + 1, j - 1) while it lasts, else the start of column c + 1
    wire [CW-1:0] col  = {{(CW-IW){1'b0}}, ia} + {{(CW-JW){1'b0}}, jb};
    wire [CW-1:0] coln = col + {{(CW-1){1'b0}}, 1'b1};
    wire          along = (ia != IA_TOP) && (jb != {JW{1'b0}});
    wire          low  = coln <= JB_TOP_C;                   // column c + 1 starts at (0, c + 1)
    /* verilator lint_off UNUSEDSIGNAL */                      // the spare bits of a column number
    wire [CW-1:0] in_  = coln - JB_TOP_C;
    /* verilator lint_on UNUSEDSIGNAL */

    always @(posedge clk) begin
        if (rst) begin
            busy <= 1'b0;
            ia <= {IW{1'b0}}; jb <= {JW{1'b0}};
            first <= 1'b0; newcol <= 1'b0;
        end else if (take) begin
            busy   <= 1'b1;
            ia     <= {IW{1'b0}};       // column 0 holds one pair: the two bottom limbs
            jb     <= {JW{1'b0}};
            first  <= 1'b1;
            newcol <= 1'b1;
        end else if (busy) begin
            first <= 1'b0;
            if (last) begin
                busy <= 1'b0;
            end else if (along) begin
                ia <= ia + {{(IW-1){1'b0}}, 1'b1};
                jb <= jb - {{(JW-1){1'b0}}, 1'b1};
                newcol <= 1'b0;
            end else begin
                ia <= low ? {IW{1'b0}} : in_[IW-1:0];
                jb <= low ? coln[JW-1:0] : JB_TOP;
                newcol <= 1'b1;
            end
        end
    end

    always @(posedge clk) begin
        if (take) begin
            a_x <= {{(XA-A_W+1){a[A_W-1]}}, a[A_W-2:0]};
            b_x <= {{(XB-B_W+1){b[B_W-1]}}, b[B_W-2:0]};
        end
    end

    // ---- the limb pair: one 16 x 16 unsigned product and its sign correction ----
    wire [LIMB-1:0] a_l = a_x[LIMB*ia +: LIMB];
    wire [LIMB-1:0] b_l = b_x[LIMB*jb +: LIMB];
    reg  [LIMB-1:0] au, bu;     // registered limbs: the SB_MAC16 input registers
    reg             sa, sb;     // sign bits of top limbs
    reg  [2*LIMB-1:0] prod;     // registered au * bu: the SB_MAC16 output register
    reg  signed [LIMB+1:0] corr;
    reg  signed [PP_W-1:0] pp;
    reg  [2:0] v_q, f_q, n_q, l_q;  // valid / first / new column / last of stages 1..3

    wire signed [LIMB+1:0] au_x = {2'b00, au};
    wire signed [LIMB+1:0] bs_x = {sb & bu[LIMB-1], sb & bu[LIMB-1], bu};
    always @(posedge clk) begin
        au   <= a_l;
        bu   <= b_l;
        sa   <= (ia == IA_TOP) & a_l[LIMB-1];
        sb   <= (jb == JB_TOP) & b_l[LIMB-1];
        prod <= au * bu;
        corr <= (sb ? au_x : {(LIMB+2){1'b0}}) + (sa ? bs_x : {(LIMB+2){1'b0}});
        pp   <= $signed({2'b00, prod}) - $signed({corr, {LIMB{1'b0}}});
    end

    always @(posedge clk) begin
        if (rst) begin
            v_q <= 3'd0; f_q <= 3'd0; n_q <= 3'd0; l_q <= 3'd0;
            out_valid <= 1'b0;
        end else begin
            // bit 0: limbs registered; 1: product; 2: partial product (accumulated next)
            v_q <= {v_q[1:0], busy};
            f_q <= {f_q[1:0], first};
            n_q <= {n_q[1:0], newcol};
            l_q <= {l_q[1:0], busy & last};
            out_valid <= v_q[2] & l_q[2];
        end
    end

    // ---- column sums, least significant column first ----
    reg  signed [ACC_W-1:0] acc;
    reg  signed [TOP_W-1:0] p_top;
    wire signed [ACC_W-1:0] pp_x  = {{(ACC_W-PP_W){pp[PP_W-1]}}, pp};
    // the column below is complete: its low 16 bits are stored in p (below), the rest carries on
    wire signed [ACC_W-1:0] carry = acc >>> LIMB;            // (signed, on its own: arithmetic)
    wire signed [ACC_W-1:0] acc_0 = f_q[2] ? {ACC_W{1'b0}} : (n_q[2] ? carry : acc);
    wire signed [ACC_W-1:0] acc_n = acc_0 + pp_x;
    always @(posedge clk) begin
        if (v_q[2]) begin
            acc <= acc_n;
            if (l_q[2]) p_top <= acc_n[TOP_W-1:0];
        end
    end
    generate
        if (NC > 1) begin : g_limbs
            reg [RES_W-1:0] res;    // p below the top column, one 16-bit limb per completed column
            reg [EW-1:0]    ec;     // the next limb to store
            always @(posedge clk) begin
                if (v_q[2] && (f_q[2] || n_q[2])) begin
                    if (f_q[2]) begin
                        ec <= {EW{1'b0}};
                    end else begin
                        res[LIMB*ec +: LIMB] <= acc[LIMB-1:0];
                        ec <= ec + {{(EW-1){1'b0}}, 1'b1};
                    end
                end
            end
            assign p = {p_top, res};
        end else begin : g_one
            assign p = p_top;
        end
    endgenerate
endmodule

`default_nettype wire
