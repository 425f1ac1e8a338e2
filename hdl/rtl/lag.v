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
// Interface: in_valid / out_valid, one sample per cycle (the update is combinational).
// Latency: 1 cycle.
`default_nettype none

module lag #(
    parameter integer TEMP_W   = 18,
    parameter integer GUARD    = 24,
    parameter integer STATE_W  = 43,
    parameter integer ALPHA_W  = 16,
    parameter integer ALPHA_M  = 55877,
    parameter integer ALPHA_S  = 25,
    parameter integer DECIM    = 1,        // the state updates on every DECIM-th sample (>= 1)
    parameter integer ROUNDING = 1,
    parameter integer OVERFLOW = 1
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
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
    endgenerate

    reg signed [STATE_W-1:0] st;                       // te with GUARD extra fraction bits
    reg                      primed;
    reg [PH_W-1:0]           phase;                    // 0: this sample updates the state
    wire                     update = in_valid & (phase == {PH_W{1'b0}});

    wire signed [STATE_W-1:0] xe = {{(STATE_W-TEMP_W){temp[TEMP_W-1]}}, temp};
    wire signed [STATE_W-1:0] xg = xe <<< GUARD;       // exact: fits STATE_W - 1 bits
    wire signed [STATE_W-1:0] base = primed ? st : xg; // not primed: start settled, d = 0
    wire signed [DW-1:0]      d = {xg[STATE_W-1], xg} - {base[STATE_W-1], base};
    wire signed [MW-1:0]      m = M_C;
    wire signed [PW-1:0]      p = d * m;

    wire signed [RW-1:0] step;
    fx_round #(.IN_W(PW), .SHIFT(ALPHA_S), .ROUNDING(ROUNDING), .OUT_W(RW)) u_step (.x(p), .y(step));
    /* verilator lint_off UNUSEDSIGNAL */
    wire signed [SW-1:0] sum = {{(SW-STATE_W){base[STATE_W-1]}}, base} + {{(SW-RW){step[RW-1]}}, step};
    /* verilator lint_on UNUSEDSIGNAL */
    wire signed [STATE_W-1:0] st_next = sum[STATE_W-1:0];  // in range: between base and xg

    wire [TEMP_W-1:0] te_c;
    wire              ovf_c;
    fx_convert #(.IN_W(STATE_W), .SHIFT(GUARD), .ROUNDING(ROUNDING), .OUT_W(TEMP_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_out (.x(st_next), .y(te_c), .ovf(ovf_c));

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
endmodule

`default_nettype wire
