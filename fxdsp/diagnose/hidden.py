"""Hidden-effect cases: simulated logs with one randomly chosen cause, and the confusion matrix.

Each case draws (from its seed) a scenario, the optional columns (always including the ones its
cause needs to be observable at all, and rate_dps when the programme applies a rate), the cause's
parameters and its size. Sizes are multiples (SNR) of the effective white noise of the channel
where the cause shows: the simulator's default channel noise (output 0.05 % of S0, temp_c 0.01 C,
ref_temp_c 0.005 C, freq_hz 0.001 Hz) combined with the thermometer's noise times the channel's
temperature slope (a 0.01 C RTD noise on a 1 mV/C bias is 0.01 mV of output noise against the
baseline), so "detectable" has one meaning across sensors and units (each draw is in its cause's record,
:mod:`fxdsp.causes`):

==========================  ==================================================================
cause                       drawn parameter, and how its size is set
==========================  ==================================================================
thermal_lag                 tau_s log-uniform 300..4000 s; output and RTD noise (scaled
                            together) and freq noise set so the lag's rms effect is SNR x the
                            effective noise of each channel
ramp_rate                   k such that rms(k dT/dt) = SNR x output noise, random sign
hysteresis                  |h| = SNR x output noise, random sign
warmup                      tau_s log-uniform 900..7200 s; a such that rms over the first
                            3 tau_s = SNR x output noise, random sign
aging_drift                 r such that rms(r t/3600 - mean) = SNR x output noise, random sign
quadrature_leak             c such that rms(c (quad - mean)) = SNR x output noise, random sign
sf_nonlinearity             k3 such that rms(S k3 rate^3) = SNR x output noise, random sign
rtd_nonlinearity            b such that rms(b (Tref - 25)^2 - mean) = SNR x temp_c noise
frequency_nonlinearity      k2 such that rms(k2 (Te - 25)^2 - mean) = SNR x freq noise
none                        nothing; a third of the cases add flicker (bias instability, a
                            tenth of the white level), a third a bias random walk whose
                            standard deviation at the end of the run is WANDER x noise
==========================  ==================================================================

SNR is drawn uniformly in SNR_RANGE (5..20; ``--snr LO HI`` to probe the limit), WANDER in
WANDER_RANGE (2..10). Every log is a full chamber programme with its dwells halved
(DURATION_SCALE), 3k..6.5k rows at 10 s. Run ``fxdsp diagnose-hidden --per-cause 20`` for the
confusion matrix.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from fxdsp import logfile
from fxdsp.causes import CAUSES
from fxdsp.errors import InputError

SNR_RANGE = (5.0, 20.0)
WANDER_RANGE = (2.0, 10.0)
ALL_CAUSES = tuple(CAUSES)
# columns without which a cause cannot be seen at all
NEEDS = {c.name: c.needs for c in CAUSES.values() if c.needs}
OPTIONAL = logfile.OPTIONAL
SCENARIOS_FOR = {
    # paper000's tumble applies a = cos(theta) in {1, 0, -1}: a^3 = a, k3 cannot be told from S
    "sf_nonlinearity": ("paper002", "random"),
}
DEFAULT_SCENARIOS = ("paper002", "paper001", "paper000", "ramp", "random")
DURATION_SCALE = 0.5  # halves every dwell: ~3..4k rows per log, still one chamber run


@dataclass
class Case:
    cause: str
    seed: int
    scenario: str
    columns: tuple[str, ...]
    effects: dict
    noise: dict
    snr: float
    log: dict
    truth: dict
    causes: tuple = ()  # every hidden cause ((cause,) for one, two for a pair, () for none)
    outside: str | None = None  # an effect outside the contract's list added to the output (OUTSIDE)


def _effective_noise(truth: dict, levels: dict, columns) -> dict[str, float]:
    """White noise each channel shows against the baseline fitted on the logged thermometer: its
    own noise plus the thermometer's noise times the channel's temperature slope."""
    base = truth["baseline"]
    te, rate = truth["Te"] - base["t_ref_c"], truth["rate_dps"]
    der = np.polynomial.polynomial.polyder
    slope = (np.polynomial.polynomial.polyval(te, der(base["bias_poly"]))
             + np.polynomial.polynomial.polyval(te, der(base["sf_poly"])) * rate)
    thermometer = levels["ref_temp_c"] if "ref_temp_c" in columns else levels["temp_c"]
    return {"output": float(np.sqrt(levels["output"] ** 2 + levels["temp_c"] ** 2 * np.mean(slope ** 2))),
            "temp_c": float(np.hypot(levels["temp_c"], levels["ref_temp_c"])),
            "freq_hz": float(np.hypot(levels["freq_hz"], base["k_hz_per_c"] * thermometer))}


def make_case(cause: str, seed: int, scenario: str | None = None, snr_range=SNR_RANGE,
              second: str | None = None, outside: str | None = None, third: str | None = None) -> Case:
    """One simulated log with ``cause`` (and ``second``, for a pair, and ``third``, for a triple)
    hidden in it, and the effect ``outside`` the contract's list (OUTSIDE) added to its output."""
    if outside is not None and outside not in OUTSIDE:
        raise InputError(f"outside: unknown effect {outside!r}; expected one of {', '.join(OUTSIDE)}")
    from fxdsp.sim import generate_log  # the colleague's simulator: the ground truth of these tests

    if third is not None and second is None:
        raise InputError("third: a triple needs a second cause")
    causes = tuple(c for c in (cause, second, third) if c is not None)
    if len(causes) > 1 and (len(set(causes)) < len(causes) or "none" in causes):
        raise InputError(f"second: a pair or triple needs different causes other than none, got {causes}")
    key = [seed] + [ALL_CAUSES.index(c) for c in causes]
    rng = np.random.default_rng(key)
    allowed = [s for s in DEFAULT_SCENARIOS if all(s in SCENARIOS_FOR.get(c, DEFAULT_SCENARIOS) for c in causes)]
    scenario = scenario or str(rng.choice(allowed))
    if "sf_nonlinearity" in causes and scenario == "random":
        # a random programme may draw no rate table: move to the next seed that has one
        sub = 0
        while True:
            probe = generate_log(scenario, {}, seed=seed * 1000 + sub, columns=("rate_dps",),
                                 duration_scale=DURATION_SCALE, noise="off")
            if np.ptp(probe["rate_dps"]) > 0:
                break
            sub += 1
        sim_seed = seed * 1000 + sub
    else:
        sim_seed = seed
    extra = [c for c in OPTIONAL if rng.random() < 0.5]
    needed = tuple(n for c in causes for n in NEEDS.get(c, ()))
    probe = generate_log(scenario, {}, seed=sim_seed, columns=("rate_dps",), duration_scale=DURATION_SCALE,
                         noise="off")
    if np.ptp(probe["rate_dps"]) > 0:
        needed = needed + ("rate_dps",)  # without it the rate table is an unexplained output
    columns = tuple(c for c in OPTIONAL if c in extra or c in needed)
    kw = dict(seed=sim_seed, duration_scale=DURATION_SCALE)
    clean, truth0 = generate_log(scenario, {}, columns=OPTIONAL, noise="off", return_truth=True, **kw)
    from fxdsp.sim.noise import default_noise
    levels = default_noise(truth0["baseline"]["sf_poly"][0])
    sigma = _effective_noise(truth0, levels, columns)
    effects: dict = {}
    noise: dict = {}
    snrs = []
    # a lag sets the channel noise itself (its size is set by scaling the noise): draw it first,
    # and size the other cause against the noise the log will really have
    for c in sorted(causes, key=lambda c: c != "thermal_lag"):
        snr = float(rng.uniform(*snr_range))
        sign = 1.0 if rng.random() < 0.5 else -1.0
        e, n = _draw_effect(c, rng, snr, sign, scenario, kw, clean, truth0, levels, sigma)
        effects.update(e)
        noise.update(n)
        snrs.append(snr)
        sigma = _effective_noise(truth0, {**levels, **{k: v for k, v in noise.items() if k in levels}}, columns)
    log, truth = generate_log(scenario, effects, columns=columns, noise=noise or None,
                              return_truth=True, **kw)
    case = Case(cause, seed, scenario, columns, effects, noise, snrs[0], log, truth)
    case.causes = causes if cause != "none" else ()
    if outside is not None:
        # drawn from its own stream: the in-contract part of the case is the same with or without it
        orng = np.random.default_rng(key + [len(ALL_CAUSES) + list(OUTSIDE).index(outside)])
        shape = OUTSIDE[outside](orng, log["time_s"], truth)
        shape = shape - np.mean(shape)
        size = float(orng.uniform(*snr_range)) * sigma["output"]
        log["output"] = log["output"] + shape * (size / max(float(np.std(shape)), 1e-300))
        case.outside = outside
        case.truth = {**truth, "outside": {"effect": outside, "rms": size}}
    return case


