// iir: cascade of SECTIONS direct-form-I biquads with second-order error feedback
// (fxdsp.blocks.iir). Per section, from its input v (the previous section's output):
//   acc = ((b0 v + b1 x1 + b2 x2) << SHIFT_B) - ((a1 y1 + a2 y2) << SHIFT_A) + c1 e1 + c2 e2
//   r   = round(acc >> OUT_SHIFT) by ROUNDING (floor / half_up / half_even / toward_zero)
//   y   = fit(r) into DATA_W bits by OVERFLOW (wrap / saturate), ovf[s] flagged
//   e   = acc - (r << OUT_SHIFT), 0 after an overflow
// exact in ACC_W bits. Coefficients from COEF_FILE: 7 words per section (b0 b1 b2 a1 a2 c1 c2),
// COEF_W bits each, sign-extended. State (x1 x2 y1 y2 e1 e2) advances only on an accepted sample;
// rst clears it (the model's reset()). Both architectures give the same y / ovf for every input.
// ARCH = 0: one sample per cycle, the cascade is combinational (one multiplier per product).
//   Interface: in_valid / out_valid (in_ready is tied high). Latency: 1 cycle.
// ARCH = 1: serial. The 7 products of every section run through ONE fx_mac_serial (one 16 x 16
//   multiplier: one SB_MAC16), sequenced section after section by a small FSM; the coefficient
//   ROM (ACOEF_FILE, from the generator: b << SHIFT_B, -(a << SHIFT_A), c in ACOEF_W bits, so that
//   every product is added as it comes) is read through a register (block RAM). Interface:
//   in_valid / in_ready / out_valid; in_ready is high only when idle, a sample is taken at an edge
//   with in_valid && in_ready. MAC operands: a = coefficient word or error e (MA_W = max(ACOEF_W,
//   OUT_SHIFT + 2) bits), b = data or error weight c (DATA_W bits); a product takes N = ceil(MA_W/16) * ceil(DATA_W/16)
//   multiplier cycles (fx_mac_serial latency N + 3). Schedule of a section, in edges after the
//   one that takes the sample (section 0) or after the previous section's update:
//     1 + k N, k = 0..6:   product k issued, in ROM order b0 v, b1 x1, b2 x2, a1 y1, a2 y2,
//                          c1 e1, c2 e2 (v: the section's input); the ROM reads word k + 1 meanwhile
//     (k + 1) N + 5:       product k registered (already aligned, the a products negated: the words)
//     (k + 1) N + 6, + 7:  added into the low, then the high half of sum (AW bits in two halves:
//                          carry chains of AW/2 + 1 bits; the low carry as the high half's carry in)
//     7 N + 8:             r = round(sum) registered (fx_round, ROUNDING)
//     7 N + 9:             fit(r) and its flag (fx_fit, OVERFLOW), error sum - (r << OUT_SHIFT)
//     7 N + 10:            state update (e = 0 after an overflow); the output is the next
//                          section's v; after the last section out_valid is high with y and ovf
//   Cycles per sample: SECTIONS * (7 N + 10) + 1 (416 cycles, 96 kS/s at 40 MHz, hold
//   floor(415 / (7 N + 10)) sections). Latency: SECTIONS * (7 N + 10) cycles from the accepting edge to out_valid.
//   CHANNELS (ARCH = 1 only, default 1): CHANNELS independent signals through the one engine, the
//   same coefficients for each, a state per (channel, section). x, y are CHANNELS * DATA_W bits
//   (channel c in bits [c DATA_W +: DATA_W]), ovf CHANNELS * SECTIONS bits, channel-major (channel
//   c's sections in [c SECTIONS +: SECTIONS]). The FSM runs channel 0's sections, then channel 1's,
//   ...: a channel is one more pass of the section schedule above (the ROM address wraps to b0 of
//   section 0 at the end of a channel). y's slice of channel c loads at the end of channel c; all
//   of y and ovf are valid with out_valid. Cycles per sample: CHANNELS * SECTIONS * (7 N + 10) + 1;
//   latency CHANNELS * SECTIONS * (7 N + 10). CHANNELS = 1 is the single-channel engine above.
//   COEF_SETS (CHANNELS > 1): 1 = every channel filters with the same coefficients (ACOEF_FILE holds
//   one set: 7 SECTIONS words); CHANNELS = one set per channel (SETS_FILE, read instead: 7 SECTIONS
//   CHANNELS words, channel c's from word 7 SECTIONS c), e.g. two different filters through one engine.
//   SPLIT = 1 (CHANNELS > 1): the last channel is a pass of its own. A sample then takes two passes,
//   each started by in_valid and ended by out_valid: channels 0 .. CHANNELS - 2 (x's slices of them
//   read at the first take), then the last channel (its slice read at the second take). Passes
//   alternate from reset; y and ovf slices of a channel change only in its own pass. Cycles per pass:
//   (channels of the pass) * SECTIONS * (7 N + 10) + 1. chain_paper002 ARCH = 1 runs its output
//   low-pass as such a last channel of the demodulator's I / Q engine.
//   State (ARCH = 1): in block RAM, not flip-flops (two SB_RAM40_4K-friendly memories, one
//   registered read port and one write port each: x1 x2 y1 y2 in one, e1 e2 in the other). The
//   state word of product k is read while k holds, like its coefficient; a pair's newer word is
//   marked by a per-slot bit (ph) and an update writes the new value over the older word and flips
//   it (x in the S_LO cycle, y and e in S_UPD), so nothing is copied; rst clears per-slot
//   "written" bits and a word not written since rst reads as 0 (the model's reset state), so the
//   RAM needs no clearing. Same schedule and cycles as above.
//   EXT_MAC = 1: no multiplier here; the products go out on the mac_* bundle (fx_mac_port) to a
//   multiplier shared with other blocks (demod's, chain_paper002's), the schedule unchanged.
`default_nettype none

module iir #(
    parameter integer DATA_W    = 24,
    parameter integer SECTIONS  = 1,
    parameter integer COEF_W    = 35,
    parameter integer ACOEF_W   = 39,    // ARCH = 1: the word of ACOEF_FILE (b << SHIFT_B, -(a << SHIFT_A), c)
    parameter integer SHIFT_B   = 0,
    parameter integer SHIFT_A   = 4,
    parameter integer OUT_SHIFT = 37,
    parameter integer ACC_W     = 64,
    parameter integer ROUNDING  = 1,
    parameter integer OVERFLOW  = 1,
    parameter integer ARCH      = 0,     // 0: one sample per cycle; 1: serial, one shared multiplier
    parameter integer CHANNELS  = 1,     // signals through the engine (> 1: ARCH = 1 only)
    parameter integer COEF_SETS = 1,     // coefficient sets: 1 (ACOEF_FILE, shared) or CHANNELS (SETS_FILE, one per channel)
    parameter integer SPLIT     = 0,     // 1: the last channel runs as a pass of its own (CHANNELS > 1)
    parameter integer EXT_MAC   = 0,     // ARCH = 1: 0 its own fx_mac_serial; 1 the external one on mac_* (fx_mac_port)
    parameter integer MAC_A_W   = 48,    // EXT_MAC = 1: the external multiplier's operand widths (>= MA_W, MB_W)
    parameter integer MAC_B_W   = 32,    // (a: MAC_A_W bits, b: MAC_B_W bits; 3 x 2 limbs by default)
    parameter         COEF_FILE = "iir_coef.hex",       // ARCH = 0: b0 b1 b2 a1 a2 c1 c2 per section
    parameter         ACOEF_FILE = "iir_acoef.hex",     // ARCH = 1: the same words aligned, the a's negated
    parameter         SETS_FILE = "iir_sets_coef.hex"   // COEF_SETS > 1: read instead of ACOEF_FILE (a set per channel)
) (
    input  wire                         clk,
    input  wire                         rst,
    input  wire                         in_valid,
    output wire                         in_ready,  // ARCH = 1: low while a sample is being computed
    input  wire [CHANNELS*DATA_W-1:0]   x,
    output reg                          out_valid,
    output reg  [CHANNELS*DATA_W-1:0]   y,
    output reg  [CHANNELS*SECTIONS-1:0] ovf,
    // the external multiplier (ARCH = 1 and EXT_MAC = 1; else the outputs are 0): fx_mac_port's bundle
    output wire                          mac_in_valid,
    input  wire                          mac_in_ready,
    output wire [MAC_A_W-1:0]            mac_a,
    output wire [MAC_B_W-1:0]            mac_b,
    output wire [3:0]                    mac_na,
    output wire [3:0]                    mac_nb,
    input  wire                          mac_out_valid,
    input  wire [MAC_A_W+MAC_B_W-1:0]    mac_p
`ifdef FORMAL
    ,
    // the products requested on the mac_* bundle and not yet answered (ARCH = 1, EXT_MAC = 1): a
    // formal proof holds the external multiplier's own count to it (fxdsp.hdl.formal)
    output wire [2:0]                    f_mac_in_flight
