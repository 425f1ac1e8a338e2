"""The drive loop's budget: what the loop's own arithmetic costs against what its drive ADC allows.

Both loops, the bit-exact one and its float reference, are closed on the same simulated mode
(:mod:`fxdsp.sim.resonator`) with the same pick-off noise, from power-on. The float loop reads
the same drive ADC codes, so its errors are the **floor**: the drive ADC's noise and quantisation
carried through an ideal loop. The margin is 20 log10(fixed / floor) of the frequency word's noise;
within ``WITHIN_DB`` the loop's arithmetic spends its bits well.

Figures, measured after lock (``lock_time``: the phase error below 1 mrad and the amplitude within
100 ppm of its set point at every record to the end):

* acquisition: the lock time from power-on, also in the mode's own time constant tau = 2Q/w;
* the frequency word (averaged over ``RECORD_S`` records, a counter's gate) against the resonance
  the mode really has: bias and noise in Hz, and in mC through the mode's k = df/dT;
* amplitude stability in ppm of the set point; the reference's phase error (the NCO against the
  mode's own motion, rms in urad; the detector's measured phase error beside it), and the rate error
  it causes as the demodulator's reference: phase x quadrature (``NOMINAL_QUADRATURE_FS`` of the rate
  full scale) in deg/h;
* the bias the rounding rules predict (``predicted_bias``): the phase detector's own bias (its
  arithmetic against float, open loop on an in-phase pick-off, ``Drive.detector_errors``) moves the
  lock off resonance by b / (2 pi tau); the PI's frequency word and its conversion to Hz add their
  rounding's mean (``expected_mean_q``: -1/2 LSB for floor).

Everything returns data; ``fxdsp budget`` prints it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from fxdsp.blocks.drive import Drive
from fxdsp.fixed import quantize
from fxdsp.sensors import NEAREST_SAT, NOMINAL_QUADRATURE_FS
from fxdsp.sim.driveloop import STEP_S, ClosedLoopRun, closed_loop, lock_time, samples_per_step
from fxdsp.sim.resonator import DriveResonator, resonator_for
from fxdsp.budget.attribution import expected_mean_q
from fxdsp.errors import InputError

WITHIN_DB = 3.0
TEMPS_C = (-40.0, 25.0, 85.0)   # the range's ends and room temperature
RECORD_S = STEP_S               # records on the resonance's own steps: the truth is constant over each
MEASURE_S = 5.0                 # measured after lock: 500 records, ~100 loop time constants
RAMP = (-40.0, 85.0, 1.0)       # the chamber ramp of the acceptance: from, to (C), C/min


@dataclass(frozen=True)
class LoopFigures:
    """One loop's figures over the measured records (after lock, or over the ramp)."""

    lock_s: float | None
    f_bias_hz: float
    f_noise_hz: float
    f_max_hz: float                # the largest |error| of a record
    amp_ppm: float
    phase_urad: float              # the reference's phase error: the NCO against the mode's motion, rms
    detector_urad: float           # the phase error the loop measures (its detector's noise included), rms
    records: int


@dataclass(frozen=True)
class DriveBudget:
    """The budget of one drive loop in one scenario (a temperature, or a ramp)."""

    table: str
    scenario: str
    temp_c: tuple[float, float]    # the scenario's range (equal for a constant temperature)
    tau_s: float                   # 2Q/w at the scenario's start
    k_hz_per_c: float              # the mode's df/dT
    record_s: float
    fixed: LoopFigures
    floor: LoopFigures             # the float loop on the same ADC codes
    predicted_bias_hz: dict        # the rounding rules' frequency bias, per term, and their sum
    rate_full_scale_dps: float

    @property
    def margin_db(self) -> float | None:
        """None when either noise is exactly 0 (a noiseless mode: no floor to compare with)."""
        if self.fixed.f_noise_hz <= 0 or self.floor.f_noise_hz <= 0:
            return None
        return 20.0 * math.log10(self.fixed.f_noise_hz / self.floor.f_noise_hz)

    @property
    def within(self) -> bool:
        return self.margin_db is not None and self.margin_db <= WITHIN_DB

    def mc(self, hz: float, signed: bool = False) -> float | None:
        """A frequency error in mC through the mode's k (``signed``: a bias, as the temperature it
        reads); None for a mode whose frequency does not move with temperature (not a thermometer)."""
        if self.k_hz_per_c == 0:
            return None
        return hz / (self.k_hz_per_c if signed else abs(self.k_hz_per_c)) * 1e3

    def rate_deg_h(self, phase_urad: float) -> float:
        """The rate error a reference phase error causes on the nominal quadrature, deg/h."""
        return phase_urad * 1e-6 * NOMINAL_QUADRATURE_FS * self.rate_full_scale_dps * 3600.0

    def as_dict(self) -> dict:
        out = asdict(self)
        for name in ("fixed", "floor"):
            fig = getattr(self, name)
            out[name].update(lock_tau=None if fig.lock_s is None else fig.lock_s / self.tau_s,
                             t_bias_mc=self.mc(fig.f_bias_hz, signed=True),
                             t_noise_mc=self.mc(fig.f_noise_hz), t_max_mc=self.mc(fig.f_max_hz),
                             rate_deg_h=self.rate_deg_h(fig.phase_urad))
        out.update(margin_db=self.margin_db, within=self.within, within_db=WITHIN_DB,
                   quadrature_fs=NOMINAL_QUADRATURE_FS)
        return out


