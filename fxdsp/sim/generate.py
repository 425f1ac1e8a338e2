"""Synthetic chamber logs in the canonical format: the baseline of the contract plus chosen causes.

The log is built in the order the physics happens:

1. the chamber programme gives the air temperature, the rate-table rate and the tumble angle;
2. the heat path (isothermal by default, see :mod:`fxdsp.sim.thermal`) gives the RTD node and die
   temperatures; the RTD readout is linear (offset, gain) unless ``rtd_nonlinearity`` bends it;
3. Te, the temperature of the sensing element on the RTD's linear scale, equals the noise-free
   ``temp_c`` in the baseline; ``thermal_lag`` delays it by the contract's first-order lag;
4. output = B(Te) + S(Te) * rate (+ this run's repeatability offsets, :mod:`fxdsp.sim.repeatability`,
   when asked), then the output causes; freq_hz = f0 + k Te (+ turnover);
5. independent noise per channel, each from its own random stream so that requesting one more
   column never changes the noise of the others.

Causes are injected with :mod:`fxdsp.mechanisms` (the same functions the diagnosis fits). Derivative
and ramp-state causes are driven by the noise-free temp_c: the physics responds to the true
temperature change, not to the ADC noise on its reading.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from fxdsp.causes import inject
from fxdsp.errors import InputError
from fxdsp.sim import noise as noise_mod
from fxdsp.sim.model import Baseline, as_model, scenario_baseline, validate_effects
from fxdsp import logfile
from fxdsp.sim.programmes import PROGRAMMES, programme, sample
from fxdsp.sim.repeatability import Repeatability
from fxdsp.sim.thermal import ThermalChain

SCENARIOS: tuple[str, ...] = tuple(PROGRAMMES)
REQUIRED_COLUMNS = logfile.REQUIRED   # the contract's columns, said once in the log file's module
OPTIONAL_COLUMNS = logfile.OPTIONAL
DEFAULT_TIME_STEP_S = 10.0

# quadrature: a level of 2 S0 (i.e. 2 deg/s-equivalent, typical of an untrimmed MEMS gyro) wandering
# by +-0.5 S0 on periods of 1..6 h, drawn from its own stream: independent of the temperature programme
QUAD_MEAN_PER_SF = 2.0
QUAD_SWING_PER_SF = 0.5

# appending a stream leaves the others unchanged (SeedSequence.spawn: child i depends on i only)
_STREAMS = ("programme", "quad", "output", "temp_c", "ref_temp_c", "freq_hz", "quad_noise", "repeatability")


def parse_columns(columns) -> tuple[str, ...]:
    """The optional columns asked for (a list or "a,b"), each once, in order; ValueError naming an unknown one."""
    if isinstance(columns, str):
        columns = [c.strip() for c in columns.split(",") if c.strip()]
    out = []
    for name in columns:
        if name in REQUIRED_COLUMNS:
            continue  # always present; asking for them is harmless
        if name not in OPTIONAL_COLUMNS:
            raise InputError(f"columns: unknown column {name!r}; optional columns are "
                             f"{', '.join(OPTIONAL_COLUMNS)}")
        if name not in out:
            out.append(name)
    return tuple(out)


def _quadrature(rng: np.random.Generator, time_s: np.ndarray, sf0: float) -> np.ndarray:
    periods = rng.uniform(3600.0, 6 * 3600.0, size=3)
    phases = rng.uniform(0, 2 * np.pi, size=3)
    weights = rng.uniform(0.5, 1.0, size=3)
    swing = sum(w * np.sin(2 * np.pi * time_s / p + ph) for w, p, ph in zip(weights, periods, phases))
    swing /= weights.sum()
    return abs(sf0) * (QUAD_MEAN_PER_SF + QUAD_SWING_PER_SF * swing)


def _applied_input(scenario: str, sampled) -> np.ndarray:
    if scenario == "paper000":
        # accelerometer: the input column carries a = g cos(theta), in g (what the operator applies)
        return np.round(np.cos(np.deg2rad(sampled.angle_deg)), 12)
    return sampled.rate_dps


RTD_ELEMENTS = ("ideal", "pt_bridge")


def _rtd_readout(t_c: np.ndarray, element: str) -> np.ndarray:
    """Temperature the readout reports for an element at t_c."""
    if element not in RTD_ELEMENTS:
        raise InputError(f"rtd_element: unknown {element!r}; expected one of {', '.join(RTD_ELEMENTS)}")
    if element == "ideal":
        return t_c
    from fxdsp.blocks.rtd import RtdPhysics

    real = RtdPhysics(law="cvd")  # the bridge of paper 002 with a 500-Ohm IEC 60751 platinum element
    assumed = RtdPhysics(law="linear", beta_per_c=real.a)  # the paper's linear law, slope = CVD A
    return assumed.temperature_from_fraction(real.adc_fraction(real.resistance(t_c)))


def _through_loop(drive, t, freq, die_c, stream, progress: bool, warmup_s: float) -> np.ndarray:
    """The freq_hz column read through ``drive`` closed on the simulated resonance, the loop
    switched on ``warmup_s`` before the first row's interval."""
    from fxdsp.sim.driveloop import loop_frequency
    from fxdsp.sim.resonator import resonator_for

    lo, hi = float(np.min(freq)), float(np.max(freq))
    if lo < drive.f_hz - drive.lock_range_hz or hi > drive.f_hz + drive.lock_range_hz:
        raise InputError(f"drive loop [{drive.name}]: the simulated resonance spans {lo:.4f} .. {hi:.4f} Hz, outside "
                         f"its f_hz +- lock_range_hz = {drive.f_hz:g} +- {drive.lock_range_hz:g} Hz")
    return loop_frequency(drive, resonator_for(drive), t, freq, die_c, seed=int(stream.integers(2**62)),
                          warmup_s=warmup_s, progress=progress)


