"""Mutation proof of the HDL regressions: each single-point mutation of the RTL (one textual edit in
one file, still compiling) must make a regression check fail.

Checks are file-driven runs (fast) of either the committed golden vectors or a model-computed
stream on a design that uses the mutated mode; a mutation is *caught* when an output word or the
overflow-flag count differs from the model.

A mutant that does not compile proves nothing about the checks: every mutant is first compiled on
its own (``iverilog -g2005`` on all mutated sources, generated headers of the default design, in its
own build directory), and a compile failure there or of a check's harness raises
:class:`MutantBroken`, an error of the harness, never a kill.
"""

from __future__ import annotations

import contextlib
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from conftest import lag_chain
from fxdsp.vectors import load
from hdl_util import RTL, SERIAL, ICARUS_MIN_SAMPLES, icarus_samples, icarus_window, VECTORS, BuildFailed, HarnessTimeout, UndefinedWord, build_dir, \
    design_of, generate_into, model_run, mutated_rtl, mutated_top, rtl_sources, run_harness


class MutantBroken(RuntimeError):
    """A mutant (or the unmutated copy) that does not compile: the mutation list is wrong."""

HALF_EVEN = {"bias_subtract": {"out_format": "s23.21", "rounding": "half_even"},
             "iir": {"data_format": "s23.21", "num_format": "s24.32", "den_format": "s28.26"}}
# SF(T) with steps at the breakpoints: the default calibration is continuous there, so the
# segment rule (a breakpoint belongs to the upper segment) is invisible in the committed vectors
DISCONTINUOUS = {"piecewise": {"sf": {"coefficients": [[0.99, 2.1e-4], [1.0, 2.7e-4], [0.98, 3.3e-4],
                                                       [1.01, 3.9e-4]]}}}
# lag with 2 guard bits and a fast alpha: the rounding of each state step shows in the output
LAG_FEW_GUARD = {"lag": {"tau_s": 0.4, "alpha_bits": 8, "state_guard_bits": 2}}
TOWARD_ZERO = {"bias_subtract": {"out_format": "s23.21", "rounding": "toward_zero"},
               "iir": {"data_format": "s23.21", "num_format": "s24.32", "den_format": "s28.26"}}
# a drive frequency off any simple ratio of fs, with a phase offset: the NCO visits every bin and
# sub-bin offset (at the default f/fs = 1/12 the golden vectors see only 12 phases)
NCO_GENERIC = {"demod": {"f_hz": 7993.1234, "phase_offset_turns": 0.3}}
# the drive DAC one bit short of the gain's range: it saturates whenever the carrier passes half scale
DAC_HALF = {"drive": {"dac_format": "s16.16"}}
# the drive loop's PLL from its first update (no minimum amplitude), and the serial variant
PLL_ALWAYS = {"drive": {"pll_min_amp": 0.0}}
SER = {"ARCH": 1}


@dataclass
class Mutation:
    key: str
    file: str
    old: str
    new: str
    what: str
    checks: tuple  # (design overrides or None, block, gapped[, extra module parameters: a serial variant])


