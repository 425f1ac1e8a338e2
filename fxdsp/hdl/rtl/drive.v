// drive: the drive loop of paper 002's figure 4 (fxdsp.blocks.drive): a PLL and an amplitude
// controller keeping the drive mode at its resonance with a set amplitude. Per sample x (drive ADC):
//   phase detector: cos, -sin of the NCO phase (nco_wave), mixers i = fit(R(x cos >> MIX_SHIFT)),
//     q = fit(R(x msin >> MIX_SHIFT)) into DATA_W bits (the factor 2 is in MIX_SHIFT), one iir
//     low-pass per channel (LPF_*, its own LPF_ROUNDING / LPF_OVERFLOW): mix_lpf;
//   every UPDATE_EVERY samples: CORDIC vectoring (cordic_vector), amp = fit(R(x_K INV_K >>
//     AMP_SHIFT)), the phase error e = angle - PHASE_SET wrapped once into (-PI_WORD, PI_WORD] (the
//     angle is within +-3.4 rad and PHASE_SET within +-pi, so one wrap suffices); while amp >= MIN_AMP
//     the PLL (drive_pi: KP_F, KI_F, PI_SHIFT_F, limits +-LOCK_RANGE) sets ftw = FTW_CENTER + df and
//     f = fit(HZ_CENTER + R(df HZ_COEF >> HZ_SHIFT)) into FREQ_W bits (held below MIN_AMP); the
//     amplitude PI (KP_A, KI_A, PI_SHIFT_A, limits 0 .. GAIN_MAX) on AMP_SET - amp sets the gain;
//   dac = fit(R(gain msin' >> DAC_SHIFT)) into DAC_W bits, msin' the NCO read ADVANCE / 2**ADVANCE_BITS
//     samples ahead (phase + ((ftw ADVANCE) >>> ADVANCE_BITS), floor): the DAC's latency and hold;
//   phase += ftw (mod 2**PHASE_BITS).
// Outputs per sample: dac, f (Hz on the freq format), amp and phase (held between updates; phase is
// e, on ANGLE_W bits), nco (the phase word the mixers read: a demodulator's reference). nco_next is
// the word the next sample's nco will be, valid whenever no sample is in flight (after out_valid, and
// from reset): a reader takes its reference with the sample instead of waiting for the loop's pass.
// Rounding R by ROUNDING (0 floor, 1 half_up, 2 half_even, 3 toward_zero); every fit by OVERFLOW
// (0 wrap, 1 saturate), flagged in ovf = {f, dac, amp, lpf_q[LPF_SECTIONS], lpf_i[LPF_SECTIONS],
// mix_q, mix_i} (amp's flag only at an update, f's only at a PLL update: the model counts them
// there). The PIs' limits are the control law's clamps, always saturating, not overflows. The NCO
// correction is rounded by ROUNDING and has no fit (the model proves NCO_W bits hold it).
// rst returns every register to the model's reset(). Both architectures give the same words.
// ARCH = 0: one sample per cycle at most: in_valid / out_valid, in_ready tied high. A sample's
//   low-pass outputs are registered by the iir (its latency 1); in the next cycle the update, the
//   DAC word and the next phase are combinational, registered at its end with out_valid. The next
//   sample, if it comes in that cycle, reads the new phase combinationally (the feedback closes
//   within a sample, as in the model). Latency: 2 cycles.
// ARCH = 1: serial. The phase detector is the serial demodulator's engine (demod ARCH = 1, REF = 1:
//   the table at the loop's phase, one multiplier, the two-channel iir, the iterative CORDIC and its
//   amplitude product, EXT_MAC = 1 on this module's multiplier), whose CORDIC runs every sample; the
//   controller's products (KP_F e, KI_F e, KP_A ea, KI_A ea, ftw ADVANCE, df HZ_COEF, then gain
//   -sin') go through the same multiplier, each on its own limb counts (VAR_N = 1; ENG_A_W x ENG_B_W,
//   the generator's widest operands; EXT_MAC = 1 the external one on mac_*), and the carrier's -sin'
//   is a wave pass of the same engine (demod WAVE = 1).
//   The PIs (drive_pi) and the conversions work on the registered products. Every sample runs the
//   same schedule (the update's products too, kept only at an update: a constant cycles per
//   sample, what the sample period must hold), in edges after the edge 0 that takes the sample:
//     0 .. D:          the demodulator's pass (D its cycles per sample, demod.v): amp, angle
//                      and flags registered with its out_valid; e = wrap(angle - PHASE_SET), ea =
//                      AMP_SET - amp and the PLL's enable combinational on them from there
//     D + 1 ..:        KP_F e, KI_F e, KP_A ea, KI_A ea issued back to back (N_PF, N_IF, N_PA, N_IA
//                      limb products each), then collected; the PIs (drive_pi, PIPE = 1: five
//                      register stages, fed from the cycle the last product is registered) kept
//                      five cycles later: ftw' and the gain at this sample, df
//     then:            ftw' ADVANCE and df HZ_COEF issued back to back, collected; the carrier's
//                      phase = phase + ((ftw' ADVANCE) >>> ADVANCE_BITS) and f registered
//     then:            the wave pass (3 N + 12 cycles, N the demodulator's limb products) and -sin'
//                      registered; gain -sin' issued, collected, dac registered; every output with
//                      out_valid, the next phase = phase + ftw'; in_ready again
//   Cycles per sample: D + 3 N + 13 + N_PF + N_IF + N_PA + N_IA + N_ADV + N_HZ + N_DAC + 25, D the
//   demodulator's cycles per sample and N_* each product's limb pairs (its operands' 16-bit limbs,
//   the constants' at their own width): fxdsp.blocks.drive.DriveDatapath.serial_cycles, against
//   416 at 40 MHz and 96 kS/s.
//   Interface: in_valid / in_ready / out_valid; in_ready is high only when idle, out_valid a one-cycle
//   pulse with every output (held until the next).
`default_nettype none
`default_nettype none

