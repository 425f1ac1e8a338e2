// fx_mac_serial: the exact signed product p = a * b of an A_W-bit by a B_W-bit two's-complement
// operand, computed on ONE 16 x 16 unsigned multiplier iterated over 16-bit limb pairs, so that
// yosys `synth_ice40 -dsp` maps it to exactly one SB_MAC16 (the serial variants of the blocks and
// the chain tops run all their products through one of these).
// Limbs: a and b are sign-extended to NA = ceil(A_W/16) and NB = ceil(B_W/16) limbs; the top limb
// is signed, the lower ones unsigned. The partial product of limbs (i, j) is exact in 34 bits:
//   a_i * b_j = au * bu - 2**16 * (sb * au + sa * bs)
// au, bu: the limbs read as unsigned; sa, sb: their sign bits when they are top limbs (else 0);
// bs: limb j read with its own signedness. The multiplier sees only unsigned 16 x 16 operands (a
// SB_MAC16 cannot switch its operand signedness per cycle); the correction is a small adder.
// Summation, least significant column first (columns c = i + j = 0 .. NA+NB-2):
//   acc = (first pair ? 0 : new column ? acc >> 16 : acc) + a_i * b_j
// and when a column is complete its low 16 bits are final: they shift in at the top of a register
// of limbs (one source per flip-flop, no limb index) before the shift of acc; the top column's high
// half goes above them, so after the last column the register holds the product. The adder is only ACC_W (~38) bits wide whatever A_W and B_W are (a carry
// chain short enough for 40 MHz on an iCE40UP5K); the top column's sum is the top of p. Exact:
// the column sums and the carries never leave ACC_W bits.
// Rounding: none (no floor / half_up / half_even / toward_zero here; the caller rounds with
// fx_round). Overflow: none (P_W = A_W + B_W holds every product).
// Interface: in_valid / in_ready; out_valid is a one-cycle pulse, p is registered and valid in
// that cycle (the next product's first column shifts the register at the next edge at the earliest:
// every caller reads p there).
// Schedule, in edges after the edge that accepts (a, b) (N = NA * NB limb pairs):
//   edge t = 1..N: limb pair t-1 registered (au, bu, signs: the SB_MAC16 input registers)
//   edge t + 1:    32-bit unsigned product registered (the SB_MAC16 output register), correction beside it
//   edge t + 2:    signed 34-bit partial product registered
//   edge t + 3:    accumulated; after edge N + 3 out_valid is high with p
// Latency: N + 3 cycles. Cycles per product: N (in_ready is high when idle and in the cycle of the
// last limb pair, so operands issued back to back keep the multiplier busy every cycle).
// VAR_N = 1 (a multiplier shared by callers of different widths, e.g. chain_paper002 ARCH = 1):
// A_W, B_W are the widest operands, whole limbs (multiples of 16); each product runs on its own limb
// counts na (1..NA), nb (1..NB), taken with a, b: the caller sign-extends its operands into a, b, and
// gets its own schedule (N = na nb pairs, latency N + 3, in_ready as above). p is then TOP-aligned:
// the register of limbs is NA + NB limbs, so a product of nc = na + nb - 1 columns is
// p[P_W-1 -: 16 (na + nb)] (the caller's exact product sign-extended to na + nb limbs, its value in
// the low bits of that window: fx_mac_port takes it there); the bits below are left over from
// earlier products. VAR_N = 0: na, nb are not read (NA, NB), the logic is that of a fixed-width
// product, p = a * b (the register's low P_W bits: every column is the product's).
`default_nettype none

module fx_mac_serial #(
    parameter integer A_W = 32,    // bits of the signed operand a (>= 2)
    parameter integer B_W = 24,    // bits of the signed operand b (>= 2)
    parameter integer VAR_N = 0    // 1: limb counts na, nb per product (a shared multiplier); 0: NA, NB
) (
    input  wire                      clk,
    input  wire                      rst,        // synchronous; drops a product in flight
    input  wire                      in_valid,   // a, b are taken at an edge with in_valid && in_ready
    output wire                      in_ready,
    input  wire signed [A_W-1:0]     a,
    input  wire signed [B_W-1:0]     b,
    /* verilator lint_off UNUSEDSIGNAL */   // VAR_N = 0: not read; else the bits above NA, NB
    input  wire [3:0]                na,         // VAR_N = 1: limbs of a in this product (1..NA <= 8)
    input  wire [3:0]                nb,         // VAR_N = 1: limbs of b (1..NB)
    /* verilator lint_on UNUSEDSIGNAL */
    output reg                       out_valid,  // one cycle per product, in the order accepted
    output wire signed [A_W+B_W-1:0] p           // a * b, exact, while out_valid
`ifdef FORMAL
    ,
    // the products taken and not yet answered (those whose out_valid cycle has not passed): a
    // formal proof ties its caller's state to it (fxdsp.hdl.formal: nothing in flight while idle)
    output wire [2:0]                f_in_flight
