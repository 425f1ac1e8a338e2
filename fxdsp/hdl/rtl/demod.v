// demod: synchronous demodulator (fxdsp.blocks.demod): nco (quarter-wave table with first-order
// interpolation, NCO_W-bit cos / -sin), two mixers, two iir low-pass filters, CORDIC vectoring
// for amplitude and phase.
//   mixers: i = fit(round(x * cos >> MIX_SHIFT)), q = fit(round(x * msin >> MIX_SHIFT)) into
//     DATA_W bits (the factor 2 is in MIX_SHIFT: the product read one fraction bit coarser);
//   low-pass: iir with the LPF_* parameters, one per channel;
//   CORDIC (ITERATIONS steps): pre-rotation by +-90 deg (HALF_PI) into the right half plane, then
//     shift-and-add with arithmetic right shifts (floor) in DATA_W + 2 guard bits, the angle
//     accumulated from ATAN_FILE (ANGLE_W bits);
//   amp = fit(round(x_K * INV_K >> AMP_SHIFT)) into DATA_W bits; phase = the angle accumulator.
// Every rounding by ROUNDING (floor / half_up / half_even / toward_zero; the filters by
// LPF_ROUNDING), every fit by OVERFLOW (wrap / saturate; the filters by LPF_OVERFLOW), flagged in
// ovf = {amp, lpf_q[LPF_SECTIONS], lpf_i[LPF_SECTIONS], mix_q, mix_i}. The NCO correction is
// rounded by ROUNDING and has no fit (the model proves NCO_W bits hold it).
// PHASE_TRIM: the NCO reference's rotation (nco.v), 0 = none. Both architectures give the same
// i, q, amp, phase, ovf for every input.
// ARCH = 0: one sample per cycle, everything combinational (nco, mix_lpf: 4 + 2 x 7 multipliers,
//   cordic_vector: the CORDIC unrolled). Interface: in_valid / out_valid (in_ready tied high); the
//   NCO and filter states advance only on in_valid, rst returns them to reset. Latency: 2 cycles (i, q delayed to align
//   with amp, phase).
// ARCH = 1: serial. The quarter-wave table is read through ONE registered read port
//   (tq <= qsin[addr]: block RAM), qsin[k] and qsin[~k] in consecutive cycles (cb's word first:
//   qsin[k] in odd quadrants, qsin[~k] in even ones; then the complement address, mb's word); the
//   six products of a sample (d = delta * TWO_PI, mb * d, -cb * d, x * cos, x * msin, x_K * INV_K)
//   run through ONE fx_mac_serial (one SB_MAC16); the mixer and amplitude products through ONE
//   fx_convert_pipe (the amplitude's product is scaled to the mixers' shift by the constant
//   INV_K << (MIX_SHIFT - AMP_SHIFT), or the mixers' up by p << (AMP_SHIFT - MIX_SHIFT)); both
//   low-pass filters through ONE serial iir (ARCH = 1, CHANNELS = 2), whose products go through the
//   same fx_mac_serial (the iir's EXT_MAC bundle: it computes only while the FSM waits in S_LPF,
//   where the demodulator issues nothing; each keeps its own limb counts: N, M below); the
//   CORDIC is iterative, one step per three cycles on ONE shifter (x, then y), x and y loaded through
//   its own adders. The phase
//   accumulator advances once per accepted sample (two halves, the carry registered between).
//   Interface: in_valid / in_ready / out_valid; in_ready is high only when idle (which includes the
//   out_valid cycle), a sample is taken at an edge with in_valid && in_ready; out_valid is a
//   one-cycle pulse with i, q, amp, phase, ovf (held until the next out_valid).
//   MAC operands: a = dr (delta, then d: DW = INTERP_BITS + TWO_PI_W + 3 bits) or cx (x, then
//   the CORDIC x: XW = max(IN_W, DATA_W + 3) bits); b = TWO_PI, mb, -cb, cos, -sin or
//   INV_K << ASH (MB_W = max(TWO_PI_W + 1, NCO_W, INV_K_W + ASH) bits, ASH = max(0, MIX_SHIFT -
//   AMP_SHIFT)); every product takes N = ceil(max(DW, XW)/16) * ceil(MB_W/16) multiplier cycles.
//   The filters: M = ceil(max(LPF_ACOEF_W, LPF_OUT_SHIFT + 2)/16) * ceil(DATA_W/16) (6 at the
//   default), F = 2 LPF_SECTIONS (7 M + 10) cycles for both channels (104 at the default).
//   Schedule, in edges after the edge 0 that takes the sample (the ROM address is the phase's
//   index k while idle):
//     0:              tq = cb's word; x (into the CORDIC x), delta, the address, quadrant
//                     registered; phase low half advanced
//     1:              tq = mb's word (complement address); -cb registered (quadrant sign: the
//                     word or ~word + 1 on the correction's adder); delta * TWO_PI issued; phase high half
//     2:              mb registered (the same adder)
//     N + 5:          d registered (the MAC's out_valid cycle)
//     N + 6, 2N + 6:  mb * d, then -cb * d issued (back to back)
//     2N + 10, + 11:  round(mb * d) (fx_round), then cos = cb + it registered
//     3N + 10, + 11:  round(-cb * d), then -sin = mb + it registered
//     3N + 12, 4N + 12: x * cos, then x * -sin issued
//     4N + 16 .. 18:  i = fit(round(x * cos)) (fx_convert_pipe: round, fit), registered
//     5N + 16 .. 18:  q likewise; both go to the iir at 5N + 18
//     5N + 18 + F:    the iir's out_valid follows; at 5N + 19 + F li, lq load the CORDIC x, y
//                     through its adders (x, y, z cleared while waiting for the iir)
//     5N + 20 + F .. + 22: the pre-rotation (x, y = +-y, -+x when x < 0; z = +-HALF_PI), on the
//                     CORDIC's own adders with the accumulating operands zeroed
//     5N + 23 + F ..: the ITERATIONS shift-and-add steps, three edges each: x >>> j registered,
//                     then y >>> j (one shifter), then the adders (atan ROM read by j)
//     5N + 23 + F + 3 ITERATIONS: x_K * INV_K issued
//     6N + 27 + F + 3 ITERATIONS .. + 29: amp = fit(round(...)) (fx_convert_pipe), then every
//                     output registered, out_valid high; in_ready high again
//   Cycles per sample: 6 N + 30 + 3 ITERATIONS + 2 LPF_SECTIONS (7 M + 10) (a config's value: the
//   hardware report's cycles column, against 416 at 40 MHz and 96 kS/s).
//   Latency: one cycle less (out_valid in the cycle in which the next sample may be taken).
//   The shared multiplier: max(MA_W, the filters' a) x max(MB_W, DATA_W) bits, each rounded up to
//   whole 16-bit limbs (fx_mac_serial VAR_N = 1, whose products come back top-aligned in them); EXT_MAC = 1: none here, its requests (the demodulator's and the filters') go out on
//   the mac_* bundle (fx_mac_port), e.g. to chain_paper002's one multiplier.
//   AUX_LPF = 1 (ARCH = 1): the filter engine also runs an auxiliary low-pass of the same format
//   (LPF_* parameters) with its own coefficients, as its third channel (iir CHANNELS = 3, COEF_SETS = 3,
//   SPLIT = 1; AUX_COEF_FILE holds the I, Q and auxiliary sets, 7 LPF_SECTIONS words each): a sample
//   on aux_in_valid / aux_x is filtered while the demodulator is idle (its in_ready low meanwhile)
//   and leaves on aux_out_valid / aux_y / aux_ovf after LPF_SECTIONS (7 M + 10) + 1 cycles; the
//   caller gives it only when in_ready is high (chain_paper002's output low-pass, after the
//   subtraction; a simulation check stops otherwise). AUX_LPF = 0: the aux ports are not read, aux_y
//   and aux_ovf are 0 and aux_out_valid low.
// REF = 1: the reference is an input: the table is read at (ref_phase + PHASE_TRIM) mod
//   2**PHASE_BITS, ref_phase taken with x (a drive loop's accumulator word, the model's input ref; FTW
//   and PHASE0 are not read). REF = 0: ref_phase is not read (the demodulator's own accumulator).
// WAVE = 1 (ARCH = 1): a wave pass: wave_in_valid (while in_ready, never with in_valid) takes ref_phase and
//   runs the table engine alone (edges 0 .. 3N + 11 of the schedule above: the ROM, the multiplier
//   and the correction's adder), then wave_out_valid is high for one cycle with wave_msin = -sin at
//   ref_phase + PHASE_TRIM (the bit-exact word the mixers would read there, held until the next pass)
//   and in_ready again: 3 N + 12 cycles from its accepting edge to the next (the drive loop's carrier,
//   read ahead of its detector).
//   The mixers, filters and CORDIC do not run; x is loaded into the CORDIC's x and cleared before it
//   is read. WAVE = 0: wave_in_valid is not read, wave_out_valid is low and wave_msin 0.
`default_nettype none

module demod #(
    parameter integer IN_W          = 24,
    parameter integer DATA_W        = 24,
    parameter integer PHASE_BITS    = 48,
    parameter integer LUT_BITS      = 12,
    parameter integer LUT_W         = 22,
    parameter integer INTERP_BITS   = 12,
    parameter [63:0]  TWO_PI        = 64'd25736,
    parameter integer TWO_PI_W      = 16,
    parameter integer CORR_SHIFT    = 37,
    parameter integer NCO_W         = 23,
    parameter [63:0]  FTW           = 64'd23456248059221,
    parameter [63:0]  PHASE0        = 64'd0,
    parameter [63:0]  PHASE_TRIM    = 64'd0,
    parameter integer MIX_SHIFT     = 20,
    parameter integer ROUNDING      = 1,
    parameter integer OVERFLOW      = 1,
    parameter integer LPF_SECTIONS  = 1,
    parameter integer LPF_COEF_W    = 35,
    parameter integer LPF_ACOEF_W   = 39,
    parameter integer LPF_SHIFT_B   = 0,
    parameter integer LPF_SHIFT_A   = 4,
    parameter integer LPF_OUT_SHIFT = 37,
    parameter integer LPF_ACC_W     = 64,
    parameter integer LPF_ROUNDING  = 1,
    parameter integer LPF_OVERFLOW  = 1,
    parameter integer ITERATIONS    = 16,
    parameter integer ANGLE_W       = 20,
    parameter [63:0]  HALF_PI       = 64'd205887,
    parameter [63:0]  INV_K         = 64'd79594,
    parameter integer INV_K_W       = 18,
    parameter integer AMP_SHIFT     = 17,
    parameter         QSIN_FILE     = "demod_qsin.hex",
    parameter         LPF_COEF_FILE = "demod_lpf_coef.hex",
    parameter         LPF_ACOEF_FILE = "demod_lpf_acoef.hex",   // the serial engine's words (iir ACOEF_FILE)
    parameter         ATAN_FILE     = "demod_atan.hex",
    parameter integer ARCH          = 0,    // 0: one sample per cycle (in_ready tied high); 1: serial
    parameter integer EXT_MAC       = 0,    // ARCH = 1: 0 its own fx_mac_serial; 1 the external one on mac_* (fx_mac_port)
    parameter integer MAC_A_W       = 48,   // EXT_MAC = 1: the external multiplier's operand widths (>= the
    parameter integer MAC_B_W       = 32,   // demod's and its low-pass filters' operands)
    parameter integer AUX_LPF       = 0,    // ARCH = 1: 1 the filter engine also runs the aux low-pass (aux_*)
    parameter         AUX_COEF_FILE = "demod_aux_lpf_coef.hex",  // AUX_LPF = 1: the I, Q and aux sets
    parameter integer REF           = 0,    // 1: the reference is the ref input (else the own accumulator)
    parameter integer WAVE          = 0     // ARCH = 1: 1 the table engine also runs wave passes (wave_*)
) (
    input  wire                      clk,
    input  wire                      rst,
    input  wire                      in_valid,
    output wire                      in_ready,
    input  wire [IN_W-1:0]           x,
    output reg                       out_valid,
    output reg  [DATA_W-1:0]         i,
    output reg  [DATA_W-1:0]         q,
    output reg  [DATA_W-1:0]         amp,
    output reg  [ANGLE_W-1:0]        phase,
    output reg  [2*LPF_SECTIONS+2:0] ovf,
    // the external multiplier (ARCH = 1 and EXT_MAC = 1; else the outputs are 0): fx_mac_port's bundle
    output wire                          mac_in_valid,
    input  wire                          mac_in_ready,
    output wire [MAC_A_W-1:0]            mac_a,
    output wire [MAC_B_W-1:0]            mac_b,
    output wire [3:0]                    mac_na,
    output wire [3:0]                    mac_nb,
    input  wire                          mac_out_valid,
    input  wire [MAC_A_W+MAC_B_W-1:0]    mac_p,
    // the auxiliary low-pass channel (ARCH = 1 and AUX_LPF = 1)
    input  wire                          aux_in_valid,
    input  wire [DATA_W-1:0]             aux_x,
    output wire                          aux_out_valid,
    output wire [DATA_W-1:0]             aux_y,
    output wire [LPF_SECTIONS-1:0]       aux_ovf,
    // the reference (REF = 1): an accumulator word per sample, taken with x (or by a wave pass); not
    // named ref (a SystemVerilog keyword)
    input  wire [PHASE_BITS-1:0]         ref_phase,
    // the wave pass (ARCH = 1 and WAVE = 1)
    input  wire                          wave_in_valid,
    output wire                          wave_out_valid,
    output wire [NCO_W-1:0]              wave_msin
`ifdef FORMAL
    ,
    // the products requested on the mac_* bundle and not yet answered (ARCH = 1, EXT_MAC = 1): a
    // formal proof holds the external multiplier's own count to it (fxdsp.hdl.formal)
    output wire [2:0]                    f_mac_in_flight
