"""The drive loop (fxdsp.blocks.drive) closed on the drive mode (fxdsp.sim.resonator): it acquires
from power-on and locks on both papers' resonators at every temperature of the range, the bit-exact
loop is as quiet as its float reference, and a PI with the wrong sign loses lock.

The expectations come from the physics, not from the code: the resonance a resonator really has
at that temperature (w(T) or f0 + kT), its steady amplitude under a held drive (Q/w^2 per unit
force), the 90 deg lag at resonance, the set point of the amplitude loop; the tolerances are the
issue's (1 mrad, 100 ppm).
"""

from __future__ import annotations

import numpy as np
import pytest

from fxdsp.blocks.drive import P_KI_F, P_KP_F, S_AMP, S_FTW, S_INTEG_F
from fxdsp.sim.driveloop import closed_loop, lock_time
from fxdsp.sim.resonator import PAPER002_DRIVE, PRESETS, _open_drive

LOOPS = PRESETS   # the built-in tables and the modes they were designed for


GRID_C = [float(t) for t in range(-40, 86, 5)]   # the issue's -40..85 C, every 5 C (a run is ~0.06 s)


@pytest.mark.parametrize("temp_c", GRID_C)
@pytest.mark.parametrize("table", sorted(LOOPS))
def test_the_loop_locks_from_power_on_at_the_resonance(design, table, temp_c):
    drive, res = design.blocks[table], LOOPS[table]
    tau = float(res.tau_s(temp_c))
    seconds = max(3.0, 6 * tau)
    run = closed_loop(drive, res, temp_c, seconds, seed=3, record_every=96)
    t_lock = lock_time(run, drive)
    assert t_lock is not None, f"{table} at {temp_c} C never locked"
    # from rest the amplitude rises as 1 - exp(-t / tau) at full gain: lock in a few time constants
    assert t_lock < 4 * tau, f"{table} at {temp_c} C locked after {t_lock:.2f} s = {t_lock / tau:.1f} tau"
    after = run.t_s > t_lock
    rms = np.sqrt(np.mean(run.phase_rad[after] ** 2))
    assert rms < 1e-3
    # the frequency word is the resonance the mode has at this temperature (not the NCO's centre,
    # which is off by up to 15 Hz): a lag left uncompensated would bias it by lag / (2 pi tau)
    bias = np.mean(run.f_hz[after] - run.true_f_hz[after])
    assert abs(bias) < 1e-3, f"{table} at {temp_c} C: frequency {bias * 1e3:.3f} mHz off the resonance"
    # away from 25 C the NCO has to travel to the resonance (>= 0.5 Hz at 10 C off: the test is not a no-op)
    assert abs(run.true_f_hz[0] - drive.f_hz) > 0.5 or abs(temp_c - 25.0) <= 10.0


@pytest.mark.parametrize("table", sorted(LOOPS))
def test_the_bit_exact_loop_is_as_quiet_as_its_float_reference(design, table):
    """Same resonator, same pick-off noise: the fixed-point loop's frequency noise within 3 dB of the
    float loop's (its arithmetic adds less than the drive ADC's noise), its bias within it."""
    drive, res = design.blocks[table], LOOPS[table]
    runs = [closed_loop(drive, res, 60.0, 5.0, seed=5, fixed=fixed, record_every=96) for fixed in (True, False)]
    tail = [r.f_hz[r.t_s > 2.5] - r.true_f_hz[r.t_s > 2.5] for r in runs]
    std_fixed, std_float = (float(np.std(t)) for t in tail)
    assert std_fixed < np.sqrt(2) * std_float, (std_fixed, std_float)
    assert abs(np.mean(tail[0]) - np.mean(tail[1])) < 2 * std_float


def test_a_closed_loop_run_is_deterministic_per_seed(design):
    drive, res = design.blocks["drive"], LOOPS["drive"]
    a, b, c = (closed_loop(drive, res, 0.0, 0.5, seed=s) for s in (7, 7, 8))
    assert np.array_equal(a.f_hz, b.f_hz) and np.array_equal(a.amp, b.amp)
    assert not np.array_equal(a.f_hz, c.f_hz)