`endif
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
    localparam integer IW    = (NA > 1) ? $clog2(NA) : 1;    // limb index widths
    localparam integer JW    = (NB > 1) ? $clog2(NB) : 1;
    localparam integer CW    = $clog2(NA + NB) + 1;          // column number i + j, one spare bit
    localparam integer IA_TOP_I = NA - 1;
    localparam integer JB_TOP_I = NB - 1;
    localparam [IW-1:0] IA_TOP = IA_TOP_I[IW-1:0];
    localparam [JW-1:0] JB_TOP = JB_TOP_I[JW-1:0];

    generate
        if (A_W < 2 || B_W < 2) begin : g_bad_width
            initial begin $display("fx_mac_serial: A_W and B_W must be >= 2, got %0d, %0d", A_W, B_W); $finish; end
        end
        if (VAR_N != 0 && (NA > 8 || NB > 8 || XA != A_W || XB != B_W)) begin : g_bad_limbs
            initial begin $display("fx_mac_serial: VAR_N = 1 takes whole limbs, up to 8, got %0d x %0d bits", A_W, B_W);
                          $finish; end
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

    // the top limbs of this product: NA - 1, NB - 1, or (VAR_N = 1) na - 1, nb - 1 taken with a, b
    wire [IW-1:0] ia_top;
    wire [JW-1:0] jb_top;
    wire [CW-1:0] jb_top_c = {{(CW-JW){1'b0}}, jb_top};
    wire last = (ia == ia_top) && (jb == jb_top);             // the top column has one pair: the last
    assign in_ready = ~busy | last;
    wire take = in_valid & in_ready;

    // next pair: along the column (i + 1, j - 1) while it lasts, else the start of column c + 1
    wire [CW-1:0] col  = {{(CW-IW){1'b0}}, ia} + {{(CW-JW){1'b0}}, jb};
    wire [CW-1:0] coln = col + {{(CW-1){1'b0}}, 1'b1};
    wire          along = (ia != ia_top) && (jb != {JW{1'b0}});
    wire          low  = coln <= jb_top_c;                   // column c + 1 starts at (0, c + 1)
    /* verilator lint_off UNUSEDSIGNAL */                      // the spare bits of a column number
    wire [CW-1:0] in_  = coln - jb_top_c;
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
                jb <= low ? coln[JW-1:0] : jb_top;
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

    wire [LIMB-1:0] prod_hi, prod_lo;
    assign {prod_hi, prod_lo} = prod;
    wire signed [LIMB+1:0] au_x = {2'b00, au};
    wire signed [LIMB+1:0] bs_x = {sb & bu[LIMB-1], sb & bu[LIMB-1], bu};
    always @(posedge clk) begin
        au   <= a_l;
        bu   <= b_l;
        sa   <= (ia == ia_top) & a_l[LIMB-1];
        sb   <= (jb == jb_top) & b_l[LIMB-1];
        prod <= au * bu;
        corr <= (sb ? au_x : {(LIMB+2){1'b0}}) + (sa ? bs_x : {(LIMB+2){1'b0}});
        // prod - (corr << 16): the correction has no bit below 16, so those are prod's as they are
        // (a full-width subtraction kept ~26 LUT4 on a carry chain whose low operand bits are 0)
        pp   <= {$signed({2'b00, prod_hi}) - corr, prod_lo};
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
    wire signed [ACC_W-1:0] pp_x  = {{(ACC_W-PP_W){pp[PP_W-1]}}, pp};
    // the column below is complete: its low 16 bits are stored in p (below), the rest carries on
    wire signed [ACC_W-1:0] carry = acc >>> LIMB;            // (signed, on its own: arithmetic)
    wire signed [ACC_W-1:0] acc_0 = f_q[2] ? {ACC_W{1'b0}} : (n_q[2] ? carry : acc);
    wire signed [ACC_W-1:0] acc_n = acc_0 + pp_x;
    always @(posedge clk) if (v_q[2]) acc <= acc_n;
    generate
        if (VAR_N == 0) begin : g_fixed_n
            assign ia_top = IA_TOP;
            assign jb_top = JB_TOP;
        end else begin : g_var_n
            // na - 1, nb - 1: the low bits (the counts are <= NA, NB)
            /* verilator lint_off UNUSEDSIGNAL */
            wire [3:0]    na1 = na - 4'd1;
            wire [3:0]    nb1 = nb - 4'd1;
            wire [3-IW:0] na1_hi;
            wire [3-JW:0] nb1_hi;
            /* verilator lint_on UNUSEDSIGNAL */
            wire [IW-1:0] na1_lo;
            wire [JW-1:0] nb1_lo;
            assign {na1_hi, na1_lo} = na1;
            assign {nb1_hi, nb1_lo} = nb1;
            reg  [IW-1:0] ia_top_q;
            reg  [JW-1:0] jb_top_q;
            always @(posedge clk) if (take) begin ia_top_q <= na1_lo; jb_top_q <= nb1_lo; end
            assign ia_top = ia_top_q;
            assign jb_top = jb_top_q;
        end
        // p: each column's low 16 bits shift in at the top of res as the column completes (its last
        // pair is accumulated: the next pair starts a new column, or it is the product's last), the top
        // column's high half into hi. {hi, res} is NA + NB limbs and a product of nc columns lies at its
        // top: VAR_N = 0, nc = NC, the whole of it (p its low P_W bits); VAR_N = 1, whole limbs, p all of
        // it, top-aligned. One source per flip-flop (a limb store with a limb index would put a multiplexer before each)
        localparam integer RL = NC;                              // limbs of res
        reg  [LIMB*RL-1:0] res;
        reg  [LIMB-1:0]    hi;
        wire               colend = v_q[2] & (l_q[2] | n_q[1]);
        /* verilator lint_off UNUSEDSIGNAL */   // above the top column's 32 bits: sign copies
        wire [ACC_W-2*LIMB-1:0] acc_n_hi;
        /* verilator lint_on UNUSEDSIGNAL */
        wire [LIMB-1:0]    acc_n_l0, acc_n_l1;
        assign {acc_n_hi, acc_n_l1, acc_n_l0} = acc_n;
        if (RL > 1) begin : g_shift
            wire [LIMB*(RL-1)-1:0] res_up;              // res's upper limbs, which move down one
            /* verilator lint_off UNUSEDSIGNAL */       // the lowest limb: shifted out
            wire [LIMB-1:0]        res_out;
            /* verilator lint_on UNUSEDSIGNAL */
            assign {res_up, res_out} = res;
            always @(posedge clk) if (colend) res <= {acc_n_l0, res_up};
        end else begin : g_one_limb
            always @(posedge clk) if (colend) res <= acc_n_l0;
        end
        always @(posedge clk) if (v_q[2] && l_q[2]) hi <= acc_n_l1;
        /* verilator lint_off UNUSEDSIGNAL */       // VAR_N = 0: above P_W, the product's sign copies
        wire [LIMB*(RL+1)-1:0] field = {hi, res};
        /* verilator lint_on UNUSEDSIGNAL */
        assign p = field[P_W-1:0];
    endgenerate
`ifdef FORMAL
    // a product is selected (busy) until its last limb pair, then in one of the three stages (l_q),
    // then out: at most five at once
    // (one-bit terms summed in the 3-bit context of the assignment)
    assign f_in_flight = busy + l_q[0] + l_q[1] + l_q[2] + out_valid;
`endif
endmodule

`default_nettype wire
