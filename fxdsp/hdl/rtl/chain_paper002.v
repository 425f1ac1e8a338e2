// chain_paper002: the paper 002 RTD path (fxdsp.chains.Paper002Chain), top level.
//   rtd_code -> rtd -> temp -> piecewise_sf -> SF ; vsa / SF -> sf_divide -> demod (I)
//   temp -> piecewise_bias -> bias ; I - bias -> bias_subtract -> iir -> rate
// Optional stages, chosen by the config through the generated header (absent = the above, and the
// disabled stage is not elaborated): LAG_EN = 1 puts lag (lag_params.vh) between rtd and the two
// coefficient engines (SF and bias see the die-temperature estimate te; the temp output stays the
// thermometer's); the NCO reference's phase trim is demod's PHASE_TRIM (demod_params.vh, 0 = none).
// Every block's parameters come from the generated headers (`fxdsp hdl-gen`), i.e. from the one
// config; roundings (floor / half_up / half_even / toward_zero) and overflows (wrap / saturate)
// are those of each block. The demodulator's Q channel runs as in the model (its filter state is
// part of the reference) but only I is used; amp and phase are left unconnected.
// Interface (both architectures): valid/ready with one sample in flight: in_ready is high when the
// chain is idle, which includes the cycle of out_valid (busy clears as out_valid is registered, so
// the next sample may enter as this one leaves); a sample is accepted on in_valid && in_ready and
// leaves (temp, rate, ovf) with a one-cycle out_valid. Both architectures give the same temp, rate
// and ovf for every input (the same blocks' bits; only the cycle order differs).
// ovf: every block's overflow flags of the sample, valid with out_valid:
// {iir, bias_subtract, demod, sf_divide (zero, out), piecewise_bias, piecewise_sf, [lag,] rtd}.
// ARCH = 0: every block in its one-sample-per-clock variant (the divider iterative).
//   Latency ceil((VSA_W + sf.fl + guard_bits) / DIV_UNROLL) + 7 + LAG_EN cycles from acceptance to
//   out_valid (55 at DIV_UNROLL = 1 on the default config: 16 + 22 + 10 = 48 divider steps), one
//   sample every latency + 1 cycles; SF and bias computed at once.
// ARCH = 1: every block that has a serial variant in it, .ARCH(1): rtd, [lag,] piecewise_sf,
//   piecewise_bias, iir, demod (the rtd LUT and the demod's NCO table in block RAM), sf_divide
//   (iterative in both; ARCH = 1 pipelines its output path); bias_subtract is one registered stage.
//   ONE fx_mac_serial (one SB_MAC16, MAC_A_W x MAC_B_W operands, VAR_N = 1) serves rtd, the
//   piecewise engine(s), demod (its own products and its low-pass filters') and iir: they run one
//   after another, so each gets EXT_MAC = 1 and issues on its mac_* bundle (fx_mac_port) with its own
//   limb counts, i.e. its own schedule; the requests (at most one at a time, a simulation check
//   says so) select the operands, out_valid goes to the block that issued (own, set at the take).
//   [The lag keeps its own multiplier.] One filter engine: when the output low-pass has the
//   demodulator's low-pass format (LPF_SHARED, from the generator), the output filter is the third
//   channel of the demodulator's I / Q filter engine (demod AUX_LPF = 1, its coefficients the third
//   set of LPF_SETS_FILE, from the generator), run after the subtraction while the demodulator is idle, with
//   the same schedule as the iir of its own (D_iir); else the iir has an engine of its own. Each
//   block starts on its predecessor's out_valid pulse and holds its registered outputs until its
//   next sample, so one sample in flight needs no buffering (every block is idle when its pulse
//   comes: each one's in_ready is high again at most a cycle after its own out_valid, long before
//   the chain's next sample reaches it); the demodulator alone, whose schedule is its own, gets a
//   handshake: its start waits for its in_ready and for the bias engine's (idle: off the shared
//   multiplier; the divider's quotient holds meanwhile).
//   Schedule (D_x: edges from block x's accepting edge to its successor's, = its cycles per sample
//   for the serial blocks (each header gives it; demod's too: 6 N + 30 + 3 ITERATIONS + 2
//   LPF_SECTIONS (7 M + 10)), = ceil(NW / DIV_UNROLL) + 6 for the pipelined divider (ARCH = 1),
//   NW = VSA_W + sf.fl + guard_bits):
//     rtd from the accepting edge; [lag on rtd's out_valid;] piecewise_sf on the temperature's
//     out_valid; then, on SF's out_valid, sf_divide (vsa / SF; vsa registered at acceptance) and
//     piecewise_bias (the temperature held by rtd / lag) at once: the two Horner engines never
//     run together (one shared MAC), the bias engine runs while the divider works (the divider
//     has no multiplier); demod on the later of the divider's out_valid and the bias engine's
//     (the shared multiplier: demod's first product is issued without a wait) (and its in_ready); the
//     subtraction I - bias one cycle after the later of demod's and the bias engine's out_valid
//     (both held in the blocks' output registers); iir on the subtraction's out_valid; out_valid
//     one cycle after the iir's, busy cleared with it.
//   Cycles per sample (accepting edge to the next sample's, back to back):
//     D_rtd + [D_lag] + D_sf + max(D_div, D_bias) + D_demod + 3 + D_iir
//   = (N_rtd + 10) + [(N_lag + 11)] + (ORDER_sf (N_sf + 10) + 7) + max(ceil(NW/DIV_UNROLL) + 6,
//     ORDER_b (N_b + 10) + 7) + D_demod + 3 + (SECTIONS (7 N_iir + 10) + 1), the N the blocks'
//     limb counts (their headers);
//   349 at the default config and DIV_UNROLL = 1: 12 + 21 + max(54, 21) + 206 + 3 + 53 (366 with
//   the lag at DECIM = 1: + 17; 316 at DIV_UNROLL = 7, where the bias engine's 21 cycles outlast
//   the divider's 13), against 416 cycles per sample at 40 MHz and 96 kS/s.
//   One coefficient engine: when SF(T) and bias(T) differ only in their coefficients and output
//   stage (PW_SHARED, from the generator: the same breakpoints, formats and rules), they are the
//   two coefficient sets of ONE piecewise engine (SETS = 2, the bias set's COEF_ALIGN, OUT_SHIFT,
//   OUT_W, OUT_SIGNED, ACOEF_W from PW1_* and BIAS_W, both sets in PW_SETS_FILE): the bias pass starts as
//   SF's out_valid leaves, as the bias engine of its own would, so the schedule above is unchanged;
//   else (e.g. the random set half_even_narrow) two engines.
`default_nettype none

module chain_paper002 #(
`include "chain_paper002_params.vh"
    , parameter integer DIV_UNROLL = 1
    , parameter integer ARCH = 0    // 0: one-sample-per-clock blocks; 1: their serial variants
    // ARCH = 1: operand widths of the one multiplier the serial blocks share: 3 x 2 limbs of 16 bits
    // (the widest products of the default config, the iir's and the demod filters' 39-bit coefficient
    // or error x 24-bit data, need them); a block whose operands exceed them stops the elaboration
    , parameter integer MAC_A_W = 48
    , parameter integer MAC_B_W = 32   // (see MAC_A_W)
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              in_valid,
    output wire              in_ready,
    input  wire [VSA_W-1:0]  vsa,
    input  wire [CODE_W-1:0] rtd_code,
    output reg               out_valid,
    output reg  [TEMP_W-1:0] temp,
    output reg  [RATE_W-1:0] rate,
    output reg  [N_OVF-1:0]  ovf
);
    // ARCH = 1 and one low-pass format: the output low-pass runs on the demodulator's filter engine
    localparam integer AUX = (ARCH == 1 && LPF_SHARED != 0) ? 1 : 0;
    // ARCH = 1 and one coefficient-engine format: SF(T) and bias(T) on one piecewise engine
    localparam integer PW = (ARCH == 1 && PW_SHARED != 0) ? 1 : 0;
    reg busy;
    assign in_ready = ~busy;
    wire accept = in_valid & ~busy;

    // ---- the shared multiplier's bundle (fx_mac_port; ARCH = 1, below): each serial block's request,
    // one reply. Users, bit i of own: 0 rtd, 1 piecewise_sf, 2 piecewise_bias, 3 demod (its own
    // products and its low-pass filters'), 4 iir. ARCH = 0: no request, nothing replies.
    localparam integer NU = 5;
    localparam integer MAC_P_W = MAC_A_W + MAC_B_W;
    wire               rt_req, sf_req, bi_req, dm_req, ir_req;
    wire [MAC_A_W-1:0] rt_a, sf_a, bi_a, dm_a, ir_a;
    wire [MAC_B_W-1:0] rt_b, sf_b, bi_b, dm_b, ir_b;
    wire [3:0]         rt_na, sf_na, bi_na, dm_na, ir_na, rt_nb, sf_nb, bi_nb, dm_nb, ir_nb;
    wire               sh_ready, sh_valid;
    wire [MAC_P_W-1:0] sh_p;
    reg  [NU-1:0]      own;      // who issued the product in the multiplier: its out_valid goes there

    reg [VSA_W-1:0] vsa_r;

    // ---- temperature ----
    wire              t_v;
    wire [TEMP_W-1:0] t_w;
    wire              ovf_rtd;
    rtd #(