`endif
);
    localparam integer E_W = OUT_SHIFT + 2;
    localparam integer C_W = 4;                  // |c| <= 2 (checked by the generator)
    localparam integer PW  = COEF_W + DATA_W;    // exact coefficient x data product
    localparam integer CE_W = C_W + E_W;
    // accumulator: ACC_W from the model's bound, at least as wide as one product
    localparam integer AW0 = (ACC_W > PW) ? ACC_W : PW;
    localparam integer AW  = (AW0 > CE_W) ? AW0 : CE_W;
    localparam integer RW  = AW - OUT_SHIFT + 1;

    genvar s;
    generate
        if (CHANNELS < 1 || (CHANNELS > 1 && ARCH != 1)) begin : g_bad_channels
            initial begin $display("iir: CHANNELS > 1 needs ARCH = 1, got CHANNELS %0d, ARCH %0d", CHANNELS, ARCH);
                          $finish; end
        end
        if ((COEF_SETS != 1 && COEF_SETS != CHANNELS) || (SPLIT != 0 && (SPLIT != 1 || CHANNELS < 2)))
        begin : g_bad_split
            initial begin $display("iir: COEF_SETS must be 1 or CHANNELS and SPLIT 0, or 1 with CHANNELS > 1, got %0d, %0d, %0d",
                                   COEF_SETS, SPLIT, CHANNELS); $finish; end
        end
        if (ARCH == 0) begin : g_par
`ifdef FORMAL
            assign f_mac_in_flight = 3'd0;