def _outside_step(rng, t, truth):
    """A level change at one instant in the middle 60 % of the run (a mode hop, a connector moved)."""
    return (t >= t[0] + rng.uniform(0.2, 0.8) * (t[-1] - t[0])).astype(float)


def _outside_periodic(rng, t, truth):
    """A slow periodic term unrelated to the chamber (the lab's air conditioning, a supply's cycle):
    3 .. 12 periods per run, random phase."""
    return np.sin(2.0 * np.pi * rng.uniform(3.0, 12.0) * (t - t[0]) / (t[-1] - t[0]) + rng.uniform(0, 2 * np.pi))


def _outside_two_lags(rng, t, truth):
    """A second, slower thermal path: the output also follows the temperature through a lag of
    5 .. 20 % of the run (a lag with two time constants; one lag absorbs only part of it)."""
    from fxdsp import mechanisms as mech

    temp = truth["temp_c"]
    return mech.first_order_lag(t, temp, rng.uniform(0.05, 0.2) * (t[-1] - t[0]), initial=float(temp[0])) - temp


def _outside_sloped_hysteresis(rng, t, truth):
    """A heating/cooling difference that grows with temperature (a hysteresis that is no constant
    offset: the constant part is the contract's hysteresis, the slope is not)."""
    from fxdsp import mechanisms as mech

    temp = truth["temp_c"]
    x = (temp - 0.5 * (temp.max() + temp.min())) / max(0.5 * float(np.ptp(temp)), 1.0)
    return mech.ramp_direction(t, temp) * x