`endif
);
    localparam integer MW = IN_W + NCO_W;
    localparam integer WW = DATA_W + 3;        // CORDIC work: DATA_W + 2 guard bits, + 1 spare
    localparam integer AW = ANGLE_W + 2;       // angle accumulator, never overflows the port
    localparam integer PW = WW + INV_K_W;

    generate
        if (ARCH != 0 && ARCH != 1) begin : g_bad_arch
            initial begin $display("demod: ARCH must be 0 or 1, got %0d", ARCH); $finish; end
        end
        if (AUX_LPF != 0 && (ARCH != 1 || AUX_LPF != 1)) begin : g_bad_aux
            initial begin $display("demod: AUX_LPF = 1 needs ARCH = 1, got AUX_LPF %0d, ARCH %0d", AUX_LPF, ARCH);
                          $finish; end
        end
        if (REF != 0 && REF != 1) begin : g_bad_ref
            initial begin $display("demod: REF must be 0 or 1, got %0d", REF); $finish; end
        end
        if (WAVE != 0 && (ARCH != 1 || WAVE != 1)) begin : g_bad_wave
            initial begin $display("demod: WAVE = 1 needs ARCH = 1, got WAVE %0d, ARCH %0d", WAVE, ARCH); $finish; end
        end
        if (WAVE == 0) begin : g_no_wave_port
            assign wave_out_valid = 1'b0;
            assign wave_msin = {NCO_W{1'b0}};
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_wave = wave_in_valid;
            /* verilator lint_on UNUSEDSIGNAL */
        end
        if (REF == 0) begin : g_no_ref
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_ref = ^ref_phase;
            /* verilator lint_on UNUSEDSIGNAL */
        end
        if (AUX_LPF == 0) begin : g_no_aux_port
            // no auxiliary channel (always so at ARCH = 0): aux_* not read, the outputs 0
            assign aux_out_valid = 1'b0;
            assign aux_y = {DATA_W{1'b0}};
            assign aux_ovf = {LPF_SECTIONS{1'b0}};
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_aux = aux_in_valid ^ (^aux_x);
            /* verilator lint_on UNUSEDSIGNAL */
        end
        if (ARCH == 0) begin : g_par
`ifdef FORMAL
            assign f_mac_in_flight = 3'd0;
