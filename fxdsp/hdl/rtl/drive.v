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
// e, on ANGLE_W bits), nco (the phase word the mixers read: a demodulator's reference).
// Rounding R by ROUNDING (0 floor, 1 half_up, 2 half_even, 3 toward_zero); every fit by OVERFLOW
// (0 wrap, 1 saturate), flagged in ovf = {f, dac, amp, lpf_q[LPF_SECTIONS], lpf_i[LPF_SECTIONS],
// mix_q, mix_i} (amp's flag only at an update, f's only at a PLL update: the model counts them
// there). The PIs' limits are the control law's clamps, always saturating, not overflows. The NCO
// correction is rounded by ROUNDING and has no fit (the model proves NCO_W bits hold it).
// One sample per cycle at most (ARCH = 0 only so far): in_valid / out_valid, in_ready tied high.
// A sample's low-pass outputs are registered by the iir (its latency 1); in the next cycle the
// update, the DAC word and the next phase are combinational, registered at its end with out_valid.
// The next sample, if it comes in that cycle, reads the new phase combinationally (the feedback
// closes within a sample, as in the model). rst returns every register to the model's reset().
// Latency: 2 cycles.
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
    parameter         QSIN_FILE     = "drive_qsin.hex",
    parameter         ATAN_FILE     = "drive_atan.hex"
) (
    input  wire                      clk,
    input  wire                      rst,
    input  wire                      in_valid,
    input  wire [IN_W-1:0]           x,
    output reg                       out_valid,
    output reg  [DAC_W-1:0]          dac,
    output reg  [FREQ_W-1:0]         f,
    output reg  [DATA_W-1:0]         amp,
    output reg  [ANGLE_W-1:0]        phase,
    output reg  [PHASE_BITS-1:0]     nco,
    output reg  [2*LPF_SECTIONS+4:0] ovf
);
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
    endgenerate

    // ---- loop state (the model's S_* registers) ----
    reg  [PHASE_BITS-1:0] ph_next;        // the phase the next sample reads, once the last update is in
    reg  [PHASE_BITS-1:0] ph_q;           // the phase the sample in the low-pass read
    reg  signed [63:0]    ftw;            // the frequency word
    reg  signed [63:0]    integ_f, integ_a;
    reg  [GAIN_W-1:0]     gain;
    reg  [CW-1:0]         cnt;            // samples since the last update

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

    // the phase error, wrapped once into (-pi, pi]
    wire signed [EW-1:0] pi_e  = {{(EW-ANGLE_W){PI_C[ANGLE_W-1]}}, PI_C};
    wire signed [EW-1:0] set_e = {{(EW-ANGLE_W){SET_C[ANGLE_W-1]}}, SET_C};
    wire signed [EW-1:0] e0 = {z[AW-1], z} - set_e;
    wire signed [EW-1:0] e_w = (e0 > pi_e) ? e0 - (pi_e <<< 1) : (e0 <= -pi_e) ? e0 + (pi_e <<< 1) : e0;

    // PLL: held below MIN_AMP, where the angle is the noise's
    wire pll_on = $signed({amp_c[DATA_W-1], amp_c}) >= $signed(MIN_AMP_C);
    wire signed [63:0] integ_f_n, df;
    /* verilator lint_off UNUSEDSIGNAL */    // the limit events: the model's limits, not overflows
    wire lim_fi, lim_fo, lim_ai, lim_ao;
    /* verilator lint_on UNUSEDSIGNAL */
    drive_pi #(.E_W(EW), .KP(KP_F), .KI(KI_F), .SHIFT(PI_SHIFT_F), .LO(-LOCK_RANGE), .HI(LOCK_RANGE),
               .ROUNDING(ROUNDING)) u_pll (.e(e_w), .integ(integ_f), .integ_n(integ_f_n), .out(df),
                                           .integ_lim(lim_fi), .out_lim(lim_fo));
    wire signed [63:0] hz_p = df * HZ_COEF_C;      // < 2**62: fxdsp.blocks.drive.hz_words
    wire signed [HR-1:0] hz_r;
    fx_round #(.IN_W(64), .SHIFT(HZ_SHIFT), .ROUNDING(ROUNDING), .OUT_W(HR)) u_hz (.x(hz_p), .cin(1'b0), .y(hz_r));
    wire signed [64:0] hz_sum = {HZ_C[63], HZ_C} + {{(65-HR){hz_r[HR-1]}}, hz_r};
    wire [FREQ_W-1:0] f_c;
    wire ovf_f;
    fx_fit #(.IN_W(65), .OUT_W(FREQ_W), .OUT_SIGNED(1), .OVERFLOW(OVERFLOW)) u_f (.x(hz_sum), .y(f_c), .ovf(ovf_f));

    // amplitude controller
    wire signed [DATA_W+1:0] ea = $signed({1'b0, AMP_SET_C}) - $signed({{2{amp_c[DATA_W-1]}}, amp_c});
    wire signed [63:0] integ_a_n, g_n;
    drive_pi #(.E_W(DATA_W + 2), .KP(KP_A), .KI(KI_A), .SHIFT(PI_SHIFT_A), .LO(64'd0), .HI(GAIN_MAX),
               .ROUNDING(ROUNDING)) u_agc (.e(ea), .integ(integ_a), .integ_n(integ_a_n), .out(g_n),
                                           .integ_lim(lim_ai), .out_lim(lim_ao));

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
    wire signed [DP-1:0] dp_ = gw * $signed(msin_car);
    wire [DAC_W-1:0] dac_c;
    wire ovf_dac;
    fx_convert #(.IN_W(DP), .SHIFT(DAC_SHIFT), .ROUNDING(ROUNDING), .OUT_W(DAC_W), .OUT_SIGNED(1),
                 .OVERFLOW(OVERFLOW)) u_dac (.x(dp_), .cin(1'b0), .y(dac_c), .ovf(ovf_dac));

    // ---- registers ----
    // ph_q: the phase of the sample taken (at in_valid); its update, the DAC word and every output,
    // nco = ph_q among them, at pend
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
            out_valid <= pend;
            if (pend) begin
                ph_next <= ph_upd;
                ftw <= ftw_u;
                gain <= gain_u[GAIN_W-1:0];
                cnt <= upd ? {CW{1'b0}} : cnt + {{(CW-1){1'b0}}, 1'b1};
                // f, amp and phase are the model's held words: the outputs hold them between updates
                if (pll_upd) begin
                    integ_f <= integ_f_n;
                    f <= f_c;
                end
                if (upd) begin
                    integ_a <= integ_a_n;
                    amp <= amp_c;
                    phase <= e_w[ANGLE_W-1:0];
                end
                dac <= dac_c;
                nco <= ph_q;
                ovf <= {pll_upd & ovf_f, ovf_dac, upd & ovf_amp, ovf_ml};
            end
            if (in_valid) ph_q <= ph_in;
        end
    end
endmodule

`default_nettype wire