`endif
            // ---- one sample per cycle: the cascade is combinational ----
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
            wire [SECTIONS-1:0] ovf_c;
            reg [COEF_W-1:0] coef [0:7*SECTIONS-1];     // read at constant addresses: constants
            initial $readmemh(COEF_FILE, coef);
            for (s = 0; s < SECTIONS; s = s + 1) begin : g_sec
                wire signed [COEF_W-1:0] b0 = coef[7*s+0];
                wire signed [COEF_W-1:0] b1 = coef[7*s+1];
                wire signed [COEF_W-1:0] b2 = coef[7*s+2];
                wire signed [COEF_W-1:0] a1 = coef[7*s+3];
                wire signed [COEF_W-1:0] a2 = coef[7*s+4];
                // error-feedback weights are tiny integers (-nearest(a)): C_W bits of their ROM words
                /* verilator lint_off UNUSEDSIGNAL */
                wire [COEF_W-1:0] c1w = coef[7*s+5];
                wire [COEF_W-1:0] c2w = coef[7*s+6];
                /* verilator lint_on UNUSEDSIGNAL */
                wire signed [C_W-1:0] c1 = c1w[C_W-1:0];
                wire signed [C_W-1:0] c2 = c2w[C_W-1:0];
                reg signed [DATA_W-1:0] x1, x2, y1, y2;
                reg signed [E_W-1:0]    e1, e2;
                wire signed [DATA_W-1:0] v;
                if (s == 0) begin : g_in
                    assign v = x;
                end else begin : g_chain
                    assign v = g_sec[s-1].out;
                end
                // exact products at their own width (COEF_W x DATA_W, not AW x AW), summed in AW
                wire signed [PW-1:0]    pb0 = b0 * v;
                wire signed [PW-1:0]    pb1 = b1 * x1;
                wire signed [PW-1:0]    pb2 = b2 * x2;
                wire signed [PW-1:0]    pa1 = a1 * y1;
                wire signed [PW-1:0]    pa2 = a2 * y2;
                wire signed [CE_W-1:0]  pc1 = c1 * e1;
                wire signed [CE_W-1:0]  pc2 = c2 * e2;
                wire signed [AW-1:0] num = {{(AW-PW){pb0[PW-1]}}, pb0} + {{(AW-PW){pb1[PW-1]}}, pb1}
                                            + {{(AW-PW){pb2[PW-1]}}, pb2};
                wire signed [AW-1:0] den = {{(AW-PW){pa1[PW-1]}}, pa1} + {{(AW-PW){pa2[PW-1]}}, pa2};
                wire signed [AW-1:0] efb = {{(AW-CE_W){pc1[CE_W-1]}}, pc1} + {{(AW-CE_W){pc2[CE_W-1]}}, pc2};
                wire signed [AW-1:0] acc = (num <<< SHIFT_B) - (den <<< SHIFT_A) + efb;
                wire signed [RW-1:0] r;
                fx_round #(.IN_W(AW), .SHIFT(OUT_SHIFT), .ROUNDING(ROUNDING), .OUT_W(RW)) u_round (.x(acc), .cin(1'b0), .y(r));
                wire [DATA_W-1:0] out;
                fx_fit #(.IN_W(RW), .OUT_W(DATA_W), .OUT_SIGNED(1), .OVERFLOW(OVERFLOW)) u_fit
                    (.x(r), .y(out), .ovf(ovf_c[s]));
                wire signed [AW-1:0] re  = {{(AW-RW){r[RW-1]}}, r};
                /* verilator lint_off UNUSEDSIGNAL */
                wire signed [AW-1:0] err = acc - (re <<< OUT_SHIFT);
                /* verilator lint_on UNUSEDSIGNAL */
                wire signed [E_W-1:0] e = ovf_c[s] ? {E_W{1'b0}} : err[E_W-1:0];
                always @(posedge clk) begin
                    if (rst) begin
                        x1 <= {DATA_W{1'b0}}; x2 <= {DATA_W{1'b0}};
                        y1 <= {DATA_W{1'b0}}; y2 <= {DATA_W{1'b0}};
                        e1 <= {E_W{1'b0}};    e2 <= {E_W{1'b0}};
                    end else if (in_valid) begin
                        x1 <= v;  x2 <= x1;
                        y1 <= out; y2 <= y1;
                        e1 <= e;  e2 <= e1;
                    end
                end
            end

            always @(posedge clk) begin
                if (rst) begin
                    out_valid <= 1'b0;
                    y         <= {DATA_W{1'b0}};
                    ovf       <= {SECTIONS{1'b0}};
                end else begin
                    out_valid <= in_valid;
                    if (in_valid) begin
                        y   <= g_sec[SECTIONS-1].out;
                        ovf <= ovf_c;
                    end
                end
            end
        end else begin : g_ser
            // ---- serial: the 7 products of every section through one shared fx_mac_serial ----
            localparam integer MA_W = (ACOEF_W > E_W) ? ACOEF_W : E_W;        // a: coefficient word or error e
            localparam integer MB_W = DATA_W;                                // b: data or weight c
            localparam integer MP_W = MA_W + MB_W;
            localparam integer RA_W = (7 * SECTIONS * COEF_SETS > 1) ? $clog2(7 * SECTIONS * COEF_SETS) : 1;
            localparam integer RA_LAST_I = 7 * SECTIONS * COEF_SETS - 1;     // ROM address 7 (set S + sec) + k
            localparam [RA_W-1:0] RA_LAST = RA_LAST_I[RA_W-1:0];
            localparam integer SEC_W = (SECTIONS > 1) ? $clog2(SECTIONS) : 1;
            localparam integer SEC_LAST_I = SECTIONS - 1;
            localparam [SEC_W-1:0] SEC_LAST = SEC_LAST_I[SEC_W-1:0];
            localparam integer SLOTS = CHANNELS * SECTIONS;                  // state slots (channel, section)
            localparam integer SL_W = (SLOTS > 1) ? $clog2(SLOTS) : 1;
            localparam integer CH_W = (CHANNELS > 1) ? $clog2(CHANNELS) : 1;
            localparam integer CH_LAST_I = CHANNELS - 1;
            localparam integer NA = CHANNELS - SPLIT;                         // channels of the first pass
            localparam integer NA_LAST_I = NA - 1;
            localparam integer B_SLOT_I = NA * SECTIONS;                      // the last channel's first slot (SPLIT)
            localparam [CH_W-1:0] CH_LAST = CH_LAST_I[CH_W-1:0];
            localparam [CH_W-1:0] NA_LAST = NA_LAST_I[CH_W-1:0];
            localparam integer LO_W = AW / 2;   // the accumulator in two halves: short carry chains
            localparam integer HI_W = AW - LO_W;
            localparam [2:0] S_IDLE  = 3'd0;    // FSM states
            localparam [2:0] S_MAC   = 3'd1;    // products issued and accumulated
            localparam [2:0] S_LO    = 3'd2;    // the last product's low half ...
            localparam [2:0] S_HI    = 3'd3;    // ... and high half
            localparam [2:0] S_ROUND = 3'd4;
            localparam [2:0] S_FIT   = 3'd5;    // fit and error registered
            localparam [2:0] S_UPD   = 3'd6;    // state update, next section or output
            localparam [2:0] K_B0 = 3'd0;       // product slots, in ROM order
            //               K_B1 = 1: b1 x1 (the newest x word: no case of its own)
            localparam [2:0] K_B2 = 3'd2;
            localparam [2:0] K_A1 = 3'd3;
            localparam [2:0] K_A2 = 3'd4;
            localparam [2:0] K_C1 = 3'd5;
            localparam [2:0] K_C2 = 3'd6;
            localparam [2:0] K_END = 3'd7;      // all seven issued

            if (DATA_W < C_W) begin : g_bad_data_w
                initial begin $display("iir: ARCH=1 needs DATA_W >= %0d, got %0d", C_W, DATA_W); $finish; end
            end

            reg [2:0]        st;
            reg [SEC_W-1:0]  sec;       // section being computed (of the channel ch)
            reg [CH_W-1:0]   ch;        // channel being computed
            wire [31:0]      ch_n = {{(32-CH_W){1'b0}}, ch};   // ch as a number (compared with a loop index)
            wire [SL_W-1:0]  slot;      // its state slot: ch * SECTIONS + sec
            wire signed [DATA_W-1:0] x_first;   // channel 0 of the input sample
            wire signed [DATA_W-1:0] x_next;    // the next channel's input, at the end of a channel
            reg [2:0]        k;         // next product to issue (0..6; 7: all issued)
            reg [2:0]        rk;        // next product to come back from the MAC (0..6)
            reg [RA_W-1:0]   ra;        // ROM address of product k of section sec: 7 sec + k
            // the coefficient words as the products take them (ACOEF_FILE, or SETS_FILE: a set per
            // channel): b << SHIFT_B, -(a << SHIFT_A), c, so every product is added as it comes (no
            // alignment multiplexer, no inversion: ~64 LUT4 at the default config). Read through a
            // register: block RAM (in logic, the 21 words of the paper 002 chain's shared engine cost
            // ~50 LUT4 more)
            (* rom_style = "block" *) reg [ACOEF_W-1:0] acoef [0:7*SECTIONS*COEF_SETS-1];
            // the file of the sets (two parameters: a string conditional would pad the shorter name)
            if (COEF_SETS > 1) begin : g_sets_file
                initial $readmemh(SETS_FILE, acoef);
            end else begin : g_acoef_file
                initial $readmemh(ACOEF_FILE, acoef);
            end
            reg [ACOEF_W-1:0] coef_q;   // registered ROM read
            reg              rom_ok;    // coef_q is acoef[ra] (one cycle after ra moves)
            reg signed [DATA_W-1:0] v;  // the section's input: x, then each section's output
            reg [LO_W-1:0]   sum_lo;    // the section's accumulator (the parallel variant's acc):
            reg [HI_W-1:0]   sum_hi;    // the high half adds the low half's carry one cycle later
            reg [AW-1:0]     term_q;    // the product, registered
            reg              lo_go;     // the low half adds term_q this cycle
            reg              c_q;       // carry out of the low half
            reg [HI_W-1:0]   th_q;      // high half of the term, for the next cycle
            reg              hi_go;     // the high half adds th_q + c_q this cycle
            wire signed [AW-1:0] sum = {sum_hi, sum_lo};
            reg signed [RW-1:0] r_q;    // round(sum)
            reg [DATA_W-1:0] out_q;     // fit(r_q) ...
            reg              ovf_q;     // ... its overflow flag
            reg [E_W-1:0]    res_q;     // sum - (r_q << OUT_SHIFT): the error before the overflow rule
            reg [SLOTS-1:0]  ovf_w;     // flags of the sections done so far
            // the state in block RAM, one registered read port and one write port each (SB_RAM40_4K):
            // xy = x1, x2, y1, y2 (DATA_W bits) at {slot, pair (0 x, 1 y), word}, e = e1, e2 (E_W bits)
            // at {slot, word}. A pair's two words are the newest (1) and the one before (2): word ph of
            // the slot is the newest, ~ph the older; an update writes the new value over the older word
            // and flips ph, so nothing is copied. A word not written since rst reads as 0 (vld: the
            // model's reset state) without clearing the RAM.
            (* ram_style = "block" *) reg [DATA_W-1:0] ram_xy [0:4*(1<<SL_W)-1];
            (* ram_style = "block" *) reg [E_W-1:0]    ram_e  [0:2*(1<<SL_W)-1];
            reg [SLOTS-1:0]  ph;        // per slot: which word of each pair is the newest
            reg [SLOTS-1:0]  vld0;      // per slot: word 0 / word 1 written since rst
            reg [SLOTS-1:0]  vld1;
            reg [DATA_W-1:0] xy_q;      // registered reads
            reg [E_W-1:0]    e_q;
            reg              rd_ok_q;   // ... of words written since rst
            wire ch_done = (sec == SEC_LAST);                   // the channel's last section
            // the pass's last channel: every channel, or (SPLIT) the first pass's last, then the last channel
            wire all_done = ch_done && (CHANNELS == 1 || ch == CH_LAST || (SPLIT != 0 && ch == NA_LAST));
            wire pass_b;                // SPLIT: the next (or current) pass is the last channel's
            wire signed [DATA_W-1:0] x_pass;    // the pass's first input: channel 0's, or the last channel's

            // ---- channels: the state slot, the other channels' inputs ----
            if (CHANNELS == 1) begin : g_one_ch
                assign slot = sec;
                assign x_first = x;
                assign x_next = x_first;     // never used: one channel
                assign pass_b = 1'b0;
                assign x_pass = x_first;
            end else begin : g_chs
                reg [SL_W-1:0] slot_q;       // ch * SECTIONS + sec, counted
                wire take = (st == S_IDLE) && in_valid;
                assign x_first = x[DATA_W-1:0];
                assign slot = slot_q;
                if (NA == 1) begin : g_single   // SPLIT with two channels: a channel per pass
                    assign x_next = x_first;    // never used: one channel per pass
                end else begin : g_first_pass
                    // channels 1 .. NA - 1 of the sample (the first pass's), the next one lowest
                    reg [(NA-1)*DATA_W-1:0] xr;
                    wire [(NA-1)*DATA_W-1:0] x_rest = x[DATA_W +: (NA-1)*DATA_W];
                    if (NA == 2) begin : g_two
                        assign x_next = xr;
                        always @(posedge clk) if (take) xr <= x_rest;
                    end else begin : g_more
                        wire [DATA_W-1:0] xr_lo;
                        wire [(NA-2)*DATA_W-1:0] xr_hi;
                        assign {xr_hi, xr_lo} = xr;
                        assign x_next = xr_lo;
                        always @(posedge clk) begin
                            if (take) xr <= x_rest;
                            else if (st == S_UPD && ch_done) xr <= {xr_lo, xr_hi};   // rotate: next channel lowest
                        end
                    end
                end
                if (SPLIT != 0) begin : g_split
                    // the passes alternate: the first pass's channels, then the last channel alone
                    reg pb;
                    always @(posedge clk) begin
                        if (rst) pb <= 1'b0;
                        else if (st == S_UPD && all_done) pb <= ~pb;
                    end
                    assign pass_b = pb;
                    assign x_pass = pb ? x[CH_LAST_I*DATA_W +: DATA_W] : x_first;
                end else begin : g_whole
                    assign pass_b = 1'b0;
                    assign x_pass = x_first;
                end
                // the pass's first slot: 0, or the last channel's (pass_b)
                always @(posedge clk) begin
                    if (take) slot_q <= pass_b ? B_SLOT_I[SL_W-1:0] : {SL_W{1'b0}};
                    else if (st == S_UPD) slot_q <= slot_q + {{(SL_W-1){1'b0}}, 1'b1};
                end
            end

            assign in_ready = (st == S_IDLE);
            always @(posedge clk) coef_q <= acoef[ra];

            // ---- operands of product k of section sec: the state word read for k (one cycle ahead,
            // like the coefficient: both are read while k holds, rom_ok says when) ----
            // k = 1, 2: x1 (newest word), x2; 3, 4: y1, y2; 5, 6: e1, e2
            wire ph_s = ph[slot];
            wire rd_w = ph_s ^ (k == K_B2 || k == K_A2 || k == K_C2);   // the word: newest, or the older
            wire [SL_W+1:0] xy_ra = {slot, (k == K_A1 || k == K_A2), rd_w};
            wire [SL_W:0]   e_ra  = {slot, rd_w};
            wire            rd_ok = rd_w ? vld1[slot] : vld0[slot];
            always @(posedge clk) begin
                xy_q  <= ram_xy[xy_ra];
                e_q   <= ram_e[e_ra];
                rd_ok_q <= rd_ok;
            end
            wire signed [DATA_W-1:0] s_xy = xy_q & {DATA_W{rd_ok_q}};
            wire signed [E_W-1:0]    s_e  = e_q & {E_W{rd_ok_q}};
            wire signed [MA_W-1:0] ca  = {{(MA_W-ACOEF_W+1){coef_q[ACOEF_W-1]}}, coef_q[ACOEF_W-2:0]};
            wire signed [MA_W-1:0] ea  = {{(MA_W-E_W+1){s_e[E_W-1]}}, s_e[E_W-2:0]};
            // the error-feedback weight: the low C_W bits of its ROM word, as the parallel variant
            wire signed [MB_W-1:0] cb  = {{(MB_W-C_W+1){coef_q[C_W-1]}}, coef_q[C_W-2:0]};
            reg  signed [MA_W-1:0] a_op;
            reg  signed [MB_W-1:0] b_op;
            always @* begin
                case (k)
                    K_B0: begin a_op = ca;  b_op = v;  end
                    K_C1, K_C2: begin a_op = ea; b_op = cb; end
                    default: begin a_op = ca; b_op = s_xy; end   // x1, x2, y1, y2 (the a's words negated)
                endcase
            end

            wire mac_ready, mac_valid;
            // the request: product k's operands are there (not gated by in_ready: see demod.v); issued
            // at the edge where the multiplier's in_ready is high too
            wire mac_req = (st == S_MAC) && (k != K_END) && rom_ok;
            wire issue = mac_req && mac_ready;
            wire signed [MP_W-1:0] p;
            fx_mac_port #(.A_W(MA_W), .B_W(MB_W), .EXT_MAC(EXT_MAC), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)) u_mac
                (.clk(clk), .rst(rst), .in_valid(mac_req), .in_ready(mac_ready), .a(a_op), .b(b_op), .na(4'd0), .nb(4'd0),
                 .out_valid(mac_valid), .p(p), .mac_in_valid(mac_in_valid), .mac_in_ready(mac_in_ready), .mac_a(mac_a), .mac_b(mac_b),
                     .mac_na(mac_na), .mac_nb(mac_nb), .mac_out_valid(mac_out_valid), .mac_p(mac_p));

            // ---- accumulation: every product fits PW or CE_W <= AW bits, so p is exact in AW ----
            wire signed [AW-1:0] pa;
            if (MP_W <= AW) begin : g_p_ext
                assign pa = {{(AW-MP_W+1){p[MP_W-1]}}, p[MP_W-2:0]};
            end else begin : g_p_cut
                /* verilator lint_off UNUSEDSIGNAL */
                wire signed [MP_W-1:0] p_all = p;
                /* verilator lint_on UNUSEDSIGNAL */
                assign pa = p_all[AW-1:0];
            end
            wire [LO_W-1:0] term_lo;
            wire [HI_W-1:0] term_hi;
            assign {term_hi, term_lo} = term_q;
            // the section's first product adds to 0: sum is cleared (the flip-flops' synchronous reset,
            // no multiplexer before the adders) at rst and in S_UPD, after the section's last use of it
            // (res_q, r_q registered in S_FIT) and N + 3 cycles or more before the next section's first add
            wire [LO_W-1:0] lo_base = sum_lo;
            wire [HI_W-1:0] hi_base = sum_hi;
            // the low half's carry into the high half through an extra low bit ({a, 1} + {b, c} = 2 (a +
            // b + c) + 1 + ~c): one adder each
            wire [LO_W-1:0] lo_n;
            wire            lo_c;
            wire [HI_W-1:0] hi_n;
            /* verilator lint_off UNUSEDSIGNAL */
            wire            hi_cin_bit;
            /* verilator lint_on UNUSEDSIGNAL */
            assign {lo_c, lo_n} = {1'b0, lo_base} + {1'b0, term_lo};
            assign {hi_n, hi_cin_bit} = {hi_base, 1'b1} + {th_q, c_q};

            // ---- round, fit, error: the same primitives as the parallel variant ----
            wire signed [RW-1:0] r_c;
            fx_round #(.IN_W(AW), .ROUNDING(ROUNDING), .SHIFT(OUT_SHIFT), .OUT_W(RW)) u_round (.x(sum), .cin(1'b0), .y(r_c));
            wire [DATA_W-1:0] out_c;
            wire              ovf_c;
            fx_fit #(.IN_W(RW), .OUT_W(DATA_W), .OUT_SIGNED(1), .OVERFLOW(OVERFLOW)) u_fit
                (.x(r_q), .y(out_c), .ovf(ovf_c));
            // the error sum - (r_q << OUT_SHIFT) in E_W = OUT_SHIFT + 2 bits: r_q << OUT_SHIFT has no bit
            // below OUT_SHIFT, so those are sum's as they are and only the two above them subtract (a
            // full-width subtraction kept ~37 LUT4 on a carry chain whose low operand bits are 0)
            wire [E_W-1:0] res;
            if (OUT_SHIFT > 0) begin : g_err
                /* verilator lint_off UNUSEDSIGNAL */   // above the error's two top bits
                wire [AW-OUT_SHIFT-1:0] sum_up;
                wire [RW-1:0]           r_all = r_q;
                /* verilator lint_on UNUSEDSIGNAL */
                wire [OUT_SHIFT-1:0]    sum_low;
                assign {sum_up, sum_low} = sum;
                wire [1:0] e_top = sum_up[1:0] - r_all[1:0];
                assign res = {e_top, sum_low};
            end else begin : g_err_none
                /* verilator lint_off UNUSEDSIGNAL */
                wire [AW-1:0] res_all = sum - {{(AW-RW+1){r_q[RW-1]}}, r_q[RW-2:0]};
                /* verilator lint_on UNUSEDSIGNAL */
                assign res = res_all[E_W-1:0];
            end
            wire signed [E_W-1:0] e_c = ovf_q ? {E_W{1'b0}} : res_q;
            reg [SLOTS-1:0] ovf_n;      // the flags with this section's
            always @* begin
                ovf_n = ovf_w;
                ovf_n[slot] = ovf_q;
            end

            // fit and error of r_q, registered every cycle: r_q holds from S_ROUND to S_UPD, so in
            // S_UPD they are those of this section's r_q (no enable: a shorter path into them)
            always @(posedge clk) begin
                out_q <= out_c;
                ovf_q <= ovf_c;
                res_q <= res;
            end

            // the state writes, over the slot's older words (~ph): x = the section's input once its
            // seven products are issued (S_LO), y and e when the section's output is known (S_UPD)
            wire              upd   = (st == S_UPD);
            wire              xy_we = (st == S_LO) || upd;      // one write port: x, then y
            wire [SL_W+1:0]   xy_wa = {slot, upd, ~ph_s};
            wire [DATA_W-1:0] xy_wd = upd ? out_q : v;
            always @(posedge clk) begin
                if (xy_we) ram_xy[xy_wa] <= xy_wd;
                if (upd)   ram_e[{slot, ~ph_s}] <= e_c;
            end

            // a channel's output slice loads in the S_UPD of its last section: the enable registered in
            // S_FIT (ch and sec hold from there to S_UPD), so each slice's clock enable is a flip-flop, not
            // a decode of the state (whose fan-out to every channel's enables would be a chain's slowest
            // placed path, mostly routing)
            reg [CHANNELS-1:0] y_ld;
            integer i;
            always @(posedge clk) begin
                for (i = 0; i < CHANNELS; i = i + 1)
                    y_ld[i] <= !rst && (st == S_FIT) && ch_done && (CHANNELS == 1 || ch_n == i);
                if (rst) y <= {(CHANNELS*DATA_W){1'b0}};
                else
                    for (i = 0; i < CHANNELS; i = i + 1)   // the channel's output (constant slices)
                        if (y_ld[i]) y[i*DATA_W +: DATA_W] <= out_q;
            end
            always @(posedge clk) begin
                if (rst) begin
                    st <= S_IDLE; sec <= {SEC_W{1'b0}}; ch <= {CH_W{1'b0}}; k <= K_B0; rk <= K_B0;
                    lo_go <= 1'b0; hi_go <= 1'b0; sum_lo <= {LO_W{1'b0}}; sum_hi <= {HI_W{1'b0}};
                    ra <= {RA_W{1'b0}}; rom_ok <= 1'b0; ovf_w <= {SLOTS{1'b0}};
                    out_valid <= 1'b0; ovf <= {SLOTS{1'b0}};
                    ph <= {SLOTS{1'b0}}; vld0 <= {SLOTS{1'b0}}; vld1 <= {SLOTS{1'b0}};
                end else begin
                    out_valid <= 1'b0;
                    rom_ok <= ~issue;
                    if (issue) begin
                        k  <= k + 3'd1;
                        ra <= (ra == RA_LAST) ? {RA_W{1'b0}} : ra + {{(RA_W-1){1'b0}}, 1'b1};
                    end
                    lo_go <= mac_valid;
                    hi_go <= lo_go;
                    if (mac_valid) begin
                        term_q   <= pa;
                        rk  <= (rk == K_C2) ? K_B0 : rk + 3'd1;
                    end
                    if (lo_go) begin
                        c_q      <= lo_c;
                        sum_lo   <= lo_n;
                        th_q     <= term_hi;
                    end
                    if (hi_go) sum_hi <= hi_n;
                    if (st == S_UPD) begin   // cleared for the next section's first product (lo_base)
                        sum_lo <= {LO_W{1'b0}}; sum_hi <= {HI_W{1'b0}};
                    end
                    case (st)
                        S_IDLE: if (in_valid) begin
                            v <= x_pass; sec <= {SEC_W{1'b0}}; ch <= pass_b ? CH_LAST : {CH_W{1'b0}};
                            k <= K_B0; st <= S_MAC;
                        end
                        S_MAC: if (mac_valid && rk == K_C2) st <= S_LO;
                        S_LO: st <= S_HI;
                        S_HI: st <= S_ROUND;
                        S_ROUND: begin
                            r_q <= r_c; st <= S_FIT;
                        end
                        S_FIT: st <= S_UPD;
                        default: begin   // S_UPD: the section's output and its state update
                            // the state: x (written in S_LO), y and e over the older words, now the newest
                            ph[slot] <= ~ph_s;
                            if (ph_s) vld0[slot] <= 1'b1;
                            else      vld1[slot] <= 1'b1;
                            v <= out_q;
                            ovf_w[slot] <= ovf_q;
                            if (all_done) begin
                                st <= S_IDLE; out_valid <= 1'b1; ovf <= ovf_n;
                            end else if (ch_done) begin   // the next channel, from its section 0
                                v <= x_next; sec <= {SEC_W{1'b0}}; ch <= ch + {{(CH_W-1){1'b0}}, 1'b1};
                                k <= K_B0; st <= S_MAC;
                            end else begin
                                sec <= sec + {{(SEC_W-1){1'b0}}, 1'b1}; k <= K_B0; st <= S_MAC;
                            end
                        end
                    endcase
                end
            end
`ifdef FORMAL
            // products issued (k) less those returned (rk): the multiplier's own count must agree
            assign f_mac_in_flight = (st == S_MAC) ? k - rk : 3'd0;
            // invariants of every state reachable from rst (proven with the rest, fxdsp.hdl.formal):
            // stated so that an induction proof starts only from states a reset can reach (from an
            // idle state with rk = 7 the seventh product would never be counted and the FSM would wait forever)
            always @* begin
                if (!rst) begin
                    fsm_state_is_one_of_seven: assert(st <= S_UPD);
                    returned_product_index_in_range: assert(rk <= K_C2);
                    section_in_range: assert(sec <= SEC_LAST);
                    idle_means_no_product_in_flight: assert(st != S_IDLE || (rk == K_B0 && !lo_go && !hi_go));
                end
            end
`endif
        end
    endgenerate
endmodule

`default_nettype wire
