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
// Both architectures give the same y / ovf for every input.
// ARCH = 0: one sample per cycle, Horner combinational (one multiplier per product).
//   Interface: in_valid / out_valid (in_ready is tied high). Latency: 1 cycle.
// ARCH = 1: serial. The ORDER products acc * t run through ONE fx_mac_serial (one 16 x 16
//   multiplier: one SB_MAC16, N = ceil(ACC_W/16) * ceil((T_W+1)/16) multiplier cycles, latency
//   N + 3); every rounding and every fit gets a cycle of its own; the coefficient ROM is read
//   through a register (block RAM friendly). Interface: in_valid / in_ready / out_valid; in_ready
//   is high only when idle. Schedule, in edges after the one that takes the sample (temp and
//   t = temp - T0 registered):
//     1: breakpoint compares registered;  2: ROM address of c[seg][ORDER] (seg = their count);
//     3: ROM word registered;  4: acc = fit(round(c >> TOP_SHIFT)), address of c[seg][ORDER-1]
//     per power k = ORDER-1 .. 0, from edge b (b = 4 for the first):
//       b + 1:          acc * t issued to the MAC;  b + N + 4: product registered by the MAC
//       b + N + 5:      the product registered here (prod_q: the rounding adder's carry chain starts
//                       beside its operand, not across the die at a shared multiplier's register)
//       b + N + 6, + 7: round(product >> PROD_SHIFT), then its fit (product flag)
//       b + N + 8:      p << ACC_ALIGN[k] registered
//       b + N + 9:      its sum with c[seg][k] << COEF_ALIGN[k] (the ROM word as read: ACOEF_FILE,
//                       the generator's aligned copy of the coefficients) registered
//       b + N + 10, +11: round(sum >> ACC_ALIGN[k]), then acc = its fit (acc flag), next address
//     then round(acc >> OUT_SHIFT), then y = its fit with out_valid (out flag).
//   Cycles per sample: ORDER * (N + 11) + 7, e.g. 37 for the paper 001 bias (ORDER 2, 32-bit
//   acc, 24-bit temperature: N = 4), 58 for k0 (ORDER 3, N = 6). Latency: that minus 1.
//   EXT_MAC = 1: no multiplier here; the products go out on the mac_* bundle (fx_mac_port) to a
//   multiplier shared with other blocks (chain_paper002's), the schedule unchanged.
//   SETS = 2 (ARCH = 1 only): two coefficient engines in one. A second set of coefficients (and its
//   own COEF_ALIGN_1, OUT_SHIFT_1, OUT_W_1, OUT_SIGNED_1, ACOEF_W_1; every other parameter and the breakpoints
//   are shared) is evaluated on every sample right after the first: the first set's y, ovf leave
//   with out_valid, the engine is idle for that one cycle and starts the second pass at the next
//   edge on the same temp (registered at the take), whose y_1, ovf_1 leave with out_valid_1:
//   2 (ORDER (N + 11) + 7) cycles per sample, the same as two engines started one after the other.
//   in_ready stays low from the take to out_valid_1. SETS_FILE (read instead of ACOEF_FILE) holds set
//   0's SEGMENTS (ORDER + 1) words, then set 1's. chain_paper002 ARCH = 1 runs SF(T) and bias(T) so
//   (PW_SHARED). SETS = 1: out_valid_1 stays low, y_1 and ovf_1 are 0.
`default_nettype none

module piecewise #(
    parameter integer T_W        = 22,
    parameter integer ORDER      = 1,
    parameter integer SEGMENTS   = 4,
    parameter integer COEF_W     = 24,
    parameter integer ACOEF_W    = 30,    // ARCH = 1: the word of ACOEF_FILE (c_k << COEF_ALIGN[k], c_ORDER)
    parameter integer ACC_W      = 32,
    parameter integer OUT_W      = 24,
    parameter integer OUT_SIGNED = 0,
    parameter [63:0]  T0         = 64'd0,
    parameter integer TOP_SHIFT  = 0,
    parameter integer PROD_SHIFT = 13,
    parameter [63:0]  ACC_ALIGN  = 64'h0,
    parameter [63:0]  COEF_ALIGN = 64'h7,
    parameter integer OUT_SHIFT  = 7,
    parameter integer ROUNDING   = 1,
    parameter integer OVERFLOW   = 1,
    parameter integer ARCH       = 0,     // 0: one sample per cycle; 1: serial, one shared multiplier
    parameter integer EXT_MAC    = 0,     // ARCH = 1: 0 its own fx_mac_serial; 1 the external one on mac_* (fx_mac_port)
    parameter integer MAC_A_W    = 48,    // EXT_MAC = 1: the external multiplier's operand widths (>= ACC_W, T_W + 1)
    parameter integer MAC_B_W    = 32,    // (a: MAC_A_W bits, b: MAC_B_W bits; 3 x 2 limbs by default)
    parameter         COEF_FILE  = "piecewise_sf_coef.hex",     // ARCH = 0: the coefficients
    parameter         ACOEF_FILE = "piecewise_sf_acoef.hex",    // ARCH = 1: the same, aligned (ACOEF_W bits)
    parameter         BP_FILE    = "piecewise_sf_bp.hex",
    parameter integer SETS         = 1,     // 1; 2 (ARCH = 1): a second coefficient set per sample (y_1, ovf_1)
    parameter [63:0]  COEF_ALIGN_1 = 64'h00a,   // SETS = 2: the second set's COEF_ALIGN ...
    parameter integer OUT_SHIFT_1  = 12,        // ... OUT_SHIFT,
    parameter integer OUT_W_1      = 18,        // ... OUT_W
    parameter integer OUT_SIGNED_1 = 0,         // ... OUT_SIGNED and
    parameter integer ACOEF_W_1    = 24,        // ... ACOEF_W (the rest is the first set's)
    parameter         SETS_FILE    = "piecewise_sets_coef.hex"   // SETS = 2: both sets' aligned words, read instead of ACOEF_FILE
) (
    input  wire                  clk,
    input  wire                  rst,
    input  wire                  in_valid,
    output wire                  in_ready,  // ARCH = 1: low while a sample is being computed
    input  wire [T_W-1:0]        temp,
    output reg                   out_valid,
    output reg  [OUT_W-1:0]      y,
    output reg  [2*ORDER+1:0]    ovf,
    output reg                   out_valid_1,   // SETS = 2: the second set's result (SETS = 1: low, 0)
    output reg  [OUT_W_1-1:0]    y_1,
    output reg  [2*ORDER+1:0]    ovf_1,
    // the external multiplier (ARCH = 1 and EXT_MAC = 1; else the outputs are 0): fx_mac_port's bundle
    output wire                          mac_in_valid,
    input  wire                          mac_in_ready,
    output wire [MAC_A_W-1:0]            mac_a,
    output wire [MAC_B_W-1:0]            mac_b,
    output wire [3:0]                    mac_na,
    output wire [3:0]                    mac_nb,
    input  wire                          mac_out_valid,
    input  wire [MAC_A_W+MAC_B_W-1:0]    mac_p
);
    localparam integer NC  = ORDER + 1;
    localparam integer NBP = SEGMENTS - 1;
    localparam integer SEG_W = (SEGMENTS > 1) ? $clog2(SEGMENTS) : 1;
    localparam integer TW1 = T_W + 1;
    localparam integer PW  = ACC_W + TW1;
    localparam [T_W-1:0] T0_C = T0[T_W-1:0];

    localparam integer S1  = (SETS == 2) ? 1 : 0;    // a second set
    reg [COEF_W-1:0] coef [0:SEGMENTS*NC-1];         // ARCH = 0 (read at the selected segment)
    initial $readmemh(COEF_FILE, coef);
    generate
        if ((SETS != 1 && SETS != 2) || (SETS == 2 && ARCH != 1)) begin : g_bad_sets
            initial begin $display("piecewise: SETS must be 1, or 2 with ARCH = 1, got %0d, ARCH %0d", SETS, ARCH);
                          $finish; end
        end
    endgenerate

    // ---- segment select: count the breakpoints <= t_sel (the input: ARCH 0; registered: ARCH 1) ----
    /* verilator lint_off UNUSEDSIGNAL */  // one segment: no breakpoint reads it
    wire [T_W-1:0]   t_sel;
    /* verilator lint_on UNUSEDSIGNAL */
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
                assign le[b] = $signed(bpv) <= $signed(t_sel);
            end
            // the compares counted: as computed (ARCH 0), or registered (ARCH 1: the compare carry
            // chains and the count in one cycle were a 40 MHz path; t_sel holds for the sample)
            wire [NBP-1:0] le_n;
            if (ARCH == 0) begin : g_le_now
                assign le_n = le;
            end else begin : g_le_reg
                reg [NBP-1:0] le_q;
                always @(posedge clk) le_q <= le;
                assign le_n = le_q;
            end
            reg [SEG_W-1:0] cnt;
            integer i;
            always @* begin
                cnt = {SEG_W{1'b0}};
                for (i = 0; i < NBP; i = i + 1)
                    cnt = cnt + {{(SEG_W-1){1'b0}}, le_n[i]};
            end
            assign seg = cnt;
        end
    endgenerate

    wire signed [TW1-1:0] t = {temp[T_W-1], temp} - {T0_C[T_W-1], T0_C};

    // width of the exact Horner sum of power k (as the parallel variant's SW), and its maximum
    function integer sum_w;
        input integer kk;
        integer aa, ca;
        begin
            aa = {24'd0, ACC_ALIGN[8*kk +: 8]};
            ca = {24'd0, COEF_ALIGN[8*kk +: 8]};
            if (S1 != 0 && {24'd0, COEF_ALIGN_1[8*kk +: 8]} > ca) ca = {24'd0, COEF_ALIGN_1[8*kk +: 8]};
            sum_w = ((ACC_W + aa > COEF_W + ca) ? ACC_W + aa : COEF_W + ca) + 1;
        end
    endfunction
    function integer sum_w_max;
        input integer unused;
        integer kk;
        begin
            sum_w_max = unused;
            for (kk = 0; kk < ORDER; kk = kk + 1)
                if (sum_w(kk) > sum_w_max) sum_w_max = sum_w(kk);
        end
    endfunction

    // coefficient of power k of the selected segment
    function [COEF_W-1:0] c_of;
        input [SEG_W-1:0] s;
        input integer k;
        begin
            c_of = coef[s * NC + k];
        end
    endfunction

    genvar j;
    generate
    if (ARCH == 0) begin : g_par
    assign in_ready = 1'b1;
    always @(posedge clk) begin     // one set (SETS = 1)
        out_valid_1 <= 1'b0; y_1 <= {OUT_W_1{1'b0}}; ovf_1 <= {(2*ORDER+2){1'b0}};
    end
    // no multiplier in this variant: the bundle unused
    assign mac_in_valid = 1'b0;
    assign mac_a = {MAC_A_W{1'b0}};
    assign mac_b = {MAC_B_W{1'b0}};
    assign mac_na = 4'd0;
    assign mac_nb = 4'd0;
    /* verilator lint_off UNUSEDSIGNAL */
    wire unused_mac = mac_in_ready ^ mac_out_valid ^ (^mac_p);
    /* verilator lint_on UNUSEDSIGNAL */
    assign t_sel = temp;

    // ---- top coefficient into the accumulator ----
    wire [ACC_W-1:0] acc_top;
    wire             ovf_top;
    wire signed [COEF_W-1:0] c_top = c_of(seg, ORDER);
    fx_convert #(.IN_W(COEF_W), .SHIFT(TOP_SHIFT), .ROUNDING(ROUNDING), .OUT_W(ACC_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_top (.x(c_top), .cin(1'b0), .y(acc_top), .ovf(ovf_top));

    // ---- Horner stages, j = 0 .. ORDER-1 handles power k = ORDER-1-j ----
    wire [ACC_W-1:0] acc_fin;
    wire [ORDER-1:0] ovf_prod;
    wire [ORDER-1:0] ovf_acc;
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
                         .OVERFLOW(OVERFLOW)) u_prod (.x(prod), .cin(1'b0), .y(p), .ovf(ovf_prod[j]));
            wire signed [COEF_W-1:0] ck = c_of(seg, K);
            wire signed [SW-1:0] pe  = {{(SW-ACC_W){p[ACC_W-1]}}, p};
            wire signed [SW-1:0] ce  = {{(SW-COEF_W){ck[COEF_W-1]}}, ck};
            wire signed [SW-1:0] sum = (pe <<< AA) + (ce <<< CA);
            wire [ACC_W-1:0] acc_out;
            fx_convert #(.IN_W(SW), .SHIFT(AA), .ROUNDING(ROUNDING), .OUT_W(ACC_W), .OUT_SIGNED(1),
                         .OVERFLOW(OVERFLOW)) u_sum (.x(sum), .cin(1'b0), .y(acc_out), .ovf(ovf_acc[j]));
        end
    assign acc_fin = g_h[ORDER-1].acc_out;

    wire [OUT_W-1:0] y_c;
    wire             ovf_out;
    fx_convert #(.IN_W(ACC_W), .SHIFT(OUT_SHIFT), .ROUNDING(ROUNDING), .OUT_W(OUT_W), .OUT_SIGNED(OUT_SIGNED),
                 .OVERFLOW(OVERFLOW)) u_out (.x(acc_fin), .cin(1'b0), .y(y_c), .ovf(ovf_out));

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
    end else begin : g_ser
        // ---- serial: one fx_mac_serial, one rounding or fit per cycle ----
        localparam integer KW   = (ORDER > 1) ? $clog2(ORDER) : 1;  // power index 0..ORDER-1
        localparam integer RA_N = SETS * SEGMENTS * NC;
        localparam integer RA_W = (RA_N > 1) ? $clog2(RA_N) : 1;
        localparam integer ORW0 = (OUT_SHIFT > 0) ? ACC_W - OUT_SHIFT + 1 : ACC_W - OUT_SHIFT;
        localparam integer ORW  = (ORW0 < 2) ? 2 : ORW0;    // round(acc >> OUT_SHIFT)
        localparam integer ORW1_0 = (OUT_SHIFT_1 > 0) ? ACC_W - OUT_SHIFT_1 + 1 : ACC_W - OUT_SHIFT_1;
        localparam integer ORW1 = (ORW1_0 < 2) ? 2 : ORW1_0; // round(acc >> OUT_SHIFT_1)
        localparam integer SET1_I = SEGMENTS * NC;           // the second set's first ROM word
        localparam [RA_W-1:0] SET1_A = SET1_I[RA_W-1:0];
        localparam integer SWM  = sum_w_max(0);             // the widest Horner sum over the powers
        localparam integer SRW  = SWM + 1;                  // its rounding (right shifts only)
        localparam integer NC_I = NC;
        localparam integer ORDER_I = ORDER;
        localparam [RA_W-1:0] NC_A = NC_I[RA_W-1:0];
        localparam [RA_W-1:0] ORDER_A = ORDER_I[RA_W-1:0];
        localparam [KW-1:0]   K_TOP = ORDER_I[KW-1:0] - 1'b1;

        localparam [3:0] S_IDLE = 4'd0;
        localparam [3:0] S_SEG = 4'd1;
        localparam [3:0] S_ADDR = 4'd2;
        localparam [3:0] S_ROM = 4'd3;
        localparam [3:0] S_TOP = 4'd4;
        localparam [3:0] S_ISSUE = 4'd5;
        localparam [3:0] S_WAIT = 4'd6;
        localparam [3:0] S_PFIT = 4'd7;
        localparam [3:0] S_ALGN = 4'd8;
        localparam [3:0] S_SUM = 4'd9;
        localparam [3:0] S_SRND = 4'd10;
        localparam [3:0] S_SFIT = 4'd11;
        localparam [3:0] S_ORND = 4'd12;
        localparam [3:0] S_PREG = 4'd14;   // the product registered here (prod_q)
        localparam [3:0] S_OFIT = 4'd13;

        reg [3:0]               st;
        reg [T_W-1:0]           temp_q;     // the sample
        reg signed [TW1-1:0]    t_q;        // t = temp - T0
        reg [RA_W-1:0]          ra;         // ROM address: seg NC + k
        // the coefficient words as the Horner sum adds them (ACOEF_FILE, or SETS_FILE: both sets'):
        // c_k << COEF_ALIGN[k] (the set's), c_ORDER as it is: no alignment multiplexer, no register
        // between the ROM's and the adder (~26 LUT4 of the paper 002 chain's shared engine)
        localparam integer RWD = (S1 != 0 && ACOEF_W_1 > ACOEF_W) ? ACOEF_W_1 : ACOEF_W;
        reg [RWD-1:0] acoef [0:SETS*SEGMENTS*NC-1];
        // the file of the sets (two parameters: a string conditional would pad the shorter name)
        if (S1 != 0) begin : g_sets_file
            initial $readmemh(SETS_FILE, acoef);
        end else begin : g_acoef_file
            initial $readmemh(ACOEF_FILE, acoef);
        end
        reg [RWD-1:0]           coef_q;     // registered ROM read
        reg [KW-1:0]            k;          // the power being added
        reg signed [ACC_W-1:0]  acc_q;
        reg signed [SWM-1:0]    s_q;        // the Horner sum of power k
        reg signed [SRW-1:0]    sr_q;       // round(s_q)
        reg signed [ORW-1:0]    or_q;       // round(acc >> OUT_SHIFT) (the second set: its own below)
        reg                     set_q;      // the set of this pass (SETS = 2; else 0)
        reg                     out0_q;     // this cycle is S_OFIT of set 0's pass / set 1's: the output
        reg                     out1_q;     // registers' enables, decoded a cycle early (short paths)
        reg                     pend;       // SETS = 2: the sample's second set still to run
        reg                     ovf_top_q;
        reg [ORDER-1:0]         ovf_prod_q; // bit j: power ORDER-1-j, as the parallel variant
        reg [ORDER-1:0]         ovf_acc_q;

        assign in_ready = (st == S_IDLE) && !pend;
        always @(posedge clk) begin
            out0_q <= !rst && (st == S_ORND) && !set_q;
            out1_q <= !rst && (st == S_ORND) && set_q;
        end
        assign t_sel = temp_q;
        always @(posedge clk) coef_q <= acoef[ra];

        // the multiplier: acc * t, exact
        wire mac_ready, mac_valid;
        wire signed [PW-1:0] prod;
        fx_mac_port #(.A_W(ACC_W), .B_W(TW1), .EXT_MAC(EXT_MAC), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)) u_mac
            (.clk(clk), .rst(rst), .in_valid(st == S_ISSUE), .in_ready(mac_ready), .a(acc_q), .b(t_q), .na(4'd0),
             .nb(4'd0), .out_valid(mac_valid), .p(prod), .mac_in_valid(mac_in_valid), .mac_in_ready(mac_in_ready), .mac_a(mac_a), .mac_b(mac_b),
                 .mac_na(mac_na), .mac_nb(mac_nb), .mac_out_valid(mac_out_valid), .mac_p(mac_p));

        // top coefficient into the accumulator (a short path: its word, not aligned)
        wire [ACC_W-1:0] acc_top;
        wire             ovf_top;
        fx_convert #(.IN_W(RWD), .SHIFT(TOP_SHIFT), .ROUNDING(ROUNDING), .OUT_W(ACC_W), .OUT_SIGNED(1),
                     .OVERFLOW(OVERFLOW)) u_top (.x(coef_q), .cin(1'b0), .y(acc_top), .ovf(ovf_top));

        // product: round (as the MAC returns it), then fit (in S_PFIT); held from S_ALGN on
        wire [ACC_W-1:0] p_q;
        wire             ovf_p;
        /* verilator lint_off UNUSEDSIGNAL */   // the FSM knows when the product is there
        wire             p_v;
        /* verilator lint_on UNUSEDSIGNAL */
        reg signed [PW-1:0] prod_q;   // the product, registered beside its rounding adder
        always @(posedge clk) if (mac_valid) prod_q <= prod;
        fx_convert_pipe #(.IN_W(PW), .SHIFT(PROD_SHIFT), .ROUNDING(ROUNDING), .OUT_W(ACC_W), .OUT_SIGNED(1),
                          .OVERFLOW(OVERFLOW)) u_prod (.clk(clk), .rst(rst), .in_valid(st == S_PREG), .x(prod_q),
                                                       .cin(1'b0), .out_valid(p_v), .y(p_q), .ovf(ovf_p));

        // Horner sum and its rounding, one alignment per power (selected by k): the aligned product is
        // registered first, so the sum is one adder from registers (not one per power behind a
        // multiplexer, which would be the critical path of a third-order engine)
        wire signed [SWM-1:0] pe = {{(SWM-ACC_W){p_q[ACC_W-1]}}, p_q};
        // c[seg][k] << COEF_ALIGN[k]: the word as read (coef_q holds c[seg][k] from the ROM read after
        // the address moved to it until the next power's, long past S_SUM)
        wire signed [SWM-1:0] ce = {{(SWM-RWD+1){coef_q[RWD-1]}}, coef_q[RWD-2:0]};
        wire [SWM-1:0] pal_k [0:ORDER-1];   // p << ACC_ALIGN[k]
        wire [SRW-1:0] srnd_k [0:ORDER-1];  // round(s_q >> ACC_ALIGN[k])
        for (j = 0; j < ORDER; j = j + 1) begin : g_k
            localparam integer AA = {24'd0, ACC_ALIGN[8*j +: 8]};
            assign pal_k[j] = pe <<< AA;
            fx_round #(.IN_W(SWM), .SHIFT(AA), .ROUNDING(ROUNDING), .OUT_W(SRW)) u_srnd (.x(s_q), .cin(1'b0), .y(srnd_k[j]));
        end
        reg signed [SWM-1:0] pal_q;
        wire [ACC_W-1:0] acc_c;
        wire             ovf_a;
        fx_fit #(.IN_W(SRW), .OUT_W(ACC_W), .OUT_SIGNED(1), .OVERFLOW(OVERFLOW)) u_sfit
            (.x(sr_q), .y(acc_c), .ovf(ovf_a));

        // output: round, then fit (the second set: its own shift and format, its own register: both
        // rounded results are registered in S_ORND, each fit reads its own, no multiplexer)
        wire signed [ORW-1:0]  or_c;
        fx_round #(.IN_W(ACC_W), .SHIFT(OUT_SHIFT), .ROUNDING(ROUNDING), .OUT_W(ORW)) u_ornd (.x(acc_q), .cin(1'b0), .y(or_c));
        wire [OUT_W-1:0] y_c;
        wire             ovf_o;
        fx_fit #(.IN_W(ORW), .OUT_W(OUT_W), .OUT_SIGNED(OUT_SIGNED), .OVERFLOW(OVERFLOW)) u_ofit
            (.x(or_q), .y(y_c), .ovf(ovf_o));
        wire [OUT_W_1-1:0] y1_c;
        wire               ovf1_o;
        if (S1 != 0) begin : g_set1_out
            wire signed [ORW1-1:0] or1_c;
            reg  signed [ORW1-1:0] or1_q;   // round(acc >> OUT_SHIFT_1)
            fx_round #(.IN_W(ACC_W), .SHIFT(OUT_SHIFT_1), .ROUNDING(ROUNDING), .OUT_W(ORW1)) u_ornd1
                (.x(acc_q), .cin(1'b0), .y(or1_c));
            always @(posedge clk) if (st == S_ORND) or1_q <= or1_c;
            fx_fit #(.IN_W(ORW1), .OUT_W(OUT_W_1), .OUT_SIGNED(OUT_SIGNED_1), .OVERFLOW(OVERFLOW)) u_ofit1
                (.x(or1_q), .y(y1_c), .ovf(ovf1_o));
        end else begin : g_one_set
            assign y1_c = {OUT_W_1{1'b0}};
            assign ovf1_o = 1'b0;
        end

        wire [RA_W-1:0] seg_a = {{(RA_W > SEG_W ? RA_W - SEG_W : 0){1'b0}}, seg};   // valid from S_ADDR
        wire [KW-1:0]   j_of_k = K_TOP - k;   // the parallel variant's stage index of power k

        always @(posedge clk) begin
            if (rst) begin
                st <= S_IDLE; ra <= {RA_W{1'b0}}; k <= {KW{1'b0}}; set_q <= 1'b0; pend <= 1'b0;
                out_valid <= 1'b0; y <= {OUT_W{1'b0}}; ovf <= {(2*ORDER+2){1'b0}};
                out_valid_1 <= 1'b0; y_1 <= {OUT_W_1{1'b0}}; ovf_1 <= {(2*ORDER+2){1'b0}};
            end else begin
                out_valid <= 1'b0;
                out_valid_1 <= 1'b0;
                case (st)
                    S_IDLE: if (in_valid || pend) begin   // a sample, or its second set (temp_q holds)
                        if (!pend) begin temp_q <= temp; t_q <= t; end
                        set_q <= pend; pend <= 1'b0; st <= S_SEG;
                    end
                    S_SEG:  st <= S_ADDR;   // the compares of temp_q are registered (le_q)
                    S_ADDR: begin ra <= (set_q ? SET1_A : {RA_W{1'b0}}) + seg_a * NC_A + ORDER_A; st <= S_ROM; end
                    S_ROM:  st <= S_TOP;
                    S_TOP:  begin
                        acc_q <= acc_top; ovf_top_q <= ovf_top;
                        k <= K_TOP; ra <= ra - 1'b1; st <= S_ISSUE;
                    end
                    S_ISSUE: if (mac_ready) st <= S_WAIT;
                    S_WAIT:  if (mac_valid) st <= S_PREG;   // the product is registered at this edge ...
                    S_PREG:  st <= S_PFIT;                  // ... rounded at this one ...
                    S_PFIT:  st <= S_ALGN;                  // ... and fitted at this one (u_prod)
                    S_ALGN:  begin
                        pal_q <= pal_k[k]; ovf_prod_q[j_of_k] <= ovf_p; st <= S_SUM;
                    end
                    S_SUM:   begin s_q <= pal_q + ce; st <= S_SRND; end
                    S_SRND:  begin sr_q <= srnd_k[k]; st <= S_SFIT; end
                    S_SFIT:  begin
                        acc_q <= acc_c; ovf_acc_q[j_of_k] <= ovf_a;
                        if (k == {KW{1'b0}}) begin
                            st <= S_ORND;
                        end else begin
                            k <= k - 1'b1; ra <= ra - 1'b1; st <= S_ISSUE;
                        end
                    end
                    S_ORND:  begin or_q <= or_c; st <= S_OFIT; end
                    default: st <= S_IDLE;   // S_OFIT: the pass's set out (below)
                endcase
                // the pass's outputs, enabled by the registered S_OFIT decode (SETS = 2: set 0's starts set 1's)
                if (out1_q) begin
                    y_1 <= y1_c; ovf_1 <= {ovf1_o, ovf_prod_q, ovf_acc_q, ovf_top_q}; out_valid_1 <= 1'b1;
                end
                if (out0_q) begin
                    y <= y_c; ovf <= {ovf_o, ovf_prod_q, ovf_acc_q, ovf_top_q}; out_valid <= 1'b1;
                    pend <= (S1 != 0);
                end
            end
        end
    end
    endgenerate
endmodule

`default_nettype wire