`endif
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

            // ---- NCO and mixers ----
            wire [NCO_W-1:0] cos_w, msin_w;
            if (REF != 0) begin : g_ref     // the table at the input's word plus the trim
                localparam [PHASE_BITS-1:0] TRIM_C = PHASE_TRIM[PHASE_BITS-1:0];
                nco_wave #(.PHASE_BITS(PHASE_BITS), .LUT_BITS(LUT_BITS), .LUT_W(LUT_W), .INTERP_BITS(INTERP_BITS),
                           .TWO_PI(TWO_PI), .TWO_PI_W(TWO_PI_W), .CORR_SHIFT(CORR_SHIFT), .NCO_W(NCO_W),
                           .ROUNDING(ROUNDING), .QSIN_FILE(QSIN_FILE)) u_wave
                    (.phase(ref_phase + TRIM_C), .cos_o(cos_w), .msin_o(msin_w));
            end else begin : g_own
                nco #(.PHASE_BITS(PHASE_BITS), .LUT_BITS(LUT_BITS), .LUT_W(LUT_W), .INTERP_BITS(INTERP_BITS),
                      .TWO_PI(TWO_PI), .TWO_PI_W(TWO_PI_W), .CORR_SHIFT(CORR_SHIFT), .NCO_W(NCO_W), .FTW(FTW),
                      .PHASE0(PHASE0), .PHASE_TRIM(PHASE_TRIM), .ROUNDING(ROUNDING), .QSIN_FILE(QSIN_FILE)) u_nco
                    (.clk(clk), .rst(rst), .step(in_valid), .cos_o(cos_w), .msin_o(msin_w));
            end

            wire [DATA_W-1:0] li, lq;
            wire [2*LPF_SECTIONS+1:0] ovf_ml;      // {lpf_q, lpf_i, mix_q, mix_i}
            wire lv;
            mix_lpf #(.IN_W(IN_W), .NCO_W(NCO_W), .DATA_W(DATA_W), .MIX_SHIFT(MIX_SHIFT), .ROUNDING(ROUNDING),
                      .OVERFLOW(OVERFLOW), .LPF_SECTIONS(LPF_SECTIONS), .LPF_COEF_W(LPF_COEF_W),
                      .LPF_ACOEF_W(LPF_ACOEF_W), .LPF_SHIFT_B(LPF_SHIFT_B), .LPF_SHIFT_A(LPF_SHIFT_A),
                      .LPF_OUT_SHIFT(LPF_OUT_SHIFT), .LPF_ACC_W(LPF_ACC_W), .LPF_ROUNDING(LPF_ROUNDING),
                      .LPF_OVERFLOW(LPF_OVERFLOW), .LPF_COEF_FILE(LPF_COEF_FILE), .LPF_ACOEF_FILE(LPF_ACOEF_FILE)) u_det
                (.clk(clk), .rst(rst), .in_valid(in_valid), .x(x), .cos_i(cos_w), .msin_i(msin_w), .out_valid(lv),
                 .li(li), .lq(lq), .ovf(ovf_ml));

            // ---- CORDIC vectoring (combinational on the filter outputs) ----
            wire signed [WW-1:0] cx;
            wire signed [AW-1:0] cz;
            cordic_vector #(.DATA_W(DATA_W), .ITERATIONS(ITERATIONS), .ANGLE_W(ANGLE_W), .HALF_PI(HALF_PI),
                            .ATAN_FILE(ATAN_FILE)) u_cordic (.x(li), .y(lq), .xk(cx), .z(cz));

            localparam [INV_K_W-1:0] INV_K_C = INV_K[INV_K_W-1:0];
            wire signed [INV_K_W-1:0] invk = INV_K_C;
            wire signed [WW-1:0] xfin = cx;
            wire signed [PW-1:0] ap = xfin * invk;
            wire [DATA_W-1:0] amp_c;
            wire ovf_amp;
            fx_convert #(.IN_W(PW), .SHIFT(AMP_SHIFT), .ROUNDING(ROUNDING), .OUT_W(DATA_W), .OUT_SIGNED(1),
                         .OVERFLOW(OVERFLOW)) u_amp (.x(ap), .cin(1'b0), .y(amp_c), .ovf(ovf_amp));
            /* verilator lint_off UNUSEDSIGNAL */
            wire signed [AW-1:0] zfin = cz;
            /* verilator lint_on UNUSEDSIGNAL */

            always @(posedge clk) begin
                if (rst) begin
                    out_valid <= 1'b0;
                    i <= {DATA_W{1'b0}}; q <= {DATA_W{1'b0}};
                    amp <= {DATA_W{1'b0}}; phase <= {ANGLE_W{1'b0}};
                    ovf <= {(2*LPF_SECTIONS+3){1'b0}};
                end else begin
                    out_valid <= lv;
                    if (lv) begin
                        i <= li;
                        q <= lq;
                        amp <= amp_c;
                        phase <= zfin[ANGLE_W-1:0];
                        ovf <= {ovf_amp, ovf_ml};
                    end
                end
            end
        end else begin : g_ser
            // ---- serial: one table read port, one shared multiplier, one two-channel iir ----
            localparam integer QBITS = LUT_BITS - 2;
            localparam integer DLW   = INTERP_BITS + 2;         // delta: odd, |delta| < 2**INTERP_BITS
            localparam integer DW    = DLW + TWO_PI_W + 1;      // d = delta * TWO_PI
            localparam integer NPW   = NCO_W + DW;              // correction product
            localparam integer CW    = NPW - CORR_SHIFT + 1;    // rounded correction
            localparam integer SW    = ((CW > NCO_W) ? CW : NCO_W) + 1;
            localparam integer XW    = (IN_W > WW) ? IN_W : WW; // x, then the CORDIC x (cx)
            localparam integer MA_W  = (DW > XW) ? DW : XW;     // MAC operand a: dr or cx
            // one fx_convert_pipe rounds the mixer and the amplitude products at CSH: the one with the
            // smaller shift is scaled up first (amp: INV_K << ASH, a constant; mixers: p << MSH)
            localparam integer CSH   = (MIX_SHIFT > AMP_SHIFT) ? MIX_SHIFT : AMP_SHIFT;
            localparam integer ASH   = CSH - AMP_SHIFT;
            localparam integer MSH   = CSH - MIX_SHIFT;
            localparam integer IKW   = INV_K_W + ASH;           // INV_K << ASH
            localparam integer CV_W  = ((MW + MSH > PW + ASH) ? MW + MSH : PW + ASH);
            localparam integer MB0   = (TWO_PI_W + 1 > NCO_W) ? TWO_PI_W + 1 : NCO_W;
            localparam integer MB_W  = (MB0 > IKW) ? MB0 : IKW; // b: constants or NCO values
            localparam integer MP_W  = MA_W + MB_W;
            // the low-pass filters' operands (iir.v ARCH = 1: coefficient or error e, data or weight c)
            // and the multiplier shared with them: the wider of each
            localparam integer LA_W  = (LPF_ACOEF_W > LPF_OUT_SHIFT + 2) ? LPF_ACOEF_W : LPF_OUT_SHIFT + 2;
            // in whole 16-bit limbs: the multiplier shared with the filters (VAR_N = 1) returns its
            // products top-aligned in whole limbs (fx_mac_serial)
            localparam integer DA_UP = ((MA_W > LA_W) ? MA_W : LA_W) + 15;
            localparam integer DB_UP = ((MB_W > DATA_W) ? MB_W : DATA_W) + 15;
            localparam integer DA_W  = 16 * (DA_UP / 16);
            localparam integer DB_W  = 16 * (DB_UP / 16);
            localparam integer PL    = PHASE_BITS / 2;          // phase accumulator: low half ...
            localparam integer PH    = PHASE_BITS - PL;         // ... and high half
            localparam integer JW    = (ITERATIONS > 1) ? $clog2(ITERATIONS) : 1;
            localparam integer J_LAST_I = ITERATIONS - 1;
            localparam [JW-1:0] J_LAST = J_LAST_I[JW-1:0];
            localparam [PHASE_BITS-1:0] FTW_C   = FTW[PHASE_BITS-1:0];
            localparam [PHASE_BITS-1:0] START_C = PHASE0[PHASE_BITS-1:0] + PHASE_TRIM[PHASE_BITS-1:0];
            localparam [PL-1:0] FTW_LO   = FTW_C[PL-1:0];
            localparam [PH-1:0] FTW_HI   = FTW_C[PHASE_BITS-1:PL];
            localparam [PL-1:0] START_LO = START_C[PL-1:0];
            localparam [PH-1:0] START_HI = START_C[PHASE_BITS-1:PL];
            localparam [TWO_PI_W-1:0] TWO_PI_C = TWO_PI[TWO_PI_W-1:0];
            localparam [INV_K_W-1:0]  INV_K_C  = INV_K[INV_K_W-1:0];
            localparam [ANGLE_W-1:0]  HALF_PI_C = HALF_PI[ANGLE_W-1:0];
            localparam [4:0] S_IDLE = 5'd0;     // FSM states; idle: the ROM reads qsin[k]
            localparam [4:0] S_RD   = 5'd1;     // the ROM reads qsin[~k]; delta * TWO_PI issued
            localparam [4:0] S_NB   = 5'd2;     // cb, mb, -cb registered
            localparam [4:0] S_WD   = 5'd3;     // waiting for d
            localparam [4:0] S_PC   = 5'd4;     // mb * d issued
            localparam [4:0] S_PM   = 5'd5;     // -cb * d issued
            localparam [4:0] S_WSIN = 5'd6;     // waiting for cos, -sin
            localparam [4:0] S_PI   = 5'd7;     // x * cos issued
            localparam [4:0] S_PQ   = 5'd8;     // x * -sin issued
            localparam [4:0] S_WMIX = 5'd9;     // waiting for i, q (fx_convert_pipe)
            localparam [4:0] S_LPF  = 5'd10;    // waiting for the two low-pass outputs
            localparam [4:0] S_COR  = 5'd11;    // pre-rotation, then ITERATIONS CORDIC steps
            localparam [4:0] S_PA   = 5'd12;    // x_K * INV_K issued
            localparam [4:0] S_WA   = 5'd13;    // waiting for amp; then the outputs
            localparam [2:0] R_D = 3'd0;        // products, in the order they come back
            localparam [2:0] R_C = 3'd1;        // mb * d
            localparam [2:0] R_M = 3'd2;        // -cb * d
            localparam [2:0] R_I = 3'd3;        // x * cos
            localparam [2:0] R_Q = 3'd4;        // x * -sin
            localparam [2:0] R_A = 3'd5;        // x_K * INV_K

            if (QBITS < 1 || DATA_W < 2) begin : g_bad_widths
                initial begin $display("demod: ARCH=1 needs LUT_BITS >= 3 and DATA_W >= 2, got %0d, %0d",
                                       LUT_BITS, DATA_W); $finish; end
            end

            reg [4:0] st;
            reg [2:0] rk;                       // the next product to come back from the MAC
            wire aux_busy;                      // AUX_LPF: the filter engine runs the aux channel
            wire idle = (st == S_IDLE) && !aux_busy;
            // a sample, or (WAVE) a wave pass: the same front end (phase fields, ROM, products D, C, M)
            wire wave_go = (WAVE != 0) && wave_in_valid;
            wire take = idle && (in_valid || wave_go);
            assign in_ready = idle;
            reg  wave_q;                        // the pass in the engine is a wave pass
            reg  wave_v;                        // its -sin in mb_q: wave_out_valid

            // ---- phase accumulator: PHASE0 + PHASE_TRIM + n FTW, in two halves (short carry chains) ----
            reg [PL-1:0] ph_lo;
            reg [PH-1:0] ph_hi;
            reg          ph_c;                  // carry of the low half, added into the high half next cycle
            localparam [PHASE_BITS-1:0] TRIM_C = PHASE_TRIM[PHASE_BITS-1:0];
            /* verilator lint_off UNUSEDSIGNAL */  // the bits below the interpolation offset: residual phase
            wire [PHASE_BITS-1:0] ph = (REF != 0) ? ref_phase + TRIM_C : {ph_hi, ph_lo};
            /* verilator lint_on UNUSEDSIGNAL */
            wire [PL:0] ph_lo_n = {1'b0, ph_lo} + {1'b0, FTW_LO};
            /* verilator lint_off UNUSEDSIGNAL */
            wire        ph_hi_cin;
            /* verilator lint_on UNUSEDSIGNAL */
            wire [PH-1:0] ph_hi_n;
            assign {ph_hi_n, ph_hi_cin} = {ph_hi, 1'b1} + {FTW_HI, ph_c};
            always @(posedge clk) begin
                if (rst) begin
                    ph_lo <= START_LO; ph_hi <= START_HI; ph_c <= 1'b0;
                end else begin
                    if (take) {ph_c, ph_lo} <= ph_lo_n;
                    if (st == S_RD) ph_hi <= ph_hi_n;
                end
            end

            // ---- bin and sub-bin offset of the phase (nco_phase, as in nco.v) ----
            wire [1:0]       quad;
            wire [QBITS-1:0] kb;
            wire signed [DLW-1:0] delta;
            nco_phase #(.PHASE_BITS(PHASE_BITS), .LUT_BITS(LUT_BITS), .INTERP_BITS(INTERP_BITS)) u_fields (
                .phase(ph), .quad(quad), .k(kb), .delta(delta));

            // ---- the quarter-wave table: one registered read port (block RAM) ----
            reg [LUT_W-1:0] qsin [0:(1<<QBITS)-1];
            initial $readmemh(QSIN_FILE, qsin);
            // read order by quadrant: first the word of cb (qsin[k] in odd quadrants, qsin[~k] in even
            // ones: nco.v's ca), then its complement ~address, the word of mb (nco.v's ma)
            reg [QBITS-1:0] k_q;                // the first address
            reg [1:0]       quad_q;
            reg [LUT_W-1:0] tq;                 // registered ROM read
            wire [QBITS-1:0] k_first = kb ^ {QBITS{~quad[0]}};
            wire [QBITS-1:0] addr = (st == S_IDLE) ? k_first : ~k_q;
            always @(posedge clk) tq <= qsin[addr];

            // ---- bin centre by quadrant symmetry (nco.v): -cb from the first word, mb from the second ----
            //   -cb = ca in quadrants 1, 2 (cb = -ca), else -ca;  mb = ma in quadrants 2, 3, else -ma
            // negated on the correction's adder (add_s below: ~tw + 1, rc_q 0 then): the word in tq is
            // ca in S_RD, ma in S_NB
            wire signed [NCO_W-1:0] tw  = {tq[LUT_W-1], tq};
            wire keep = (st == S_RD) ? (quad_q[1] ^ quad_q[0]) : quad_q[1];
            wire ld_word = (st == S_RD) || (st == S_NB);   // the table word through the adder
            reg signed [NCO_W-1:0] ncb_q;       // -cb, then cos = cb + R(mb d) = R(mb d) - (-cb)
            reg signed [NCO_W-1:0] mb_q;        // mb, then -sin = mb + R(-cb d)

            // ---- the shared multiplier ----
            reg  signed [DW-1:0] dr;            // delta, then d = delta * TWO_PI
            reg  signed [XW-1:0] cx, cy;        // x, then the CORDIC x, y
            reg  signed [AW-1:0] cz;            // the CORDIC angle
            wire signed [MA_W-1:0] dr_a = {{(MA_W-DW+1){dr[DW-1]}}, dr[DW-2:0]};
            wire signed [MA_W-1:0] cx_a = {{(MA_W-XW+1){cx[XW-1]}}, cx[XW-2:0]};
            wire signed [MB_W-1:0] twopi_b = {{(MB_W-TWO_PI_W){1'b0}}, TWO_PI_C};   // > 0
            wire signed [MB_W-1:0] invk_u  = {{(MB_W-INV_K_W+1){INV_K_C[INV_K_W-1]}}, INV_K_C[INV_K_W-2:0]};
            wire signed [MB_W-1:0] invk_b  = invk_u <<< ASH;   // a constant
            wire signed [MB_W-1:0] mb_b  = {{(MB_W-NCO_W+1){mb_q[NCO_W-1]}}, mb_q[NCO_W-2:0]};
            wire signed [MB_W-1:0] ncb_b = {{(MB_W-NCO_W+1){ncb_q[NCO_W-1]}}, ncb_q[NCO_W-2:0]};
            wire a_cx = (st == S_PI) || (st == S_PQ) || (st == S_PA);
            wire signed [MA_W-1:0] a_op = a_cx ? cx_a : dr_a;
            reg  signed [MB_W-1:0] b_op;
            always @* begin
                case (st)
                    S_PC:    b_op = mb_b;       // mb * d
                    S_PM:    b_op = ncb_b;      // -cb * d
                    S_PI:    b_op = ncb_b;      // x * cos (ncb_q holds cos by then)
                    S_PQ:    b_op = mb_b;       // x * -sin
                    S_PA:    b_op = invk_b;     // x_K * INV_K
                    default: b_op = twopi_b;    // S_RD: delta * TWO_PI
                endcase
            end
            wire mac_ready, mac_valid;
            // a request is the issuing state alone (valid/ready: the multiplier takes it with its in_ready,
            // the FSM moves on with the same in_ready), not gated by in_ready: in_ready -> request ->
            // the shared multiplier's take would be the chain's critical path
            wire mac_in = (st == S_RD) || (st == S_PC) || (st == S_PM) || (st == S_PI) || (st == S_PQ) || (st == S_PA);
            /* verilator lint_off UNUSEDSIGNAL */  // each product is exact in its own width: its top bits copy the sign
            wire signed [MP_W-1:0] p;
            /* verilator lint_on UNUSEDSIGNAL */
            // the demodulator's products and its low-pass filters' (the iir's requests on its mac_*
            // bundle) share ONE multiplier: the iir computes only while the FSM waits for it in S_LPF
            // (taken at the edge into S_LPF, its out_valid the way out), and the demodulator issues no
            // product there (its x * -sin has returned before the mixers' q, S_LPF's entry; x_K * INV_K
            // is issued after). So S_LPF selects the iir's request and routes the out_valid to it
            // (every other state: the demodulator's). Each keeps its own limb counts (VAR_N = 1) and so
            // its schedule (N and M above).
            // the requests need no select: the iir requests only in S_LPF or the aux pass, the
            // demodulator never there, so they are ORed (lpf_own off the path into the multiplier's take)
            wire lpf_own = (st == S_LPF) || aux_busy;
            wire                dm_v, lp_v, sh_ready, sh_valid;
            wire [DA_W-1:0]     dm_a, lp_a;
            wire [DB_W-1:0]     dm_b, lp_b;
            wire [3:0]          dm_na, dm_nb, lp_na, lp_nb;
            wire [DA_W+DB_W-1:0] sh_p;
            fx_mac_port #(.A_W(MA_W), .B_W(MB_W), .EXT_MAC(1), .MAC_A_W(DA_W), .MAC_B_W(DB_W)) u_mac_dm
                (.clk(clk), .rst(rst), .in_valid(mac_in), .in_ready(mac_ready), .a(a_op), .b(b_op), .na(4'd0), .nb(4'd0),
                 .out_valid(mac_valid), .p(p), .mac_in_valid(dm_v), .mac_in_ready(sh_ready), .mac_a(dm_a),
                 .mac_b(dm_b), .mac_na(dm_na), .mac_nb(dm_nb), .mac_out_valid(sh_valid & ~lpf_own), .mac_p(sh_p));
            // the shared multiplier: its own (EXT_MAC = 0) or the external one on this module's mac_*
            fx_mac_port #(.A_W(DA_W), .B_W(DB_W), .VAR_N(1), .EXT_MAC(EXT_MAC), .MAC_A_W(MAC_A_W), .MAC_B_W(MAC_B_W)) u_mac
                (.clk(clk), .rst(rst), .in_valid(lp_v | dm_v), .in_ready(sh_ready), .a(lpf_own ? lp_a : dm_a),
                 .b(lpf_own ? lp_b : dm_b), .na(lpf_own ? lp_na : dm_na), .nb(lpf_own ? lp_nb : dm_nb),
                 .out_valid(sh_valid), .p(sh_p), .mac_in_valid(mac_in_valid), .mac_in_ready(mac_in_ready), .mac_a(mac_a),
                 .mac_b(mac_b), .mac_na(mac_na), .mac_nb(mac_nb), .mac_out_valid(mac_out_valid), .mac_p(mac_p));

            // ---- NCO correction: R(p >> CORR_SHIFT) (fx_round, ROUNDING), added to mb or cb ----
            wire signed [CW-1:0] rc_c;
            fx_round #(.IN_W(NPW), .SHIFT(CORR_SHIFT), .ROUNDING(ROUNDING), .OUT_W(CW)) u_corr
                (.x(p[NPW-1:0]), .cin(1'b0), .y(rc_c));
            reg signed [CW-1:0] rc_q;           // 0 from the take until the first correction
            reg                 add_go;         // the correction in rc_q is added this cycle ...
            reg                 add_sin;        // ... to mb (-sin), else to cb = -ncb (cos: rc + ~ncb + 1)
            // the one adder: the table word as it is or negated (~tw + 1) in S_RD, S_NB (rc_q = 0),
            // the corrections after
            wire signed [NCO_W-1:0] add_a = ld_word ? (keep ? tw : ~tw) : (add_sin ? mb_q : ~ncb_q);
            wire                    add_c = ld_word ? ~keep : ~add_sin;
            /* verilator lint_off UNUSEDSIGNAL */  // the top bit: the model proves it is a sign copy; the carry-in bit
            wire signed [SW-1:0] add_s;
            wire                 add_cin;
            assign {add_s, add_cin} = {{(SW-NCO_W){add_a[NCO_W-1]}}, add_a, 1'b1} + {{(SW-CW){rc_q[CW-1]}}, rc_q, add_c};
            /* verilator lint_on UNUSEDSIGNAL */

            // ---- mixers and amplitude: fit(round(p >> CSH)), one fx_convert_pipe for the three ----
            //   i, q = fit(round(x * cos, -sin >> MIX_SHIFT)), amp = fit(round(x_K * INV_K >> AMP_SHIFT))
            wire mix_in = mac_valid && ((rk == R_I) || (rk == R_Q));
            wire amp_in = mac_valid && (rk == R_A);
            wire mix_v, mix_o;
            wire [DATA_W-1:0] mix_y;
            wire signed [CV_W-1:0] pm_x = {{(CV_W-MW+1){p[MW-1]}}, p[MW-2:0]};   // a mixer product
            wire signed [CV_W-1:0] cv_x;
            if (MSH > 0) begin : g_mix_up    // the amplitude's shift is the larger: the mixers scaled up
                wire signed [CV_W-1:0] pa_x = {{(CV_W-PW+1){p[PW-1]}}, p[PW-2:0]};
                assign cv_x = amp_in ? pa_x : (pm_x <<< MSH);
            end else begin : g_mix_as_is     // the amplitude product is already scaled by INV_K << ASH
                assign cv_x = pm_x;
            end
            fx_convert_pipe #(.IN_W(CV_W), .SHIFT(CSH), .ROUNDING(ROUNDING), .OUT_W(DATA_W), .OUT_SIGNED(1),
                              .OVERFLOW(OVERFLOW)) u_cv (.clk(clk), .rst(rst), .in_valid(mix_in | amp_in), .x(cv_x), .cin(1'b0),
                                                         .out_valid(mix_v), .y(mix_y), .ovf(mix_o));
            reg [DATA_W-1:0] mi_q;              // i of the mixer, until q joins it
            reg              got_i, ovf_mi_q, ovf_mq_q;

            // ---- the two low-pass filters: one serial iir engine, channel 0 = I, 1 = Q (AUX_LPF: and
            // channel 2 = the aux low-pass, a pass of its own while the demodulator is idle) ----
            localparam integer LCH = 2 + AUX_LPF;
            wire lpf_go = (st == S_WMIX) && mix_v && got_i;
            wire lpf_done;                      // the engine's out_valid: I and Q, or the aux channel
            wire [LCH*DATA_W-1:0] lpf_yall;
            wire [LCH*LPF_SECTIONS-1:0] lpf_oall;
            wire aux_go;
            wire [LCH*DATA_W-1:0] lpf_x;        // {[aux_x,] q, i}
`ifdef FORMAL
            wire lpf_idle;                      // the engine's in_ready: no pass in it
            wire [2:0] lpf_in_flight;           // its products on the multiplier
