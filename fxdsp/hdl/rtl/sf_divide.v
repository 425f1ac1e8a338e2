// sf_divide: scale-factor compensation y = x / SF (fxdsp.blocks.sf_divide).
//   N = x << NUM_SHIFT (exact; NUM_SHIFT = sf.fl + guard_bits)
//   q = sign(N) sign(d) (|N| div |d|)   sequential divider on magnitudes, truncating toward zero,
//                                       UNROLL quotient bits per cycle; non-restoring steps (the
//                                       remainder may go negative, the next step adds |d| back
//                                       instead of a restore: the restoring quotient bits, and the
//                                       step is one adder into the remainder register, no multiplexer)
//   y = fit(round(q >> OUT_SHIFT)) into OUT_W bits: rounding by ROUNDING (floor / half_up /
//       half_even / toward_zero), fit by OVERFLOW (wrap / saturate)
// Division by zero: full scale with the sign of x (0 for x = 0), flagged in ovf[1] when x != 0;
// ovf[0] flags the output fit.
// Interface: valid/ready. A sample is taken when in_valid && in_ready; in_ready is low while
// the divider works.
// ARCH = 0: the sign, rounding and fit of the quotient in the cycle of the last division step.
//   Latency: ceil((IN_W + NUM_SHIFT) / UNROLL) + 1 cycles from acceptance to out_valid; a new
//   sample may be accepted in the cycle out_valid is high (one sample per latency cycles).
// The sign: the quotient bits enter nq XORed with neg, so nq holds q, or ~q for a negative
//   result, and q_s = sign * q = {neg, nq} + neg: the + neg is the rounding adder's carry in
//   (fx_round cin), so the divider needs no negation adder of its own.
// ARCH = 1: the same bits, the output path pipelined for 40 MHz on an iCE40UP5K (in ARCH = 0 the
//   last division step, the rounding adder and the fit are one path): after the last step
//   (nq and neg hold), two cycles of delay (the schedule of the earlier two-stage negation), then
//   fx_convert_pipe rounds {neg, nq} + neg (one cycle) and fits (one cycle), then the output
//   register. Latency: ceil((IN_W + NUM_SHIFT) / UNROLL) + 6 cycles; in_ready is high again in the
//   out_valid cycle (one sample per latency cycles, as ARCH = 0).
`default_nettype none

module sf_divide #(
    parameter integer IN_W      = 16,
    parameter integer SF_W      = 24,
    parameter integer SF_SIGNED = 0,
    parameter integer OUT_W     = 24,
    parameter integer NUM_SHIFT = 32,
    parameter integer OUT_SHIFT = 3,
    parameter integer ROUNDING  = 0,
    parameter integer OVERFLOW  = 1,
    parameter integer UNROLL    = 1,
    parameter integer ARCH      = 0    // 0: output in the last step's cycle; 1: output path pipelined
) (
    input  wire             clk,
    input  wire             rst,
    input  wire             in_valid,
    output wire             in_ready,
    input  wire [IN_W-1:0]  x,
    input  wire [SF_W-1:0]  sf,
    output reg              out_valid,
    output reg  [OUT_W-1:0] y,
    output reg  [1:0]       ovf
);
    localparam integer NW = IN_W + NUM_SHIFT;   // |N| <= 2**(IN_W-1+NUM_SHIFT) fits NW bits
    localparam integer DW = SF_W;               // |d| fits SF_W bits, signed or unsigned
    localparam integer CW = $clog2(NW + 1);

    reg              busy;
    reg [CW-1:0]     cnt;       // quotient bits still to compute
    reg              near_end;  // cnt <= UNROLL: this cycle's steps are the last (registered decode)
    reg [NW-1:0]     nq;        // numerator bits shifted out at the top, quotient bits in at the bottom
    reg [DW:0]       rem;       // the partial remainder, signed, in [-|d|, |d|) (non-restoring)
    reg [DW-1:0]     dmag;
    reg              neg, xneg, xzero, dzero;

    wire             fin;       // ARCH 1: the output path holds a quotient (until out_valid)
    assign in_ready = ~busy & ~fin;

    // ---- operand magnitudes at acceptance ----
    wire [IN_W:0]  xext = {x[IN_W-1], x};
    /* verilator lint_off UNUSEDSIGNAL */  // |x| and |d| fit one bit less than their extension
    wire [IN_W:0]  xabs = x[IN_W-1] ? -xext : xext;
    wire [NW-1:0]  nabs = {xabs[IN_W-1:0], {NUM_SHIFT{1'b0}}};
    wire d_neg = (SF_SIGNED != 0) & sf[SF_W-1];
    wire [DW:0] dext = {((SF_SIGNED != 0) ? sf[SF_W-1] : 1'b0), sf};
    wire [DW:0] dabs = d_neg ? -dext : dext;
    /* verilator lint_on UNUSEDSIGNAL */

    // ---- up to UNROLL division steps per cycle: t = 2 r + b - |d| after a non-negative remainder,
    // 2 r + b + |d| after a negative one (one adder, |d| or its complement with the carry in); the
    // quotient bit is t >= 0 (the restoring step's bit: its restore is folded into the next step) ----
    reg [DW:0]   r_v;
    reg [NW-1:0] nq_v;
    reg [CW-1:0] c_v;
    reg [DW+1:0] t_v;
    reg          qb_v;      // the step's quotient bit
    integer u;
    always @* begin
        r_v = rem; nq_v = nq; c_v = cnt;
        t_v = {(DW+2){1'b0}}; qb_v = 1'b0;
        for (u = 0; u < UNROLL; u = u + 1) begin
            if (c_v != {CW{1'b0}}) begin
                t_v  = {r_v, nq_v[NW-1]} + ({2'b00, dmag} ^ {(DW+2){~r_v[DW]}}) + {{(DW+1){1'b0}}, ~r_v[DW]};
                qb_v = ~t_v[DW+1];
                r_v  = t_v[DW:0];
                // the quotient bit, inverted for a negative result (nq ends as ~q: see the header)
                nq_v = {nq_v[NW-2:0], qb_v ^ neg};
                c_v = c_v - {{(CW-1){1'b0}}, 1'b1};
            end
        end
    end

    // ---- sign, rounding and fit of the finished quotient ----
    wire [OUT_W-1:0] full_pos = {1'b0, {(OUT_W-1){1'b1}}};
    wire [OUT_W-1:0] full_neg = {1'b1, {(OUT_W-1){1'b0}}};
    // the last division step is this cycle: cnt <= UNROLL, decoded a cycle early from the count being
    // loaded (the count after this cycle's steps is <= UNROLL when cnt <= 2 UNROLL), so the decode
    // feeds no control path from the count's decrement chain (that path set Fmax at 39.9 MHz)
    localparam [31:0] NW32 = NW;
    localparam [31:0] U1   = UNROLL;
    localparam [31:0] U2   = 2 * UNROLL;
    wire [31:0]      cnt32 = {{(32-CW){1'b0}}, cnt};
    wire             last = busy & near_end;
    // the result of a division by zero (its own value, no rounding): full scale with the sign of x
    wire [OUT_W-1:0] y_zero = xzero ? {OUT_W{1'b0}} : (xneg ? full_neg : full_pos);

    always @(posedge clk) begin
        if (rst) begin
            busy <= 1'b0; cnt <= {CW{1'b0}}; near_end <= 1'b0;
            nq <= {NW{1'b0}}; rem <= {(DW+1){1'b0}}; dmag <= {DW{1'b0}};
            neg <= 1'b0; xneg <= 1'b0; xzero <= 1'b0; dzero <= 1'b0;
        end else begin
            if (!busy) begin
                if (in_valid && in_ready) begin
                    busy  <= 1'b1;
                    cnt   <= NW[CW-1:0];
                    near_end <= (NW32 <= U1);
                    nq    <= nabs[NW-1:0];
                    rem   <= {(DW+1){1'b0}};
                    dmag  <= dabs[DW-1:0];
                    neg   <= x[IN_W-1] ^ d_neg;
                    xneg  <= x[IN_W-1];
                    xzero <= (x == {IN_W{1'b0}});
                    dzero <= (sf == {SF_W{1'b0}});
                end
            end else begin
                rem <= r_v;
                nq  <= nq_v;
                cnt <= c_v;
                near_end <= ~last & (cnt32 <= U2);
                if (last) busy <= 1'b0;
            end
        end
    end

    generate
        if (ARCH == 0) begin : g_comb
            // q_s = {neg, nq} + neg rounded (the + neg as fx_round's carry in), then fitted
            wire signed [NW:0] qx = {neg, nq_v};
            wire [OUT_W-1:0] y_c;
            wire             o_c;
            fx_convert #(.IN_W(NW+1), .SHIFT(OUT_SHIFT), .ROUNDING(ROUNDING), .OUT_W(OUT_W), .OUT_SIGNED(1),
                         .OVERFLOW(OVERFLOW), .CIN(1)) u_out (.x(qx), .cin(neg), .y(y_c), .ovf(o_c));
            assign fin = 1'b0;
            always @(posedge clk) begin
                if (rst) begin
                    out_valid <= 1'b0; y <= {OUT_W{1'b0}}; ovf <= 2'b00;
                end else begin
                    out_valid <= last;
                    if (last) begin
                        y   <= dzero ? y_zero : y_c;
                        ovf <= dzero ? {~xzero, 1'b0} : {1'b0, o_c};
                    end
                end
            end
        end else begin : g_pipe
            // after the last step nq and neg hold (fin keeps in_ready low until out_valid); stages 1, 2:
            // delay only (the schedule is that of the two-stage negation it replaces); 3, 4:
            // fx_convert_pipe rounds {neg, nq} + neg, then fits; 5: the output register (with the
            // division-by-zero value)
            reg                q_v, h_v, fin_r;
            reg                s_v;
            wire               c_v2;
            wire [OUT_W-1:0]   y_c;
            wire               o_c;
            // q, or ~q with the sign (q_s - neg), copied in stage 2 into a register that feeds only the
            // rounding adder: its NW + 1-bit carry chain then starts beside its operand, not across the
            // die at the divider's shift register (that route alone cost 7 ns at 40 MHz)
            reg signed [NW:0]  q_r;
            reg                neg_r;
            always @(posedge clk) begin
                if (h_v) begin
                    q_r   <= {neg, nq};
                    neg_r <= neg;
                end
            end
            assign fin = fin_r;
            fx_convert_pipe #(.IN_W(NW+1), .SHIFT(OUT_SHIFT), .ROUNDING(ROUNDING), .OUT_W(OUT_W),
                              .OUT_SIGNED(1), .OVERFLOW(OVERFLOW), .CIN(1)) u_out
                (.clk(clk), .rst(rst), .in_valid(s_v), .x(q_r), .cin(neg_r), .out_valid(c_v2), .y(y_c), .ovf(o_c));
            always @(posedge clk) begin
                if (rst) begin
                    q_v <= 1'b0; h_v <= 1'b0; s_v <= 1'b0; fin_r <= 1'b0;
                    out_valid <= 1'b0; y <= {OUT_W{1'b0}}; ovf <= 2'b00;
                end else begin
                    q_v <= last;
                    h_v <= q_v;
                    s_v <= h_v;
                    out_valid <= c_v2;
                    if (last) fin_r <= 1'b1;
                    else if (c_v2) fin_r <= 1'b0;
                    if (c_v2) begin
                        y   <= dzero ? y_zero : y_c;
                        ovf <= dzero ? {~xzero, 1'b0} : {1'b0, o_c};
                    end
                end
            end
        end
    endgenerate
endmodule

`default_nettype wire