MUTATIONS = [
    Mutation("round_no_half", "fx_round.v", "assign c = half;", "assign c = {W{1'b0}};",
             "half_up: rounding constant dropped (becomes floor)", ((None, "rtd", False),)),
    Mutation("round_even_no_carry", "fx_round.v", "assign c = half - one + {{(W-1){1'b0}}, xe[RSH]};",
             "assign c = half - one;", "half_even: odd-carry dropped (ties go down)",
             ((HALF_EVEN, "bias_subtract", False),)),
    Mutation("round_tz_off_by_one", "fx_round.v", "assign c = xe[W-1] ? ((one <<< RSH) - one) : {W{1'b0}};",
             "assign c = xe[W-1] ? (one <<< RSH) : {W{1'b0}};", "toward_zero: 2**n added instead of 2**n - 1",
             ((TOWARD_ZERO, "bias_subtract", False),)),
    Mutation("fit_sat_to_wrap", "fx_fit.v", "(OVERFLOW == 1 && above) ? hi[OUT_W-1:0]",
             "(OVERFLOW == 9 && above) ? hi[OUT_W-1:0]", "saturate -> wrap on positive overflow",
             ((None, "bias_subtract", False),)),
    Mutation("fit_flag_lost", "fx_fit.v", "assign ovf = above | below;", "assign ovf = above;",
             "negative overflow not flagged", ((None, "bias_subtract", False),)),
    Mutation("rtd_shift_off_by_one", "rtd.v", "wire signed [EW-1:0]    exact = (be <<< S) + prod;",
             "wire signed [EW-1:0]    exact = (be <<< (S - 1)) + prod;", "rtd: LUT base aligned one bit short",
             ((None, "rtd", False),)),
    Mutation("segment_compare_swapped", "piecewise.v", "assign le[b] = $signed(bpv) <= $signed(t_sel);",
             "assign le[b] = $signed(bpv) < $signed(t_sel);", "breakpoint taken by the lower segment",
             ((None, "piecewise_sf", False), (DISCONTINUOUS, "piecewise_sf", False))),
    Mutation("horner_align_off_by_one", "piecewise.v", "wire signed [SW-1:0] sum = (pe <<< AA) + (ce <<< CA);",
             "wire signed [SW-1:0] sum = (pe <<< AA) + (ce <<< (CA + 1));", "coefficient aligned one bit high",
             ((None, "piecewise_bias", False),)),
    Mutation("iir_no_error_feedback", "iir.v", "(den <<< SHIFT_A) + efb;", "(den <<< SHIFT_A);",
             "error feedback dropped", ((None, "iir", False),)),
    Mutation("iir_state_free_running", "iir.v", "end else if (in_valid) begin\n                        x1 <= v;",
             "end else begin\n                        x1 <= v;", "filter state advances without in_valid",
             ((None, "iir", True),)),
    # the serial iir's scheduler (ARCH = 1) and its shared multiplier
    Mutation("iir_serial_wrong_state_slot", "iir.v", "wire rd_w = ph_s ^ (k == K_B2 || k == K_A2 || k == K_C2);",
             "wire rd_w = ph_s ^ (k == K_A2 || k == K_C2);", "serial: b2 multiplies x1 (operand of the wrong slot)",
             ((None, "iir", False, SERIAL["iir"]),)),
    # the serial iir's state in block RAM: the older word of each pair is overwritten, the reset is a mask
    Mutation("iir_serial_state_overwrites_newest", "iir.v", "wire [SL_W+1:0]   xy_wa = {slot, upd, ~ph_s};",
             "wire [SL_W+1:0]   xy_wa = {slot, upd, ph_s};",
             "serial: the update writes x and y over the newest words (x1, y1) instead of the older (x2, y2 lost)",
             ((None, "iir", False, SERIAL["iir"]),)),
    Mutation("iir_serial_reset_state_unmasked", "iir.v", "wire signed [DATA_W-1:0] s_xy = xy_q & {DATA_W{rd_ok_q}};",
             "wire signed [DATA_W-1:0] s_xy = xy_q;",
             "serial: x, y words not written since rst read from the RAM as they are (not the model's zero state)",
             ((None, "iir", False, SERIAL["iir"]),)),
    Mutation("iir_serial_wrong_coefficient_words", "iir.v", "initial $readmemh(ACOEF_FILE, acoef);",
             "initial $readmemh(COEF_FILE, acoef);",
             "serial: the products take the parallel variant's words (not aligned, the a products added instead "
             "of subtracted)",
             ((None, "iir", False, SERIAL["iir"]),)),
    Mutation("iir_serial_stale_sum", "iir.v", "S_LO: st <= S_HI;", "S_LO: st <= S_ROUND;",
             "serial: rounding reads the accumulator's high half before the last product reaches it",
             ((None, "iir", False, SERIAL["iir"]),)),
    Mutation("iir_serial_missed_stall", "iir.v", "assign in_ready = (st == S_IDLE);", "assign in_ready = 1'b1;",
             "serial: in_ready high while a sample is computed (samples taken mid-schedule are lost)",
             (({}, "iir", False, SERIAL["iir"]),)),
    Mutation("mac_lower_limb_signed", "fx_mac_serial.v", "sb   <= (jb == jb_top) & b_l[LIMB-1];",
             "sb   <= b_l[LIMB-1];", "serial MAC: a lower limb of b read as signed",
             ((None, "iir", False, SERIAL["iir"]),)),
    Mutation("mac_column_carry_logical", "fx_mac_serial.v", "carry = acc >>> LIMB;", "carry = acc >> LIMB;",
             "serial MAC: a negative column carry shifted in logically",
             ((None, "iir", False, SERIAL["iir"]),)),
    Mutation("nco_free_running", "nco.v", "else if (step) phase <= phase + FTW_C;", "else phase <= phase + FTW_C;",
             "NCO phase advances without in_valid", ((None, "demod", True),)),
    Mutation("nco_no_interpolation", "nco_wave.v", "assign cos_o  = c_sum[NCO_W-1:0];", "assign cos_o  = cb;",
             "NCO cos without its first-order correction: the old phase-truncating table",
             ((None, "demod", False),)),
    Mutation("nco_quadrant_sign", "nco_wave.v", "wire signed [NCO_W-1:0] mb = quad[1] ? ma : -ma;",
             "wire signed [NCO_W-1:0] mb = quad[1] ? -ma : ma;", "NCO -sin with the quadrant sign inverted",
             ((None, "demod", False),)),
    Mutation("nco_offset_not_centred", "nco_phase.v", "wire [INTERP_BITS:0] odd = {r, 1'b1};",
             "wire [INTERP_BITS:0] odd = {r, 1'b0};", "NCO sub-bin offset truncated instead of centred (a bias)",
             ((None, "demod", False), (NCO_GENERIC, "demod", False))),
    Mutation("nco_correction_floor", "nco_wave.v", ".ROUNDING(ROUNDING), .OUT_W(CW)) u_rm",
             ".ROUNDING(0), .OUT_W(CW)) u_rm", "NCO -sin correction rounded by floor, not the configured rule",
             ((None, "demod", False),)),
    Mutation("cordic_logical_shift", "cordic_vector.v", "tx = cx - (cy >>> j);", "tx = cx - (cy >> j);",
             "CORDIC arithmetic shift -> logical", ((None, "demod", False),)),
    # ---- the drive loop (one sample per clock): its loop filter, phase detector, control and drive ----
    Mutation("drive_pll_rounding_floor", "drive.v", ".ROUNDING(ROUNDING), .PIPE(ARCH)) u_pll",
             ".ROUNDING(0), .PIPE(ARCH)) u_pll",
             "drive: the PLL's loop filter rounds by floor, not the configured rule (a frequency bias)",
             ((None, "drive", False),)),
    Mutation("drive_pi_winds_up", "drive_pi.v", "wire hold = ((o1w > hi_w) && e_pos) || ((o1w < lo_w) && e_neg);",
             "wire hold = 1'b0;", "drive: the PIs integrate while their output is limited (wind-up)",
             ((None, "drive", False),)),
    Mutation("drive_detector_stale_phase", "drive.v", "wire [PHASE_BITS-1:0] ph_in = pend ? ph_upd : ph_next;",
             "wire [PHASE_BITS-1:0] ph_in = ph_next;",
             "drive: the phase detector reads the phase before the last sample's update when samples come back to "
             "back", ((None, "drive", False),)),
    Mutation("drive_detector_q_sign", "mix_lpf.v", "wire signed [MW-1:0] pq_ = $signed(x) * $signed(msin_i);",
             "wire signed [MW-1:0] pq_ = -($signed(x) * $signed(msin_i));",
             "drive: the phase detector's Q mixer inverted (the angle's sign: the PLL pushes away)",
             ((None, "drive001", False),)),
    Mutation("drive_carrier_not_advanced", "drive.v", "wire [PHASE_BITS-1:0] ph_car = ph_q + adv[PHASE_BITS-1:0];",
             "wire [PHASE_BITS-1:0] ph_car = ph_q;", "drive: the DAC carrier read without its advance",
             ((None, "drive", False),)),
    Mutation("drive_update_early", "drive.v", "wire upd = pend && (cnt == LAST);", "wire upd = pend && (cnt == 0);",
             "drive: the control update on the first sample of each group, not the last", ((None, "drive", False),)),
    Mutation("drive_dac_stale_gain", "drive.v", "wire signed [GW-1:0] gw = gain_u[GW-1:0];",
             "wire signed [GW-1:0] gw = {1'b0, gain};", "drive: the DAC reads the gain before this sample's update",
             ((None, "drive", False),)),
    Mutation("drive_hz_floor", "drive.v", ".ROUNDING(ROUNDING), .OUT_W(HR)) u_hz", ".ROUNDING(0), .OUT_W(HR)) u_hz",
             "drive: the frequency word in Hz rounded by floor", ((None, "drive", False),)),
    Mutation("drive_pll_not_held", "drive.v", "wire pll_upd = upd && pll_on;", "wire pll_upd = upd;",
             "drive: the PLL runs below the minimum amplitude (on the noise's angle)", ((None, "drive", False),)),
    Mutation("drive_dac_flag_lost", "drive.v", "ovf <= {s_pll & ovf_f, ovf_dac, s_upd & s_ovf_amp, s_ovf_det};",
             "ovf <= {s_pll & ovf_f, 1'b0, s_upd & s_ovf_amp, s_ovf_det};",
             "drive: the DAC's overflow not flagged", ((DAC_HALF, "drive", False),)),
    # ---- the serial drive loop (ARCH = 1): its products' windows, the carrier's wave pass, the stall;
    # the PLL on from the first update (no minimum amplitude) so that its words move in the window ----
    Mutation("drive_serial_product_routed_wrong", "drive.v", "K_PF:    pf_q <= pf64;", "K_PF:    pf_q <= if64;",
             "serial drive: the PLL's KP_F e register takes the KI_F e port's product (the wrong window)",
             ((PLL_ALWAYS, "drive", False, SER),)),
    Mutation("drive_serial_hz_product_routed_wrong", "drive.v", "K_HZ:    hz_q <= hz64;", "K_HZ:    hz_q <= adv_p;",
             "serial drive: the frequency word in Hz from the carrier advance's product",
             ((PLL_ALWAYS, "drive", False, SER),)),
    Mutation("drive_serial_stale_carrier", "drive.v", "S_WV: if (wave_v) st <= S_DIS;", "S_WV: st <= S_DIS;",
             "serial drive: the DAC product issued before the wave pass returns -sin' (the last sample's)",
             ((None, "drive", False, SER),)),
    Mutation("drive_serial_carrier_at_detector_phase", "drive.v", "(st == S_CAR) ? car_q : ph_next", "ph_next",
             "serial drive: the wave pass reads the detector's phase, not the advanced carrier's",
             ((None, "drive", False, SER),)),
    Mutation("drive_serial_pll_every_sample", "drive.v", "wire pll_upd = upd_q && pll_on;", "wire pll_upd = pll_on;",
             "serial drive: the PLL's state kept at every sample, not only at an update",
             ((PLL_ALWAYS, "drive", False, SER),)),
    Mutation("drive_serial_missed_stall", "drive.v", "assign in_ready = (st == S_IDLE);", "assign in_ready = 1'b1;",
             "serial drive: in_ready high while a sample is computed (samples taken mid-schedule are lost)",
             ((None, "drive", True, SER),)),
    Mutation("demod_wave_pass_runs_on", "demod.v", "st <= wave_q ? S_IDLE : S_PI;", "st <= S_PI;",
             "serial demod: a wave pass goes on into the mixers (its products collide with the caller's)",
             ((None, "drive", False, SER),)),
    Mutation("divider_strict_compare", "sf_divide.v", "qb_v = ~t_v[DW+1];", "qb_v = ~t_v[DW+1] & (t_v[DW:0] != 0);",
             "division step takes r >= d as r > d (an exact step's quotient bit lost)", ((None, "sf_divide", False),)),
    Mutation("divider_always_subtracts", "sf_divide.v", "({2'b00, dmag} ^ {(DW+2){~r_v[DW]}}) + {{(DW+1){1'b0}}, ~r_v[DW]}",
             "({2'b00, dmag} ^ {(DW+2){1'b1}}) + {{(DW+1){1'b0}}, 1'b1}",
             "non-restoring step subtracts |d| after a negative remainder too (no restore at all)",
             ((None, "sf_divide", False),)),
    Mutation("divide_by_zero_sign", "sf_divide.v", "(xneg ? full_neg : full_pos)", "full_pos",
             "x / 0 saturates positive whatever the sign of x", ((None, "sf_divide", False),)),
    Mutation("divide_quotient_sign_dropped", "sf_divide.v", "nq_v = {nq_v[NW-2:0], qb_v ^ neg};",
             "nq_v = {nq_v[NW-2:0], qb_v};", "a negative quotient's bits not inverted as they enter (the "
             "sign applied to a wrong magnitude)", ((None, "sf_divide", False),)),
    Mutation("lag_no_guard_bits", "lag.v", "st     <= st_next;", "st     <= (st_next >>> GUARD) <<< GUARD;",
             "lag: state guard bits dropped (state kept at the code LSB: dead band)", ((None, "lag", False),)),
    Mutation("lag_step_floor", "lag.v", ".SHIFT(ALPHA_S), .ROUNDING(ROUNDING)", ".SHIFT(ALPHA_S), .ROUNDING(0)",
             "lag: state update not rounded (floor)", ((None, "lag", False), (LAG_FEW_GUARD, "lag", False))),
    Mutation("lag_state_free_running", "lag.v", "end else if (in_valid) begin\n            if (update) begin",
             "end else begin\n            if (phase == {PH_W{1'b0}}) begin", "lag state advances without in_valid",
             ((None, "lag", True),)),
    Mutation("chain001_misaligned", "chain_paper001.v", ".x(in_rate_in_q),", ".x(rate_in),",
             "generated chain 001: rate_in read live at the subtraction, not the sample's registered value (the "
             "next sample's rate by then)", ((None, "chain_paper001", False),)),
    # ---- serial lag (ARCH = 1) ----
    Mutation("lag_serial_carry_wrong_slot", "lag.v", "{sv_hi, 1'b1} + {step_hi, sc_q};",
             "{sv_hi, 1'b1} + {step_hi, s_lo_co};",
             "serial: the state's high half adds the carry of the already updated low half (wrong cycle's carry)",
             ((None, "lag", False, SERIAL["lag"]),)),
    Mutation("lag_serial_stale_step", "lag.v", "if (mac_valid) step_q <= step_c;", "if (issue) step_q <= step_c;",
             "serial: the state step registered when d is issued (the previous sample's product)",
             ((None, "lag", False, SERIAL["lag"]),)),
    Mutation("lag_serial_stale_state", "lag.v", "fsm <= S_RND;", "fsm <= S_FIT;",
             "serial: te rounded from the state before its high half is updated (S_RND skipped)",
             ((None, "lag", False, SERIAL["lag"]), (LAG_FEW_GUARD, "lag", False, SERIAL["lag"]))),
    Mutation("lag_serial_missed_stall", "lag.v", "assign in_ready = (fsm == S_IDLE);", "assign in_ready = 1'b1;",
             "serial: in_ready high while a sample is computed (samples taken mid-schedule are lost)",
             (({}, "lag", False, SERIAL["lag"]),)),
    Mutation("lag_serial_decim_ignored", "lag.v", "ph <= (ph == PH_LAST) ? {PH_W{1'b0}} : ph + 1'b1;",
             "ph <= {PH_W{1'b0}};", "serial: the phase never advances (every sample updates: DECIM ignored)",
             (({**lag_chain(), "lag": {"rate_hz": 96000.0 / 5, "tau_s": 0.005}}, "lag", False,
               SERIAL["lag"]),)),
    # ---- serial rtd (ARCH = 1) ----
    Mutation("rtd_serial_wrong_slot", "rtd.v", "a1_q   <= idx1;", "a1_q   <= {1'b0, idx};",
             "serial rtd: the second ROM read fetches L[i] where L[i+1] is needed",
             ((None, "rtd", False, SERIAL["rtd"]),)),
    Mutation("rtd_serial_stale_diff", "rtd.v", "if (st == S_DIFF) diff_q <= d_c;", "if (st == S_RD1) diff_q <= d_c;",
             "serial rtd: diff registered one cycle early (q still L[i], base the previous sample's)",
             ((None, "rtd", False, SERIAL["rtd"]),)),
    Mutation("rtd_serial_early_product", "rtd.v", "S_WAIT: if (mac_valid) begin", "S_WAIT: if (mac_ready) begin",
             "serial rtd: the sum reads the MAC's product before it is valid (the previous sample's)",
             ((None, "rtd", False, SERIAL["rtd"]),)),
    Mutation("rtd_serial_missed_stall", "rtd.v", "assign in_ready  = (st == S_IDLE);", "assign in_ready  = 1'b1;",
             "serial rtd: in_ready high while a sample is computed (samples taken mid-schedule are lost)",
             (({}, "rtd", False, SERIAL["rtd"]),)),
    # ---- serial piecewise, freq2temp, chain_paper001 (ARCH = 1) ----
    Mutation("pw_serial_wrong_slot", "piecewise.v", "+ seg_a * NC_A + ORDER_A;", "+ seg_a * NC_A;",
             "serial: the top coefficient read from the segment's c0 slot, every lower power one slot below "
             "its own (the previous segment's words)",
             ((None, "piecewise_k0", False, SERIAL["piecewise_k0"]),)),
    Mutation("pw_serial_stale_coefficient", "piecewise.v", "k <= K_TOP; ra <= ra - 1'b1;", "k <= K_TOP; ra <= ra;",
             "serial: the first Horner step adds the top coefficient again (ROM address not advanced)",
             ((None, "piecewise_sf", False, SERIAL["piecewise_sf"]),)),
    Mutation("pw_serial_stale_product", "piecewise.v", "S_WAIT:  if (mac_valid) st <= S_PREG;", "S_WAIT:  st <= S_PREG;",
             "serial: the product read before the MAC returns it (the previous one)",
             ((None, "piecewise_sf", False, SERIAL["piecewise_sf"]),)),
    Mutation("pw_serial_missed_stall", "piecewise.v", "assign in_ready = (st == S_IDLE) && !pend;",
             "assign in_ready = 1'b1;",
             "serial: in_ready high while a sample is computed (samples taken mid-schedule are lost)",
             (({}, "piecewise_sf", False, SERIAL["piecewise_sf"]),)),
    Mutation("f2t_serial_missed_stall", "freq2temp.v", "assign in_ready = ~busy | out_valid;", "assign in_ready = 1'b1;",
             "serial: in_ready high while the product is computed (d overwritten mid-product)",
             (({}, "freq2temp", False, SERIAL["freq2temp"]),)),
    Mutation("chain001_serial_stale_bias", "chain_paper001.v",
             "wire want_bias_subtract001 = busy & ~started_bias_subtract001 & done_piecewise_bias001;",
             "wire want_bias_subtract001 = busy & ~started_bias_subtract001;",
             "generated chain 001: the subtraction starts without waiting for bias(T) (the previous sample's)",
             ((None, "chain_paper001", False, SERIAL["chain_paper001"]),)),
    Mutation("chain001_serial_missed_stall", "chain_paper001.v", "assign in_ready = ~busy;",
             "assign in_ready = 1'b1;", "generated chain 001: in_ready high while a sample is in flight",
             (({}, "chain_paper001", False, SERIAL["chain_paper001"]),)),
    # ---- sf_divide with its output path pipelined (ARCH = 1) ----
    Mutation("divide_serial_no_carry_in", "sf_divide.v", ".x(q_r), .cin(neg_r)", ".x(q_r), .cin(1'b0)",
             "pipelined divider: the rounding adder's carry in dropped (a negative quotient rounded as ~q, "
             "one LSB below -q)",
             ((None, "sf_divide", False, SERIAL["sf_divide"]),)),
    Mutation("divide_serial_missed_stall", "sf_divide.v", "assign in_ready = ~busy & ~fin;",
             "assign in_ready = ~busy;",
             "pipelined divider: a sample accepted while the output path still holds the previous quotient",
             ((None, "sf_divide", False, SERIAL["sf_divide"]),)),
    # ---- serial demod (ARCH = 1) and its two-channel iir engine ----
    Mutation("demod_serial_wrong_slot", "demod.v", "wire [QBITS-1:0] addr = (st == S_IDLE) ? k_first : ~k_q;",
             "wire [QBITS-1:0] addr = (st == S_IDLE) ? k_first : k_q;",
             "serial demod: the second NCO table read fetches the first word again (qsin[k] where qsin[~k] is "
             "needed, or the reverse)",
             ((None, "demod", False, SERIAL["demod"]),)),
    Mutation("demod_serial_stale_mix", "demod.v", "wire mix_in = mac_valid && ((rk == R_I) || (rk == R_Q));",
             "wire mix_in = mac_ready && ((rk == R_I) || (rk == R_Q));",
             "serial demod: the mixers take the MAC's product before its out_valid (a stale product)",
             ((None, "demod", False, SERIAL["demod"]),)),
    Mutation("demod_serial_stale_d", "demod.v", "S_WD:   if (mac_valid) st <= S_PC;", "S_WD:   st <= S_PC;",
             "serial demod: the NCO corrections issued before d = delta * TWO_PI returns (delta used as d)",
             ((None, "demod", False, SERIAL["demod"]),)),
    Mutation("demod_serial_missed_stall", "demod.v", "assign in_ready = idle;", "assign in_ready = 1'b1;",
             "serial demod: in_ready high while a sample is computed (samples taken mid-schedule are lost)",
             (({}, "demod", False, SERIAL["demod"]),)),
    Mutation("demod_serial_lpf_wrong_channel_slot", "iir.v",
             "else if (st == S_UPD) slot_q <= slot_q + {{(SL_W-1){1'b0}}, 1'b1};",
             "else if (st == S_UPD) slot_q <= slot_q;",
             "two-channel iir: the Q channel reads and updates the I channel's state slot",
             ((None, "demod", False, SERIAL["demod"]),)),
    Mutation("demod_serial_cordic_short", "demod.v", "localparam integer J_LAST_I = ITERATIONS - 1;",
             "localparam integer J_LAST_I = ITERATIONS - 2;", "serial demod: one CORDIC iteration too few",
             ((None, "demod", False, SERIAL["demod"]),)),
    Mutation("demod_serial_prerotate_always", "demod.v", "wire step_en = ~pre | cx[XW-1];", "wire step_en = ~pre;",
             "serial demod: the +-90 deg pre-rotation applied in the right half plane too",
             ((None, "demod", False, SERIAL["demod"]),)),
    Mutation("demod_serial_phase_carry_lost", "demod.v", "{ph_hi, 1'b1} + {FTW_HI, ph_c};",
             "{ph_hi, 1'b1} + {FTW_HI, 1'b0};", "serial demod: the phase accumulator's low-half carry dropped",
             ((None, "demod", False, SERIAL["demod"]),)),
    Mutation("demod_serial_phase_free_running", "demod.v", "if (take) {ph_c, ph_lo} <= ph_lo_n;",
             "if (st == S_IDLE) {ph_c, ph_lo} <= ph_lo_n;",
             "serial demod: the phase advances on every idle cycle, not once per accepted sample",
             ((None, "demod", True, SERIAL["demod"]),)),
    # ---- the generated chain_paper002 top (fxdsp.hdl.chain_top; mutated as written, hdl_util.mutated_top):
    # its scheduler, ARCH = 1 (checks at DIV_UNROLL 7, on a prefix) ----
    Mutation("chain002_serial_missed_stall", "chain_paper002.v", "assign in_ready = ~busy;",
             "assign in_ready = 1'b1;", "generated chain 002: in_ready high while a sample is in flight",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("chain002_serial_live_vsa", "chain_paper002.v", ".x(in_vsa_q),", ".x(vsa),",
             "generated chain 002: the divider reads the vsa port live, not the sample's registered vsa (the next "
             "sample's, by the time the divider starts)",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("chain002_serial_stale_sf", "chain_paper002.v",
             "wire want_sf_divide = busy & ~started_sf_divide & done_piecewise_sf & ",
             "wire want_sf_divide = busy & ~started_sf_divide & ",
             "generated chain 002: the divider starts without waiting for SF(T) (the previous sample's SF)",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("chain002_serial_demod_ignores_the_multiplier", "chain_paper002.v",
             "wire go_demod = want_demod & ((ARCH == 0) | (~mac_busy & ",
             "wire go_demod = want_demod & ((ARCH == 0) | (1'b1 & ",
             "generated chain 002: the demodulator starts on the quotient while the bias pass still multiplies "
             "(missed stall: at DIV_UNROLL 48 the divider's 7 cycles end before the bias pass does; at DIV_UNROLL 7 "
             "its 13 cycles outlast it, an equivalent mutant there)",
             ((None, "chain_paper002", False, {**SERIAL["chain_paper002"], "DIV_UNROLL": 48}),)),
    Mutation("chain002_guest_pass_not_on_the_multiplier", "chain_paper002.v",
             "wire go_piecewise_bias = (SHARE != 0) ? go_piecewise_sf :",
             "wire go_piecewise_bias = (SHARE != 0) ? 1'b0 :",
             "generated chain 002: the shared engine's bias pass not counted as the multiplier busy (the "
             "demodulator may start during it, at DIV_UNROLL 48)",
             ((None, "chain_paper002", False, {**SERIAL["chain_paper002"], "DIV_UNROLL": 48}),)),
    Mutation("chain002_capture_on_start", "chain_paper002.v", "always @(posedge clk) if (bias_subtract_out_valid) begin",
             "always @(posedge clk) if (go_bias_subtract) begin",
             "generated chain 002: the subtraction's result captured as it starts, not on its out_valid (stale)",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    # ---- the generated chain_paper002_loop top: the sense demodulator on the drive loop's nco, read ahead ----
    Mutation("drive_next_nco_is_the_last_samples", "drive.v", "assign nco_next = ph_next;", "assign nco_next = ph_q;",
             "drive: nco_next gives the last sample's phase, not the next one's (the sense demodulator in paper "
             "002's whole design a sample behind the loop)",
             ((None, "chain_paper002_loop", False, SERIAL["chain_paper002_loop"]),)),
    Mutation("chain002_loop_reference_not_held", "chain_paper002_loop.v",
             "always @(posedge clk) if (accept) drive_nco_ahead_q <= drive_nco_next;",
             "always @(posedge clk) drive_nco_ahead_q <= drive_nco_next;",
             "generated chain 002 loop: the reference read ahead is not held from the accepting edge (the "
             "demodulator, starting after the loop's pass in ARCH = 0, reads the next sample's phase)",
             ((None, "chain_paper002_loop", False),)),
    # ---- one multiplier shared by the serial blocks: demod ARCH = 1 with its filters, chain 002 ARCH = 1 ----
    Mutation("chain002_mac_guest_products_lost", "chain_paper002.v",
             "on_mac_piecewise_sf | ((SHARE != 0) & on_mac_piecewise_bias)", "on_mac_piecewise_sf",
             "generated chain 002: the shared multiplier's products of the guest's pass (bias(T) on SF's engine) "
             "not routed to the engine (its owner is the host alone): the pass waits for a product that never comes",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("chain002_mac_hold_not_released", "chain_paper002.v",
             "wire on_mac_piecewise_sf = started_piecewise_sf & ~done_piecewise_sf;",
             "wire on_mac_piecewise_sf = started_piecewise_sf;",
             "generated chain 002: a member's hold on the shared multiplier not released when its result is "
             "captured (every later member waits for it: the chain stalls)",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("chain002_mac_wrong_operand_select", "chain_paper002.v", "({MAC_A_W{demod_mac_req}} & demod_mac_a)",
             "({MAC_A_W{rtd_mac_req}} & demod_mac_a)",
             "generated chain 002: the demodulator's operand a selected by another member's request (rtd's "
             "products take both operands, the demodulator's none)",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    # ---- one filter engine: the output low-pass as the demodulator's engine's third channel ----
    Mutation("chain002_lpf_stale_input", "chain_paper002.v",
             "wire want_iir = busy & ~started_iir & done_bias_subtract & ",
             "wire want_iir = busy & ~started_iir & ",
             "generated chain 002: the output low-pass (the demodulator's third filter channel) starts without "
             "waiting for the subtraction (the previous sample's difference: stale operand)",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("chain002_lpf_wrong_set", "demod.v", ".COEF_SETS((AUX_LPF != 0) ? LCH : 1)", ".COEF_SETS(1)",
             "serial chain 002: the output low-pass (the filter engine's third channel) filters with the "
             "demodulator's low-pass coefficients, not its own set (wrong slot)",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("chain002_lpf_wrong_channel_input", "iir.v",
             "assign x_pass = pb ? x[CH_LAST_I*DATA_W +: DATA_W] : x_first;", "assign x_pass = x_first;",
             "split iir engine: the last channel's pass filters channel 0's input (the demodulator's I mixer) "
             "instead of its own",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    # ---- one coefficient engine: SF(T) and bias(T) as two sets of one piecewise (fxdsp.hdl.sharing) ----
    # (the bias set's own alignment is in its ROM words now, the generator's: a wrong alignment is
    # the wrong set's words, chain002_pw_wrong_set)
    # (in_ready high between the two passes is an equivalent mutant in the chain: the demodulator, the
    # only one that waits for it, starts on the divider's out_valid, at least 7 cycles later)
    Mutation("chain002_pw_wrong_set", "piecewise.v",
             "ra <= (set_q ? SET1_A : {RA_W{1'b0}}) + seg_a * NC_A + ORDER_A;",
             "ra <= {RA_W{1'b0}} + seg_a * NC_A + ORDER_A;",
             "serial chain 002: the shared coefficient engine's bias pass reads SF's coefficients (wrong slot)",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("chain002_pw_set1_output_shift", "piecewise.v", ".SHIFT(OUT_SHIFT_1), .ROUNDING(ROUNDING), .OUT_W(ORW1)",
             ".SHIFT(OUT_SHIFT), .ROUNDING(ROUNDING), .OUT_W(ORW1)",
             "serial chain 002: the bias pass rounds its output by SF's OUT_SHIFT",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("chain002_pw_second_pass_lost", "piecewise.v", "pend <= (S1 != 0);", "pend <= 1'b0;",
             "serial chain 002: the shared coefficient engine never starts the bias pass (the chain waits for "
             "a bias that never comes)",
             ((None, "chain_paper002", False, SERIAL["chain_paper002"]),)),
    Mutation("demod_mac_valid_to_filter", "demod.v", ".mac_out_valid(sh_valid & lpf_own)",
             ".mac_out_valid(sh_valid)",
             "serial demod: the demodulator's products also counted as its low-pass filters' (out_valid not "
             "routed by the owner of the shared multiplier)",
             ((None, "demod", False, SERIAL["demod"]),)),
    Mutation("mac_var_top_limb", "fx_mac_serial.v", "if (v_q[2] && l_q[2]) hi <= acc_n_l1;",
             "if (v_q[2] && l_q[2]) hi <= acc_n_l0;",
             "shared MAC (VAR_N = 1): the top column's low half stored again as its high half (the top limb "
             "of every top-aligned product wrong)",
             ((None, "demod", False, SERIAL["demod"]),)),
    Mutation("mac_var_column_not_shifted", "fx_mac_serial.v", "wire               colend = v_q[2] & (l_q[2] | n_q[1]);",
             "wire               colend = v_q[2] & l_q[2];",
             "shared MAC (VAR_N = 1): only the last column's low half shifts into the result (the lower columns "
             "of every product lost: stale limbs)",
             ((None, "demod", False, SERIAL["demod"]),)),
]


# the one-sample-per-clock demodulator and drive loop simulate ~1-1.7k cycles/s on Icarus (their
# CORDIC and wide low-passes): their mutants run on a window of the golden set. The demodulator's
# (NCO, CORDIC: thousands of wrong words in its 5.3k golden samples) on 1200; the drive loop's on
# 3000, whose second half (the locked pick-off) outlasts the PLL's recovery from the corners at its
# lock-range limit (at 1200 the loop filter's rounding never reached the output); the other
# per-clock modules on their whole golden sets
PER_CLOCK_WINDOW = {"demod": 1200, "drive": 3000}
# serial variants are checked on the window of their stream that Icarus runs everywhere in the suite
# (fxdsp.hdl.stimuli.icarus_samples: at most 200 samples and 20k cycles, from the first change of
# input, then the stream's end); the whole golden streams would take ~0.6-2.7 M cycles per mutant
# a mutant that wrecks the output does so within a few hundred samples: every check first streams a
# window of FIRST_WINDOW samples (corners and the stream's end, icarus_window) and runs its whole
# stream only when that window passes (the unmutated RTL and the subtle mutants: a rounding rule the
# loop filter shows only after lock, a breakpoint rule, a sub-bin offset)
FIRST_WINDOW = 600


_designs: dict[str, object] = {}


def _design(overrides):
    """The design of ``overrides``, built once per process: most of the ~80 checks share a handful of
    override sets (None above all), and each build was ~0.1 s. Nothing here changes a design (a
    mutant is in its RTL copy, a generated top's by mutated_top at generation)."""
    key = repr(overrides)
    if key not in _designs:
        _designs[key] = design_of(overrides)
    return _designs[key]


def _check(rtl: Path, overrides, name: str, gapped: bool, tag: str, extra: dict | None = None) -> tuple[bool, str]:
    d = _design(overrides)
    golden = overrides is None and (VECTORS / name).is_dir()
    if golden:
        ins, outs, entry = load(VECTORS, name)
        total = sum(entry["overflows"].values())
    else:
        ins = d.all[name].stimulus(np.random.default_rng(9), 3000)
        outs = total = None
    # a serial mutant is caught within the first tens of samples of the window (every one of them, by
    # the survivor check below): half the regression's window, at least its minimum
    window = (max(ICARUS_MIN_SAMPLES, icarus_samples(d, name) // 2) if extra
              else PER_CLOCK_WINDOW.get(d.instances[name].module))
    if window:  # a serial variant, or a slow one-sample-per-clock module: a window of the stream
        ins, outs = icarus_window(ins, window), None
    size = len(next(iter(ins.values())))
    if size > FIRST_WINDOW:
        caught, why = _stream(rtl, d, name, icarus_window(ins, FIRST_WINDOW), None, None, gapped, tag, extra)
        if caught:
            return caught, why
    return _stream(rtl, d, name, ins, outs, total, gapped, tag, extra)


def _stream(rtl: Path, d, name: str, ins: dict, outs, total, gapped: bool, tag: str, extra) -> tuple[bool, str]:
    """Stream ``ins`` through the mutant's harness; ``outs``/``total`` None: the model on ``ins``."""
    if outs is None:
        outs, total = model_run(d, name, ins)
    unroll = 7 if name in ("sf_divide", "chain_paper002") else None
    try:
        got, ovf, _, _ = run_harness(d, name, ins, tag, unroll=unroll, gap=gapped, rtl=rtl, extra=extra)
    except HarnessTimeout:  # fewer outputs than samples (e.g. samples lost to a missed stall)
        return True, "harness stopped at its cycle limit: fewer outputs than samples"
    except BuildFailed as exc:  # the harness did not compile: broken, not caught
        raise MutantBroken(f"{tag}: the {name} harness does not compile on {rtl.name}:\n{str(exc)[-2000:]}") from exc
    except UndefinedWord as exc:  # an output word with x/z bits (any other error is the harness's own)
        return True, f"undefined output word ({exc})"
    bad = {p: int(np.count_nonzero(got[p] != outs[p])) for p in outs}
    if any(bad.values()):
        p = max(bad, key=bad.get)
        return True, f"{bad[p]} wrong {name}.{p} words of {len(got[p])}"
    if ovf != total:
        return True, f"{ovf if ovf >= 0 else 'x'} overflow flags, model {total}"
    return False, "all outputs and flags match"


def precompile(rtl: Path, key: str, headers: Path) -> None:
    """Compile every source of ``rtl`` (all root modules at their defaults, with the generated headers
    in ``headers``: the default design's) in its own build directory; raise MutantBroken with the
    compiler's words if it fails."""
    d = build_dir(f"mut_{key}_compile")
    cmd = ["iverilog", "-g2005", "-I", str(headers), "-o", str(d / "mutant.vvp"), *map(str, rtl_sources(rtl))]
    proc = subprocess.run(cmd, cwd=d, capture_output=True, text=True)
    if proc.returncode != 0:
        raise MutantBroken(f"{key}: does not compile (exit status {proc.returncode}):\n"
                           f"{(proc.stdout + proc.stderr).strip()[-2000:]}")


# the mutants of the serial variants' schedulers (a check with module parameters) and the others:
# two halves that two test files (two pytest-xdist workers) run side by side
SERIAL_MUTATIONS = [m for m in MUTATIONS if any(len(c) > 3 for c in m.checks)]
PER_CLOCK_MUTATIONS = [m for m in MUTATIONS if m not in SERIAL_MUTATIONS]


def _generated(m: Mutation) -> bool:
    """A mutation of a generated chain top (no such file among the hand-written RTL)."""
    return not (RTL / m.file).exists()


def run(mutations=MUTATIONS, baseline: bool = True, tag: str = "mut") -> list[dict]:
    """Check the unmutated RTL (if ``baseline``) and every mutant; ``tag`` names the shared headers'
    build directory (distinct per concurrent caller)."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="fxdsp_mut_") as tmp:
        todo = []
        for m in ([None] if baseline else []) + list(mutations):
            rtl = Path(tmp) / (m.key if m else "baseline")
            if m is None or _generated(m):
                shutil.copytree(RTL, rtl)   # a generated top's mutant is applied as it is written (below)
            else:
                mutated_rtl(rtl, m.file, [(m.old, m.new)])
            todo.append((m, rtl))
        # every mutant must compile before any check may count it as caught
        broken = []
        headers = build_dir(f"{tag}_headers")
        generate_into(_design(None), headers)
        for m, rtl in todo:
            try:
                precompile(rtl, m.key if m else "baseline", headers)
            except MutantBroken as exc:
                broken.append(str(exc))
        if broken:
            raise MutantBroken(f"{len(broken)} mutant(s) do not compile:\n" + "\n".join(broken))
        for m, rtl in todo:
            checks = m.checks if m else ((None, "rtd", False), (None, "bias_subtract", False))
            t0 = time.perf_counter()
            caught, why = False, ""
            edit = mutated_top(Path(m.file).stem, [(m.old, m.new)]) if m and _generated(m) else contextlib.nullcontext()
            with edit:
                for overrides, name, gapped, *extra in checks:
                    caught, why = _check(rtl, overrides, name, gapped, f"mut_{m.key if m else 'baseline'}_{name}",
                                         *extra)
                    if caught:
                        break
            rows.append({"mutation": m.key if m else "(none: baseline)", "file": m.file if m else "-",
                         "what": m.what if m else "unmutated RTL must pass", "caught": caught, "evidence": why,
                         "seconds": round(time.perf_counter() - t0, 1)})
    return rows


def table(rows) -> str:
    lines = ["| mutation | file | what | caught | evidence |", "|---|---|---|---|---|"]
    for r in rows:
        verdict = "n/a" if r["file"] == "-" else ("yes" if r["caught"] else "**NO**")
        lines.append(f"| {r['mutation']} | {r['file']} | {r['what']} | {verdict} | {r['evidence']} |")
    return "\n".join(lines)
