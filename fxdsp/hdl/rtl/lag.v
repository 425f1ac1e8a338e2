// lag: thermal-lag compensation, a first-order low-pass on the temperature code
// (fxdsp.blocks.lag). The state st (the model's Te) carries GUARD more fraction bits than the code
// (state_guard_bits; without them a dead band of 1/alpha codes), alpha = ALPHA_M * 2**-ALPHA_S
// (ALPHA_M an ALPHA_W-bit mantissa, alpha_bits). Per accepted sample:
//   d    = (temp << GUARD) - st                      exact, STATE_W + 1 bits
//   st   = st + round(d * ALPHA_M >> ALPHA_S)        rounding by ROUNDING (floor / half_up /
//                                                    half_even / toward_zero); st stays between
//                                                    its old value and temp << GUARD (alpha <= 1)
//   te   = fit(round(st >> GUARD)) into TEMP_W bits  same ROUNDING, OVERFLOW (wrap / saturate),
//                                                    ovf flagged (unreachable while alpha <= 1)
// Primed: the first sample accepted after rst starts the state settled, st = temp << GUARD (so
// d = 0 and te = temp), as the model's reset() + run(). STATE_W is the model's state_format
// word length (TEMP_W + GUARD + 1). State (st, primed) advances only on in_valid; rst clears it.
// Decimation (DECIM, the model's decimation = the chain's fs / rate_hz): the state updates on the
// first accepted sample after rst and then on every DECIM-th; te holds between updates and ovf is
// set only on an update's sample (the model counts overflows at updates). DECIM = 1: every sample.
// Both architectures give the same te / ovf / out_valid sequence for every input (same integer
// operations, same fx_round / fx_fit, different cycle order).
// ARCH = 0: one sample per cycle, the update is combinational (the product on its own multiplier).
//   Interface: in_valid / out_valid (in_ready is tied high). Latency: 1 cycle.
// ARCH = 1: serial. The one product d * ALPHA_M runs through ONE fx_mac_serial (one 16 x 16
//   multiplier: one SB_MAC16), every other step in its own register stage, the two wide adds (d,
//   and the state update) in two halves with the carry registered between (carry chains of about
//   STATE_W/2 bits), sequenced by a small FSM. Interface: in_valid / in_ready / out_valid; in_ready
//   is high only when idle, a sample is taken at an edge with in_valid && in_ready. MAC operands:
//   a = d (DW = STATE_W + 1 bits), b = ALPHA_M (MW = ALPHA_W + 1 bits, signed); the product takes
//   N = ceil(DW/16) * ceil(MW/16) multiplier cycles (fx_mac_serial latency N + 3). Schedule, in
//   edges after the one that takes the sample (edge 0):
//     0:       the sample registered (t_q), the phase counter advanced; the first sample after rst
//              primes the state (st = temp << GUARD, so d = 0). A held sample (not an update)
//              ends here: out_valid with te unchanged and ovf = 0, in_ready stays high
//     1:       low half of d = (t_q << GUARD) - st registered, with its carry
//     2:       high half of d added; d issued to the MAC (its operand register)
//     N + 6:   step = round(d * ALPHA_M >> ALPHA_S) registered (fx_round, ROUNDING)
//     N + 7:   st = st + step: the low half (its carry registered) ...
//     N + 8:   ... and the high half
//     N + 9:   round(st >> GUARD) registered (fx_round, ROUNDING)
//     N + 10:  te = fit(...) and its flag registered (fx_fit, OVERFLOW); out_valid high, in_ready
//              high again
//   Cycles per sample: N + 11 for an update, 1 for a held sample (DECIM > 1). Latency: N + 10 cycles (update), 1 (held).
`default_nettype none

module lag #(
    parameter integer TEMP_W   = 22,       // bits of the temperature code temp / te (signed)
    parameter integer GUARD    = 20,       // extra fraction bits of the state st beyond the code
    parameter integer STATE_W  = 43,       // bits of the state st (TEMP_W + GUARD + 1)
    parameter integer ALPHA_W  = 16,       // bits of the unsigned alpha mantissa
    parameter integer ALPHA_M  = 55877,    // alpha mantissa: alpha = ALPHA_M * 2**-ALPHA_S
    parameter integer ALPHA_S  = 25,       // alpha shift
    parameter integer DECIM    = 1,        // the state updates on every DECIM-th sample (>= 1)
    parameter integer ROUNDING = 1,        // 0 floor, 1 half_up, 2 half_even, 3 toward_zero
    parameter integer OVERFLOW = 1,        // te fit: 0 wrap, 1 saturate
    parameter integer ARCH     = 0         // 0: one sample per cycle; 1: serial, one shared multiplier
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
    output wire              in_ready,     // ARCH = 1: low while a sample is being computed
    input  wire [TEMP_W-1:0] temp,
    output reg               out_valid,
    output reg  [TEMP_W-1:0] te,
    output reg               ovf
);
    localparam integer DW  = STATE_W + 1;              // d = (temp << GUARD) - te, exact
    localparam integer MW  = ALPHA_W + 1;              // the unsigned mantissa as a signed word
    localparam integer PW  = DW + MW;                  // exact d * ALPHA_M
    localparam integer RW0 = PW - ALPHA_S + 1;         // fx_round output width (right shift)
    localparam integer RW  = (RW0 < 2) ? 2 : RW0;
    localparam integer SW  = ((RW > STATE_W) ? RW : STATE_W) + 1;   // te + step, exact
    localparam [MW-1:0] M_C = ALPHA_M[MW-1:0];
    // phase counter: samples since the last update, 0..DECIM-1 (at least 1 bit wide)
    localparam integer PH_W = (DECIM > 1) ? $clog2(DECIM) : 1;
    localparam integer    PH_LAST_I = DECIM - 1;
    localparam [PH_W-1:0] PH_LAST = PH_LAST_I[PH_W-1:0];

    generate
        if (DECIM < 1) begin : g_bad_decim
            initial begin $display("lag: DECIM must be >= 1, got %0d", DECIM); $finish; end
        end
        if (ARCH != 0 && ARCH != 1) begin : g_bad_arch
            initial begin $display("lag: ARCH must be 0 or 1, got %0d", ARCH); $finish; end
        end
    endgenerate

    generate
        if (ARCH == 0) begin : g_par
    // ---- one sample per cycle: the update is combinational (this branch keeps the indentation
    // of the original module: the mutation lists name its lines) ----
    assign in_ready = 1'b1;

    reg signed [STATE_W-1:0] st;                       // te with GUARD extra fraction bits
    reg                      primed;
    reg [PH_W-1:0]           phase;                    // 0: this sample updates the state
    // DECIM = 1: every sample updates whatever the (then unread) count holds, so no state of the
    // register breaks the stated schedule (proven from any state by induction, fxdsp.hdl.formal)
    wire                     update = in_valid & ((DECIM == 1) | (phase == {PH_W{1'b0}}));

    wire signed [STATE_W-1:0] xe = {{(STATE_W-TEMP_W){temp[TEMP_W-1]}}, temp};
    wire signed [STATE_W-1:0] xg = xe <<< GUARD;       // exact: fits STATE_W - 1 bits
    wire signed [STATE_W-1:0] base = primed ? st : xg; // not primed: start settled, d = 0
    wire signed [DW-1:0]      d = {xg[STATE_W-1], xg} - {base[STATE_W-1], base};
    wire signed [MW-1:0]      m = M_C;
    wire signed [PW-1:0]      p = d * m;

    wire signed [RW-1:0] step;
    fx_round #(.IN_W(PW), .SHIFT(ALPHA_S), .ROUNDING(ROUNDING), .OUT_W(RW)) u_step (.x(p), .cin(1'b0), .y(step));
    /* verilator lint_off UNUSEDSIGNAL */
    wire signed [SW-1:0] sum = {{(SW-STATE_W){base[STATE_W-1]}}, base} + {{(SW-RW){step[RW-1]}}, step};
    /* verilator lint_on UNUSEDSIGNAL */
    wire signed [STATE_W-1:0] st_next = sum[STATE_W-1:0];  // in range: between base and xg

    wire [TEMP_W-1:0] te_c;
    wire              ovf_c;
    fx_convert #(.IN_W(STATE_W), .SHIFT(GUARD), .ROUNDING(ROUNDING), .OUT_W(TEMP_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_out (.x(st_next), .cin(1'b0), .y(te_c), .ovf(ovf_c));

    always @(posedge clk) begin
        if (rst) begin
            st     <= {STATE_W{1'b0}};
            primed <= 1'b0;
            phase  <= {PH_W{1'b0}};
        end else if (in_valid) begin
            if (update) begin
                st     <= st_next;
                primed <= 1'b1;
            end
            phase <= (phase == PH_LAST) ? {PH_W{1'b0}} : phase + 1'b1;
        end
    end

    always @(posedge clk) begin
        if (rst) begin
            out_valid <= 1'b0;
            te        <= {TEMP_W{1'b0}};
            ovf       <= 1'b0;
        end else begin
            out_valid <= in_valid;
            if (update) te <= te_c;
            if (in_valid) ovf <= update & ovf_c;
        end
    end
        end else begin : g_ser
            // ---- serial: d * ALPHA_M on one shared fx_mac_serial, a register after every step ----
            localparam integer TW0  = (GUARD > 0) ? STATE_W - GUARD + 1 : STATE_W;  // round(st >> GUARD)
            localparam integer TW   = (TW0 < 2) ? 2 : TW0;
            localparam integer DLO  = DW / 2;           // d in two halves: short carry chains
            localparam integer DHI  = DW - DLO;
            localparam integer SLO  = STATE_W / 2;      // the state likewise
            localparam integer SHI  = STATE_W - SLO;
            localparam [3:0] S_IDLE  = 4'd0;    // FSM states
            localparam [3:0] S_DLO   = 4'd1;    // d's low half registered
            localparam [3:0] S_ISSUE = 4'd2;    // d issued to the MAC (its high half added here)
            localparam [3:0] S_MAC   = 4'd3;    // waiting for the product; step registered at its end
            localparam [3:0] S_ADDLO = 4'd4;    // state update st + step: the low half ...
            localparam [3:0] S_ADDHI = 4'd5;    // ... and the high half with the low half's carry
            localparam [3:0] S_RND   = 4'd6;    // round(st >> GUARD) registered
            localparam [3:0] S_FIT   = 4'd7;    // te, ovf, out_valid

            if (STATE_W < TEMP_W + GUARD + 1) begin : g_bad_state_w
                initial begin
                    $display("lag: ARCH=1 needs STATE_W >= TEMP_W + GUARD + 1, got %0d", STATE_W);
                    $finish;
                end
            end

            reg [3:0]           fsm;
            reg [SLO-1:0]       sv_lo;      // the state (the model's Te, GUARD extra fraction bits) ...
            reg [SHI-1:0]       sv_hi;      // ... in two halves
            reg                 sv_primed;  // the state holds a value (a sample was taken since rst)
            reg [PH_W-1:0]      ph;         // samples since the last update (0: the next one updates)
            reg [TEMP_W-1:0]    t_q;        // the sample being computed
            reg [DLO-1:0]       d_lo_q;     // low half of d ...
            reg                 dc_q;       // ... and its carry into the high half
            reg signed [RW-1:0] step_q;     // round(d * ALPHA_M >> ALPHA_S)
            reg                 sc_q;       // carry of the state's low half into its high half
            reg signed [TW-1:0] r_q;        // round(st >> GUARD), fitted in the next cycle
            wire signed [STATE_W-1:0] sv = {sv_hi, sv_lo};

            assign in_ready = (fsm == S_IDLE);

            // ---- d = (t_q << GUARD) - sv = tg + ~sv + 1, in two halves (the + 1 as a carry in) ----
            wire signed [STATE_W-1:0] tx = {{(STATE_W-TEMP_W){t_q[TEMP_W-1]}}, t_q};
            wire signed [STATE_W-1:0] tg = tx <<< GUARD;        // exact: fits STATE_W - 1 bits
            wire [DLO-1:0] tg_lo, nv_lo;
            wire [DHI-1:0] tg_hi, nv_hi;
            assign {tg_hi, tg_lo} = {tg[STATE_W-1], tg};
            assign {nv_hi, nv_lo} = ~{sv[STATE_W-1], sv};
            // carries in through an extra low bit ({a, 1} + {b, c} = 2 (a + b + c) + 1 + ~c): one adder each
            wire [DLO-1:0] d_lo_c;
            wire           d_lo_co;
            wire [DHI-1:0] d_hi_c;
            /* verilator lint_off UNUSEDSIGNAL */
            wire           d_lo_cin, d_hi_cin;
            /* verilator lint_on UNUSEDSIGNAL */
            assign {d_lo_co, d_lo_c, d_lo_cin} = {1'b0, tg_lo, 1'b1} + {1'b0, nv_lo, 1'b1};
            assign {d_hi_c, d_hi_cin} = {tg_hi, 1'b1} + {nv_hi, dc_q};
            wire signed [DW-1:0] d_c = {d_hi_c, d_lo_q};
            wire signed [MW-1:0] m_c = M_C;

            wire mac_ready, mac_valid;
            wire issue = (fsm == S_ISSUE) & mac_ready;
            wire signed [PW-1:0] p;
            fx_mac_serial #(.A_W(DW), .B_W(MW)) u_mac (.clk(clk), .rst(rst), .in_valid(issue),
                .in_ready(mac_ready), .a(d_c), .b(m_c), .na(4'd0), .nb(4'd0), .out_valid(mac_valid), .p(p));

            // ---- step = round(p >> ALPHA_S): the same primitive as the parallel variant ----
            wire signed [RW-1:0] step_c;
            fx_round #(.IN_W(PW), .ROUNDING(ROUNDING), .SHIFT(ALPHA_S), .OUT_W(RW)) u_step_s (.x(p), .cin(1'b0), .y(step_c));
            // the state update is modulo 2**STATE_W (the result is in range): step at STATE_W bits
            wire [STATE_W-1:0] step_s;
            if (RW >= STATE_W) begin : g_step_cut
                /* verilator lint_off UNUSEDSIGNAL */
                wire [RW-1:0] step_all = step_q;
                /* verilator lint_on UNUSEDSIGNAL */
                assign step_s = step_all[STATE_W-1:0];
            end else begin : g_step_ext
                assign step_s = {{(STATE_W-RW){step_q[RW-1]}}, step_q};
            end
            wire [SLO-1:0] step_lo;
            wire [SHI-1:0] step_hi;
            assign {step_hi, step_lo} = step_s;
            wire [SLO-1:0] s_lo_c;
            wire           s_lo_co;
            wire [SHI-1:0] s_hi_c;
            /* verilator lint_off UNUSEDSIGNAL */
            wire           s_lo_cin, s_hi_cin;
            /* verilator lint_on UNUSEDSIGNAL */
            assign {s_lo_co, s_lo_c, s_lo_cin} = {1'b0, sv_lo, 1'b1} + {1'b0, step_lo, 1'b0};
            assign {s_hi_c, s_hi_cin} = {sv_hi, 1'b1} + {step_hi, sc_q};

            // ---- te = fit(round(sv >> GUARD)): the same primitives, one stage each ----
            wire signed [TW-1:0] r_c;
            fx_round #(.IN_W(STATE_W), .ROUNDING(ROUNDING), .SHIFT(GUARD), .OUT_W(TW)) u_te_round (.x(sv), .cin(1'b0), .y(r_c));
            wire [TEMP_W-1:0] te_c;
            wire              ovf_c;
            fx_fit #(.IN_W(TW), .OUT_W(TEMP_W), .OUT_SIGNED(1), .OVERFLOW(OVERFLOW)) u_te_fit
                (.x(r_q), .y(te_c), .ovf(ovf_c));

            // datapath registers (no reset: each is written before it is read)
            always @(posedge clk) begin
                if (fsm == S_IDLE) t_q <= temp;
                d_lo_q <= d_lo_c;       // t_q and sv hold from S_DLO to S_ISSUE: d's low half ...
                dc_q   <= d_lo_co;      // ... and carry of this sample in S_ISSUE
                if (mac_valid) step_q <= step_c;
                sc_q <= s_lo_co;        // sv_lo and step_q hold in S_ADDLO: its carry in S_ADDHI
                r_q  <= r_c;            // sv holds from S_ADDHI's edge on: in S_FIT r_q is round(sv)
            end

            always @(posedge clk) begin
                if (rst) begin
                    fsm <= S_IDLE; sv_lo <= {SLO{1'b0}}; sv_hi <= {SHI{1'b0}}; sv_primed <= 1'b0;
                    ph <= {PH_W{1'b0}}; out_valid <= 1'b0; te <= {TEMP_W{1'b0}}; ovf <= 1'b0;
                end else begin
                    out_valid <= 1'b0;
                    case (fsm)
                        S_IDLE: if (in_valid) begin
                            ph <= (ph == PH_LAST) ? {PH_W{1'b0}} : ph + 1'b1;
                            if (!sv_primed) begin           // start settled: st = temp << GUARD, d = 0
                                {sv_hi, sv_lo} <= {{(STATE_W-TEMP_W){temp[TEMP_W-1]}}, temp} <<< GUARD;
                                sv_primed <= 1'b1;
                            end
                            if ((DECIM == 1) | (ph == {PH_W{1'b0}})) begin   // DECIM = 1: as for phase above
                                fsm <= S_DLO;               // an update: through the MAC
                            end else begin
                                out_valid <= 1'b1;          // held: te unchanged, no overflow
                                ovf       <= 1'b0;
                            end
                        end
                        S_DLO: fsm <= S_ISSUE;
                        S_ISSUE: if (mac_ready) fsm <= S_MAC;
                        S_MAC: if (mac_valid) fsm <= S_ADDLO;
                        S_ADDLO: begin
                            sv_lo <= s_lo_c;
                            fsm <= S_ADDHI;
                        end
                        S_ADDHI: begin
                            sv_hi <= s_hi_c;                // sv in range: between the old sv and tg
                            fsm <= S_RND;
                        end
                        S_RND: fsm <= S_FIT;
                        default: begin                      // S_FIT
                            te <= te_c; ovf <= ovf_c; out_valid <= 1'b1;
                            fsm <= S_IDLE;
                        end
                    endcase
                end
            end
        end
    endgenerate
endmodule

`default_nettype wire