`include "rtd_params.vh"
        , .ARCH(ARCH), .EXT_MAC(ARCH), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)
    ) u_rtd (.clk(clk), .rst(rst), .in_valid(accept), .in_ready(), .code(rtd_code), .out_valid(t_v), .temp(t_w),
             .ovf(ovf_rtd),
             .mac_in_valid(rt_req), .mac_in_ready(sh_ready), .mac_a(rt_a), .mac_b(rt_b), .mac_na(rt_na),
             .mac_nb(rt_nb), .mac_out_valid(sh_valid & own[0]), .mac_p(sh_p));

    // ---- the temperature the coefficient engines see: t_w, or the lag's te (generate below) ----
    wire              ce_v;
    wire [TEMP_W-1:0] ce_w;

    // ---- SF(T) and bias(T): two engines, or (PW) one engine with two coefficient sets ----
    wire                sf_v, b_v;
    wire                b_ready;     // the bias engine is idle (ARCH 1: the demodulator may start)
    wire [SF_W-1:0]     sf_w;
    wire [BIAS_W-1:0]   b_w;
    wire [SF_OVF_W-1:0] ovf_sf;
    wire [B_OVF_W-1:0]  ovf_b;
    generate
        if (PW != 0) begin : g_pw_shared
            // SF's set, then bias's on the same temperature (SETS = 2): the bias pass starts as SF
            // leaves, as the bias engine of its own would on sf_v (ARCH 1); in_ready is high when both are done
            piecewise #(
`include "piecewise_sf_params.vh"
                , .ARCH(ARCH), .EXT_MAC(ARCH), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)
                , .SETS(2), .SETS_FILE(PW_SETS_FILE), .COEF_ALIGN_1(PW1_COEF_ALIGN), .OUT_SHIFT_1(PW1_OUT_SHIFT)
                , .OUT_W_1(BIAS_W), .OUT_SIGNED_1(PW1_OUT_SIGNED), .ACOEF_W_1(PW1_ACOEF_W)
            ) u_pw (.clk(clk), .rst(rst), .in_valid(ce_v), .in_ready(b_ready), .temp(ce_w), .out_valid(sf_v),
                    .y(sf_w), .ovf(ovf_sf), .out_valid_1(b_v), .y_1(b_w), .ovf_1(ovf_b),
                    .mac_in_valid(sf_req), .mac_in_ready(sh_ready), .mac_a(sf_a), .mac_b(sf_b), .mac_na(sf_na),
                    .mac_nb(sf_nb), .mac_out_valid(sh_valid & own[1]), .mac_p(sh_p));
            assign bi_req = 1'b0;
            assign bi_a = {MAC_A_W{1'b0}};
            assign bi_b = {MAC_B_W{1'b0}};
            assign bi_na = 4'd0;
            assign bi_nb = 4'd0;
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_own_b = own[2];     // the bias set's products are the shared engine's (own[1])
            /* verilator lint_on UNUSEDSIGNAL */
        end else begin : g_pw_two
            // the bias engine's start: with SF (ARCH 0), after it (ARCH 1: it runs during the division)
            wire b_go = (ARCH == 0) ? ce_v : sf_v;
            piecewise #(
`include "piecewise_sf_params.vh"
                , .ARCH(ARCH), .EXT_MAC(ARCH), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)
            ) u_sf (.clk(clk), .rst(rst), .in_valid(ce_v), .in_ready(), .temp(ce_w), .out_valid(sf_v), .y(sf_w),
                    .ovf(ovf_sf), .out_valid_1(), .y_1(), .ovf_1(),
                    .mac_in_valid(sf_req), .mac_in_ready(sh_ready), .mac_a(sf_a), .mac_b(sf_b), .mac_na(sf_na),
                    .mac_nb(sf_nb), .mac_out_valid(sh_valid & own[1]), .mac_p(sh_p));
            piecewise #(
`include "piecewise_bias_params.vh"
                , .ARCH(ARCH), .EXT_MAC(ARCH), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)
            ) u_bias (.clk(clk), .rst(rst), .in_valid(b_go), .in_ready(b_ready), .temp(ce_w), .out_valid(b_v),
                      .y(b_w), .ovf(ovf_b), .out_valid_1(), .y_1(), .ovf_1(),
                      .mac_in_valid(bi_req), .mac_in_ready(sh_ready), .mac_a(bi_a), .mac_b(bi_b), .mac_na(bi_na),
                      .mac_nb(bi_nb), .mac_out_valid(sh_valid & own[2]), .mac_p(sh_p));
        end
    endgenerate

    // ---- sense / SF ----
    wire             d_v;
    wire [DIV_W-1:0] d_w;
    wire [1:0]       ovf_div;
    /* verilator lint_off UNUSEDSIGNAL */
    wire             div_ready;
    /* verilator lint_on UNUSEDSIGNAL */
    sf_divide #(
`include "sf_divide_params.vh"
        , .UNROLL(DIV_UNROLL), .ARCH(ARCH)
    ) u_div (.clk(clk), .rst(rst), .in_valid(sf_v), .in_ready(div_ready), .x(vsa_r), .sf(sf_w),
             .out_valid(d_v), .y(d_w), .ovf(ovf_div));

    // ---- demodulator (I) ----
    wire                   aux_go, aux_v;        // AUX: the output low-pass on demod's filter engine
    wire [DATA_W-1:0]      aux_x, aux_y;
    wire [IIR_OVF_W-1:0]   aux_o;
    wire                   i_v;
    wire [DATA_W-1:0]      i_w;
    wire [DEMOD_OVF_W-1:0] ovf_dm;
    wire                   dm_go;     // the demodulator's start: the divider's out_valid (ARCH 1: and in_ready)
    /* verilator lint_off UNUSEDSIGNAL */
    wire                   dm_ready;  // in_ready: high in ARCH 0 (one sample per cycle), honoured in ARCH 1
    wire [DATA_W-1:0]      q_w, amp_w;
    wire [ANGLE_W-1:0]     ph_w;
    /* verilator lint_on UNUSEDSIGNAL */
    demod #(
`include "demod_params.vh"
        , .ARCH(ARCH), .EXT_MAC(ARCH), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)
        , .AUX_LPF(AUX), .AUX_COEF_FILE(LPF_SETS_FILE)
    ) u_demod (.clk(clk), .rst(rst), .in_valid(dm_go), .in_ready(dm_ready), .x(d_w), .out_valid(i_v), .i(i_w), .q(q_w),
               .amp(amp_w), .phase(ph_w), .ovf(ovf_dm),
             .mac_in_valid(dm_req), .mac_in_ready(sh_ready), .mac_a(dm_a), .mac_b(dm_b), .mac_na(dm_na),
             .mac_nb(dm_nb), .mac_out_valid(sh_valid & own[3]), .mac_p(sh_p),
             .aux_in_valid(aux_go), .aux_x(aux_x), .aux_out_valid(aux_v), .aux_y(aux_y), .aux_ovf(aux_o));

    // ---- I - bias(T), final low-pass ----
    wire             s_v;
    wire [SUB_W-1:0] s_w;
    wire             ovf_sub;
    wire              sub_go;     // the subtraction's start: demod's out_valid (ARCH 0), the join (ARCH 1)
    wire [DATA_W-1:0] sub_x;      // its I: demod's output
    wire [BIAS_W-1:0] sub_b;      // its bias: registered here (ARCH 0), the bias engine's held output (ARCH 1)
    wire [TEMP_W-1:0] temp_o;     // the temperature output: registered here (ARCH 0), rtd's held output (ARCH 1)
    bias_subtract #(
