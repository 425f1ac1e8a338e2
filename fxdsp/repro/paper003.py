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
"""

from __future__ import annotations

import numpy as np
from tqdm import tqdm

from fxdsp.blocks.demod import Demod, Nco
from fxdsp.chains import build
from fxdsp.fixed import OverflowLog, Rules, quantize, resize, to_float
from fxdsp.sim.gyro import PAPER002_GYRO, fit_coupling

PAPER = {"lambda_yx": -0.000374, "cxy": -6.96e-8, "kxy": 0.103, "err_cxy": 0.0609,
         "err_raw_cxy": 10.0, "err_filtered_cxy": 0.09, "r2": 0.99}
PHASE_NOISE_RAD = 0.01
ADDITIVE_NOISE_FS = 1e-3
DWELL_S = 0.05
SPAN_HZ = (8000.0, 8040.0)


def measure(freqs_hz, gyro=PAPER002_GYRO, seed: int = 1, phase_noise_rad: float = PHASE_NOISE_RAD,
            noise_fs: float = ADDITIVE_NOISE_FS, dwell_s: float = DWELL_S, phase_offset_rad: float = 0.0,
            progress: bool = False) -> dict:
    """S(w) measured at each frequency, with and without the demodulator's low-pass filters.
    ``phase_offset_rad``: an uncorrected phase mismatch of the sense channel (0: corrected)."""
    freqs = np.asarray(freqs_hz, float)
    if freqs.ndim != 1 or freqs.size < 3:
        raise ValueError("freqs_hz: need at least three sweep frequencies")
    if not dwell_s > 0:
        raise ValueError(f"dwell_s: must be > 0, got {dwell_s!r}")
    design = build(None)
    base = design.blocks["demod"]
    fs = design.fs_hz
    n = int(round(dwell_s * fs))
    rng = np.random.default_rng(seed)
    truth = gyro.sweep(freqs)
    fmt = base.in_format  # the demodulator's input word (s24.22, +-2)
    adc = design.blocks["sf_divide"].in_format  # the sense ADC (s16.15, +-1)
    if fmt.fl < adc.fl:
        raise ValueError(f"demod.in_format: {fmt} has fewer fraction bits than the ADC {adc}")
    amp = 0.5 * adc.max_value
    gain = 1.0 / np.abs(truth).max()  # sense channel conversion gain: largest |S| -> half scale
    sat = Rules("half_up", "saturate")
    filtered, raw, averaged = [], [], []
    log = OverflowLog()
    for f, s in tqdm(list(zip(freqs, truth)), disable=not progress, desc="sweep", leave=False):
        nco = Nco(fs, float(f), base.nco.phase_bits, base.nco.lut_bits, base.nco.lut_format,
                  interp_bits=base.nco.interp_bits, rules=base.nco.rules)
        dem = Demod(nco, fmt, base.data_format, base.lpf_i, base.lpf_q, base.angle_format, base.iterations, base.rules)
        ph = nco.reference_phase(n)
        chans = {}
        for name, a, phi in (("x", amp, 0.0), ("y", amp * gain * abs(s), np.angle(s) + phase_offset_rad)):
            sig = a * np.cos(ph + phi + phase_noise_rad * rng.standard_normal(n)) + noise_fs * rng.standard_normal(n)
            dem.reset()
            codes = resize(quantize(sig, adc, sat, log, "adc"), adc, fmt, sat, log, "adc")  # exact widening
            mi, mq = dem.mix(log, codes)
            li = dem.lpf_i.stream(log, x=mi)["y"]
            lq = dem.lpf_q.stream(log, x=mq)["y"]
            df = dem.data_format
            half = slice(n // 2, n)
            chans[name] = (complex(to_float(li[-1:], df)[0], to_float(lq[-1:], df)[0]),
                           complex(to_float(mi[-1:], df)[0], to_float(mq[-1:], df)[0]),
                           complex(to_float(li[half], df).mean(), to_float(lq[half], df).mean()))
        filtered.append(chans["y"][0] / chans["x"][0] / gain)
        raw.append(chans["y"][1] / chans["x"][1] / gain)
        averaged.append(chans["y"][2] / chans["x"][2] / gain)
    return {"freqs_hz": freqs, "truth": truth, "filtered": np.array(filtered), "raw": np.array(raw),
            "averaged": np.array(averaged),
            "overflows": log.total}


def identify(freqs_hz, s, gyro=PAPER002_GYRO) -> dict:
    wx, wy = gyro.omega(25.0)
    qx, qy = gyro.quality(25.0)
    fit = fit_coupling(freqs_hz, s, wx / (2 * np.pi), float(qx), wy / (2 * np.pi), float(qy))
    m = gyro.mass_kg
    return {"kxy": fit["alpha"] * m, "cxy": fit["eta"] * m, "lambda_yx": fit["lambda_yx"], "r2": fit["r2"]}


def errors(ident: dict) -> dict:
    return {k: abs(ident[k] / PAPER[k] - 1.0) for k in ("kxy", "cxy", "lambda_yx")}


def reproduce(n_freqs: int = 41, seed: int = 1, progress: bool = False) -> dict:
    if n_freqs < 3:
        raise ValueError(f"n_freqs: need at least 3, got {n_freqs}")
    freqs = np.linspace(*SPAN_HZ, n_freqs)
    meas = measure(freqs, seed=seed, progress=progress)
    out = {"paper": PAPER, "measure": meas, "params": {"phase_noise_rad": PHASE_NOISE_RAD,
                                                       "noise_fs": ADDITIVE_NOISE_FS, "dwell_s": DWELL_S,
                                                       "n_freqs": n_freqs, "span_hz": SPAN_HZ}}
    for key in ("truth", "filtered", "raw", "averaged"):
        ident = identify(freqs, meas[key])
        out[key] = {**ident, "err": errors(ident)}
    return out