`endif
            iir #(.DATA_W(DATA_W), .SECTIONS(LPF_SECTIONS), .COEF_W(LPF_COEF_W), .ACOEF_W(LPF_ACOEF_W), .SHIFT_B(LPF_SHIFT_B),
                  .SHIFT_A(LPF_SHIFT_A), .OUT_SHIFT(LPF_OUT_SHIFT), .ACC_W(LPF_ACC_W), .ROUNDING(LPF_ROUNDING),
                  .OVERFLOW(LPF_OVERFLOW), .ARCH(1), .CHANNELS(LCH), .COEF_SETS((AUX_LPF != 0) ? LCH : 1),
                  .SPLIT(AUX_LPF), .EXT_MAC(1), .MAC_A_W(DA_W), .MAC_B_W(DB_W), .COEF_FILE(LPF_COEF_FILE), .ACOEF_FILE(LPF_ACOEF_FILE),
                  .SETS_FILE(AUX_COEF_FILE)) u_lpf
                (.clk(clk), .rst(rst), .in_valid(lpf_go | aux_go),
`ifdef FORMAL
                 .in_ready(lpf_idle), .f_mac_in_flight(lpf_in_flight),   // read only by the invariants below
`else
                 .in_ready(),
`endif
                 .x(lpf_x), .out_valid(lpf_done),
                 .y(lpf_yall), .ovf(lpf_oall), .mac_in_valid(lp_v), .mac_in_ready(sh_ready), .mac_a(lp_a), .mac_b(lp_b),
                 .mac_na(lp_na), .mac_nb(lp_nb), .mac_out_valid(sh_valid & lpf_own), .mac_p(sh_p));
            wire lpf_v = lpf_done && !aux_busy;
            wire [2*DATA_W-1:0] lpf_y;          // {q, i} of the engine's outputs ...
            wire [2*LPF_SECTIONS-1:0] lpf_o;    // ... and their flags {lpf_q[S], lpf_i[S]}
            wire signed [DATA_W-1:0] li, lq;
            assign {lq, li} = lpf_y;
            if (AUX_LPF != 0) begin : g_aux
                reg aux_q;                      // the aux pass is in the engine: from aux_in_valid to its out_valid
                assign aux_go = aux_in_valid;
                assign lpf_x = {aux_x, mix_y, mi_q};
                assign aux_busy = aux_q;
                always @(posedge clk) begin
                    if (rst) aux_q <= 1'b0;
                    else if (aux_go) aux_q <= 1'b1;
                    else if (lpf_done) aux_q <= 1'b0;
                end
                assign aux_out_valid = lpf_done && aux_q;
                assign {aux_y, lpf_y} = lpf_yall;
                assign {aux_ovf, lpf_o} = lpf_oall;
                // an aux sample while the demodulator works would share its multiplier: the caller's
                // rule, proven of a generated top (fxdsp.hdl.formal); a simulation stops on it
