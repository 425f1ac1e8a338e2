"""Paper 003 reproduced: coupling identification from a swept sine, through the fixed-point demodulator.

At each sweep frequency f the drive pick-off x(t) = A cos(w t + p_x(t)) and the sense pick-off
y(t) = g A |S(w)| cos(w t + arg S(w) + p_y(t)) are synthesised at 96 kHz (S from
:class:`fxdsp.sim.gyro.TwoModeGyro`, i.e. the gyro of paper 003 with m = 1 ug), with white phase noise
p_x, p_y (``PHASE_NOISE_RAD`` per sample) and white additive noise, quantised to the sense ADC format
(s16.15, half scale), widened exactly to the demodulator's input word and demodulated by
``fxdsp.blocks.demod.Demod`` (config's NCO, mixer, 2nd-order 200 Hz low-pass, all bit-exact) with
its NCO retuned to f. The steady state is synthesised directly (the mechanical
transient of Q = 20000 at 8 kHz, 0.8 s, is assumed waited out, as a sweep does).

The measured ratio is read as one snapshot of I and Q at the end of the dwell
(``DWELL_S``), either after the low-pass filters (what the FPGA's filtered registers hold) or
straight from the mixers (no filtering: the snapshot carries the 2w mixing product and the full
phase noise). The sense gain g (chosen so the largest |S| uses half the ADC range) is divided out
(the paper's conversion-gain ratio). This project's variant ("averaged") also averages the
filtered I and Q over the second half of the dwell (a boxcar after the IIR, ``DWELL_S / 2``).
Then :func:`fxdsp.sim.gyro.fit_coupling` solves
S Dy = -alpha - j w eta + lambda_yx Dx by least squares with the known modal parameters.

Channel mismatch and the paper's correction (its section 3.2): :func:`measure` can give the sense
channel a phase offset (and a conversion-gain error) against the drive channel, uncorrected;
:func:`channel_correction` measures both on the simulated device the paper's way - each mode forced
alone at its own resonance, where it lags its force by exactly 90 deg, so a channel's phase offset
is its measured resonance phase + 90 deg, and the resonance amplitudes with the modal Q/w^2 give the
channels' conversion-gain ratio - and :func:`correct` rotates and rescales the measured S with them.
:func:`mismatch_case` runs the sweep with a mismatch and identifies it uncorrected and corrected.
"""

from __future__ import annotations

import numpy as np
from tqdm import tqdm

from fxdsp.blocks.demod import Demod, Nco
from fxdsp.chains import build
from fxdsp.fixed import OverflowLog, Rules, quantize, resize, to_float
from fxdsp.sim.gyro import PAPER002_GYRO, T0_C, fit_coupling
from fxdsp.errors import InputError

PAPER = {"lambda_yx": -0.000374, "cxy": -6.96e-8, "kxy": 0.103, "err_cxy": 0.0609,
         "err_lambda_yx": 0.542e-6, "err_kxy": 0.205e-6,
         "err_raw_cxy": 10.0, "err_filtered_cxy": 0.09, "r2": 0.99}
PHASE_NOISE_RAD = 0.01
ADDITIVE_NOISE_FS = 1e-3
DWELL_S = 0.05
SPAN_HZ = (8000.0, 8040.0)
SENSE_EXCITATION_RATIO = 0.25  # sense-mode test excitation word / drive-mode one (a power of two)
# channel mismatch of the correction demonstration: 0.5 deg of sense-channel phase (then also a 2 %
# sense-gain error: component tolerances of a C/V stage)
MISMATCH_PHASE_RAD = float(np.deg2rad(0.5))
MISMATCH_GAIN = 0.02


def _setup():
    design = build(None)
    base = design.blocks["demod"]
    fmt = base.in_format  # the demodulator's input word (s24.22, +-2)
    adc = design.blocks["sf_divide"].in_format  # the sense ADC (s16.15, +-1)
    if fmt.fl < adc.fl:
        raise InputError(f"demod.in_format: {fmt} has fewer fraction bits than the ADC {adc}")
    return design.fs_hz, base, fmt, adc


