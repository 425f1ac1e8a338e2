"""The drive loop closed on its resonator: the loop's DAC word drives the mode, the mode's pick-off
feeds the loop's ADC, sample by sample (:mod:`fxdsp.sim.resonator` for the mode and its front end,
:mod:`fxdsp.blocks.drive` for the loop).

The bit-exact loop and its float reference are closed on the same resonator with the same
pick-off noise (one seed), so the difference between their frequency words is the loop's own
arithmetic. Both are compiled loops over chunks of samples (state carried between chunks, the
noise of each chunk drawn from one generator in order): a one-hour run at 96 kS/s is 346 M samples.

The temperature is a profile in steps of ``samples_per_temp`` samples (default 10 ms): the
resonator's coefficients are recomputed once per step. What is recorded every ``record_every``
samples: the frequency word in Hz, the measured amplitude, the phase error, the resonance the
resonator really has at that moment and the temperature.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from fxdsp.blocks.drive import (_drive_step, _drive_step_float, Drive, FS_AMP, FS_ERR, FS_F, FS_PHASE, S_AMP, S_ERR, S_F,
                            S_FTW, S_PHASE, wrap_rad)
from fxdsp.fixed import OverflowLog
from fxdsp.sim.resonator import DriveResonator, adc_code, resonator_step
from fxdsp.errors import InputError

CHUNK = 1 << 20
STEP_S = 0.01   # the temperature (and resonance) profile's step
MAX_KEPT = 50_000_000   # ADC codes a run keeps at most (400 MB)


def records_of(drive: Drive, record_every: int | None) -> int:
    """Samples per record of a closed-loop run (default: one per control update); the run's chunks
    follow it, so a run replayed (:class:`ModeTwin`) must use the same."""
    return int(record_every or drive.update_every)


def samples_per_step(fs_hz: float) -> int:
    """Samples of one profile step at ``fs_hz``."""
    return max(1, round(fs_hz * STEP_S))


@njit(cache=True)
def _closed(n, record_every, fixed, st, lpf_st, p, qsin, atans, lb, la, lc, counts, lcounts, fst, flpf, fp, sos, coef,
            per_step, step0, rst, noise, adc_scale, lo, hi, dac_scale, codes, omega, turn):
    """n samples of the loop on the resonator: the bit-exact one (``fixed``: its state ``st``,
    ``lpf_st``, parameters ``p`` ...) or the float reference (``fst``, ``flpf``, ``fp``, ``sos``),
    both reading the same ADC. ``rst`` = x, v, held drive, ADC saturations; ``coef`` the resonator's
    steps of this chunk, the first at global step ``step0 // per_step``. Records every
    ``record_every`` samples the frequency word (fixed: the tuning word; float: Hz), amplitude and
    phase error at the record, and the mean of the Hz output over the record's window (fixed: in
    freq_format LSBs). ``codes``: the ADC codes the loop read, kept when it has n entries. The
    reference's phase error at each record: the NCO's phase (fixed: accumulator x ``turn``, the
    turns per LSB) against the mode's, atan2(-v / w, x) with ``omega`` = w per step, wrapped."""
    m = n // record_every
    rec = np.empty((5, m))
    x, v, u = rst[0], rst[1], rst[2]
    base = step0 // per_step
    acc = 0.0
    for i in range(n):
        code, s = adc_code(x + noise[i], adc_scale, lo, hi)
        rst[3] += s
        if codes.shape[0] == n:
            codes[i] = code
        if fixed:
            d = _drive_step(code, st, lpf_st, p, qsin, atans, lb, la, lc, counts, lcounts) * dac_scale
            acc += st[S_F]
        else:
            d = _drive_step_float(code / adc_scale, fst, flpf, fp, sos)
            acc += fst[FS_F]
        j = min((step0 + i) // per_step - base, coef.shape[0] - 1)
        x, v = resonator_step(x, v, u, coef, j)
        u = d
        if (i + 1) % record_every == 0:
            k = (i + 1) // record_every - 1
            if fixed:   # the tuning word (< 2**53: exact in float64)
                rec[0, k], rec[1, k], rec[2, k] = st[S_FTW], st[S_AMP], st[S_ERR]
                nco = st[S_PHASE] * turn
            else:
                rec[0, k], rec[1, k], rec[2, k] = fst[FS_F], fst[FS_AMP], fst[FS_ERR]
                nco = fst[FS_PHASE]
            rec[3, k] = acc / record_every
            rec[4, k] = wrap_rad(2 * np.pi * nco - np.arctan2(-v / omega[j], x))
            acc = 0.0
    rst[0], rst[1], rst[2] = x, v, u
    return rec


@dataclass
class ClosedLoopRun:
    """What a closed-loop run recorded (every ``record_every`` samples, at times ``t_s``)."""

    t_s: np.ndarray
    f_hz: np.ndarray          # the loop's frequency word in Hz, at the record
    f_mean_hz: np.ndarray     # the loop's Hz output (freq_format) averaged over each record's window
    amp: np.ndarray           # measured amplitude (pick-off FS)
    phase_rad: np.ndarray     # PLL phase error
    true_f_hz: np.ndarray     # the resonator's resonance at that moment
    temp_c: np.ndarray
    adc_saturations: int
    overflows: OverflowLog
    limits: dict              # samples with a PI at its limit (fxdsp.blocks.drive.LIMITS), fixed loop only
    ref_phase_rad: np.ndarray  # the NCO's phase against the mode's motion (a demodulator's reference error)
    adc_codes: np.ndarray | None = None   # every drive ADC code the loop read (keep_codes)


@dataclass
class Chunk:
    """One compiled run's share of a closed loop: samples start .. start + m, the resonator's
    coefficients of the temperature steps they span (the first at global step start // per_step),
    their pick-off noise and the resonance (rad/s) per step."""

    start: int
    m: int
    coef: np.ndarray
    noise: np.ndarray
    omega: np.ndarray


def _profile(temp_c, freq_hz):
    """(temperatures, resonances or None) per profile step, checked."""
    temps = np.atleast_1d(np.asarray(temp_c, dtype=float))
    freqs = None if freq_hz is None else np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if freqs is not None and freqs.shape != temps.shape:
        if temps.size != 1:
            raise InputError(f"temp_c: {temps.size} steps, freq_hz {freqs.size}: one value, or one per step of both")
        temps = np.broadcast_to(temps, freqs.shape)
    for what, arr in (("temp_c", temps), ("freq_hz", freqs)):
        if arr is not None and not np.all(np.isfinite(arr)):
            raise InputError(f"{what}: not finite")
    return temps, freqs


def _chunks(drive: Drive, resonator: DriveResonator, temps, freqs, n: int, per_step: int, rec: int, seed: int,
            progress: bool = False):
    """The chunks of an n-sample run in order: whole records and whole temperature steps each (the
    grids are the global ones), the noise of each drawn from one generator in order. One plan for
    the compiled loop and for a loop stepped from outside (:class:`ModeTwin`)."""
    fs = drive.fs_hz
    rng = np.random.default_rng(seed)
    chunk = max(rec * per_step, CHUNK // (rec * per_step) * rec * per_step)
    starts = range(0, n, chunk)
    if progress:
        from tqdm import tqdm

        starts = tqdm(starts, unit="chunk", desc="closed loop")
    last = temps.size - 1
    for start in starts:
        m = min(chunk, n - start)
        steps = np.minimum(np.arange(start // per_step, (start + m - 1) // per_step + 1), last)
        coef = resonator.coefficients(temps[steps], fs, None if freqs is None else freqs[steps])
        noise = rng.normal(0.0, resonator.noise_fs, m) if resonator.noise_fs else np.zeros(m)
        omega = 2 * np.pi * (resonator.frequency_hz(temps[steps]) if freqs is None else freqs[steps])
        yield Chunk(start, m, coef, noise, np.asarray(omega, dtype=float))


class ModeTwin:
    """The resonator and pick-off ADC of :func:`closed_loop`, one sample at a time, for a loop that
    runs outside Python (the RTL in a co-simulation): the same coefficients, noise and arithmetic
    (the compiled ``adc_code`` and ``resonator_step``), so a loop that gives the model's DAC words
    reads the model's ADC codes. Per sample: :meth:`code`, then :meth:`drive` with the DAC word."""

    def __init__(self, drive: Drive, resonator: DriveResonator, temp_c, seconds: float, seed: int = 1,
                 samples_per_temp: int | None = None, record_every: int | None = None):
        """The arguments of the :func:`closed_loop` run to replay (its chunks follow its records)."""
        fs = drive.fs_hz
        self.n = int(round(seconds * fs))
        self.per_step = int(samples_per_temp or samples_per_step(fs))
        temps, freqs = _profile(temp_c, None)
        rec = records_of(drive, record_every)
        self._chunks = list(_chunks(drive, resonator, temps, freqs, self.n, self.per_step, rec, seed))
        fi = drive.in_format
        self._adc = (float(2**fi.fl), fi.min_int, fi.max_int)
        self._dac_scale = 2.0**-drive.dac_format.fl
        self.i, self._c, self._k = 0, 0, 0   # the sample, its chunk and index in it
        self.x = self.v = self.u = 0.0
        self.saturations = 0

    def code(self) -> int:
        """The ADC code of the current sample."""
        c = self._chunks[self._c]
        code, sat = adc_code(self.x + c.noise[self._k], *self._adc)
        self.saturations += int(sat)
        return int(code)

    def drive(self, dac_word: int) -> None:
        """The loop's DAC word for the current sample: the mode moves one sample under the previous
        one's (the DAC holds it), this one is held next."""
        c = self._chunks[self._c]
        j = min((c.start + self._k) // self.per_step - c.start // self.per_step, c.coef.shape[0] - 1)
        self.x, self.v = resonator_step(self.x, self.v, self.u, c.coef, j)
        self.u = int(dac_word) * self._dac_scale
        self.i += 1
        self._k += 1
        if self._k == c.m and self._c + 1 < len(self._chunks):
            self._c, self._k = self._c + 1, 0


def closed_loop(drive: Drive, resonator: DriveResonator, temp_c, seconds: float, seed: int = 1,
                fixed: bool = True, samples_per_temp: int | None = None, record_every: int | None = None,
                progress: bool = False, freq_hz=None, keep_codes: bool = False) -> ClosedLoopRun:
    """Run the loop closed on ``resonator`` for ``seconds`` from power-on (resonator at rest, loop
    reset). ``temp_c``: one temperature or a profile, one value per ``samples_per_temp`` samples
    (default :data:`STEP_S`); ``freq_hz``: a resonance profile on the same steps replacing
    the resonator's f(T) (a log's simulated resonance, its effects included). ``fixed``: the
    bit-exact loop, else the float reference. ``keep_codes``: also every ADC code the loop read
    (``adc_codes``; at most ``MAX_KEPT`` samples): fed to the block, or to a chain it heads, open
    loop, they give the closed loop's words again, bit for bit."""
    fs = drive.fs_hz
    n = int(round(seconds * fs))
    per_step = int(samples_per_temp or samples_per_step(fs))
    rec = records_of(drive, record_every)
    if rec < 1 or n < rec:
        raise InputError(f"record_every: {rec} must be within 1..{n} samples")
    if keep_codes and n > MAX_KEPT:
        raise InputError(f"keep_codes: {n} samples; at most {MAX_KEPT} are kept ({MAX_KEPT / fs:g} s)")
    temps, freqs = _profile(temp_c, freq_hz)
    fi = drive.in_format
    adc_scale = float(2**fi.fl)
    rst = np.zeros(4)
    log = OverflowLog()
    drive.reset()
    st, lpf_st = drive.state, drive.lpf_state
    counts, lcounts = drive._counts()
    prm, qsin, atans, lb, la, lc = drive.kernel_args()
    fst, flpf = drive.float_state()
    dac_scale = 2.0**-drive.dac_format.fl
    parts, codes = [], []
    for c in _chunks(drive, resonator, temps, freqs, n, per_step, rec, seed, progress):
        kept = np.empty(c.m if keep_codes else 0, dtype=np.int64)
        parts.append(_closed(c.m, rec, fixed, st, lpf_st, prm, qsin, atans, lb, la, lc, counts, lcounts, fst, flpf,
                             drive._fprm, drive.lpf.sos, c.coef, per_step, c.start, rst, c.noise, adc_scale, fi.min_int,
                             fi.max_int, dac_scale, kept, c.omega, 2.0**-drive.nco.phase_bits))
        codes.append(kept)
    last = temps.size - 1
    ftw, amp, err, mean, ref_err = np.concatenate(parts, axis=1)
    if fixed:
        drive._log(log, counts, lcounts)
        f_hz = drive.frequency_hz(ftw.astype(np.int64))
        mean = mean * 2.0**-drive.freq_format.fl
        amp = amp * 2.0**-drive.data_format.fl
        err = err * 2.0**-drive.angle_format.fl
    else:
        f_hz = ftw
    idx = np.arange(1, f_hz.size + 1) * rec
    steps = np.minimum((idx - 1) // per_step, last)
    true_f = resonator.frequency_hz(temps[steps]) if freqs is None else freqs[steps]
    limits = dict(drive.limits) if fixed else {}
    drive.reset()
    return ClosedLoopRun(idx / fs, f_hz, mean, amp, err, true_f, temps[steps], int(rst[3]), log, limits,
                         ref_err, np.concatenate(codes) if keep_codes else None)


def lock_time(run: ClosedLoopRun, drive: Drive, phase_rad: float = 1e-3, amp_ppm: float = 100.0) -> float | None:
    """The time after which the loop stays locked: |phase error| < ``phase_rad`` and the amplitude
    within ``amp_ppm`` of the set point at every record to the end (None: never)."""
    ok = (np.abs(run.phase_rad) < phase_rad) & (np.abs(run.amp / drive.amp_setpoint - 1) < amp_ppm * 1e-6)
    bad = np.flatnonzero(~ok)
    if bad.size == 0:
        return float(run.t_s[0])
    if bad[-1] == ok.size - 1:
        return None
    return float(run.t_s[bad[-1] + 1])


def loop_frequency(drive: Drive, resonator: DriveResonator, t_s, freq_hz, temp_c, seed: int = 1,
                   warmup_s: float = 5.0, fixed: bool = True, progress: bool = False) -> np.ndarray:
    """The frequency a log's ``freq_hz`` column reads through the drive loop: the loop closed on a
    mode whose resonance follows ``freq_hz`` (and its Q ``temp_c``) at the log's times ``t_s``
    (uniform rows, interpolated to 10 ms steps); row k is the mean of the loop's Hz output over the
    row interval that ends at t_k (a counter's gate). The loop is switched on ``warmup_s`` before
    the interval of the first row, at the first row's conditions."""
    t = np.asarray(t_s, dtype=float)
    if t.size < 2:
        raise InputError("t_s: the drive loop needs a log of at least two rows")
    dt = float(t[1] - t[0])
    rec = int(round(dt * drive.fs_hz))
    if rec < 1 or abs(rec / drive.fs_hz - dt) > 1e-9 * max(1.0, dt) or not np.allclose(np.diff(t), dt, rtol=0,
                                                                                        atol=1e-9 * max(1.0, dt)):
        raise InputError(f"t_s: the rows must be a whole number of drive-loop samples apart (fs = "
                         f"{drive.fs_hz:g} Hz), evenly; got a step of {dt:g} s")
    per_step = samples_per_step(drive.fs_hz)
    # whole records from the start: the warm-up is a whole number of rows before the first one
    lead = int(np.ceil((warmup_s + dt) / dt))
    n_rec = lead + t.size - 1
    start = t[0] - lead * dt
    grid = start + (np.arange(int(np.ceil(n_rec * rec / per_step)) + 1) + 0.5) * per_step / drive.fs_hz
    freqs = np.interp(grid, t, np.asarray(freq_hz, dtype=float))
    temps = np.interp(grid, t, np.asarray(temp_c, dtype=float))
    run = closed_loop(drive, resonator, temps, n_rec * rec / drive.fs_hz, seed=seed, fixed=fixed,
                      samples_per_temp=per_step, record_every=rec, progress=progress, freq_hz=freqs)
    return run.f_mean_hz[-t.size:]