`ifdef FORMAL
                always @* if (!rst && aux_in_valid) aux_only_when_idle: assert(idle);
`else
`ifndef SYNTHESIS
                always @(posedge clk) begin
                    if (!rst && aux_in_valid && !idle) begin
                        $display("demod: aux_in_valid while busy (state %0d, aux %b)", st, aux_q);
                        $finish;
                    end
                end
`endif
`endif
            end else begin : g_no_aux
                assign aux_go = 1'b0;
                assign aux_busy = 1'b0;
                assign lpf_x = {mix_y, mi_q};
                assign lpf_y = lpf_yall;
                assign lpf_o = lpf_oall;
            end

            // ---- the wave pass's answer: -sin in mb_q from its last add to the next pass ----
            if (WAVE != 0) begin : g_wave
                assign wave_out_valid = wave_v;
                assign wave_msin = mb_q;
`ifndef FORMAL
`ifndef SYNTHESIS
                // a wave pass with a sample in the same cycle would lose the sample: the caller's rule
                always @(posedge clk) begin
                    if (!rst && wave_in_valid && (in_valid || !idle)) begin
                        $display("demod: wave_in_valid with in_valid or while busy (state %0d)", st);
                        $finish;
                    end
                end
`endif
`endif
            end else begin : g_wave_off
                /* verilator lint_off UNUSEDSIGNAL */
                wire unused_wave_regs = wave_v;
                /* verilator lint_on UNUSEDSIGNAL */
            end

            // ---- CORDIC: one step per cycle on cx, cy, cz ----
            reg [JW-1:0] j;
            reg          pre;                   // the pre-rotation step (before step 0)
            localparam [1:0] CP_X = 2'd0;       // the cycles of a step: x >>> j registered,
            localparam [1:0] CP_Y = 2'd1;       // ... y >>> j registered,
            localparam [1:0] CP_ADD = 2'd2;     // ... the adders update
            reg [1:0]    cp;                    // the cycle of a step (CP_*)
            reg [ANGLE_W-1:0] atan [0:ITERATIONS-1];
            initial $readmemh(ATAN_FILE, atan);
            wire [ANGLE_W-1:0] atv = pre ? HALF_PI_C : atan[j];
            wire signed [AW-1:0] at = {{2{atv[ANGLE_W-1]}}, atv};
            wire neg = cy[XW-1];                // rotate toward y = 0
            // the pre-rotation is step 0 with the accumulating operands zeroed:
            //   x' = 0 +- y, y' = 0 -+ x, z' = 0 +- HALF_PI (taken only when x < 0)
            // cx, cy load through the same adders (no multiplexer behind them, the critical path): the
            // base operand is the value, the shifted operand 0 (cy = 0 while idle: x into cx at the
            // accepting edge; cx = cy = cz = 0 in S_LPF until li, lq load)
            wire signed [XW-1:0] x_ext  = {{(XW-IN_W+1){x[IN_W-1]}}, x[IN_W-2:0]};
            wire signed [XW-1:0] li_ext = {{(XW-DATA_W+1){li[DATA_W-1]}}, li[DATA_W-2:0]};
            wire signed [XW-1:0] lq_ext = {{(XW-DATA_W+1){lq[DATA_W-1]}}, lq[DATA_W-2:0]};
            wire signed [XW-1:0] bx = (st == S_IDLE) ? x_ext : (st == S_LPF) ? li_ext : pre ? {XW{1'b0}} : cx;
            wire signed [XW-1:0] by = (st == S_LPF) ? lq_ext : pre ? {XW{1'b0}} : cy;
            // ONE shifter for x and y: x >>> j registered in a step's cycle 0, y >>> j in cycle 1, the
            // adders take both in cycle 2 (three cycles per step; the shifter's mux levels and the
            // XW-bit adder in one cycle held the demod to 34 MHz, and a second shifter cost ~56 LUT4).
            // Outside the CORDIC cp alternates 0, 1, so sx, sy are 0 whenever cx, cy have been 0 for
            // two cycles (and from rst), as the loads need
            reg  signed [XW-1:0] sx, sy;
            wire signed [XW-1:0] sh_in = cp[0] ? cy : cx;
            wire signed [XW-1:0] sh = sh_in >>> j;   // floor (arithmetic) shift: blocks.demod.cordic_vector
            always @(posedge clk) begin
                if (rst) begin            // 0 from the reset on: a sample may come at once
                    sx <= {XW{1'b0}}; sy <= {XW{1'b0}};
                end else begin
                    if (cp == CP_X) sx <= sh;
                    if (cp == CP_Y) sy <= sh;
                end
            end
            // y >= 0: x + (y >> j), y - (x >> j), z + atan; y < 0: x - (y >> j), y + (x >> j), z - atan
            // (a - b as a + ~b + 1: the 1 as a carry in through an extra low bit)
            /* verilator lint_off UNUSEDSIGNAL */
            wire cx_cin, cy_cin, cz_cin;
            /* verilator lint_on UNUSEDSIGNAL */
            wire signed [XW-1:0] cx_n, cy_n;
            wire signed [AW-1:0] cz_n;
            assign {cx_n, cx_cin} = {bx, 1'b1} + {sy ^ {XW{neg}}, neg};
            assign {cy_n, cy_cin} = {by, 1'b1} + {sx ^ {XW{~neg}}, ~neg};
            assign {cz_n, cz_cin} = {cz, 1'b1} + {at ^ {AW{neg}}, neg};
            wire step_en = ~pre | cx[XW-1];     // the pre-rotation only for x < 0
            wire step    = (st == S_COR) && (cp == CP_ADD) && step_en;
            wire ld_lpf  = (st == S_LPF) && lpf_v;        // li, lq into cx, cy (z stays 0)
            wire clr_all = rst || ((st == S_LPF) && !lpf_v);
            always @(posedge clk) begin
                if (clr_all) cx <= {XW{1'b0}};
                else if (take || ld_lpf || step) cx <= cx_n;
                if (clr_all || st == S_WA) cy <= {XW{1'b0}};  // 0 again before the next sample's x loads
                else if (ld_lpf || step) cy <= cy_n;
                if (clr_all) cz <= {AW{1'b0}};
                else if (step) cz <= cz_n;
            end

            // ---- datapath registers ----
            always @(posedge clk) begin
                if (take) begin
                    dr     <= {{(DW-DLW+1){delta[DLW-1]}}, delta[DLW-2:0]};
                    k_q    <= k_first;
                    quad_q <= quad;
                end
                if (mac_valid && rk == R_D) dr <= p[DW-1:0];
                if (take) rc_q <= {CW{1'b0}};
                else if (mac_valid && (rk == R_C || rk == R_M)) rc_q <= rc_c;
                if ((st == S_RD) || (add_go && !add_sin)) ncb_q <= add_s[NCO_W-1:0];
                if ((st == S_NB) || (add_go && add_sin))  mb_q  <= add_s[NCO_W-1:0];
                if (st == S_WMIX && mix_v && !got_i) begin
                    mi_q <= mix_y; ovf_mi_q <= mix_o;
                end
                if (lpf_go) ovf_mq_q <= mix_o;
            end

            always @(posedge clk) begin
                if (rst) begin
                    st <= S_IDLE; rk <= R_D; add_go <= 1'b0; add_sin <= 1'b0; got_i <= 1'b0;
                    wave_q <= 1'b0; wave_v <= 1'b0;
                    j <= {JW{1'b0}}; pre <= 1'b0; cp <= CP_X;
                    out_valid <= 1'b0;
                    i <= {DATA_W{1'b0}}; q <= {DATA_W{1'b0}};
                    amp <= {DATA_W{1'b0}}; phase <= {ANGLE_W{1'b0}};
                    ovf <= {(2*LPF_SECTIONS+3){1'b0}};
                end else begin
                    out_valid <= 1'b0;
                    wave_v <= (st == S_WSIN) && add_go && add_sin && wave_q;
                    cp <= (cp == CP_X) ? CP_Y : CP_X;   // outside the CORDIC: x, y shifted in turn
                    add_go  <= mac_valid && (rk == R_C || rk == R_M);
                    add_sin <= (rk == R_M);
                    if (mac_valid) rk <= rk + 3'd1;
                    case (st)
                        S_IDLE: if (take) begin
                            rk <= R_D; got_i <= 1'b0; st <= S_RD; wave_q <= wave_go;
                        end
                        S_RD:   st <= S_NB;
                        S_NB:   st <= S_WD;
                        S_WD:   if (mac_valid) st <= S_PC;
                        S_PC:   if (mac_ready) st <= S_PM;
                        S_PM:   if (mac_ready) st <= S_WSIN;
                        S_WSIN: if (add_go && add_sin) st <= wave_q ? S_IDLE : S_PI;   // a wave pass ends
                        S_PI:   if (mac_ready) st <= S_PQ;
                        S_PQ:   if (mac_ready) st <= S_WMIX;
                        S_WMIX: if (mix_v) begin
                            got_i <= 1'b1;
                            if (got_i) st <= S_LPF;
                        end
                        S_LPF:  if (lpf_v) begin
                            j <= {JW{1'b0}}; pre <= 1'b1; cp <= CP_X; st <= S_COR;
                        end
                        S_COR:  begin
                            cp <= (cp == CP_ADD) ? CP_X : (cp == CP_X) ? CP_Y : CP_ADD;
                            if (cp == CP_ADD) begin
                                pre <= 1'b0;
                                if (!pre) begin
                                    j <= j + {{(JW-1){1'b0}}, 1'b1};
                                    if (j == J_LAST) st <= S_PA;
                                end
                            end
                        end
                        S_PA:   if (mac_ready) st <= S_WA;
                        default: if (mix_v) begin   // S_WA: amp converted; every output registered, out_valid
                            st <= S_IDLE; out_valid <= 1'b1;
                            i <= li; q <= lq; amp <= mix_y; phase <= cz[ANGLE_W-1:0];
                            ovf <= {mix_o, lpf_o, ovf_mq_q, ovf_mi_q};
                        end
                    endcase
                end
            end
`ifdef FORMAL
            // the products in flight: the demodulator's (those its states have issued, less those
            // returned, rk; products are numbered R_* in their order) and the filter engine's
            reg [2:0] issued;
            always @* begin
                case (st)
                    S_IDLE, S_RD:        issued = rk;   // none in flight (S_RD: delta * TWO_PI being taken)
                    S_NB, S_WD, S_PC:    issued = R_C;  // d issued
                    S_PM:                issued = R_M;  // and mb * d
                    S_WSIN, S_PI:        issued = R_I;  // and -cb * d
                    S_PQ:                issued = R_Q;  // and x * cos
                    S_WA:                issued = R_A + 3'd1;
                    default:             issued = R_A;  // S_WMIX .. S_PA: and x * -sin
                endcase
            end
            assign f_mac_in_flight = (issued - rk) + lpf_in_flight;
            // invariants of every state reachable from rst (proven with the rest, fxdsp.hdl.formal):
            // stated so that an induction proof starts only from states a reset can reach (from an
            // unused FSM code, or with the filter engine running a pass nobody gave it, the induction
            // of the interface failed at 208 cycles: the engine's requests took the multiplier's
            // answers, rk passed R_A and the FSM waited in S_WSIN forever)
            always @* begin
                if (!rst) begin
                    fsm_state_is_one_of_fourteen: assert(st <= S_WA);
                    // rk: the products returned so far, by the state that waits for them
                    returned_products_match_the_state: assert(
                        (st == S_IDLE) ? (rk == R_D || rk == R_A + 3'd1 || (wave_q && rk == R_I)) :
                        (st <= S_WD)   ? (rk == R_D) :
                        (st <= S_PM)   ? (rk == R_C) :
                        (st == S_WSIN) ? (rk >= R_C && rk <= R_I) :
                        (st <= S_PQ)   ? (rk == R_I) :
                        (st == S_WMIX) ? (rk >= R_I && rk <= R_A) :
                        (st <= S_PA)   ? (rk == R_A) : (rk == R_A || rk == R_A + 3'd1));
                    // the filter engine runs only for S_LPF or the aux pass, and does run there
                    engine_busy_only_when_given_a_pass: assert(lpf_idle || lpf_own);
                    engine_busy_while_waited_for: assert(!lpf_own || !lpf_idle || lpf_done);
                    aux_pass_only_while_idle: assert(!aux_busy || st == S_IDLE);
                    first_mixer_output_only_in_s_wmix: assert(!got_i || st >= S_WMIX || st == S_IDLE);
                    no_conversion_out_while_idle: assert(st != S_IDLE || !mix_v);
                end
            end
`endif
        end
    endgenerate
endmodule

`default_nettype wire