def test_a_pi_with_the_wrong_sign_loses_lock(design):
    """The PLL's gains negated: positive feedback pushes the frequency away from the resonance to a
    lock-range limit, where it stays (the correct loop locks in the same run, test above)."""
    drive, res = design.blocks["drive"], LOOPS["drive"]
    prm = drive._prm.copy()
    prm[P_KP_F], prm[P_KI_F] = -prm[P_KP_F], -prm[P_KI_F]
    prm.setflags(write=False)   # as the block's own (a writable array is another numba type: a new compile)
    good = drive._prm
    try:
        drive._prm = prm
        run = closed_loop(drive, res, 85.0, 3.0, seed=3, record_every=96)
    finally:
        drive._prm = good
    assert lock_time(run, drive) is None
    assert abs(run.f_hz[-1] - run.true_f_hz[-1]) > 1.0
    assert run.limits["pll_limit"] > 0


def test_the_resonator_has_its_physical_amplitude_and_lag(design):
    """Driven by a held sinusoid at resonance from the DAC, the mode settles (10 tau) to the amplitude
    gain * d * (Q/Q0) (w0/w)^2 (times the hold's sinc(f/fs), the fundamental of a staircase) and lags
    the drive's samples by 90 deg plus the DAC's 1.5 samples (one of latency, half of hold)."""
    res = PAPER002_DRIVE.with_(noise_fs=0.0)
    fs, temp = 96000.0, 60.0
    f = float(res.frequency_hz(temp))
    n = int(10 * res.tau_s(temp) * fs)
    d = 0.25
    dac_fmt_fl = 15
    phase = 2 * np.pi * f / fs * np.arange(n)
    dac = np.floor(d * np.cos(phase) * 2**dac_fmt_fl + 0.5).astype(np.int64)
    coef = res.coefficients([temp], fs)
    codes, sat = _open_drive(dac, 2.0**-dac_fmt_fl, coef, n, np.zeros(3), np.zeros(n), 2.0**20, -(2**40), 2**40)
    tail = slice(n - 9600, n)
    x = codes[tail] / 2.0**20
    ref = np.exp(-1j * phase[tail])
    z = 2 * np.mean(x * ref)     # complex amplitude against the drive's phase
    want = res.gain * d * (res.quality(temp) / res.q0) * (res.f0_hz / f) ** 2 * np.sinc(f / fs)
    assert abs(abs(z) / want - 1) < 2e-3
    lag = -np.angle(z)
    assert lag == pytest.approx(np.pi / 2 + 2 * np.pi * f / fs * 1.5, abs=2e-3)
    assert sat == 0


def _short_programme(monkeypatch):
    """A 60 s chamber programme (a hold, then a 6 C/min ramp): short enough to close the loop on
    in a test, the ramp steep enough to make a lagging readout visible."""
    from fxdsp.sim import generate
    from fxdsp.sim.programmes import Segment

    monkeypatch.setattr(generate, "programme",
                        lambda scenario, scale, rng: ([Segment(20.0, 25.0), Segment(40.0, 29.0, phase="ramp")], 25.0, 5.0))


def test_simulate_reads_freq_hz_through_the_loop(monkeypatch, tmp_path):
    """`fxdsp simulate --drive-loop drive001`: the freq_hz column is the loop's reading of the
    simulated resonance f0 + k Te, each row the mean over the second before it (the counter's gate):
    within 1 mC-equivalent of that mean at every row, 0.2 mC on average."""
    import numpy as np

    from fxdsp.cli import main
    from fxdsp.sim.logio import read_log

    _short_programme(monkeypatch)
    out = tmp_path / "log.csv"
    assert main(["simulate", "--scenario", "paper001", "--drive-loop", "drive001", "--time-step", "1",
                 "--noise", "off", "--seed", "4", "--out", str(out)]) == 0
    log, comments = read_log(out)
    t, f = np.asarray(log["time_s"]), np.asarray(log["freq_hz"])
    te = np.asarray(log["temp_c"])           # noise off: the die temperature on the RTD's scale
    resonance = 3837.471 + 0.0536 * te
    # the row's gate spans the second before it: the ramp's mean is half a row behind
    gate = np.interp(t - 0.5, t, resonance)
    err = (f - gate)[1:]
    print("freq_hz through the loop minus the gated resonance, mHz:", np.round(err * 1e3, 4))
    assert np.abs(err).max() < 0.0536e-3, err      # 1 mC-equivalent at worst (reading at the row: 50 mC off)
    assert abs(np.mean(err)) < 0.0107e-3           # 0.2 mC-equivalent on average
    assert "through the drive loop [drive001]" in comments["freq_hz"]