`include "bias_subtract_params.vh"
    ) u_sub (.clk(clk), .rst(rst), .in_valid(sub_go), .x(sub_x), .bias(sub_b), .out_valid(s_v), .y(s_w),
             .ovf(ovf_sub));
    wire                 r_v;
    wire [RATE_W-1:0]    r_w;
    wire [IIR_OVF_W-1:0] ovf_iir;
    generate
        if (AUX != 0) begin : g_lpf_shared
            // the output low-pass: the demodulator's filter engine's third channel (aux_*)
            assign aux_go  = s_v;
            assign aux_x   = s_w;     // LPF_SHARED: the output low-pass's data format is the demodulator's
            assign r_v     = aux_v;
            assign r_w     = aux_y;
            assign ovf_iir = aux_o;
            assign ir_req = 1'b0;
            assign ir_a = {MAC_A_W{1'b0}};
            assign ir_b = {MAC_B_W{1'b0}};
            assign ir_na = 4'd0;
            assign ir_nb = 4'd0;
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_own = own[4];       // the output low-pass's products are demod's (own[3])
            /* verilator lint_on UNUSEDSIGNAL */
        end else begin : g_lpf_own
            assign aux_go = 1'b0;
            assign aux_x  = {DATA_W{1'b0}};
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_aux = aux_v ^ (^aux_y) ^ (^aux_o);
            /* verilator lint_on UNUSEDSIGNAL */
            iir #(
`include "iir_params.vh"
                , .ARCH(ARCH), .EXT_MAC(ARCH), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)
            ) u_iir (.clk(clk), .rst(rst), .in_valid(s_v), .in_ready(), .x(s_w), .out_valid(r_v), .y(r_w), .ovf(ovf_iir),
                     .mac_in_valid(ir_req), .mac_in_ready(sh_ready), .mac_a(ir_a), .mac_b(ir_b), .mac_na(ir_na),
                     .mac_nb(ir_nb), .mac_out_valid(sh_valid & own[4]), .mac_p(sh_p));
        end
    endgenerate

    // ---- per-sample registers (one sample in flight) ----
    reg                ovf_rtd_r;
    reg [SF_OVF_W-1:0] ovf_sf_r;
    reg [B_OVF_W-1:0]  ovf_b_r;
    reg [1:0]          ovf_div_r;
    reg [DEMOD_OVF_W-1:0] ovf_dm_r;
    reg                ovf_sub_r;
    always @(posedge clk) begin
        if (accept) vsa_r <= vsa;
        if (t_v) ovf_rtd_r <= ovf_rtd;
        if (sf_v) ovf_sf_r <= ovf_sf;
        if (b_v) ovf_b_r <= ovf_b;
        if (d_v) ovf_div_r <= ovf_div;
        if (i_v) ovf_dm_r <= ovf_dm;
        if (s_v) ovf_sub_r <= ovf_sub;
    end

    // ---- optional stages and the ovf vector they extend ----
    wire [N_OVF-1:0] ovf_n;
    generate
        if (LAG_EN != 0) begin : g_lag
            wire lag_v, ovf_lag;
            wire [TEMP_W-1:0] te_w;
            lag #(