module drive #(
    parameter integer IN_W          = 16,    // drive ADC word, signed
    parameter integer DATA_W        = 24,    // mixers, low-pass, amplitude
    parameter integer PHASE_BITS    = 48,    // NCO accumulator (turns * 2**PHASE_BITS)
    parameter integer LUT_BITS      = 12,    // NCO table: bins per turn = 2**LUT_BITS
    parameter integer LUT_W         = 22,    // quarter-table word
    parameter integer INTERP_BITS   = 12,    // phase bits that drive the interpolation
    parameter [63:0]  TWO_PI        = 64'd25736,
    parameter integer TWO_PI_W      = 16,
    parameter integer CORR_SHIFT    = 37,    // NCO correction product -> table LSBs
    parameter integer NCO_W         = 23,    // NCO cos / -sin: LUT_W + 1
    parameter integer MIX_SHIFT     = 13,    // x * nco -> data, read as 2 x nco
    parameter integer ROUNDING      = 1,
    parameter integer OVERFLOW      = 1,
    parameter integer LPF_SECTIONS  = 2,     // the low-pass (one design for both channels): iir.v
    parameter integer LPF_COEF_W    = 35,
    parameter integer LPF_SHIFT_B   = 0,
    parameter integer LPF_SHIFT_A   = 4,
    parameter integer LPF_OUT_SHIFT = 37,
    parameter integer LPF_ACC_W     = 64,
    parameter integer LPF_ROUNDING  = 1,
    parameter integer LPF_OVERFLOW  = 1,
    parameter integer LPF_ACOEF_W   = 39,
    parameter         LPF_COEF_FILE  = "drive_lpf_coef.hex",
    parameter         LPF_ACOEF_FILE = "drive_lpf_acoef.hex",   // the serial iir's words (not read here)
    parameter integer ITERATIONS    = 24,    // CORDIC steps
    parameter integer ANGLE_W       = 24,    // angle format word
    parameter [63:0]  HALF_PI       = 64'd3294199,
    parameter [63:0]  INV_K         = 64'd79594,   // 1/K, INV_K_W bits
    parameter integer INV_K_W       = 18,
    parameter integer AMP_SHIFT     = 17,    // x_K * INV_K -> data
    parameter integer UPDATE_EVERY  = 8,     // samples per control update
    parameter [63:0]  PHASE_SET     = 64'd0,       // the PLL's set point (angle LSBs)
    parameter [63:0]  PI_WORD       = 64'd6588397, // pi (angle LSBs): the error's wrap
    parameter [63:0]  FTW_CENTER    = 64'd23498176102627,  // f_hz as a tuning word
    parameter [63:0]  LOCK_RANGE    = 64'd58640620148,     // +- tuning-word LSBs
    parameter [63:0]  KP_F          = 64'd28346144,        // tuning LSBs per angle LSB, x 2**PI_SHIFT_F
    parameter [63:0]  KI_F          = 64'd74961,
    parameter integer PI_SHIFT_F    = 10,
    parameter [63:0]  AMP_SET       = 64'd2097152,         // amplitude set point (data LSBs)
    parameter [63:0]  KP_A          = 64'd159009391,       // gain LSBs per data LSB, x 2**PI_SHIFT_A
    parameter [63:0]  KI_A          = 64'd87649,
    parameter integer PI_SHIFT_A    = 28,
    parameter integer GAIN_W        = 18,    // drive gain word
    parameter [63:0]  GAIN_MAX      = 64'd129761,
    parameter [63:0]  ADVANCE       = 64'd24,      // carrier advance, samples x 2**ADVANCE_BITS (signed)
    parameter integer ADVANCE_BITS  = 4,
    parameter integer DAC_W         = 16,    // drive DAC word, signed
    parameter integer DAC_SHIFT     = 23,    // gain x carrier -> DAC
    parameter [63:0]  HZ_CENTER     = 64'd2100900659,      // f_hz on the freq format
    parameter [63:0]  HZ_COEF       = 64'd49152000,        // fs / 2**PHASE_BITS, x 2**HZ_SHIFT
    parameter integer HZ_SHIFT      = 39,
    parameter integer FREQ_W        = 32,    // the frequency word in Hz
    parameter [63:0]  MIN_AMP       = 64'd20972,           // the PLL holds below this amplitude
    parameter integer ENG_A_W       = 48,    // ARCH = 1: the multiplier's operands (whole limbs): the widest of
    parameter integer ENG_B_W       = 32,    // the detector's and the controller's products
    parameter         QSIN_FILE     = "drive_qsin.hex",
    parameter         ATAN_FILE     = "drive_atan.hex",
    parameter integer ARCH          = 0,     // 0: one sample per cycle (in_ready tied high); 1: serial
    parameter integer EXT_MAC       = 0,     // ARCH = 1: 0 its own fx_mac_serial (ENG_A_W x ENG_B_W); 1 the external one
    parameter integer MAC_A_W       = 48,    // EXT_MAC = 1: the external multiplier's operand widths (>= ENG_A_W,
    parameter integer MAC_B_W       = 32     // ENG_B_W)
) (
    input  wire                      clk,
    input  wire                      rst,
    input  wire                      in_valid,
    output wire                      in_ready,
    input  wire [IN_W-1:0]           x,
    output reg                       out_valid,
    output reg  [DAC_W-1:0]          dac,
    output reg  [FREQ_W-1:0]         f,
    output reg  [DATA_W-1:0]         amp,
    output reg  [ANGLE_W-1:0]        phase,
    output reg  [PHASE_BITS-1:0]     nco,
    output wire [PHASE_BITS-1:0]     nco_next,   // the nco the next sample will output, while none is in flight
    output reg  [2*LPF_SECTIONS+4:0] ovf,
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
    // bits of v read as a two's-complement number, sign included (a 64-bit constant's operand width)
    function integer sbits;
        input [63:0] v;
        integer k;
        begin
            sbits = 1;
            for (k = 0; k < 63; k = k + 1)
                if (v[k] != v[63]) sbits = k + 2;
        end
    endfunction
    // the operand width for a constant: at least 2 bits (fx_mac_serial's smallest operand)
    function integer opw;
        input integer w;
        begin
            opw = (w < 2) ? 2 : w;
        end
    endfunction

    localparam integer WW = DATA_W + 3;            // CORDIC work
    localparam integer AW = ANGLE_W + 2;           // CORDIC angle
    localparam integer EW = AW + 1;                // the phase error before its wrap
    localparam integer PW = WW + INV_K_W;          // x_K * INV_K
    localparam integer GW = GAIN_W + 1;            // the gain, 0 .. GAIN_MAX, as a signed operand
    localparam integer DP = GW + NCO_W;            // gain * carrier
    localparam integer HR = 65 - HZ_SHIFT;         // df * HZ_COEF rounded (a right shift of 64 bits)
    localparam signed [63:0] FTW_C    = FTW_CENTER;
    localparam signed [63:0] HZ_C     = HZ_CENTER;
    localparam signed [63:0] HZ_COEF_C = HZ_COEF;
    localparam signed [63:0] ADV_C    = ADVANCE;
    localparam signed [63:0] KP_F_C   = KP_F;
    localparam signed [63:0] KI_F_C   = KI_F;
    localparam signed [63:0] KP_A_C   = KP_A;
    localparam signed [63:0] KI_A_C   = KI_A;
    localparam [ANGLE_W-1:0] PI_C     = PI_WORD[ANGLE_W-1:0];
    localparam [ANGLE_W-1:0] SET_C    = PHASE_SET[ANGLE_W-1:0];
    localparam [DATA_W:0]    AMP_SET_C = AMP_SET[DATA_W:0];
    localparam [DATA_W:0]    MIN_AMP_C = MIN_AMP[DATA_W:0];
    localparam integer CW = (UPDATE_EVERY > 1) ? $clog2(UPDATE_EVERY) : 1;
    localparam integer LAST_I = UPDATE_EVERY - 1;
    localparam [CW-1:0] LAST = LAST_I[CW-1:0];

    generate
        if (HZ_SHIFT < 1 || HZ_SHIFT > 63 || UPDATE_EVERY < 1) begin : g_bad_params
            initial begin $display("drive: HZ_SHIFT must be 1..63 and UPDATE_EVERY >= 1, got %0d, %0d",
                                   HZ_SHIFT, UPDATE_EVERY); $finish; end
        end
        if (ARCH != 0 && ARCH != 1) begin : g_bad_arch
            initial begin $display("drive: ARCH must be 0 or 1, got %0d", ARCH); $finish; end
        end
    endgenerate

    // ---- loop state (the model's S_* registers) ----
    reg  [PHASE_BITS-1:0] ph_next;        // the phase the next sample reads, once the last update is in
    reg  [PHASE_BITS-1:0] ph_q;           // the phase of the sample in the detector
    assign nco_next = ph_next;
    reg  signed [63:0]    ftw;            // the frequency word
    reg  signed [63:0]    integ_f, integ_a;
    reg  [GAIN_W-1:0]     gain;
    reg  [CW-1:0]         cnt;            // samples since the last update

    // ---- the control update's arithmetic, one description for both architectures: on the angle
    // z_s and amplitude amp_s of the sample's detector, the PIs' products and the Hz and DAC products
    // (ARCH = 0: combinational, ARCH = 1: registered) ----
    wire signed [AW-1:0] z_s;
    wire [DATA_W-1:0]    amp_s;
    wire signed [63:0]   pe_f, ie_f, pe_a, ie_a;   // KP_F e, KI_F e, KP_A ea, KI_A ea: exact (the model's proof)
    wire signed [63:0]   hz_p;                     // df HZ_COEF < 2**62: fxdsp.blocks.drive.hz_words
    wire signed [DP-1:0] dp_;                      // gain -sin'

    // the phase error, wrapped once into (-pi, pi]
    wire signed [EW-1:0] pi_e  = {{(EW-ANGLE_W){PI_C[ANGLE_W-1]}}, PI_C};
    wire signed [EW-1:0] set_e = {{(EW-ANGLE_W){SET_C[ANGLE_W-1]}}, SET_C};
    wire signed [EW-1:0] e0 = {z_s[AW-1], z_s} - set_e;
    wire signed [EW-1:0] e_w = (e0 > pi_e) ? e0 - (pi_e <<< 1) : (e0 <= -pi_e) ? e0 + (pi_e <<< 1) : e0;

    // PLL: held below MIN_AMP, where the angle is the noise's
    wire pll_on = $signed({amp_s[DATA_W-1], amp_s}) >= $signed(MIN_AMP_C);
    wire signed [63:0] integ_f_n, df;
    /* verilator lint_off UNUSEDSIGNAL */    // the limit events: the model's limits, not overflows
    wire lim_fi, lim_fo, lim_ai, lim_ao;
    /* verilator lint_on UNUSEDSIGNAL */
    // ARCH = 1: pipelined (PIPE, five cycles), the serial FSM waits for them
    drive_pi #(.E_W(EW), .SHIFT(PI_SHIFT_F), .LO(-LOCK_RANGE), .HI(LOCK_RANGE), .ROUNDING(ROUNDING), .PIPE(ARCH)) u_pll
        (.clk(clk), .e(e_w), .pe(pe_f), .ie(ie_f), .integ(integ_f), .integ_n(integ_f_n), .out(df), .integ_lim(lim_fi),
         .out_lim(lim_fo));
    wire signed [HR-1:0] hz_r;
    fx_round #(.IN_W(64), .SHIFT(HZ_SHIFT), .ROUNDING(ROUNDING), .OUT_W(HR)) u_hz (.x(hz_p), .cin(1'b0), .y(hz_r));
    wire signed [64:0] hz_sum = {HZ_C[63], HZ_C} + {{(65-HR){hz_r[HR-1]}}, hz_r};
    wire [FREQ_W-1:0] f_c;
    wire ovf_f;
    fx_fit #(.IN_W(65), .OUT_W(FREQ_W), .OUT_SIGNED(1), .OVERFLOW(OVERFLOW)) u_f (.x(hz_sum), .y(f_c), .ovf(ovf_f));

    // amplitude controller
    wire signed [DATA_W+1:0] ea = $signed({1'b0, AMP_SET_C}) - $signed({{2{amp_s[DATA_W-1]}}, amp_s});
    wire signed [63:0] integ_a_n, g_n;
    drive_pi #(.E_W(DATA_W + 2), .SHIFT(PI_SHIFT_A), .LO(64'd0), .HI(GAIN_MAX), .ROUNDING(ROUNDING), .PIPE(ARCH)) u_agc
        (.clk(clk), .e(ea), .pe(pe_a), .ie(ie_a), .integ(integ_a), .integ_n(integ_a_n), .out(g_n), .integ_lim(lim_ai),
         .out_lim(lim_ao));

    // the DAC word
    wire [DAC_W-1:0] dac_c;
    wire ovf_dac;
    fx_convert #(.IN_W(DP), .SHIFT(DAC_SHIFT), .ROUNDING(ROUNDING), .OUT_W(DAC_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_dac (.x(dp_), .cin(1'b0), .y(dac_c), .ovf(ovf_dac));

    // ---- the loop's registers, one set: rst gives the model's reset(); each architecture says when
    // they load (the updates' words above) ----
    wire                  s_take;         // a sample taken: its phase (s_ph)
    wire [PHASE_BITS-1:0] s_ph;
    wire                  s_count;        // the sample counted (cnt: the update on the last of a group)
    wire                  s_commit;       // the sample's PIs kept: the PLL's at s_pll, the amplitude's at s_upd
    wire                  s_upd, s_pll;   // an update sample; and the PLL on at it
    wire                  s_out;          // every output, out_valid; the next phase from s_ftw
    wire signed [63:0]    s_ftw;          // the frequency word after this sample's update
    wire                  s_ovf_amp;      // the detector's flags: amp, {lpf_q, lpf_i, mix_q, mix_i}
    wire [2*LPF_SECTIONS+1:0] s_ovf_det;
    /* verilator lint_off UNUSEDSIGNAL */    // g_n is within 0 .. GAIN_MAX: GAIN_W bits; s_ftw above PHASE_BITS
    wire signed [63:0] g_n_u = g_n;
    wire signed [63:0] s_ftw_u = s_ftw;
    /* verilator lint_on UNUSEDSIGNAL */
    always @(posedge clk) begin
        if (rst) begin
            ph_next <= {PHASE_BITS{1'b0}};
            ph_q <= {PHASE_BITS{1'b0}};
            nco <= {PHASE_BITS{1'b0}};
            ftw <= FTW_C;
            integ_f <= 64'sd0; integ_a <= 64'sd0;
            gain <= {GAIN_W{1'b0}};
            cnt <= {CW{1'b0}};
            out_valid <= 1'b0;
            dac <= {DAC_W{1'b0}}; f <= HZ_C[FREQ_W-1:0]; amp <= {DATA_W{1'b0}}; phase <= {ANGLE_W{1'b0}};
            ovf <= {(2*LPF_SECTIONS+5){1'b0}};
        end else begin
            out_valid <= s_out;
            if (s_take) ph_q <= s_ph;
            if (s_count) cnt <= (cnt == LAST) ? {CW{1'b0}} : cnt + {{(CW-1){1'b0}}, 1'b1};
            if (s_commit && s_pll) begin
                integ_f <= integ_f_n;
                ftw <= FTW_C + df;
            end
            if (s_commit && s_upd) begin
                integ_a <= integ_a_n;
                gain <= g_n_u[GAIN_W-1:0];
            end
            if (s_out) begin
                // f, amp and phase are the model's held words: the outputs hold them between updates
                if (s_pll) f <= f_c;
                if (s_upd) begin
                    amp <= amp_s;
                    phase <= e_w[ANGLE_W-1:0];
                end
                dac <= dac_c;
                nco <= ph_q;
                ph_next <= ph_q + s_ftw_u[PHASE_BITS-1:0];
                ovf <= {s_pll & ovf_f, ovf_dac, s_upd & s_ovf_amp, s_ovf_det};
            end
        end
    end


    generate
    if (ARCH == 0) begin : g_par
        assign in_ready = 1'b1;
        // no multiplier bundle in this variant
        assign mac_in_valid = 1'b0;
        assign mac_a = {MAC_A_W{1'b0}};
        assign mac_b = {MAC_B_W{1'b0}};
        assign mac_na = 4'd0;
        assign mac_nb = 4'd0;
        /* verilator lint_off UNUSEDSIGNAL */
        wire unused_mac = mac_in_ready ^ mac_out_valid ^ (^mac_p);
        /* verilator lint_on UNUSEDSIGNAL */

        // ---- phase detector: NCO, mixers, low-pass ----
        wire pend;                            // the low-pass outputs of the last sample: its update now
        wire [PHASE_BITS-1:0] ph_upd;         // the phase after this update (pend)
        wire [PHASE_BITS-1:0] ph_in = pend ? ph_upd : ph_next;   // the phase a sample taken now reads
        wire [NCO_W-1:0] cos_w, msin_w;
        nco_wave #(.PHASE_BITS(PHASE_BITS), .LUT_BITS(LUT_BITS), .LUT_W(LUT_W), .INTERP_BITS(INTERP_BITS),
                   .TWO_PI(TWO_PI), .TWO_PI_W(TWO_PI_W), .CORR_SHIFT(CORR_SHIFT), .NCO_W(NCO_W), .ROUNDING(ROUNDING),
                   .QSIN_FILE(QSIN_FILE)) u_wave (.phase(ph_in), .cos_o(cos_w), .msin_o(msin_w));
        wire [DATA_W-1:0] li, lq;
        wire [2*LPF_SECTIONS+1:0] ovf_ml;     // {lpf_q, lpf_i, mix_q, mix_i} of the sample in pend
        mix_lpf #(.IN_W(IN_W), .NCO_W(NCO_W), .DATA_W(DATA_W), .MIX_SHIFT(MIX_SHIFT), .ROUNDING(ROUNDING),
                  .OVERFLOW(OVERFLOW), .LPF_SECTIONS(LPF_SECTIONS), .LPF_COEF_W(LPF_COEF_W), .LPF_ACOEF_W(LPF_ACOEF_W),
                  .LPF_SHIFT_B(LPF_SHIFT_B), .LPF_SHIFT_A(LPF_SHIFT_A), .LPF_OUT_SHIFT(LPF_OUT_SHIFT),
                  .LPF_ACC_W(LPF_ACC_W), .LPF_ROUNDING(LPF_ROUNDING), .LPF_OVERFLOW(LPF_OVERFLOW),
                  .LPF_COEF_FILE(LPF_COEF_FILE), .LPF_ACOEF_FILE(LPF_ACOEF_FILE)) u_det
            (.clk(clk), .rst(rst), .in_valid(in_valid), .x(x), .cos_i(cos_w), .msin_i(msin_w), .out_valid(pend),
             .li(li), .lq(lq), .ovf(ovf_ml));

        // ---- the control update (every UPDATE_EVERY samples) ----
        wire upd = pend && (cnt == LAST);
        wire signed [WW-1:0] xk;
        wire signed [AW-1:0] z;
        cordic_vector #(.DATA_W(DATA_W), .ITERATIONS(ITERATIONS), .ANGLE_W(ANGLE_W), .HALF_PI(HALF_PI),
                        .ATAN_FILE(ATAN_FILE)) u_cordic (.x(li), .y(lq), .xk(xk), .z(z));
        localparam [INV_K_W-1:0] INV_K_C = INV_K[INV_K_W-1:0];
        wire signed [PW-1:0] ap = xk * $signed(INV_K_C);
        wire [DATA_W-1:0] amp_c;
        wire ovf_amp;
        fx_convert #(.IN_W(PW), .SHIFT(AMP_SHIFT), .ROUNDING(ROUNDING), .OUT_W(DATA_W), .OUT_SIGNED(1),
                     .OVERFLOW(OVERFLOW)) u_amp (.x(ap), .cin(1'b0), .y(amp_c), .ovf(ovf_amp));
        assign z_s = z;
        assign amp_s = amp_c;
        wire signed [63:0] e64 = {{(64-EW){e_w[EW-1]}}, e_w};
        wire signed [63:0] ea64 = {{(62-DATA_W){ea[DATA_W+1]}}, ea};
        assign pe_f = KP_F_C * e64;
        assign ie_f = KI_F_C * e64;
        assign pe_a = KP_A_C * ea64;
        assign ie_a = KI_A_C * ea64;
        assign hz_p = df * HZ_COEF_C;

        // the words after this sample's update
        wire pll_upd = upd && pll_on;
        wire signed [63:0] ftw_u = pll_upd ? FTW_C + df : ftw;
        /* verilator lint_off UNUSEDSIGNAL */    // g_n is within 0 .. GAIN_MAX: GAIN_W bits
        wire signed [63:0] gain_u = upd ? g_n : {{(64-GAIN_W){1'b0}}, gain};
        /* verilator lint_on UNUSEDSIGNAL */

        // ---- drive: the carrier read ahead, times the gain ----
        wire signed [63:0] adv_p = ftw_u * ADV_C;      // < 2**62: the model's proof
        /* verilator lint_off UNUSEDSIGNAL */
        wire signed [63:0] adv = adv_p >>> ADVANCE_BITS;   // floor
        wire [PHASE_BITS-1:0] ftw_bits = ftw_u[PHASE_BITS-1:0];
        /* verilator lint_on UNUSEDSIGNAL */
        wire [PHASE_BITS-1:0] ph_car = ph_q + adv[PHASE_BITS-1:0];
        assign ph_upd = ph_q + ftw_bits;
        /* verilator lint_off UNUSEDSIGNAL */    // the carrier's cos is not read
        wire [NCO_W-1:0] cos_car;
        /* verilator lint_on UNUSEDSIGNAL */
        wire [NCO_W-1:0] msin_car;
        nco_wave #(.PHASE_BITS(PHASE_BITS), .LUT_BITS(LUT_BITS), .LUT_W(LUT_W), .INTERP_BITS(INTERP_BITS),
                   .TWO_PI(TWO_PI), .TWO_PI_W(TWO_PI_W), .CORR_SHIFT(CORR_SHIFT), .NCO_W(NCO_W), .ROUNDING(ROUNDING),
                   .QSIN_FILE(QSIN_FILE)) u_carrier (.phase(ph_car), .cos_o(cos_car), .msin_o(msin_car));
        wire signed [GW-1:0] gw = gain_u[GW-1:0];
        assign dp_ = gw * $signed(msin_car);

        // ---- the loop's registers: a sample's phase at in_valid; its update, the DAC word and every
        // output (nco = ph_q among them) at pend ----
        assign s_take = in_valid;
        assign s_ph = ph_in;
        assign s_count = pend;
        assign s_commit = pend;
        assign s_upd = upd;
        assign s_pll = pll_upd;
        assign s_out = pend;
        assign s_ftw = ftw_u;
        assign s_ovf_amp = ovf_amp;
        assign s_ovf_det = ovf_ml;
    end else begin : g_ser
        // ---- serial: the phase detector on the serial demodulator's engine, the controller's
        // products on its multiplier, the carrier a wave pass of its table engine ----
        localparam integer FW  = (sbits(FTW_CENTER + LOCK_RANGE) > sbits(FTW_CENTER - LOCK_RANGE)) ?
                                 sbits(FTW_CENTER + LOCK_RANGE) : sbits(FTW_CENTER - LOCK_RANGE);   // ftw
        localparam integer DFW = sbits(LOCK_RANGE);   // df, within +-LOCK_RANGE
        // the products, in their order on the multiplier: kind, limbs of a (the variable), of b
        localparam [2:0] K_PF  = 3'd0;      // KP_F e
        localparam [2:0] K_IF  = 3'd1;      // KI_F e
        localparam [2:0] K_PA  = 3'd2;      // KP_A ea
        localparam [2:0] K_IA  = 3'd3;      // KI_A ea
        localparam [2:0] K_ADV = 3'd4;      // ftw ADVANCE
        localparam [2:0] K_HZ  = 3'd5;      // df HZ_COEF
        localparam [2:0] K_DAC = 3'd6;      // gain -sin'
        // the constant operands' widths (sign included)
        localparam integer W_PF = opw(sbits(KP_F)), W_IF = opw(sbits(KI_F)), W_PA = opw(sbits(KP_A));
        localparam integer W_IA = opw(sbits(KI_A)), W_ADV = opw(sbits(ADVANCE)), W_HZ = opw(sbits(HZ_COEF));
        localparam [W_PF-1:0]  KP_F_B = KP_F[W_PF-1:0];
        localparam [W_IF-1:0]  KI_F_B = KI_F[W_IF-1:0];
        localparam [W_PA-1:0]  KP_A_B = KP_A[W_PA-1:0];
        localparam [W_IA-1:0]  KI_A_B = KI_A[W_IA-1:0];
        localparam [W_ADV-1:0] ADV_B  = ADVANCE[W_ADV-1:0];
        localparam [W_HZ-1:0]  HZ_B   = HZ_COEF[W_HZ-1:0];
        localparam [3:0] S_IDLE = 4'd0;     // in_ready; a sample goes to the detector
        localparam [3:0] S_DET  = 4'd1;     // the demodulator's pass
        localparam [3:0] S_PIS  = 4'd2;     // KP_F e, KI_F e, KP_A ea, KI_A ea issued
        localparam [3:0] S_PIW  = 4'd3;     // ... collected
        localparam [3:0] S_PI   = 4'd4;     // the PIs registered (at an update)
        localparam [3:0] S_AIS  = 4'd5;     // ftw ADVANCE, df HZ_COEF issued
        localparam [3:0] S_AIW  = 4'd6;     // ... collected
        localparam [3:0] S_CAR  = 4'd7;     // the wave pass at the carrier's phase started
        localparam [3:0] S_WV   = 4'd8;     // ... its -sin'
        localparam [3:0] S_DIS  = 4'd9;     // gain -sin' issued
        localparam [3:0] S_DW   = 4'd10;    // ... collected
        localparam [3:0] S_OUT  = 4'd11;    // every output registered, out_valid

        if (EXT_MAC != 0 && (MAC_A_W < ENG_A_W || MAC_B_W < ENG_B_W)) begin : g_bad_bundle
            initial begin $display("drive: EXT_MAC = 1 needs MAC_A_W >= %0d, MAC_B_W >= %0d, got %0d, %0d", ENG_A_W, ENG_B_W,
                                   MAC_A_W, MAC_B_W); $finish; end
        end

        reg [3:0] st;
        reg [2:0] ik, rk;                   // the next product to issue, to come back
        reg [2:0] pw;                       // cycles in S_PI
        localparam [2:0] PI_LAST = 3'd4;    // the pipelined PIs' answer: the fifth cycle in S_PI (their
                                            // inputs, all registered, from the cycle before)
        reg       upd_q;                    // this sample updates the PIs
        reg signed [AW-1:0]   z_q;          // the detector's angle, amplitude and flags
        reg [DATA_W-1:0]      amp_q;
        reg [2*LPF_SECTIONS+2:0] dovf_q;    // {amp, lpf_q, lpf_i, mix_q, mix_i}
        reg signed [63:0]     pf_q, if_q, pa_q, ia_q, hz_q;   // the products
        reg signed [DP-1:0]   dp_q;
        reg signed [DFW-1:0]  df_q;
        reg [PHASE_BITS-1:0]  car_q;        // the carrier's phase: ph_q + ((ftw ADVANCE) >>> ADVANCE_BITS)
        reg [NCO_W-1:0]       msin_q;       // -sin' at car_q
        wire pll_upd = upd_q && pll_on;
        assign z_s = z_q;
        assign amp_s = amp_q;
        assign pe_f = pf_q;
        assign ie_f = if_q;
        assign pe_a = pa_q;
        assign ie_a = ia_q;
        assign hz_p = hz_q;
        assign dp_ = dp_q;

        // ---- the detector: demod's serial engine on the loop's phase (and the carrier's wave pass) ----
        wire take = (st == S_IDLE) && in_valid;
        assign in_ready = (st == S_IDLE);
        wire det_own = (st == S_DET) || (st == S_CAR) || (st == S_WV);   // the demodulator's products
        wire det_v, d_ready, wave_v;
        wire [DATA_W-1:0] d_amp;
        wire [ANGLE_W-1:0] d_phase;
        wire [2*LPF_SECTIONS+2:0] d_ovf;
        wire [NCO_W-1:0] d_msin;
        wire d_mv;
        wire [ENG_A_W-1:0] d_ma;
        wire [ENG_B_W-1:0] d_mb;
        wire [3:0] d_na, d_nb;
        wire sh_ready, sh_valid;
        wire [ENG_A_W+ENG_B_W-1:0] sh_p;
        /* verilator lint_off UNUSEDSIGNAL */   // the demodulator's in_ready: high whenever this FSM is idle
        wire d_ready_u = d_ready;
        /* verilator lint_on UNUSEDSIGNAL */
        demod #(.IN_W(IN_W), .DATA_W(DATA_W), .PHASE_BITS(PHASE_BITS), .LUT_BITS(LUT_BITS), .LUT_W(LUT_W),
                .INTERP_BITS(INTERP_BITS), .TWO_PI(TWO_PI), .TWO_PI_W(TWO_PI_W), .CORR_SHIFT(CORR_SHIFT),
                .NCO_W(NCO_W), .PHASE_TRIM(64'd0), .MIX_SHIFT(MIX_SHIFT), .ROUNDING(ROUNDING), .OVERFLOW(OVERFLOW),
                .LPF_SECTIONS(LPF_SECTIONS), .LPF_COEF_W(LPF_COEF_W), .LPF_ACOEF_W(LPF_ACOEF_W),
                .LPF_SHIFT_B(LPF_SHIFT_B), .LPF_SHIFT_A(LPF_SHIFT_A), .LPF_OUT_SHIFT(LPF_OUT_SHIFT),
                .LPF_ACC_W(LPF_ACC_W), .LPF_ROUNDING(LPF_ROUNDING), .LPF_OVERFLOW(LPF_OVERFLOW),
                .ITERATIONS(ITERATIONS), .ANGLE_W(ANGLE_W), .HALF_PI(HALF_PI), .INV_K(INV_K), .INV_K_W(INV_K_W),
                .AMP_SHIFT(AMP_SHIFT), .QSIN_FILE(QSIN_FILE), .LPF_COEF_FILE(LPF_COEF_FILE),
                .LPF_ACOEF_FILE(LPF_ACOEF_FILE), .ATAN_FILE(ATAN_FILE), .ARCH(1), .EXT_MAC(1), .MAC_A_W(ENG_A_W),
                .MAC_B_W(ENG_B_W), .REF(1), .WAVE(1)) u_det
            (.clk(clk), .rst(rst), .in_valid(take), .in_ready(d_ready), .x(x), .out_valid(det_v), .i(), .q(),
             .amp(d_amp), .phase(d_phase), .ovf(d_ovf),
             .mac_in_valid(d_mv), .mac_in_ready(sh_ready), .mac_a(d_ma), .mac_b(d_mb), .mac_na(d_na), .mac_nb(d_nb),
             .mac_out_valid(sh_valid & det_own), .mac_p(sh_p),
             .aux_in_valid(1'b0), .aux_x({DATA_W{1'b0}}), .aux_out_valid(), .aux_y(), .aux_ovf(),
             .ref_phase((st == S_CAR) ? car_q : ph_next), .wave_in_valid(st == S_CAR), .wave_out_valid(wave_v),
             .wave_msin(d_msin));

        // ---- the controller's products, a the variable and b the constant (or -sin'), each through a
        // port of its own widths onto the one multiplier (fx_mac_port: its request sign-extended, its
        // limb counts, its product from its window of the multiplier's word) ----
        wire c_v = (st == S_PIS) || (st == S_AIS) || (st == S_DIS);
        wire c_got;
        /* verilator lint_off UNUSEDSIGNAL */   // above FW bits: sign copies (ftw within FTW_CENTER +- LOCK_RANGE)
        wire signed [63:0] ftw_a = ftw;
        /* verilator lint_on UNUSEDSIGNAL */
        /* verilator lint_off UNUSEDSIGNAL */   // the ports' own handshakes: the FSM's states are theirs
        wire [6:0] k_rdy, k_v, k_ov;
        /* verilator lint_on UNUSEDSIGNAL */
        wire [ENG_A_W-1:0] a_pf, a_if, a_pa, a_ia, a_adv, a_hz, a_dac;
        wire [ENG_B_W-1:0] b_pf, b_if, b_pa, b_ia, b_adv, b_hz, b_dac;
        wire [3:0]  n_pf, n_if, n_pa, n_ia, n_adv, n_hz, n_dac, m_pf, m_if, m_pa, m_ia, m_adv, m_hz, m_dac;
        wire signed [EW+W_PF-1:0]          p_pf;
        wire signed [EW+W_IF-1:0]          p_if;
        wire signed [DATA_W+2+W_PA-1:0]    p_pa;
        wire signed [DATA_W+2+W_IA-1:0]    p_ia;
        wire signed [FW+W_ADV-1:0]         p_adv;
        wire signed [DFW+W_HZ-1:0]         p_hz;
        /* verilator lint_off UNUSEDSIGNAL */   // gain -sin' exact in DP bits: the top is a sign copy
        wire signed [GW+NCO_W-1:0]         p_dac;
        /* verilator lint_on UNUSEDSIGNAL */
        fx_mac_port #(.A_W(EW), .B_W(W_PF), .EXT_MAC(1), .MAC_A_W(ENG_A_W), .MAC_B_W(ENG_B_W)) u_pf (.clk(clk), .rst(rst),
            .in_valid(c_v && ik == K_PF), .in_ready(k_rdy[0]), .a(e_w), .b(KP_F_B), .na(4'd0), .nb(4'd0),
            .out_valid(k_ov[0]), .p(p_pf), .mac_in_valid(k_v[0]), .mac_in_ready(sh_ready), .mac_a(a_pf), .mac_b(b_pf),
            .mac_na(n_pf), .mac_nb(m_pf), .mac_out_valid(c_got && rk == K_PF), .mac_p(sh_p));
        fx_mac_port #(.A_W(EW), .B_W(W_IF), .EXT_MAC(1), .MAC_A_W(ENG_A_W), .MAC_B_W(ENG_B_W)) u_if (.clk(clk), .rst(rst),
            .in_valid(c_v && ik == K_IF), .in_ready(k_rdy[1]), .a(e_w), .b(KI_F_B), .na(4'd0), .nb(4'd0),
            .out_valid(k_ov[1]), .p(p_if), .mac_in_valid(k_v[1]), .mac_in_ready(sh_ready), .mac_a(a_if), .mac_b(b_if),
            .mac_na(n_if), .mac_nb(m_if), .mac_out_valid(c_got && rk == K_IF), .mac_p(sh_p));
        fx_mac_port #(.A_W(DATA_W + 2), .B_W(W_PA), .EXT_MAC(1), .MAC_A_W(ENG_A_W), .MAC_B_W(ENG_B_W)) u_pa (.clk(clk), .rst(rst),
            .in_valid(c_v && ik == K_PA), .in_ready(k_rdy[2]), .a(ea), .b(KP_A_B), .na(4'd0), .nb(4'd0),
            .out_valid(k_ov[2]), .p(p_pa), .mac_in_valid(k_v[2]), .mac_in_ready(sh_ready), .mac_a(a_pa), .mac_b(b_pa),
            .mac_na(n_pa), .mac_nb(m_pa), .mac_out_valid(c_got && rk == K_PA), .mac_p(sh_p));
        fx_mac_port #(.A_W(DATA_W + 2), .B_W(W_IA), .EXT_MAC(1), .MAC_A_W(ENG_A_W), .MAC_B_W(ENG_B_W)) u_ia (.clk(clk), .rst(rst),
            .in_valid(c_v && ik == K_IA), .in_ready(k_rdy[3]), .a(ea), .b(KI_A_B), .na(4'd0), .nb(4'd0),
            .out_valid(k_ov[3]), .p(p_ia), .mac_in_valid(k_v[3]), .mac_in_ready(sh_ready), .mac_a(a_ia), .mac_b(b_ia),
            .mac_na(n_ia), .mac_nb(m_ia), .mac_out_valid(c_got && rk == K_IA), .mac_p(sh_p));
        fx_mac_port #(.A_W(FW), .B_W(W_ADV), .EXT_MAC(1), .MAC_A_W(ENG_A_W), .MAC_B_W(ENG_B_W)) u_adv (.clk(clk), .rst(rst),
            .in_valid(c_v && ik == K_ADV), .in_ready(k_rdy[4]), .a(ftw_a[FW-1:0]), .b(ADV_B), .na(4'd0), .nb(4'd0),
            .out_valid(k_ov[4]), .p(p_adv), .mac_in_valid(k_v[4]), .mac_in_ready(sh_ready), .mac_a(a_adv), .mac_b(b_adv),
            .mac_na(n_adv), .mac_nb(m_adv), .mac_out_valid(c_got && rk == K_ADV), .mac_p(sh_p));
        fx_mac_port #(.A_W(DFW), .B_W(W_HZ), .EXT_MAC(1), .MAC_A_W(ENG_A_W), .MAC_B_W(ENG_B_W)) u_hzp (.clk(clk), .rst(rst),
            .in_valid(c_v && ik == K_HZ), .in_ready(k_rdy[5]), .a(df_q), .b(HZ_B), .na(4'd0), .nb(4'd0),
            .out_valid(k_ov[5]), .p(p_hz), .mac_in_valid(k_v[5]), .mac_in_ready(sh_ready), .mac_a(a_hz), .mac_b(b_hz),
            .mac_na(n_hz), .mac_nb(m_hz), .mac_out_valid(c_got && rk == K_HZ), .mac_p(sh_p));
        fx_mac_port #(.A_W(GW), .B_W(NCO_W), .EXT_MAC(1), .MAC_A_W(ENG_A_W), .MAC_B_W(ENG_B_W)) u_dacp (.clk(clk), .rst(rst),
            .in_valid(c_v && ik == K_DAC), .in_ready(k_rdy[6]), .a({1'b0, gain}), .b(msin_q), .na(4'd0), .nb(4'd0),
            .out_valid(k_ov[6]), .p(p_dac), .mac_in_valid(k_v[6]), .mac_in_ready(sh_ready), .mac_a(a_dac), .mac_b(b_dac),
            .mac_na(n_dac), .mac_nb(m_dac), .mac_out_valid(c_got && rk == K_DAC), .mac_p(sh_p));
        reg [ENG_A_W-1:0] c_a;              // the request of product ik
        reg [ENG_B_W-1:0] c_b;
        reg [3:0]  c_na, c_nb;
        always @* begin
            case (ik)
                K_PF:    begin c_a = a_pf;  c_b = b_pf;  c_na = n_pf;  c_nb = m_pf;  end
                K_IF:    begin c_a = a_if;  c_b = b_if;  c_na = n_if;  c_nb = m_if;  end
                K_PA:    begin c_a = a_pa;  c_b = b_pa;  c_na = n_pa;  c_nb = m_pa;  end
                K_IA:    begin c_a = a_ia;  c_b = b_ia;  c_na = n_ia;  c_nb = m_ia;  end
                K_ADV:   begin c_a = a_adv; c_b = b_adv; c_na = n_adv; c_nb = m_adv; end
                K_HZ:    begin c_a = a_hz;  c_b = b_hz;  c_na = n_hz;  c_nb = m_hz;  end
                default: begin c_a = a_dac; c_b = b_dac; c_na = n_dac; c_nb = m_dac; end
            endcase
        end
        // the one multiplier (each product on its own limb counts): the demodulator's requests while it
        // runs, the controller's between
        fx_mac_port #(.A_W(ENG_A_W), .B_W(ENG_B_W), .VAR_N(1), .EXT_MAC(EXT_MAC), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)) u_mac
            (.clk(clk), .rst(rst), .in_valid(det_own ? d_mv : c_v), .in_ready(sh_ready), .a(det_own ? d_ma : c_a),
             .b(det_own ? d_mb : c_b), .na(det_own ? d_na : c_na), .nb(det_own ? d_nb : c_nb),
             .out_valid(sh_valid), .p(sh_p), .mac_in_valid(mac_in_valid), .mac_in_ready(mac_in_ready), .mac_a(mac_a),
             .mac_b(mac_b), .mac_na(mac_na), .mac_nb(mac_nb), .mac_out_valid(mac_out_valid), .mac_p(mac_p));
        assign c_got = sh_valid && !det_own;
        // the products sign-extended to 64 bits (each fits 63: the model's proof)
        wire signed [63:0] pf64, if64, pa64, ia64, adv_p, hz64;
        fx_fit #(.IN_W(EW + W_PF), .OUT_W(64), .OUT_SIGNED(1), .OVERFLOW(0)) u_xpf (.x(p_pf), .y(pf64), .ovf());
        fx_fit #(.IN_W(EW + W_IF), .OUT_W(64), .OUT_SIGNED(1), .OVERFLOW(0)) u_xif (.x(p_if), .y(if64), .ovf());
        fx_fit #(.IN_W(DATA_W + 2 + W_PA), .OUT_W(64), .OUT_SIGNED(1), .OVERFLOW(0)) u_xpa (.x(p_pa), .y(pa64), .ovf());
        fx_fit #(.IN_W(DATA_W + 2 + W_IA), .OUT_W(64), .OUT_SIGNED(1), .OVERFLOW(0)) u_xia (.x(p_ia), .y(ia64), .ovf());
        fx_fit #(.IN_W(FW + W_ADV), .OUT_W(64), .OUT_SIGNED(1), .OVERFLOW(0)) u_xadv (.x(p_adv), .y(adv_p), .ovf());
        fx_fit #(.IN_W(DFW + W_HZ), .OUT_W(64), .OUT_SIGNED(1), .OVERFLOW(0)) u_xhz (.x(p_hz), .y(hz64), .ovf());
        /* verilator lint_off UNUSEDSIGNAL */
        wire signed [63:0] adv = adv_p >>> ADVANCE_BITS;   // floor: the model's >>
        /* verilator lint_on UNUSEDSIGNAL */

        // ---- the loop's registers: a sample's phase when taken, its count with the detector's answer,
        // the PIs kept in S_PI, every output in S_OUT (the frequency word then already this sample's) ----
        assign s_take = take;
        assign s_ph = ph_next;
        assign s_count = (st == S_DET) && det_v;
        assign s_commit = (st == S_PI) && (pw == PI_LAST);
        assign s_upd = upd_q;
        assign s_pll = pll_upd;
        assign s_out = (st == S_OUT);
        assign s_ftw = ftw;
        assign s_ovf_amp = dovf_q[2*LPF_SECTIONS+2];
        assign s_ovf_det = dovf_q[2*LPF_SECTIONS+1:0];

        always @(posedge clk) begin
            if (c_got) begin
                case (rk)
                    K_PF:    pf_q <= pf64;
                    K_IF:    if_q <= if64;
                    K_PA:    pa_q <= pa64;
                    K_IA:    ia_q <= ia64;
                    K_ADV:   car_q <= ph_q + adv[PHASE_BITS-1:0];
                    K_HZ:    hz_q <= hz64;
                    default: dp_q <= p_dac[DP-1:0];
                endcase
            end
            if (det_v) begin
                z_q <= {{2{d_phase[ANGLE_W-1]}}, d_phase};
                amp_q <= d_amp;
                dovf_q <= d_ovf;
            end
            if (wave_v) msin_q <= d_msin;
            if (s_commit) df_q <= df[DFW-1:0];
        end

        always @(posedge clk) begin
            if (rst) begin
                st <= S_IDLE; ik <= K_PF; rk <= K_PF; upd_q <= 1'b0; pw <= 3'd0;
            end else begin
                if (c_got) rk <= rk + 3'd1;
                if (c_v && sh_ready) ik <= ik + 3'd1;
                case (st)
                    S_IDLE: if (take) st <= S_DET;
                    S_DET: if (det_v) begin
                        upd_q <= (cnt == LAST);
                        st <= S_PIS;
                    end
                    S_PIS: if (sh_ready && ik == K_IA) st <= S_PIW;
                    S_PIW: if (rk == K_ADV) begin
                        pw <= 3'd0; st <= S_PI;
                    end
                    S_PI: begin             // the PIs on the registered products, kept at an update
                        pw <= pw + 3'd1;
                        if (pw == PI_LAST) st <= S_AIS;
                    end
                    S_AIS: if (sh_ready && ik == K_HZ) st <= S_AIW;
                    S_AIW: if (rk == K_DAC) st <= S_CAR;
                    S_CAR: st <= S_WV;
                    S_WV: if (wave_v) st <= S_DIS;
                    S_DIS: if (sh_ready) st <= S_DW;
                    S_DW: if (rk == K_DAC + 3'd1) st <= S_OUT;
                    default: begin    // S_OUT: the outputs (the loop's registers)
                        ik <= K_PF; rk <= K_PF;
                        st <= S_IDLE;
                    end
                endcase
            end
        end
    end
    endgenerate
endmodule

`default_nettype wire