def generate_log(scenario: str = "paper002", effects: dict | None = None, seed: int = 0,
                 columns=OPTIONAL_COLUMNS, *, return_truth: bool = False,
                 time_step_s: float = DEFAULT_TIME_STEP_S, duration_scale: float = 1.0,
                 noise: dict | str | None = None, model=None, thermal: ThermalChain | None = None,
                 rtd_element: str = "ideal", repeatability: Repeatability | None = None, drive_loop=None,
                 progress: bool = False):
    """Simulate one chamber run and return its canonical log.

    Parameters
    ----------
    scenario : one of :data:`SCENARIOS` (the chamber programme and, unless ``model`` is given, the
        sensor's baseline; see :mod:`fxdsp.sim.programmes` and :mod:`fxdsp.sim.model`).
    effects : ``{cause: {parameter: value}}`` with the contract's names (``{}``: baseline only).
        They are added to the effects of ``model`` (same cause: these win).
    seed : integer seed; the same arguments give identical arrays.
    columns : optional contract columns to include (iterable or "a,b" string); ``time_s``,
        ``temp_c`` and ``output`` are always present.
    return_truth : also return a dict of the noise-free signals and the model used.
    time_step_s : sample interval (default 10 s: a paper002 run is about 6000 rows).
    duration_scale : multiplies every hold (dwell, log, rate step, tumble position); ramps keep
        the chamber's physical ramp rate.
    noise : overrides of :func:`fxdsp.sim.noise.default_noise` keys (``output``, ``temp_c``,
        ``ref_temp_c``, ``freq_hz``, ``quad``, ``bias_instability``, ``rate_random_walk``), or
        ``"off"`` for a noise-free log.
    model : a replay model (path, dict or :class:`fxdsp.sim.model.Model`) replacing the scenario's
        baseline; its effects are applied too.
    thermal : an optional :class:`fxdsp.sim.thermal.ThermalChain` (air -> package -> die); ``None``
        keeps the contract's isothermal baseline.
    rtd_element : ``"ideal"`` (the contract's linear thermometer) or ``"pt_bridge"``: a real platinum
        element (IEC 60751 Callendar-Van Dusen) in paper 002's bridge and in-amp
        (:class:`fxdsp.blocks.rtd.RtdPhysics`), read out with the linear law RT = R0 (1 + A T) as
        paper 002 does: the readout then bends by about B/A (T - 25)^2, -0.5 C at 60 C, which is
        what ``rtd_nonlinearity`` describes.
    repeatability : an optional :class:`fxdsp.sim.repeatability.Repeatability`: this run's turn-on
        and per-temperature-point bias and SF offsets, drawn from the run's own stream (``None``, the
        default: the device repeats exactly, as the contract's baseline does).
    drive_loop : an optional drive loop (:class:`fxdsp.blocks.drive.Drive`): ``freq_hz`` is then read
        as the papers' instrument reads it, through the bit-exact loop closed at 96 kS/s on a mode
        whose resonance is the simulated one (:func:`fxdsp.sim.driveloop.loop_frequency`: each row
        the mean over its interval; about 70 s of computing per simulated hour), instead of the
        resonance plus white noise. The resonance must stay within the loop's lock range.

    Returns
    -------
    ``log`` (dict column -> float array), or ``(log, truth)`` with ``return_truth=True``.
    """
    if scenario not in SCENARIOS:
        raise InputError(f"scenario: unknown name {scenario!r}; expected one of {', '.join(SCENARIOS)}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed: must be a non-negative integer, got {seed!r}")
    wanted = parse_columns(columns)
    replay = as_model(model)
    baseline: Baseline = scenario_baseline(scenario)
    if replay:  # the fields the replay model gives replace the scenario's
        baseline = dataclasses.replace(baseline, **{k: getattr(replay.baseline, k) for k in replay.given})
    causes = dict(replay.effects) if replay else {}
    causes.update(validate_effects(effects))
    streams = dict(zip(_STREAMS, (np.random.default_rng(s)
                                  for s in np.random.SeedSequence(int(seed)).spawn(len(_STREAMS)))))

    segments, start_c, loop_warmup_s = programme(scenario, float(duration_scale), streams["programme"])
    run = sample(segments, start_c, float(time_step_s))
    t, n = run.time_s, run.time_s.size

    # --- temperatures -------------------------------------------------------------------------
    nodes = (thermal.temperatures(t, run.air_c) if thermal
             else {"air": run.air_c, "package": run.air_c, "die": run.air_c})
    rtd_true = nodes[thermal.rtd_node] if thermal else run.air_c
    signals = {"t": t, "rtd_true": rtd_true}   # what a cause's injection may read (fxdsp.causes)
    rtd_c = inject("rtd", _rtd_readout(rtd_true, rtd_element), causes, signals)
    temp_clean = baseline.rtd_offset_c + baseline.rtd_gain * rtd_c
    te = baseline.rtd_offset_c + baseline.rtd_gain * nodes["die"]  # the die on the RTD's linear scale
    te = inject("te", te, causes, signals)

    # --- output and resonator ------------------------------------------------------------------
    rate = _applied_input(scenario, run)
    effective_rate = inject("rate", rate, causes, signals)
    output = baseline.bias(te) + baseline.sf(te) * effective_rate
    rep_draw = None
    if repeatability is not None:
        if not isinstance(repeatability, Repeatability):
            raise InputError(f"repeatability: expected a Repeatability, got {type(repeatability).__name__}")
        rep_bias, rep_sf, rep_draw = repeatability.offsets(streams["repeatability"], t, segments, start_c)
        output = output + baseline.sf_poly[0] * rep_bias + baseline.sf(te) * rep_sf * effective_rate
    quad = _quadrature(streams["quad"], t, baseline.sf_poly[0])
    signals.update(temp_clean=temp_clean, te=te, quad=quad)
    output = inject("output", output, causes, signals)
    freq = inject("freq", baseline.freq(te), causes, signals)

    # --- noise ----------------------------------------------------------------------------------
    levels = noise_mod.resolve_noise(noise, baseline.sf_poly[0])
    dt = float(time_step_s)
    log = {"time_s": t.copy(),
           "temp_c": temp_clean + noise_mod.white(streams["temp_c"], n, levels["temp_c"]),
           "output": output + noise_mod.output_noise(streams["output"], n, dt, levels)}
    optional = {
        "ref_temp_c": lambda: run.air_c + noise_mod.white(streams["ref_temp_c"], n, levels["ref_temp_c"]),
        "rate_dps": lambda: np.asarray(rate, float).copy(),
        "freq_hz": lambda: freq + noise_mod.white(streams["freq_hz"], n, levels["freq_hz"]),
        "quad": lambda: quad + noise_mod.white(streams["quad_noise"], n, levels["quad"]),
    }
    if drive_loop is not None:
        if "freq_hz" not in wanted:   # the loop would run for nothing and the caller not know it
            raise InputError(f"drive_loop [{drive_loop.name}]: columns has no freq_hz to read through it")
        optional["freq_hz"] = lambda: _through_loop(drive_loop, t, freq, nodes["die"], streams["freq_hz"], progress,
                                                    loop_warmup_s)
    for name in wanted:
        log[name] = optional[name]()
    if not return_truth:
        return log
    truth = {
        "scenario": scenario, "seed": int(seed), "time_step_s": dt,
        "Te": te, "air_temp_c": run.air_c, "package_temp_c": nodes["package"], "die_temp_c": nodes["die"],
        "temp_c": temp_clean, "ref_temp_c": run.air_c, "output": output, "freq_hz": freq, "quad": quad,
        "rate_dps": np.asarray(rate, float), "angle_deg": run.angle_deg, "setpoint_c": run.setpoint_c,
        "phase": run.phase, "segment": run.segment,
        "baseline": baseline.as_dict(), "effects": {k: dict(v) for k, v in causes.items()},
        "noise": levels, "thermal": thermal,
    }
    if rep_draw is not None:
        truth["repeatability"] = rep_draw
    return log, truth