`include "lag_params.vh"
                , .ARCH(ARCH)
            ) u_lag (.clk(clk), .rst(rst), .in_valid(t_v), .in_ready(), .temp(t_w), .out_valid(lag_v), .te(te_w),
                     .ovf(ovf_lag));
            reg ovf_lag_r;
            always @(posedge clk) if (lag_v) ovf_lag_r <= ovf_lag;
            assign ce_v  = lag_v;
            assign ce_w  = te_w;
            assign ovf_n = {ovf_iir, ovf_sub_r, ovf_dm_r, ovf_div_r, ovf_b_r, ovf_sf_r, ovf_lag_r, ovf_rtd_r};
        end else begin : g_direct
            assign ce_v  = t_v;
            assign ce_w  = t_w;
            assign ovf_n = {ovf_iir, ovf_sub_r, ovf_dm_r, ovf_div_r, ovf_b_r, ovf_sf_r, ovf_rtd_r};
        end
    endgenerate

    // ---- sequencing of the coefficient engines, the demodulator and the subtraction ----
    generate
        if (ARCH == 0) begin : g_par
            // one-sample-per-clock blocks: every start is the predecessor's out_valid
            assign dm_go  = d_v;
            assign sub_go = i_v;
            assign sub_x  = i_w;
            // the pipelined blocks' outputs move on with the next sample's: temperature and bias held here
            reg [TEMP_W-1:0] temp_r;
            reg [BIAS_W-1:0] b_r;
            always @(posedge clk) begin
                if (t_v) temp_r <= t_w;
                if (b_v) b_r <= b_w;
            end
            assign sub_b  = b_r;
            assign temp_o = temp_r;
            // no shared multiplier
            assign sh_ready = 1'b0;
            assign sh_valid = 1'b0;
            assign sh_p = {MAC_P_W{1'b0}};
            always @(posedge clk) own <= {NU{1'b0}};
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_mac = rt_req ^ sf_req ^ bi_req ^ dm_req ^ ir_req ^ b_ready
                              ^ (^rt_a) ^ (^sf_a) ^ (^bi_a) ^ (^dm_a) ^ (^ir_a) ^ (^rt_b) ^ (^sf_b) ^ (^bi_b) ^ (^dm_b)
                              ^ (^ir_b) ^ (^rt_na) ^ (^sf_na) ^ (^bi_na) ^ (^dm_na) ^ (^ir_na) ^ (^rt_nb) ^ (^sf_nb)
                              ^ (^bi_nb) ^ (^dm_nb) ^ (^ir_nb);
            /* verilator lint_on UNUSEDSIGNAL */
        end else begin : g_ser
            // the demodulator: started on the divider's out_valid once its in_ready is high and the
            // bias engine is idle (the quotient d_w holds in the divider's output register until the
            // next division). The bias engine's idle is what keeps the two off the shared multiplier
            // at once (the demodulator's first product is issued without a wait); it costs no cycle
            // when the bias engine finishes before the divider (always with the serial demod's ...
            // and at the default config: 21 against 54 cycles)
            reg dm_pend;
            assign dm_go = (d_v | dm_pend) & dm_ready & b_ready;
            always @(posedge clk) begin
                if (rst | accept) dm_pend <= 1'b0;
                else dm_pend <= (d_v | dm_pend) & ~dm_go;
            end

            // ---- the one multiplier of the serial blocks: they run one after another (the schedule
            // above; the demodulator after the bias engine), so at most one requests at a time: the
            // operands are selected by the requests (one-hot), in_ready goes to every block (only the
            // requester reads it), and out_valid to the block that issued the product (own, set
            // as the multiplier takes it). Each block keeps its own limb counts (VAR_N = 1), so its
            // schedule is that of its own multiplier.
            wire [NU-1:0] req = {ir_req, dm_req, bi_req, sf_req, rt_req};
            wire [MAC_A_W-1:0] sh_a = ({MAC_A_W{rt_req}} & rt_a) | ({MAC_A_W{sf_req}} & sf_a) | ({MAC_A_W{bi_req}} & bi_a)
                                    | ({MAC_A_W{dm_req}} & dm_a) | ({MAC_A_W{ir_req}} & ir_a);
            wire [MAC_B_W-1:0] sh_b = ({MAC_B_W{rt_req}} & rt_b) | ({MAC_B_W{sf_req}} & sf_b) | ({MAC_B_W{bi_req}} & bi_b)
                                    | ({MAC_B_W{dm_req}} & dm_b) | ({MAC_B_W{ir_req}} & ir_b);
            wire [3:0] sh_na = ({4{rt_req}} & rt_na) | ({4{sf_req}} & sf_na) | ({4{bi_req}} & bi_na)
                             | ({4{dm_req}} & dm_na) | ({4{ir_req}} & ir_na);
            wire [3:0] sh_nb = ({4{rt_req}} & rt_nb) | ({4{sf_req}} & sf_nb) | ({4{bi_req}} & bi_nb)
                             | ({4{dm_req}} & dm_nb) | ({4{ir_req}} & ir_nb);
            wire sh_in = |req;
            fx_mac_serial #(.A_W(MAC_A_W), .B_W(MAC_B_W), .VAR_N(1)) u_mac (.clk(clk), .rst(rst), .in_valid(sh_in),
                .in_ready(sh_ready), .a(sh_a), .b(sh_b), .na(sh_na), .nb(sh_nb), .out_valid(sh_valid), .p(sh_p));
            always @(posedge clk) begin
                if (rst) own <= {NU{1'b0}};
                else if (sh_in & sh_ready) own <= req;
            end
`ifndef SYNTHESIS
            // simulation only: two requests at once would be a scheduling error (one product lost)
            always @(posedge clk) begin
                if (!rst && (req & (req - {{(NU-1){1'b0}}, 1'b1})) != {NU{1'b0}}) begin
                    $display("chain_paper002: blocks %b request the shared multiplier at once", req);
                    $finish;
                end
            end
`endif
            // the subtraction: one cycle after the later of I (demod's out_valid) and bias(T) (the
            // bias engine's out_valid), from the blocks' output registers: each holds its value until its
            // block's next sample, which is the chain's next (no copy here; the temperature likewise)
            reg i_done, b_done, sub_q;
            wire last = (i_v & (b_done | b_v)) | (b_v & i_done);
            always @(posedge clk) begin
                if (rst | accept) begin
                    i_done <= 1'b0; b_done <= 1'b0; sub_q <= 1'b0;
                end else begin
                    sub_q <= last;
                    if (i_v) i_done <= 1'b1;
                    if (b_v) b_done <= 1'b1;
                end
            end
            assign sub_go = sub_q;
            assign sub_x  = i_w;
            assign sub_b  = b_w;
            assign temp_o = t_w;
        end
    endgenerate

    always @(posedge clk) begin
        if (rst) begin
            busy      <= 1'b0;
            out_valid <= 1'b0;
            temp      <= {TEMP_W{1'b0}};
            rate      <= {RATE_W{1'b0}};
            ovf       <= {N_OVF{1'b0}};
        end else begin
            out_valid <= r_v;
            if (accept) busy <= 1'b1;
            if (r_v) begin
                busy <= 1'b0;
                temp <= temp_o;
                rate <= r_w;
                ovf  <= ovf_n;
            end
        end
    end
endmodule

`default_nettype wire