# effects outside the contract's list, as shapes of the output in time (scaled to SNR x its noise)
OUTSIDE = {"step": _outside_step, "periodic": _outside_periodic, "two_lags": _outside_two_lags,
           "sloped_hysteresis": _outside_sloped_hysteresis}


@dataclass
class _Draw:
    """What a cause's draw (fxdsp.causes) reads: the generator's random stream, the SNR and sign
    drawn for it, the clean log and its truth, the channels' effective noise and the noise levels."""

    rng: np.random.Generator
    snr: float
    sign: float
    clean: dict
    truth: dict
    sigma: dict
    levels: dict
    scenario: str
    kw: dict

    @property
    def t(self) -> np.ndarray:
        return self.clean["time_s"]

    def simulate(self, effects: dict) -> dict:
        """The noise-free log of the same run with ``effects``."""
        from fxdsp.sim import generate_log

        return generate_log(self.scenario, effects, columns=OPTIONAL, noise="off", **self.kw)


def _draw_effect(cause, rng, snr, sign, scenario, kw, clean, truth0, levels, sigma):
    """(effects, noise) of one cause, sized to ``snr`` x the channel's effective white noise."""
    if cause != "none":
        return CAUSES[cause].draw(_Draw(rng, snr, sign, clean, truth0, sigma, levels, scenario, kw))
    noise: dict = {}
    kind = rng.integers(3)
    if kind == 1:
        # flicker at a tenth of the white level per sample: a wandering bias, not a cause
        noise["bias_instability"] = 0.1 * levels["output"]
    elif kind == 2:
        # bias random walk that wanders WANDER_RANGE x the effective noise over the run: the
        # look-alike of aging, warm-up and hysteresis
        t = clean["time_s"]
        wander = float(rng.uniform(*WANDER_RANGE))
        noise["rate_random_walk"] = wander * sigma["output"] / np.sqrt(t[-1] - t[0])
    return {}, noise


def diagnose_case(case: Case):
    from fxdsp.diagnose.api import diagnose_columns

    return diagnose_columns(case.log, source="sim")


def parameters_within(case: Case, found: dict, tolerance: float = 0.25) -> bool:
    if case.cause == "none":
        return True
    truth = case.effects[case.cause]
    return all(abs(found.get(k, np.nan) - v) <= tolerance * abs(v) for k, v in truth.items())


@dataclass
class Confusion:
    """Outcome of :func:`confusion`: ``matrix[truth, found]`` over ALL_CAUSES (found: the first cause
    named, ``none`` when none), per-cause counts of the checks, and one tuple per case that missed."""

    per_cause: int
    causes: tuple[str, ...]
    matrix: np.ndarray
    params_ok: dict[str, int]
    gain_ok: dict[str, int]
    extra: dict[str, int]
    failures: list[tuple]
    seconds: float
    flagged: dict[str, int] = field(default_factory=dict)   # reports whose `remaining` is significant
    outside: str | None = None                              # the effect outside the list every case has


def case_outcome(case: Case, diag) -> dict:
    """What one case's diagnosis found, as plain data (JSON-able): the record the confusion tally
    reads, here and in `fxdsp sweep hidden`."""
    cause = case.cause
    got = diag.causes[0] if diag.causes else "none"
    found = diag.parameters.get(cause)
    return {"scenario": case.scenario, "columns": list(case.columns), "snr": case.snr, "found": list(diag.causes),
            "outside": case.outside, "flagged": bool(diag.remaining["significant"]),
            "first": got,
            "params_ok": bool(got == cause and parameters_within(case, diag.parameters.get(cause, {}))),
            "gain_ok": bool(cause == "none" or diag.gain["ratio"] > 1.3), "gain_ratio": float(diag.gain["ratio"]),
            "parameters": found, "truth": case.effects.get(cause)}