@pytest.mark.parametrize("args, words", [
    (["--drive-loop", "nosuch"], ["--drive-loop", "'nosuch'", "drive, drive001"]),
    (["--drive-loop", "drive"], ["[drive]", "outside"]),                       # paper 001's 3838 Hz mode
    (["--drive-loop", "drive001", "--columns", "rate_dps"], ["--drive-loop", "freq_hz"]),
    (["--config", "x.toml"], ["--config", "--drive-loop"]),
])
def test_simulate_drive_loop_bad_input_is_one_line(monkeypatch, tmp_path, capsys, args, words):
    from fxdsp.cli import main

    _short_programme(monkeypatch)
    out = tmp_path / "log.csv"
    if "x.toml" in args:
        (tmp_path / "x.toml").write_text("")
        args = [a.replace("x.toml", str(tmp_path / "x.toml")) for a in args]
    assert main(["simulate", "--scenario", "paper001", "--time-step", "1", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and all(w in err for w in words), err
    assert not out.exists()


@pytest.mark.parametrize("fs_hz", [96000.0, 96153.85, 1e8 / 1040.0, 48000.0 * 1.37])
def test_the_frequency_word_in_hz_holds_at_any_sample_rate(fs_hz):
    """The frequency word reads in Hz within 1.25 LSB of ``ftw * fs / 2**phase_bits`` (exact, in
    fractions) across the lock range, on sample rates that are and are not short binary fractions."""
    from fractions import Fraction

    from conftest import design_with

    d = design_with(**{"system.fs_hz": fs_hz})
    rng = np.random.default_rng(11)
    for name in LOOPS:
        b = d.blocks[name]
        dp, fl, bits = b.datapath, b.freq_format.fl, b.nco.phase_bits
        dfs = np.concatenate([[-dp.lock_range, 0, dp.lock_range],
                              rng.integers(-dp.lock_range, dp.lock_range, 200, endpoint=True)])
        # a loop settled on a pick-off at the set amplitude, then one control update from a PLL
        # integrator anywhere in the lock range: the frequency word it sets (the loop's state)
        # against the Hz word it outputs
        x = b.nominal_stimulus(rng, 2048)["x"]
        settled = b.run(x=x[:-dp.update_every]).state
        assert settled["loop"][S_AMP] > b.datapath.min_amp
        x = x[-dp.update_every:]
        for df in dfs.tolist():
            state = {k: v.copy() if hasattr(v, "copy") else v for k, v in settled.items()}
            state["loop"][S_INTEG_F] = int(df) << dp.pi_shift_f
            got = b.run(x=x, state=state)
            ftw = int(got.state["loop"][S_FTW])
            exact = Fraction(ftw) * Fraction(fs_hz) / (1 << bits) * (1 << fl)
            assert abs(int(got.outputs["f"][-1]) - exact) <= Fraction(5, 4), (name, fs_hz, df)


def _batch_sem(x: np.ndarray, batches: int = 10) -> float:
    """Standard error of a correlated series' mean from the spread of its batch means."""
    means = np.array([b.mean() for b in np.array_split(x, batches)])
    return float(means.std(ddof=1) / np.sqrt(batches))


@pytest.mark.parametrize("table", sorted(LOOPS))
def test_a_truncating_loop_biases_the_frequency_by_what_the_budget_predicts(table):
    """Rounding by floor in the detector, the PI and the Hz word (a truncating design) against the
    same loop rounding half_up, closed on the same mode with the same noise: the frequency words'
    mean difference is the difference of the biases the budget predicts, within 4 standard errors,
    and that prediction is far outside the measurement's resolution (the test can fail)."""
    from conftest import design_with

    from fxdsp.budget.drive_loop import detector_bias_rad, figures, predicted_bias

    res = LOOPS[table]
    loops = {rnd: design_with(**{f"{table}.rounding": rnd, f"{table}.lpf.rounding": rnd}).blocks[table]
             for rnd in ("half_up", "floor")}
    runs = {rnd: closed_loop(b, res, 25.0, 10.0, seed=4, record_every=960) for rnd, b in loops.items()}
    start = max(figures(r, loops[k]).lock_s for k, r in runs.items())
    sel = runs["floor"].t_s > start
    diff = runs["floor"].f_mean_hz[sel] - runs["half_up"].f_mean_hz[sel]
    pred = {rnd: predicted_bias(b, res, 25.0, detector_bias_rad(b, res))["total"] for rnd, b in loops.items()}
    want = pred["floor"] - pred["half_up"]
    sem = _batch_sem(diff)
    assert abs(want) > 8 * sem, (want, sem)
    assert abs(diff.mean() - want) < 4 * sem, (diff.mean(), want, sem)


@pytest.mark.parametrize("table,lo,hi", [("drive", 84.0, 85.0), ("drive001", -40.0, -39.0)])
def test_over_a_chamber_ramp_the_loop_stays_locked_within_3_db_of_its_floor(design, table, lo, hi):
    """A minute of the -40 -> 85 C ramp at 1 C/min, at each end of the range: locked before the
    ramp starts and at every record of it; the temperature read from the frequency word (through
    the mode's k) within 3 dB of the float loop's on the same ADC codes (the budget's floor)."""
    from fxdsp.budget.drive_loop import ramp

    drive = design.blocks[table]
    b = ramp(drive, design.rate_full_scale_dps, lo, hi, 1.0, resonator=LOOPS[table], seed=6)
    hold = max(3.0, 6 * float(LOOPS[table].tau_s(lo)))
    assert b.fixed.lock_s is not None and b.fixed.lock_s < hold
    assert b.fixed.records >= 0.99 * (hi - lo) * 60 / b.record_s
    assert 20 * np.log10(b.mc(b.fixed.f_noise_hz) / b.mc(b.floor.f_noise_hz)) <= 3.0
    assert b.within


@pytest.mark.parametrize("temp_c", [-40.0, 85.0])
def test_the_paper001_chain_reads_the_mode_temperature_from_the_loop(design, temp_c):
    """Paper 001 from the drive ADC: the codes the loop read closed on paper 001's mode, through the
    drive loop block (its frequency word is the closed loop's mean at every record: the same loop,
    bit for bit) into chain_paper001's frequency input (the loop's Hz word is its format): the
    temperature it reads through f0 and k is the mode's within 2 mC, and the bias it subtracts from
    a zero rate is paper 001's polynomial there."""
    drive, chain = design.blocks["drive001"], design.chains["chain_paper001"]
    run = closed_loop(drive, LOOPS["drive001"], temp_c, 6.0, seed=8, record_every=96, keep_codes=True)
    f = drive.run(x=run.adc_codes).outputs["f"]
    assert drive.outputs["f"] == chain.inputs["f"]
    assert np.array_equal((f * drive.outputs["f"].lsb).reshape(-1, 96).mean(axis=1), run.f_mean_hz)
    real = chain.real_outputs(chain.run(f=f, rate_in=np.zeros(f.size, dtype=np.int64)))
    settled = slice(f.size // 2, None)
    assert abs(real["temp"][settled].mean() - temp_c) < 2e-3
    bias = 1469.5 - 36.92 * temp_c - 0.25 * temp_c ** 2      # paper 001's S(T), deg/h
    assert abs(real["rate"][settled].mean() + bias) < 0.05


def test_a_demodulator_on_an_input_reference_is_its_own_nco_bit_for_bit(design):
    """reference = "input" fed the words of its own accumulator is today's demodulator (the open-loop
    option and its vectors), bit for bit, outputs and overflow counts; its float reference reads the
    reference in turns."""
    import copy

    from fxdsp.blocks.demod import Demod
    from fxdsp.config import Section

    own = design.blocks["demod"]
    table = copy.deepcopy(design.config.data["demod"])
    table["reference"] = "input"   # (the paper 002 chain would then leave its ref open: the block alone)
    ext = Demod.from_config(Section(table, "demod"), design.fs_hz, own.in_format)
    st = own.stimulus(np.random.default_rng(21), 4096)
    words = own.nco.accumulator(st["x"].size)
    a, b = own.run(**st), ext.run(x=st["x"], ref=words)
    for port in own.outputs:
        assert a.outputs[port].tolist() == b.outputs[port].tolist(), port
    assert a.overflows == b.overflows
    x = st["x"] * own.in_format.lsb
    ra, rb = own.reference(x=x), ext.reference(x=x, ref=words / 2.0**own.nco.phase_bits)
    # the float NCO runs at the exact f_hz, the words at the quantised one: 2e-11 rad apart here
    assert np.allclose(ra["i"], rb["i"], atol=1e-9)
    with pytest.raises(ValueError, match="ref"):
        own.run(x=st["x"], ref=words)


def test_the_paper002_demodulator_on_the_loop_nco_follows_the_resonance(design):
    """chain_paper002_drive at 85 C, 15 Hz below the NCO's centre, fed the codes the loop read closed
    on paper 002's mode and a sense pick-off in phase with the drive (the pick-off itself): on the
    loop's NCO it demodulates to the amplitude in phase and nothing in quadrature; the same
    demodulator on its own NCO at the centre sees the pick-off beat at the offset."""
    import copy

    from fxdsp.blocks.demod import Demod
    from fxdsp.config import Section

    chain, drive = design.chains["chain_paper002_drive"], design.blocks["drive"]
    run = closed_loop(drive, LOOPS["drive"], 85.0, 4.0, seed=9, record_every=96, keep_codes=True)
    codes = run.adc_codes
    out = chain.real_outputs(chain.run(drive_adc=codes, vsa=codes))
    settled = slice(codes.size // 2, None)
    assert abs(out["rate_i"][settled].mean() / drive.amp_setpoint - 1) < 1e-3
    assert np.abs(out["quad"][settled]).max() < 1e-3 * drive.amp_setpoint
    table = copy.deepcopy(design.config.data["demod002"])
    table.update(reference="nco", phase_bits=drive.nco.phase_bits)   # its own accumulator, the loop's width
    own = Demod.from_config(Section(table, "demod002"), design.fs_hz, drive.in_format)
    beat = own.real_outputs(own.run(x=codes))["i"][settled]
    assert beat.std() > 0.2 * drive.amp_setpoint


def test_the_locked_reference_has_no_open_loop_drift(design):
    """A minute of lock on paper 002's mode: the Allan deviation of the reference's error (each loop's
    NCO against its own mode's motion, fixed minus float) falls at the longest tau, where an open-loop
    NCO's rounding drift would make it rise; that drift is at most half a tuning-word LSB."""
    from fxdsp.budget.drive_loop import reference_allan

    drive = design.blocks["drive"]
    a = reference_allan(drive, design.rate_full_scale_dps, seconds=60.0, seed=2)
    assert a.taus[-1] >= 10.0 and a.no_drift, (a.taus, a.adev_locked)
    assert a.open_drift_rad_per_h <= np.pi * drive.fs_hz / 2.0**drive.nco.phase_bits * 3600 * (1 + 1e-9)


def test_repro_drive_loop_without_paper_001_is_one_line():
    """--drive-loop reads paper 001's frequency: asked of another paper, one line and exit 2, before
    any reproduction runs."""
    from conftest import run_cli

    rc, err = run_cli(["repro", "--paper", "003", "--drive-loop"])
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "--drive-loop" in err and "001" in err, err


def test_a_wire_to_a_reference_the_demodulator_does_not_take_names_the_key():
    """A chain wiring the drive loop's NCO to a demodulator that runs its own (reference missing,
    misspelt or "nco") is bad input naming the table's key, before the table is read."""
    import copy

    from conftest import default_data
    from fxdsp.chains import build
    from fxdsp.config import Config
    from fxdsp.errors import InputError

    wire = "'drive.nco -> demod002.ref' drives it"
    for edit, want, then in (({"reference": "nco"}, "demod002.reference: 'nco'", wire),
                             ({"reference": None}, "demod002.reference: missing", wire),
                             ({"reference": None, "referenc": "input"}, "demod002.referenc: unknown key",
                              "did you mean 'reference'")):
        data = copy.deepcopy(default_data())
        data["demod002"].update(edit)
        data["demod002"] = {k: v for k, v in data["demod002"].items() if v is not None}
        with pytest.raises(InputError) as info:
            build(Config(data, source="<test>"))
        msg = str(info.value)
        assert msg.startswith(want) and then in msg, msg


def test_the_power_on_scenario_logs_the_acquisition(design):
    """`simulate --scenario power_on --drive-loop drive001`: the loop is switched on at the first
    row, so freq_hz starts at the NCO's centre (paper 001's 25 C resonance) and settles on the
    resonance the mode has at 50 C within a few of its time constants."""
    from fxdsp.sim import generate_log

    drive = design.blocks["drive001"]
    log, truth = generate_log("power_on", effects={}, seed=2, columns=("freq_hz",), time_step_s=0.01,
                              drive_loop=drive, return_truth=True, duration_scale=0.25)
    f, want = log["freq_hz"], truth["freq_hz"]
    assert abs(want[0] - drive.f_hz) > 1.0                       # the mode is far from the centre ...
    assert abs(f[0] - drive.f_hz) < abs(want[0] - f[0])         # ... and the loop starts nearer the centre
    near = np.abs(f - want) < 1e-3
    settled = np.flatnonzero(~near)[-1] + 1                       # from here on within 1 mHz
    tau = float(LOOPS["drive001"].tau_s(50.0))
    assert settled * 0.01 < 6 * tau and settled < f.size - 100, (settled, tau)


def _loop_only_config(tmp_path, **demod002) -> str:
    """A user's config of a drive loop and a demodulator on its NCO, nothing else (no RTL anywhere)."""
    from conftest import default_data
    from fxdsp.config import dumps

    data = {k: v for k, v in default_data().items() if k in ("system", "stimulus", "drive", "demod002")}
    data["demod002"].update(demod002)
    data["chain"] = {"mine": dict(default_data()["chain"]["paper002_drive"])}
    path = tmp_path / "loop.toml"
    path.write_text(dumps(data), encoding="utf-8")
    return str(path)


@pytest.mark.parametrize("command", ["hdl-gen", "rtl", "formal"])
def test_an_hdl_command_on_a_design_without_rtl_is_bad_input(tmp_path, command):
    """Nothing to generate, prove or verify is one line and exit 2, not "0 of 0 DUTs" and exit 0."""
    from conftest import default_data, run_cli
    from fxdsp.config import dumps

    # every kind of block has RTL now: a design of no block at all
    data = {k: v for k, v in default_data().items() if k in ("system", "stimulus")}
    path = tmp_path / "no_blocks.toml"
    path.write_text(dumps(data), encoding="utf-8")
    rc, err = run_cli([command, "--config", str(path), "--out", str(tmp_path / "out")])
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "no block or chain has RTL" in err, err
    assert not (tmp_path / "out").exists()


def test_a_reference_wired_from_a_word_that_is_not_a_phase_is_refused(tmp_path):
    """demod.ref takes an accumulator's phase word (turns): wired from the loop's Hz word it is bad
    input naming the port and the wire, not a 32-bit 'phase' read from a frequency."""
    from fxdsp.chains import build
    from fxdsp.errors import InputError

    path = _loop_only_config(tmp_path)
    text = open(path).read().replace("drive.nco -> demod002.ref", "drive.f -> demod002.ref")
    open(path, "w").write(text)
    with pytest.raises(InputError, match=r"demod002\.ref: drive\.freq_format .*'drive\.f -> demod002\.ref'"):
        build(path)


def test_the_budget_of_a_loop_whose_mode_is_not_a_thermometer(design):
    """A user's loop on the mode its table was designed for (no temperature law, k = 0): its budget
    has no mC figures (None, '-' in the text) instead of a division by zero; the rest is measured."""
    from fxdsp.budget.drive_loop import at_temperature, format_budget
    from fxdsp.sim.resonator import DriveResonator

    drive = design.blocks["drive"]
    b = at_temperature(drive, 25.0, design.rate_full_scale_dps, resonator=DriveResonator.matching(drive),
                       measure_s=2.0)
    assert b.k_hz_per_c == 0 and b.mc(1e-3) is None and b.as_dict()["fixed"]["t_noise_mc"] is None
    assert b.fixed.lock_s is not None and b.fixed.f_noise_hz > 0 and b.within
    assert " - " in format_budget(b)


def test_the_mode_twin_stepped_by_the_models_loop_reads_the_closed_loops_codes(design):
    """The co-simulation's resonator (fxdsp.sim.driveloop.ModeTwin), stepped one sample at a time by
    the bit-exact loop's own step, reads every ADC code closed_loop read (the same coefficients,
    noise and arithmetic, across temperature-step boundaries); one DAC word off (by 2000 LSB: one
    sample's impulse moves the mode by ~500 ADC LSB) and the codes part."""
    from fxdsp.blocks.drive import _drive_step
    from fxdsp.sim.driveloop import ModeTwin

    drive, res = design.blocks["drive001"], LOOPS["drive001"]
    run = closed_loop(drive, res, [-10.0, 40.0, 85.0], 0.03, seed=4, samples_per_temp=1000, keep_codes=True)

    def twin_codes(bump_at: int | None) -> np.ndarray:
        twin = ModeTwin(drive, res, [-10.0, 40.0, 85.0], 0.03, seed=4, samples_per_temp=1000)
        drive.reset()
        counts, lcounts = drive._counts()
        args = drive.kernel_args()
        codes = np.empty(twin.n, dtype=np.int64)
        for i in range(twin.n):
            codes[i] = twin.code()
            dac = _drive_step(codes[i], drive.state, drive.lpf_state, *args, counts, lcounts)
            twin.drive(dac + 2000 * (i == bump_at))
        drive.reset()
        return codes

    assert np.array_equal(twin_codes(None), run.adc_codes)
    assert not np.array_equal(twin_codes(1500), run.adc_codes)