def _demodulator(fs, base, f_hz):
    nco = Nco(fs, float(f_hz), base.nco.phase_bits, base.nco.lut_bits, base.nco.lut_format,
              interp_bits=base.nco.interp_bits, rules=base.nco.rules)
    return nco, Demod(nco, base.in_format, base.data_format, base.lpf_i, base.lpf_q, base.angle_format,
                      base.iterations, base.rules)


def _channel(nco, dem, fmt, adc, log, n, a, phi, rng, phase_noise_rad, noise_fs):
    """One pick-off a cos(w t + phi) with phase and additive noise through the ADC and the
    bit-exact demodulator: (filtered snapshot, raw mixer snapshot, filtered mean over the second half)
    as complex amplitudes I + jQ = a e^{j phi}."""
    sat = Rules("half_up", "saturate")
    ph = nco.reference_phase(n)
    sig = a * np.cos(ph + phi + phase_noise_rad * rng.standard_normal(n)) + noise_fs * rng.standard_normal(n)
    dem.reset()
    codes = resize(quantize(sig, adc, sat, log, "adc"), adc, fmt, sat, log, "adc")  # exact widening
    mi, mq = dem.mix(log, codes)
    li = dem.lpf_i.stream(log, x=mi)["y"]
    lq = dem.lpf_q.stream(log, x=mq)["y"]
    df = dem.data_format
    half = slice(n // 2, n)
    return (complex(to_float(li[-1:], df)[0], to_float(lq[-1:], df)[0]),
            complex(to_float(mi[-1:], df)[0], to_float(mq[-1:], df)[0]),
            complex(to_float(li[half], df).mean(), to_float(lq[half], df).mean()))


def sense_gain(truth) -> float:
    """The sense channel's nominal conversion gain: the largest |S| of the sweep -> half scale."""
    return 1.0 / float(np.abs(np.asarray(truth, complex)).max())


def measure(freqs_hz, gyro=PAPER002_GYRO, seed: int = 1, phase_noise_rad: float = PHASE_NOISE_RAD,
            noise_fs: float = ADDITIVE_NOISE_FS, dwell_s: float = DWELL_S, phase_offset_rad: float = 0.0,
            progress: bool = False, drive_phase_offset_rad: float = 0.0, sense_gain_error: float = 0.0) -> dict:
    """S(w) measured at each frequency, with and without the demodulator's low-pass filters.

    Channel mismatch, uncorrected here (see :func:`channel_correction`): ``phase_offset_rad`` and
    ``drive_phase_offset_rad`` are the phase shifts of the sense and drive pick-off channels;
    ``sense_gain_error`` makes the sense channel's conversion gain (1 + e) times its nominal value,
    which is the one divided out."""
    freqs = np.asarray(freqs_hz, float)
    if freqs.ndim != 1 or freqs.size < 3:
        raise InputError("freqs_hz: need at least three sweep frequencies")
    if not dwell_s > 0:
        raise InputError(f"dwell_s: must be > 0, got {dwell_s!r}")
    if not sense_gain_error > -1:
        raise InputError(f"sense_gain_error: must be > -1, got {sense_gain_error!r}")
    fs, base, fmt, adc = _setup()
    n = int(round(dwell_s * fs))
    rng = np.random.default_rng(seed)
    truth = gyro.sweep(freqs)
    amp = 0.5 * adc.max_value
    gain = sense_gain(truth)  # sense channel conversion gain: largest |S| -> half scale
    filtered, raw, averaged = [], [], []
    log = OverflowLog()
    for f, s in tqdm(list(zip(freqs, truth)), disable=not progress, desc="sweep", leave=False):
        nco, dem = _demodulator(fs, base, f)
        chans = {}
        for name, a, phi in (("x", amp, drive_phase_offset_rad),
                             ("y", amp * gain * (1.0 + sense_gain_error) * abs(s), np.angle(s) + phase_offset_rad)):
            chans[name] = _channel(nco, dem, fmt, adc, log, n, a, phi, rng, phase_noise_rad, noise_fs)
        filtered.append(chans["y"][0] / chans["x"][0] / gain)
        raw.append(chans["y"][1] / chans["x"][1] / gain)
        averaged.append(chans["y"][2] / chans["x"][2] / gain)
    return {"freqs_hz": freqs, "truth": truth, "filtered": np.array(filtered), "raw": np.array(raw),
            "averaged": np.array(averaged), "gain": gain,
            "overflows": log.total}


def channel_correction(gain: float, gyro=PAPER002_GYRO, seed: int = 2, phase_noise_rad: float = PHASE_NOISE_RAD,
                       noise_fs: float = ADDITIVE_NOISE_FS, dwell_s: float = DWELL_S, phase_offset_rad: float = 0.0,
                       drive_phase_offset_rad: float = 0.0, sense_gain_error: float = 0.0,
                       excitation_ratio: float = SENSE_EXCITATION_RATIO) -> dict:
    """Paper 003's amplitude and phase correction (its section 3.2), measured on the simulated device.

    Two modal tests through the same channels and bit-exact demodulator as the sweep (same channel
    mismatch arguments as :func:`measure`): the drive mode forced alone at its resonance wx, then the
    sense mode forced alone at its resonance wy with ``excitation_ratio`` times the drive's excitation
    word (the paper uses equal words; here the sense channel's gain would then saturate the ADC).
    The phases are read against the force, i.e. the NCO that generates it:

    * phase: a resonator at resonance lags its force by exactly 90 deg, so each channel's phase
      offset is its measured resonance phase + 90 deg (the paper: the compensation is the difference
      between the theoretical -90 deg and the measured resonance phase);
    * amplitude: with the modal parameters (wk, Qk, as :func:`identify` uses them), a mode's
      displacement per unit force at resonance is Qk / wk^2, so the channels' conversion-gain ratio
      is k_SF = (|Y| / (r Qy / wy^2)) / (|X| / (Qx / wx^2)).

    Returns ``phase_x_rad``, ``phase_y_rad`` (the estimated channel phase offsets), ``k_sf`` and
    ``gain_ratio`` = k_SF / ``gain`` (the nominal sense gain that :func:`measure` divides out);
    :func:`correct` applies them."""
    if not gain > 0:
        raise InputError(f"gain: must be > 0, got {gain!r}")
    if not excitation_ratio > 0:
        raise InputError(f"excitation_ratio: must be > 0, got {excitation_ratio!r}")
    fs, base, fmt, adc = _setup()
    n = int(round(dwell_s * fs))
    rng = np.random.default_rng(seed)
    log = OverflowLog()
    wx, wy = (float(w) for w in gyro.omega(25.0))
    qx, qy = (float(q) for q in gyro.quality(25.0))
    amp = 0.5 * adc.max_value
    force = amp / abs(1.0 / gyro.dynamic(wx, wx, qx))  # drive excitation: |x| at resonance = half scale
    sense_true = gain * (1.0 + sense_gain_error)
    tests = {}
    for name, w, q, g, exc, offset in (("x", wx, qx, 1.0, force, drive_phase_offset_rad),
                                       ("y", wy, qy, sense_true, force * excitation_ratio, phase_offset_rad)):
        resp = exc / gyro.dynamic(w, w, q)  # the mode's displacement at its own resonance: -90 deg
        nco, dem = _demodulator(fs, base, w / (2 * np.pi))
        tests[name] = _channel(nco, dem, fmt, adc, log, n, g * abs(resp), np.angle(resp) + offset, rng,
                               phase_noise_rad, noise_fs)[2]  # filtered and averaged, as a modal test dwells
    psi_x = float(np.angle(tests["x"]) + np.pi / 2)
    psi_y = float(np.angle(tests["y"]) + np.pi / 2)
    k_sf = (abs(tests["y"]) / (excitation_ratio * qy / wy ** 2)) / (abs(tests["x"]) / (qx / wx ** 2))
    return {"phase_x_rad": psi_x, "phase_y_rad": psi_y, "k_sf": float(k_sf), "gain_ratio": float(k_sf / gain),
            "resonance_phase_x_deg": float(np.degrees(np.angle(tests["x"]))),
            "resonance_phase_y_deg": float(np.degrees(np.angle(tests["y"]))), "overflows": log.total}


def correct(s_measured, corr: dict) -> np.ndarray:
    """S = Y/X with the channels corrected: rotated by the difference of the channels' phase
    offsets and divided by the measured gain ratio (relative to the nominal one already divided out)."""
    return (np.asarray(s_measured, complex) * np.exp(-1j * (corr["phase_y_rad"] - corr["phase_x_rad"]))
            / corr["gain_ratio"])


def identify(freqs_hz, s, gyro=PAPER002_GYRO) -> dict:
    wx, wy = gyro.omega(25.0)
    qx, qy = gyro.quality(25.0)
    fit = fit_coupling(freqs_hz, s, wx / (2 * np.pi), float(qx), wy / (2 * np.pi), float(qy))
    m = gyro.mass_kg
    return {"kxy": fit["alpha"] * m, "cxy": fit["eta"] * m, "lambda_yx": fit["lambda_yx"], "r2": fit["r2"]}


def errors(ident: dict) -> dict:
    return {k: abs(ident[k] / PAPER[k] - 1.0) for k in ("kxy", "cxy", "lambda_yx")}


def mismatch_case(freqs_hz, phase_offset_rad: float = MISMATCH_PHASE_RAD, sense_gain_error: float = 0.0,
                  seed: int = 1, gyro=PAPER002_GYRO, progress: bool = False) -> dict:
    """The sweep with an uncorrected channel mismatch, identified as measured and after
    :func:`correct` with the corrections of :func:`channel_correction` (its modal tests use seed + 1)."""
    meas = measure(freqs_hz, gyro=gyro, seed=seed, phase_offset_rad=phase_offset_rad,
                   sense_gain_error=sense_gain_error, progress=progress)
    corr = channel_correction(meas["gain"], gyro=gyro, seed=seed + 1, phase_offset_rad=phase_offset_rad,
                              sense_gain_error=sense_gain_error)
    out = {"phase_offset_rad": phase_offset_rad, "sense_gain_error": sense_gain_error, "correction": corr,
           "overflows": meas["overflows"] + corr["overflows"]}
    for key in ("filtered", "averaged"):
        for label, s in (("uncorrected", meas[key]), ("corrected", correct(meas[key], corr))):
            ident = identify(meas["freqs_hz"], s, gyro)
            out[f"{key}, {label}"] = {**ident, "err": errors(ident)}
    return out


def device(gyro=PAPER002_GYRO) -> dict:
    """What the report says of the swept device: its drive and sense modes, and its damping coupling
    against its stiffness coupling at the drive frequency, |w eta| / alpha, at 25 C (why the damping
    term is the one phase noise hides: small and in quadrature with the stiffness term)."""
    alpha, eta, _ = gyro.couplings(T0_C)
    return {"drive_hz": gyro.fx_hz, "sense_hz": gyro.fy_hz,
            "damping_share": float(abs(2 * np.pi * gyro.fx_hz * eta) / alpha)}


def reproduce(n_freqs: int = 41, seed: int = 1, progress: bool = False) -> dict:
    if n_freqs < 3:
        raise InputError(f"n_freqs: need at least 3, got {n_freqs}")
    freqs = np.linspace(*SPAN_HZ, n_freqs)
    meas = measure(freqs, seed=seed, progress=progress)
    out = {"paper": PAPER, "measure": meas, "params": {"phase_noise_rad": PHASE_NOISE_RAD,
                                                       "noise_fs": ADDITIVE_NOISE_FS, "dwell_s": DWELL_S,
                                                       "n_freqs": n_freqs, "span_hz": SPAN_HZ,
                                                       "excitation_ratio": SENSE_EXCITATION_RATIO},
           "device": device()}
    for key in ("truth", "filtered", "raw", "averaged"):
        ident = identify(freqs, meas[key])
        out[key] = {**ident, "err": errors(ident)}
    out["mismatch"] = {"phase": mismatch_case(freqs, MISMATCH_PHASE_RAD, 0.0, seed, progress=progress),
                       "phase_gain": mismatch_case(freqs, MISMATCH_PHASE_RAD, MISMATCH_GAIN, seed, progress=progress)}
    return out
