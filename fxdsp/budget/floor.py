"""How far the design is from what its input ADCs allow, how its error behaves over averaging
time, and how it moves with the drive frequency.

* Floor and margin: the floor of an output is the quantisation of the input ADCs carried to it,
  the power sum of the one-source errors of the ``ADC quantisation`` sources of the attribution.
  The margin is 20 log10(total / floor); a design within ``WITHIN_DB`` of its floor spends its bits
  well. A non-ADC source whose rms is at least half the total (its power within 6 dB of the total
  power) dominates the design error and is named.
* Allan deviation of the fixed-minus-float error of every output of a chain with a demodulator
  (its samples are at the design's rate), at constant temperature and input (``allantools.oadev``,
  octave-spaced averaging factors): bias instability (minimum of the curve) and the random walk the
  fixed-point design adds (adev at tau = 1 s / 60; the angle random walk for a rate in deg/h).
* Drive-frequency sweep of every such chain: the demodulator reference tracks the drive loop, whose
  frequency moves with temperature, w(T) = w0 [1 - a (T - T0) / 2]; the chain error is measured at
  drive frequencies across the band that the sensor's temperature range produces.

Everything returns data; ``fxdsp budget`` (cli.py) prints it.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.signal as sps

from fxdsp.chains import Design, build
from fxdsp.config import Config, table_at
from fxdsp.float_vs_fixed import port_unit
from fxdsp.budget.attribution import Attribution
from fxdsp.budget.hybrid import ADC, lowpass_of
from fxdsp.budget.optimise import chain_only, demod_of
from fxdsp.budget.static import static_errors
from fxdsp.budget.table import budget_rows
from fxdsp.errors import InputError

WITHIN_DB = 3.0          # "within 3 dB of its floor"
DOMINANT_FACTOR = 0.5    # rms >= total / 2: power within 20 log10(2) = 6.02 dB of the total power

FLICKER_FACTOR = 0.664   # IEEE 952: on the flicker floor sigma(tau) = 0.664 B, so B = min(adev) / 0.664
ALLAN_SAMPLES = 2**20    # 10.9 s at 96 kHz: tau = 1 s is measured, with 10 intervals, not extrapolated
ALLAN_TEMP_C = 25.0      # at T0 of the drive-frequency law (the input: the sensor's STEADY_LEVEL)
MIN_INTERVALS = 4        # a tau needs at least 4 intervals of the record for a usable estimate
SETTLE_TOL = 1e-6        # the filters have settled when their step response is this close to its end
WHITE_SLOPE = (-0.75, -0.25)   # local log-log slope accepted as the tau^-1/2 (white noise) part

SILICON_PPM_PER_C = 60.0       # a of silicon: w(T) = w0 [1 - a (T - T0) / 2]
T0_C = 25.0
TEMP_RANGE_C = (-40.0, 85.0)
SWEEP_POINTS = 21


# ----------------------------------------------------------------------------------------------
# Floor and margin
# ----------------------------------------------------------------------------------------------
@dataclass
class Floor:
    chain: str
    port: str
    unit: str
    floor: float                 # rms of the power sum of the ADC sources (0: no ADC reaches the output)
    total: float                 # total rms of the attribution (bit-exact vs float on the analog inputs)
    adc_sources: list[str]
    dominant: list[tuple[str, float]]   # (name, rms) of the non-ADC sources with rms >= total / 2

    @property
    def margin_db(self) -> float | None:
        """20 log10(total / floor); None when either is 0 (no ADC, or no error: no ratio)."""
        if self.floor <= 0 or self.total <= 0:
            return None
        return 20 * math.log10(self.total / self.floor)

    @property
    def within(self) -> bool | None:
        m = self.margin_db
        return None if m is None else m <= WITHIN_DB

    def as_dict(self) -> dict:
        return {"chain": self.chain, "port": self.port, "unit": self.unit, "floor": self.floor,
                "total": self.total, "margin_db": self.margin_db, "within_db": WITHIN_DB,
                "within": self.within, "adc_sources": self.adc_sources,
                "dominant_factor": DOMINANT_FACTOR,
                "dominant": [{"name": n, "rms": r} for n, r in self.dominant]}


def floor_of(att: Attribution) -> Floor:
    """Floor, total and dominant sources of one attributed output."""
    adc = [s for s in att.sources if s.source.category == ADC]
    floor = math.sqrt(sum(s.rms**2 for s in adc))
    # a source at 0 never dominates, even when the total is 0 too
    dominant = [(s.source.name, s.rms) for s in sorted(att.sources, key=lambda s: -s.rms)
                if s.source.category != ADC and s.rms > 0 and s.rms >= DOMINANT_FACTOR * att.total_rms]
    return Floor(att.chain, att.port, att.unit, floor, att.total_rms, [s.source.name for s in adc], dominant)


# ----------------------------------------------------------------------------------------------
# Allan deviation
# ----------------------------------------------------------------------------------------------
@dataclass
class Allan:
    chain: str
    port: str
    unit: str
    fs: float
    samples: int                 # measured samples (after the settling)
    settle: int                  # samples discarded first
    temp_c: float
    level: float                 # the constant physical input (the sensor's unit, e.g. rate in FS)
    taus: np.ndarray             # s
    adev: np.ndarray             # unit
    intervals: np.ndarray        # number of averages allantools used per tau
    bi_adev: float               # minimum of the curve
    bi_tau: float
    adev_1s: float               # measured at tau = 1 s, or extrapolated (see fit_taus)
    fit_taus: list[float] = field(default_factory=list)   # empty: measured; else the tau^-1/2 points used
    error: np.ndarray | None = None   # the error signal (unit), not exported

    @property
    def measured_1s(self) -> bool:
        return not self.fit_taus

    @property
    def bi_at_longest_tau(self) -> bool:
        """The minimum sits at the end of the curve: still falling, so only an upper bound."""
        return bool(self.taus.size) and self.bi_tau == float(self.taus[-1])

    @property
    def flicker_floor(self) -> float:
        return self.bi_adev / FLICKER_FACTOR

    @property
    def arw(self) -> float:
        """unit x sqrt(h) (deg/sqrt(h) for a rate in deg/h): sigma(1 s) times sqrt(1 s in h) = sigma / 60."""
        return self.adev_1s / 60.0

    def as_dict(self) -> dict:
        return {"chain": self.chain, "port": self.port, "unit": self.unit, "fs_hz": self.fs, "samples": self.samples,
                "settle_samples": self.settle, "temp_c": self.temp_c, "level": self.level,
                "curve": [{"tau_s": float(t), "adev": float(a), "intervals": float(n)}
                          for t, a, n in zip(self.taus, self.adev, self.intervals)],
                "bias_instability": {"min_adev": self.bi_adev, "tau_s": self.bi_tau,
                                     "at_longest_tau": self.bi_at_longest_tau,
                                     "flicker_floor": self.flicker_floor, "flicker_factor": FLICKER_FACTOR},
                "arw": {"adev_1s": self.adev_1s, "measured": self.measured_1s, "fit_taus_s": self.fit_taus,
                        "value": self.arw, "unit": "deg/sqrt(h)" if self.unit == "deg/h" else f"{self.unit} sqrt(h)"}}


def chain_filters(chain) -> list[np.ndarray]:
    """The float low-passes of the chain in execution order (iir members, demodulators' channel filters)."""
    return [f.sos for f in (lowpass_of(chain, p) for p in chain.netlist.order) if f is not None]


def settling_samples(chain, tol: float = SETTLE_TOL) -> int:
    """Samples until the step response of the chain's float low-passes (all in cascade) stays
    within ``tol`` of its final value: the start-up transient is not part of the noise. 0 for a
    chain without a filter."""
    if not 0 < tol < 1:
        raise InputError(f"tol: must be within (0, 1), got {tol}")
    filters = chain_filters(chain)
    if not filters:
        return 0
    sos = np.vstack(filters)
    n = 4096
    while True:
        step = sps.sosfilt(sos, np.ones(n))
        final = step[-1]
        off = np.nonzero(np.abs(step - final) > tol * abs(final))[0]
        last = int(off[-1]) + 1 if off.size else 0
        if last < n // 2 or n >= 2**22:  # the tail is long enough to trust the final value
            return last
        n *= 2


def octave_taus(samples: int, fs: float) -> np.ndarray:
    """tau = m / fs for m = 1, 2, 4, ... while the record holds MIN_INTERVALS of them."""
    m = 2 ** np.arange(int(math.log2(max(samples // MIN_INTERVALS, 1))) + 1)
    return m / fs


def white_fit(taus: np.ndarray, adev: np.ndarray) -> tuple[float, list[float]]:
    """adev at 1 s extrapolated along tau^-1/2 from the white-noise part of the curve nearest to
    1 s (the longest-tau run of points whose local slope is -1/2 +- 1/4): a filtered error is white
    only beyond the filter's correlation time, so the shortest taus can understate it. Returns
    (N = adev(tau) sqrt(tau) averaged in log over the run, the taus used)."""
    ok = adev > 0
    t, a = taus[ok], adev[ok]
    if t.size == 0:
        return 0.0, []
    if t.size == 1:
        return float(a[0] * math.sqrt(t[0])), [float(t[0])]
    slope = np.diff(np.log(a)) / np.diff(np.log(t))
    white = (slope >= WHITE_SLOPE[0]) & (slope <= WHITE_SLOPE[1])
    if not white.any():  # no white part: assume it starts at the last point (stated by fit_taus)
        return float(a[-1] * math.sqrt(t[-1])), [float(t[-1])]
    end = int(np.nonzero(white)[0][-1])
    start = end
    while start > 0 and white[start - 1]:
        start -= 1
    idx = np.arange(start, end + 2)
    n = float(np.exp(np.mean(np.log(a[idx] * np.sqrt(t[idx])))))
    return n, [float(x) for x in t[idx]]


def allan_figures(error: np.ndarray, fs: float) -> dict:
    """Octave-spaced Allan curve of ``error`` (rate samples at ``fs``), its minimum, and adev at
    tau = 1 s (measured if the record holds MIN_INTERVALS seconds, else extrapolated)."""
    # imported here, as drive_loop does: allantools (and the scipy.stats it loads) was 1.2 s of every
    # `fxdsp budget` start, a --help or a refused option included
    import allantools

    e = np.asarray(error, dtype=float)
    if fs <= 0:
        raise InputError(f"fs: must be > 0, got {fs}")
    if e.size < 2 * MIN_INTERVALS:
        raise InputError(f"error: need at least {2 * MIN_INTERVALS} samples, got {e.size}")
    taus, adev, _, ns = allantools.oadev(e, rate=fs, data_type="freq", taus=octave_taus(e.size, fs))
    taus, adev, ns = np.asarray(taus, float), np.asarray(adev, float), np.asarray(ns, float)
    k = int(np.argmin(adev))
    m1 = round(fs)  # averaging factor of tau = 1 s
    if e.size >= MIN_INTERVALS * m1:
        _, a1, _, _ = allantools.oadev(e, rate=fs, data_type="freq", taus=[m1 / fs])
        adev_1s, fit = float(a1[0]), []
    else:
        adev_1s, fit = white_fit(taus, adev)
    return {"taus": taus, "adev": adev, "intervals": ns, "bi_adev": float(adev[k]), "bi_tau": float(taus[k]),
            "adev_1s": adev_1s, "fit_taus": fit}


def carrier_chains(design: Design) -> list[str]:
    """The chains with a demodulator and a sensor: their samples are at the design's rate and they
    follow a drive frequency (the Allan deviation and the drive sweep apply)."""
    return [n for n, c in design.chains.items() if c.sensor is not None and "demod" in c.kinds.values()]


def allan_errors(design: Design, chain_name: str, ports, samples: int = ALLAN_SAMPLES,
                 temp_c: float = ALLAN_TEMP_C, seed_offset: int = 3000) -> tuple[dict[str, np.ndarray], int]:
    """Each output's bit-exact minus float (both on the same ADC codes), in its unit, at a constant
    temperature and the sensor's STEADY_LEVEL input with its noise (which dithers the ADCs as in a
    real sensor), after the filters' settling; one run of each model. Returns ({port: error}, settle)."""
    if samples < 2 * MIN_INTERVALS:
        raise InputError(f"samples: need at least {2 * MIN_INTERVALS}, got {samples}")
    chain = design.chain(chain_name, "the Allan deviation")
    if chain.sensor is None:
        raise InputError(f"{chain_name}: the Allan deviation needs the chain's sensor (its table's 'sensor')")
    settle = settling_samples(chain)
    n = samples + settle
    rng = np.random.default_rng([design.seed, seed_offset])
    stim = chain.sensor.held_inputs(np.full(n, float(temp_c)), np.full(n, float(chain.sensor.STEADY_LEVEL)), rng)
    got = chain.real_outputs(chain.run(**stim))
    ref = chain.run_float(**stim)
    return {p: (got[p] - ref[p])[settle:] * port_unit(design, chain_name, p)[1] for p in ports}, settle


def allan_chain(design: Design, chain_name: str, ports: list[str], samples: int = ALLAN_SAMPLES,
                temp_c: float = ALLAN_TEMP_C) -> list[Allan]:
    """The Allan figures of the chain's outputs ``ports``, from one run."""
    errs, settle = allan_errors(design, chain_name, ports, samples, temp_c)
    out = []
    for port, err in errs.items():
        fs = design.chains[chain_name].fs_hz
        f = allan_figures(err, fs)
        out.append(Allan(chain_name, port, port_unit(design, chain_name, port)[0], fs, int(err.size),
                         settle, float(temp_c), float(design.chains[chain_name].sensor.STEADY_LEVEL), f["taus"],
                         f["adev"], f["intervals"], f["bi_adev"], f["bi_tau"], f["adev_1s"], f["fit_taus"], err))
    return out


# ----------------------------------------------------------------------------------------------
# Drive-frequency sweep
# ----------------------------------------------------------------------------------------------
@dataclass
class DrivePoint:
    f_hz: float
    rms: float           # section 1's chain row (nominal stimulus, float on the same codes), deg/h
    mean: float
    static_rms: float    # quasi-static chamber points (static.py), deg/h
    static_mean: float
    overflows: int       # nominal + quasi-static

    def as_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class DriveSweep:
    chain: str
    port: str
    demod: str           # the demodulator table whose f_hz is swept
    f0: float
    a_ppm_per_c: float
    t0_c: float
    temp_range_c: tuple[float, float]
    band: tuple[float, float]
    points: list[DrivePoint]
    unit: str = ""

    def worst(self, attr: str) -> DrivePoint:
        """The point of the largest |attr| over the band."""
        return max(self.points, key=lambda p: abs(getattr(p, attr)))

    def as_dict(self) -> dict:
        worst = {k: {"f_hz": self.worst(k).f_hz, "value": abs(getattr(self.worst(k), k))}
                 for k in ("rms", "mean", "static_rms", "static_mean")}
        return {"chain": self.chain, "port": self.port, "demod": self.demod, "unit": self.unit, "f0_hz": self.f0,
                "a_ppm_per_c": self.a_ppm_per_c, "t0_c": self.t0_c, "temp_range_c": list(self.temp_range_c),
                "band_hz": list(self.band), "points": [p.as_dict() for p in self.points], "worst_abs": worst}


def drive_band(f0: float, a_ppm_per_c: float = SILICON_PPM_PER_C, t0_c: float = T0_C,
               temp_range_c: tuple[float, float] = TEMP_RANGE_C) -> tuple[float, float]:
    """(lowest, highest) drive frequency over the temperature range, w(T) = w0 [1 - a (T - T0) / 2]
    (the frequency falls as the temperature rises for a > 0)."""
    lo_t, hi_t = temp_range_c
    if not lo_t < hi_t:
        raise InputError(f"temp_range_c: lowest must be below highest, got {temp_range_c}")
    if f0 <= 0:
        raise InputError(f"f0: must be > 0, got {f0}")
    a = a_ppm_per_c * 1e-6
    ends = sorted((f0 * (1 - a * (hi_t - t0_c) / 2), f0 * (1 - a * (lo_t - t0_c) / 2)))
    return ends[0], ends[1]


def drive_frequencies(f0: float, points: int = SWEEP_POINTS, a_ppm_per_c: float = SILICON_PPM_PER_C,
                      t0_c: float = T0_C, temp_range_c: tuple[float, float] = TEMP_RANGE_C, *,
                      band: tuple[float, float] | None = None) -> np.ndarray:
    """``points`` frequencies evenly across :func:`drive_band`, and f0 itself: an exact ratio such as
    f/fs = 1/12 is where a phase-truncating NCO repeats the same few phases and its error becomes a
    bias; an even grid would step over it. ``band``: that band when the caller already has it."""
    if points < 2:
        raise InputError(f"points: need at least 2, got {points}")
    if band is None:
        band = drive_band(f0, a_ppm_per_c, t0_c, temp_range_c)
    return np.unique(np.append(np.linspace(band[0], band[1], points), f0))


def demod_f_hz(config: Config, design: Design, chain_name: str) -> float:
    """The configured drive frequency of the chain's demodulator."""
    return float(table_at(config.data, demod_of(config.data, chain_name))["f_hz"])


def _with_f_hz(data: dict, table: str, f_hz: float) -> dict:
    d = copy.deepcopy(data)
    table_at(d, table)["f_hz"] = float(f_hz)
    return d


def drive_points(data: dict, f_hz: float, chain_name: str, ports, table: str) -> dict[str, DrivePoint]:
    """Build the design with <table>.f_hz = f_hz and measure each chain output's error as section 1
    of the budget does, plus the quasi-static error (port units); one build for every output."""
    design = build(Config(_with_f_hz(data, table, f_hz), source=f"<drive sweep {f_hz:.3f} Hz>"))
    rows = {r.stats.port: r.stats for r in budget_rows(design, names=[chain_name])}
    static = static_errors(design, chain_name)
    out = {}
    for port in ports:
        row, st = rows[port], static[port]
        out[port] = DrivePoint(float(f_hz), row.rms * row.scale, row.mean * row.scale, st["rms"] * row.scale,
                               st["mean"] * row.scale, int(row.overflows + st["overflows"]))
    return out


def drive_sweep(config: Config, chain_name: str, ports: list[str], points: int = SWEEP_POINTS,
                a_ppm_per_c: float = SILICON_PPM_PER_C, t0_c: float = T0_C,
                temp_range_c: tuple[float, float] = TEMP_RANGE_C, progress=None) -> list[DriveSweep]:
    """The outputs' error at ``points`` drive frequencies evenly across the band of :func:`drive_band`
    around the chain demodulator's f_hz, one design per frequency for every output.
    ``progress``: a tqdm-like wrapper."""
    design = build(config)
    table = demod_of(config.data, chain_name)
    f0 = demod_f_hz(config, design, chain_name)
    band = drive_band(f0, a_ppm_per_c, t0_c, temp_range_c)
    freqs = drive_frequencies(f0, points, band=band)
    it = progress(freqs, desc=f"drive-frequency sweep of {chain_name}", unit="f") if progress else freqs
    # each point builds the chain alone (and what shares a table with it: optimise.chain_only), as the
    # word-length search does: the other chains' tables do not move its error, and building them was
    # most of a point
    data = chain_only(config.data, chain_name)
    at = [drive_points(data, f, chain_name, ports, table) for f in it]
    out = [DriveSweep(chain_name, p, table, f0, a_ppm_per_c, t0_c, tuple(temp_range_c), band, [a[p] for a in at],
                      port_unit(design, chain_name, p)[0]) for p in ports]
    return out