def tally(per_cause: int, causes, outcomes, seconds: float = 0.0) -> Confusion:
    """The confusion of ``outcomes``: (cause, case seed, case_outcome record) per case."""
    causes = tuple(causes)
    index = {c: i for i, c in enumerate(ALL_CAUSES)}
    matrix = np.zeros((len(ALL_CAUSES), len(ALL_CAUSES)), dtype=int)
    params_ok = {c: 0 for c in causes}
    gain_ok = {c: 0 for c in causes}
    extra = {c: 0 for c in causes}
    flagged = {c: 0 for c in causes}
    failures = []
    for cause, seed, r in outcomes:
        flagged[cause] += bool(r.get("flagged"))
        matrix[index[cause], index[r["first"]]] += 1
        params_ok[cause] += r["params_ok"]
        gain_ok[cause] += r["gain_ok"]
        extra[cause] += len(r["found"]) > 1
        if r["first"] != cause or not r["params_ok"] or not r["gain_ok"] or len(r["found"]) > 1:
            failures.append((cause, seed, r["scenario"], tuple(r["columns"]), round(r["snr"], 1), r["found"],
                             r["parameters"], r["truth"], round(r["gain_ratio"], 2)))
    outside = next((r.get("outside") for _, _, r in outcomes if r.get("outside")), None)
    return Confusion(per_cause, causes, matrix, params_ok, gain_ok, extra, failures, seconds, flagged, outside)


def check_snr_range(snr_range, field: str = "--snr") -> tuple[float, float]:
    """(LO, HI) of a range of SNRs a case's size is drawn from: finite, 0 < LO <= HI (an SNR of 0 or
    below would hide a cause in a log labelled with it; a non-finite one sizes nothing)."""
    lo, hi = (float(x) for x in snr_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise InputError(f"{field}: need finite 0 < LO <= HI, got {lo} {hi}")
    return lo, hi


def confusion(per_cause: int, first_seed: int = 1000, causes=ALL_CAUSES, snr_range=SNR_RANGE,
              outside: str | None = None) -> Confusion:
    """Run ``per_cause`` cases per cause (each with the effect ``outside`` the list, if given) and
    tally what the diagnosis names and whether its report says structure remains."""
    unknown = [c for c in causes if c not in ALL_CAUSES]
    if unknown:
        raise InputError(f"causes: unknown cause {unknown[0]!r}; expected some of {', '.join(ALL_CAUSES)}")
    if per_cause < 1:
        raise InputError(f"per_cause: need at least 1 case per cause, got {per_cause}")
    if first_seed < 0:
        raise InputError(f"first_seed: must be >= 0, got {first_seed}")
    snr_range = check_snr_range(snr_range)
    start = time.perf_counter()
    outcomes = []
    for cause in causes:
        for k in range(per_cause):
            case = make_case(cause, first_seed + k, snr_range=snr_range, outside=outside)
            outcomes.append((cause, case.seed, case_outcome(case, diagnose_case(case))))
    return tally(per_cause, causes, outcomes, time.perf_counter() - start)


def format_confusion(res: Confusion, timing: bool = True) -> str:
    """The matrix (rows: truth, columns: found, causes abbreviated), the per-cause checks, the timing
    line (unless ``timing`` is False: files keep no wall-clock time) and the misses."""
    n = res.per_cause
    lines = [f"{'truth / found':24s}" + "".join(f"{c[:6]:>7s}" for c in ALL_CAUSES)
             + "   params<=25%  gain>1.3  extra causes  remaining"]
    for c in res.causes:
        lines.append(f"{c:24s}" + "".join(f"{v:7d}" for v in res.matrix[ALL_CAUSES.index(c)]) +
                     f"   {res.params_ok[c]:5d}/{n:<5d} {res.gain_ok[c]:5d}/{n:<5d} {res.extra[c]:5d}"
                     f"         {res.flagged.get(c, 0):5d}/{n:<5d}")
    if res.outside:
        lines.insert(0, f"every case also has an effect outside the contract's list: {res.outside}")
    if timing:
        lines.append(f"{len(res.causes) * n} cases in {res.seconds:.0f} s")
    lines += [" ".join(["miss:", *map(str, f)]) for f in res.failures]
    return "\n".join(lines)
