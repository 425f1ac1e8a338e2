// rtd: RTD bridge ADC code -> temperature code (fxdsp.blocks.rtd).
// The code, read as offset binary, splits into a segment index (top LUT_INDEX_BITS bits) and a
// fraction (the low S = ADC_W - LUT_INDEX_BITS bits); the LUT (2**LUT_INDEX_BITS + 1 entries,
// LUT_FILE) gives exact = (L[i] << S) + (L[i+1] - L[i]) * frac, then one rounding by ROUNDING
// (floor / half_up / half_even / toward_zero) over SHIFT bits and one fit by OVERFLOW
// (wrap / saturate) into TEMP_W bits; ovf flags that fit. Both architectures give the same
// temp / ovf for every input (the same exact value, the same fx_round / fx_fit).
// ARCH = 0: one sample per cycle, the LUT read combinationally (two read ports: LUT4 logic).
//   Interface: in_valid / out_valid (in_ready is tied high). Latency: 1 cycle.
// ARCH = 1: serial. The LUT is read through ONE registered read port (q <= lut[addr]: block RAM,
//   SB_RAM40_4K), L[i] and L[i+1] in two consecutive cycles; the product diff * frac runs through
//   ONE fx_mac_serial (one 16 x 16 multiplier: one SB_MAC16); a small FSM sequences it.
//   Interface: in_valid / in_ready / out_valid; in_ready is high only when idle, a sample is taken
//   at an edge with in_valid && in_ready; out_valid is a one-cycle pulse with temp and ovf.
//   MAC operands: a = diff = L[i+1] - L[i] (LUT_W + 1 bits), b = frac zero-extended (S + 1 bits);
//   a product takes N = ceil((LUT_W + 1)/16) * ceil((S + 1)/16) multiplier cycles (fx_mac_serial
//   latency N + 3). Schedule, in edges after the edge 0 that takes the sample:
//     0:       q = L[i] registered (the ROM address is the code's index while idle); frac and
//              i + 1 registered
//     1:       q = L[i+1] registered (address i + 1); base = L[i] registered
//     2:       diff = q - base registered
//     3:       product diff * frac issued to the MAC
//     N + 7:   exact = (base << S) + product registered (the MAC's out_valid cycle)
//     N + 8:   r = round(exact) registered (fx_round, ROUNDING)
//     N + 9:   temp = fit(r) and its flag registered (fx_fit, OVERFLOW), out_valid high;
//              in_ready high again from the next cycle
//   Cycles per sample: N + 10, far inside the 416 cycles of a 96 kS/s sample at 40 MHz.
//   Latency: N + 9 cycles from the accepting edge to out_valid.
//   EXT_MAC = 1: no multiplier here; the product goes out on the mac_* bundle (fx_mac_port) to a
//   multiplier shared with other blocks (chain_paper002's), the schedule unchanged.
`default_nettype none

module rtd #(
    parameter integer ADC_W          = 16,             // ADC code bits (signed, read as offset binary)
    parameter integer LUT_INDEX_BITS = 9,              // K: segment index bits; the LUT has 2**K + 1 words
    parameter integer LUT_W          = 26,             // LUT word bits (signed temperature)
    parameter integer TEMP_W         = 22,             // output temperature bits (signed)
    parameter integer SHIFT          = 10,             // rounding shift: exact -> temp (lut.fl + S - temp.fl)
    parameter integer ROUNDING       = 1,              // 0 floor, 1 half_up, 2 half_even, 3 toward_zero
    parameter integer OVERFLOW       = 1,              // 0 wrap, 1 saturate
    parameter integer ARCH           = 0,              // 0: one sample per cycle; 1: serial, one shared multiplier
    parameter integer EXT_MAC        = 0,              // ARCH = 1: 0 its own fx_mac_serial; 1 the external one on mac_* (fx_mac_port)
    parameter integer MAC_A_W        = 48,             // EXT_MAC = 1: the external multiplier's operand widths (>= LUT_W + 1, ADC_W - LUT_INDEX_BITS + 1)
    parameter integer MAC_B_W        = 32,             // (a: MAC_A_W bits, b: MAC_B_W bits; 3 x 2 limbs by default)
    parameter         LUT_FILE       = "rtd_lut.hex"   // $readmemh file of the 2**K + 1 LUT words
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
    output wire              in_ready,   // ARCH = 1: low while a sample is being computed
    input  wire [ADC_W-1:0]  code,
    output wire              out_valid,
    output wire [TEMP_W-1:0] temp,
    output wire              ovf,
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
    localparam integer K  = LUT_INDEX_BITS;
    localparam integer S  = ADC_W - LUT_INDEX_BITS;
    localparam integer EW = LUT_W + S + 2;

    generate
        if (ARCH != 0 && ARCH != 1) begin : g_bad_arch
            initial begin $display("rtd: ARCH must be 0 or 1, got %0d", ARCH); $finish; end
        end
        if (LUT_INDEX_BITS < 1 || LUT_INDEX_BITS >= ADC_W) begin : g_bad_index
            initial begin $display("rtd: LUT_INDEX_BITS must be 1..ADC_W-1 (%0d), got %0d", ADC_W - 1,
                                   LUT_INDEX_BITS); $finish; end
        end
        if (LUT_W < 2) begin : g_bad_lut_w
            initial begin $display("rtd: LUT_W must be >= 2, got %0d", LUT_W); $finish; end
        end
    endgenerate

    reg [LUT_W-1:0] lut [0:(1<<K)];
    initial $readmemh(LUT_FILE, lut);

    wire [ADC_W-1:0] u    = {~code[ADC_W-1], code[ADC_W-2:0]};   // offset binary
    wire [K-1:0]     idx  = u[ADC_W-1:S];
    wire [S-1:0]     frac = u[S-1:0];
    wire [K:0]       idx1 = {1'b0, idx} + {{K{1'b0}}, 1'b1};

    generate
        if (ARCH == 0) begin : g_par
            // ---- one sample per cycle: both LUT words read combinationally ----
            assign in_ready = 1'b1;
            // no multiplier in this variant: the bundle unused
            assign mac_in_valid = 1'b0;
            assign mac_a = {MAC_A_W{1'b0}};
            assign mac_b = {MAC_B_W{1'b0}};
            assign mac_na = 4'd0;
            assign mac_nb = 4'd0;
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_mac = mac_in_ready ^ mac_out_valid ^ (^mac_p);
            /* verilator lint_on UNUSEDSIGNAL */
            wire signed [LUT_W-1:0] base = lut[{1'b0, idx}];
            wire signed [LUT_W-1:0] nxt  = lut[idx1];
            wire signed [LUT_W:0]   diff = {nxt[LUT_W-1], nxt} - {base[LUT_W-1], base};
            wire signed [S:0]       fr   = {1'b0, frac};
            wire signed [EW-1:0]    prod = diff * fr;
            wire signed [EW-1:0]    be   = {{(EW-LUT_W){base[LUT_W-1]}}, base};
            wire signed [EW-1:0]    exact = (be <<< S) + prod;

            fx_convert_reg #(.IN_W(EW), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(TEMP_W), .OUT_SIGNED(1),
                             .OVERFLOW(OVERFLOW)) u_out (.clk(clk), .rst(rst), .in_valid(in_valid), .x(exact),
                                                         .out_valid(out_valid), .y(temp), .ovf(ovf));
        end else begin : g_ser
            // ---- serial: one registered LUT read port, one shared fx_mac_serial ----
            localparam integer DW   = LUT_W + 1;        // diff = L[i+1] - L[i], exact
            localparam integer FW   = S + 1;            // frac as a signed (non-negative) operand
            localparam [2:0] S_IDLE  = 3'd0;    // FSM states; idle: the ROM reads L[i] of the code
            localparam [2:0] S_RD1   = 3'd1;    // the ROM reads L[i+1], base = L[i]
            localparam [2:0] S_DIFF  = 3'd2;    // diff = L[i+1] - L[i]
            localparam [2:0] S_MAC   = 3'd3;    // diff * frac issued
            localparam [2:0] S_WAIT  = 3'd4;    // waiting for the product; exact registered with it
            localparam [2:0] S_ROUND = 3'd5;    // r = round(exact)
            localparam [2:0] S_FIT   = 3'd6;    // temp = fit(r) registered, out_valid next

            reg [2:0]               st;
            reg [K:0]               a1_q;       // i + 1: the ROM address of the second read
            reg [S-1:0]             frac_q;     // the sample's fraction
            reg [LUT_W-1:0]         q;          // registered ROM read (block RAM output register)
            reg signed [LUT_W-1:0]  base_q;     // L[i]
            reg signed [DW-1:0]     diff_q;     // L[i+1] - L[i]
            reg signed [EW-1:0]     ex_q;       // the exact interpolation value

            assign in_ready  = (st == S_IDLE);

            // one read port, address registered by the RAM: the code's index while idle, then i + 1
            wire [K:0] addr = (st == S_IDLE) ? {1'b0, idx} : a1_q;
            always @(posedge clk) q <= lut[addr];

            wire signed [LUT_W-1:0] qs = q;
            wire signed [DW-1:0]    d_c = {qs[LUT_W-1], qs} - {base_q[LUT_W-1], base_q};
            always @(posedge clk) begin
                if (st == S_IDLE) begin
                    a1_q   <= idx1;
                    frac_q <= frac;
                end
                if (st == S_RD1) base_q <= qs;
                if (st == S_DIFF) diff_q <= d_c;
            end

            // ---- the product diff * frac: exact in DW + FW = EW bits ----
            wire signed [FW-1:0] fr = {1'b0, frac_q};
            wire mac_ready, mac_valid;
            wire issue = (st == S_MAC) && mac_ready;
            wire signed [EW-1:0] p;
            fx_mac_port #(.A_W(DW), .B_W(FW), .EXT_MAC(EXT_MAC), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)) u_mac
                (.clk(clk), .rst(rst), .in_valid(st == S_MAC), .in_ready(mac_ready), .a(diff_q), .b(fr), .na(4'd0), .nb(4'd0),
                 .out_valid(mac_valid), .p(p), .mac_in_valid(mac_in_valid), .mac_in_ready(mac_in_ready), .mac_a(mac_a), .mac_b(mac_b),
                     .mac_na(mac_na), .mac_nb(mac_nb), .mac_out_valid(mac_out_valid), .mac_p(mac_p));

            wire signed [EW-1:0] be   = {{(EW-LUT_W){base_q[LUT_W-1]}}, base_q};
            wire signed [EW-1:0] ex_c = (be <<< S) + p;

            // ---- round (in S_ROUND), fit (in S_FIT): the parallel variant's fx_convert, pipelined ----
            fx_convert_pipe #(.IN_W(EW), .SHIFT(SHIFT), .ROUNDING(ROUNDING), .OUT_W(TEMP_W), .OUT_SIGNED(1),
                              .OVERFLOW(OVERFLOW)) u_out (.clk(clk), .rst(rst), .in_valid(st == S_ROUND), .x(ex_q), .cin(1'b0),
                                                          .out_valid(out_valid), .y(temp), .ovf(ovf));

            always @(posedge clk) begin
                if (rst) begin
                    st <= S_IDLE;
                end else begin
                    case (st)
                        S_IDLE: if (in_valid) st <= S_RD1;
                        S_RD1:  st <= S_DIFF;
                        S_DIFF: st <= S_MAC;
                        S_MAC:  if (issue) st <= S_WAIT;
                        S_WAIT: if (mac_valid) begin
                            ex_q <= ex_c; st <= S_ROUND;
                        end
                        S_ROUND: st <= S_FIT;
                        default: st <= S_IDLE;   // S_FIT: the output registered, out_valid next
                    endcase
                end
            end
        end
    endgenerate
endmodule

`default_nettype wire