def _k(resonator: DriveResonator, temp_c: float) -> float:
    return float((resonator.frequency_hz(temp_c + 0.5) - resonator.frequency_hz(temp_c - 0.5)))


def figures(run: ClosedLoopRun, drive: Drive, start_s: float | None = None) -> LoopFigures:
    """A run's figures over its records from ``start_s`` (default: from lock)."""
    lock = lock_time(run, drive)
    # a loop that never locked is measured over its second half (its figures then say why)
    t0 = start_s if start_s is not None else lock if lock is not None else float(run.t_s[-1]) / 2
    sel = run.t_s > t0
    if np.count_nonzero(sel) < 10:
        raise InputError(f"{drive.name}: fewer than 10 records after {t0:.3g} s; run longer")
    err = run.f_mean_hz[sel] - run.true_f_hz[sel]
    rms = lambda x: float(np.sqrt(np.mean(x[sel] ** 2)) * 1e6)   # noqa: E731
    return LoopFigures(lock, float(np.mean(err)), float(np.std(err)), float(np.max(np.abs(err))),
                       float(np.std(run.amp[sel] / drive.amp_setpoint - 1) * 1e6), rms(run.ref_phase_rad),
                       rms(run.phase_rad), int(np.count_nonzero(sel)))


def detector_bias_rad(drive: Drive, resonator: DriveResonator, seconds: float = 4.0, seed: int = 1) -> float:
    """The phase detector's mean angle error (bit-exact minus float), open loop on a pick-off in
    phase with its NCO at the set amplitude with the mode's pick-off noise (the ADC's dither), after
    the low-pass has settled (the first quarter left out)."""
    n = int(seconds * drive.fs_hz)
    turns = drive.nco.accumulator(n) / 2.0**drive.nco.phase_bits
    x = drive.amp_setpoint * np.cos(2 * np.pi * turns)
    x = x + np.random.default_rng([seed, 33]).normal(0.0, resonator.noise_fs, n)
    fixed, flt = drive.detector_errors(quantize(x, drive.in_format, NEAREST_SAT))
    keep = slice(fixed.size // 4, None)
    return float(np.mean(fixed[keep] - flt[keep]))


def predicted_bias(drive: Drive, resonator: DriveResonator, temp_c: float, detector_rad: float) -> dict:
    """The frequency bias the rounding rules predict at ``temp_c`` (Hz, per term and total)."""
    dp, rnd = drive.datapath, drive.rules.rounding
    ftw_hz = drive.fs_hz / 2.0**drive.nco.phase_bits
    df = (float(resonator.frequency_hz(temp_c)) - drive.f_hz) / ftw_hz   # the locked df, in ftw LSBs
    rounding = expected_mean_q(rnd, np.array([df]))                      # a rounding's mean, in its LSBs
    lsb = 2.0**-drive.freq_format.fl                                     # of the Hz word
    terms = {
        "detector": detector_rad / (2 * np.pi * float(resonator.tau_s(temp_c))),
        "pi_word": rounding * ftw_hz,
        # the rounding, the centre word's own error and the coefficient's over df
        "hz_word": (rounding + dp.hz_center - dp.ftw_center * ftw_hz / lsb
                    + df * (dp.hz_coef * 2.0**-dp.hz_shift - ftw_hz / lsb)) * lsb,
    }
    terms["total"] = float(sum(terms.values()))
    return {k: float(v) for k, v in terms.items()}


def _budget(drive: Drive, resonator: DriveResonator, scenario: str, temps, seconds: float, start_s: float | None,
            seed: int, rate_full_scale_dps: float, progress: bool) -> DriveBudget:
    rec = samples_per_step(drive.fs_hz)
    runs = [closed_loop(drive, resonator, temps, seconds, seed=seed, fixed=fixed, record_every=rec,
                        progress=progress) for fixed in (True, False)]
    fixed, floor = (figures(r, drive, start_s) for r in runs)
    t = np.atleast_1d(temps)
    mid = float(np.mean([t.min(), t.max()]))
    return DriveBudget(drive.name, scenario, (float(t[0]), float(t[-1])), float(resonator.tau_s(float(t[0]))),
                       _k(resonator, mid), rec / drive.fs_hz, fixed, floor,
                       predicted_bias(drive, resonator, mid, detector_bias_rad(drive, resonator, seed=seed)),
                       rate_full_scale_dps)


def at_temperature(drive: Drive, temp_c: float, rate_full_scale_dps: float, resonator: DriveResonator | None = None,
                   seed: int = 1, measure_s: float = MEASURE_S) -> DriveBudget:
    """The budget at a constant temperature: from power-on, measured over ``measure_s`` after a
    lock that takes up to 4 tau."""
    res = resonator or resonator_for(drive)
    seconds = 4 * float(res.tau_s(temp_c)) + measure_s
    return _budget(drive, res, f"{temp_c:g} C", temp_c, seconds, None, seed, rate_full_scale_dps, False)


def ramp(drive: Drive, rate_full_scale_dps: float, lo_c: float = RAMP[0], hi_c: float = RAMP[1],
         c_per_min: float = RAMP[2], resonator: DriveResonator | None = None, seed: int = 1,
         progress: bool = False) -> DriveBudget:
    """The budget over a chamber ramp: power-on at ``lo_c``, held for 6 tau to lock, then ramped to
    ``hi_c`` at ``c_per_min``; measured over the ramp (its records must all be locked)."""
    res = resonator or resonator_for(drive)
    if not c_per_min > 0 or lo_c == hi_c:
        raise InputError(f"ramp: needs two temperatures and a rate > 0, got {lo_c} .. {hi_c} C at {c_per_min} C/min")
    hold = max(3.0, 6 * float(res.tau_s(lo_c)))
    ramp_s = abs(hi_c - lo_c) / c_per_min * 60.0
    steps = int(math.ceil((hold + ramp_s) / STEP_S))
    t = (np.arange(steps) + 0.5) * STEP_S
    temps = np.interp(t, [0.0, hold, hold + ramp_s], [lo_c, lo_c, hi_c])
    return _budget(drive, res, f"ramp {lo_c:g} .. {hi_c:g} C at {c_per_min:g} C/min", temps, steps * STEP_S, hold,
                   seed, rate_full_scale_dps, progress)


def format_budget(b: DriveBudget) -> str:
    """The budget as text (the CLI's section)."""
    def lock(fig):
        return "never" if fig.lock_s is None else f"{fig.lock_s:.2f} s = {fig.lock_s / b.tau_s:.2f} tau"

    lines = [f"{b.table} at {b.scenario}: tau = 2Q/w {b.tau_s:.3f} s, k {b.k_hz_per_c * 1e3:+.2f} mHz/C, "
             f"records of {b.record_s * 1e3:g} ms",
             f"  {'':8s} {'lock':>20s} {'f bias Hz':>11s} {'f noise Hz':>11s} {'T bias mC':>10s} {'T noise mC':>10s} "
             f"{'T max mC':>9s} {'amp ppm':>8s} {'ref urad':>9s} {'rate deg/h':>10s} {'det urad':>9s}"]
    def num(v, spec: str) -> str:   # a figure, or "-" where there is none (no k, no noise)
        return format(v, spec) if v is not None else format("-", ">" + spec.strip("+").split(".")[0])

    for name, fig in (("fixed", b.fixed), ("floor", b.floor)):
        lines.append(f"  {name:8s} {lock(fig):>20s} {fig.f_bias_hz:+11.3g} {fig.f_noise_hz:11.3g} "
                     f"{num(b.mc(fig.f_bias_hz, signed=True), '+10.3g')} {num(b.mc(fig.f_noise_hz), '10.3g')} "
                     f"{num(b.mc(fig.f_max_hz), '9.3g')} {fig.amp_ppm:8.3g} {fig.phase_urad:9.3g} "
                     f"{b.rate_deg_h(fig.phase_urad):10.3g} {fig.detector_urad:9.3g}")
    verdict = f"within {WITHIN_DB:g} dB" if b.within else f"NOT within {WITHIN_DB:g} dB"
    p = b.predicted_bias_hz
    margin = "no" if b.margin_db is None else f"{b.margin_db:+.2f} dB"
    lines.append(f"  margin {margin} over the floor (frequency noise) -> {verdict}; bias the rounding "
                 f"predicts {p['total']:+.3g} Hz (detector {p['detector']:+.2g}, PI word {p['pi_word']:+.2g}, Hz word "
                 f"{p['hz_word']:+.2g}); rate error at {NOMINAL_QUADRATURE_FS:g} FS quadrature")
    return "\n".join(lines)


@dataclass(frozen=True)
class ReferenceAllan:
    """The demodulator reference's error, bit-exact minus float, as the rate error it causes on the
    nominal quadrature: locked to the drive loop (each loop's NCO against its own mode's motion)
    against open loop (the same table's centre word against the exact centre frequency)."""

    table: str
    temp_c: float
    seconds: float
    record_s: float
    taus: np.ndarray
    adev_locked: np.ndarray       # deg/h
    adev_open: np.ndarray         # deg/h: a phase ramp, adev = slope tau / sqrt(2)
    open_drift_rad_per_h: float

    @property
    def tail_slope(self) -> float:
        """The log-log slope of the locked curve over its last octave (<= 0: flat or falling)."""
        return float(np.log(self.adev_locked[-1] / self.adev_locked[-2]) / np.log(self.taus[-1] / self.taus[-2]))

    @property
    def no_drift(self) -> bool:
        """No open-loop drift: the locked curve is flat or falling at the longest tau (a slope
        below +1/4; a drift rises at +1)."""
        return self.tail_slope < 0.25

    def as_dict(self) -> dict:
        return {"table": self.table, "temp_c": self.temp_c, "seconds": self.seconds, "record_s": self.record_s,
                "unit": "deg/h", "quadrature_fs": NOMINAL_QUADRATURE_FS,
                "curve": [{"tau_s": float(t), "locked": float(a), "open": float(o)}
                          for t, a, o in zip(self.taus, self.adev_locked, self.adev_open)],
                "open_drift_rad_per_h": self.open_drift_rad_per_h, "tail_slope": self.tail_slope,
                "no_drift": self.no_drift}


def reference_allan(drive: Drive, rate_full_scale_dps: float, seconds: float = 3600.0, temp_c: float = 25.0,
                    resonator: DriveResonator | None = None, seed: int = 1, progress: bool = False) -> ReferenceAllan:
    """Allan deviation of the reference's fixed-minus-float error over ``seconds`` of lock (both
    loops closed on the same mode with the same pick-off noise, from power-on; the first 10 tau
    left out), in deg/h of rate on the nominal quadrature, against the open-loop NCO's drift."""
    import allantools

    from fxdsp.budget.floor import octave_taus

    res = resonator or resonator_for(drive)
    settle = 10 * float(res.tau_s(temp_c))
    rec = samples_per_step(drive.fs_hz)
    runs = [closed_loop(drive, res, temp_c, seconds + settle, seed=seed, fixed=fixed, record_every=rec,
                        progress=progress) for fixed in (True, False)]
    keep = runs[0].t_s > settle
    to_rate = NOMINAL_QUADRATURE_FS * rate_full_scale_dps * 3600.0   # deg/h per rad of reference error
    diff = (runs[0].ref_phase_rad[keep] - runs[1].ref_phase_rad[keep]) * to_rate
    fs = drive.fs_hz / rec
    taus = octave_taus(diff.size, fs)
    taus, adev, _, _ = allantools.oadev(diff, rate=fs, data_type="freq", taus=taus)
    drift = 2 * np.pi * (drive.nco.ftw * drive.fs_hz / 2.0**drive.nco.phase_bits - drive.f_hz)   # rad/s
    return ReferenceAllan(drive.name, temp_c, seconds, rec / drive.fs_hz, np.asarray(taus), np.asarray(adev),
                          abs(drift) * to_rate * np.asarray(taus) / math.sqrt(2), abs(drift) * 3600.0)


def format_allan(a: ReferenceAllan) -> str:
    lines = [f"{a.table}: the demodulator reference, fixed minus float, as rate error on {NOMINAL_QUADRATURE_FS:g} FS "
             f"quadrature, {a.seconds:g} s at {a.temp_c:g} C (records of {a.record_s * 1e3:g} ms; allantools.oadev):",
             f"  {'tau s':>9s} {'locked deg/h':>13s} {'open loop':>11s}"]
    for t, lk, op in zip(a.taus, a.adev_locked, a.adev_open):
        lines.append(f"  {t:9.3g} {lk:13.3g} {op:11.3g}")
    lines.append(f"  locked: slope {a.tail_slope:+.2f} over the last octave -> "
                 f"{'no drift (flat or falling)' if a.no_drift else 'RISING: a drift'}; open loop drifts "
                 f"{a.open_drift_rad_per_h:.3g} rad/h (the centre word's rounding)")
    return "\n".join(lines)
