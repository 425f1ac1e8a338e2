"""Attribution of each chain's end-to-end error to its quantisation sources (item 2) and the
theory check of every rounding point (item 3).

Method: the chain's nominal stimulus is regenerated *before* its ADCs (same random draws), and the
hybrid model of :mod:`fxdsp.budget.hybrid` is run with all sources off (the float reference on the
analog signals), all on (must equal the bit-exact model: checked, reported as ``hybrid_max_diff``)
and one source at a time. The total error is bit-exact output minus float-on-analog output, so it
includes the ADC quantisation that the per-block table (float on the same codes) cannot see.

Additivity: error powers (mean square, bias included) of independent sources add. Sources that
carry a systematic, one-signed error (the NCO's deterministic phase error, the RTD LUT's chord
error, a truncation) are correlated through their means, so the check is made twice: the plain
power sum, and the split "means add linearly, variances add in power"; the largest cross terms
2 <e_i e_j> explain any gap. The superposition residual (total minus the sum of the one-source
errors) measures interaction between sources (non-linearity of the chain).

Theory (item 3): every rounding point's residue r - x is compared with q^2/12 and zero mean (ideal
rounding); the one-source output contribution is compared with the textbook model (independent
white uniform noise of the same step and mode, same error feedback, pushed through the same float
chain: that is "the gain after the stage"). A stage more than ``THEORY_DB`` worse is flagged with
the reason found (truncation bias, correlation / non-busy signal, limit cycle).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fxdsp.chains import Design, stream_key
from fxdsp.float_vs_fixed import port_unit
from fxdsp.budget.hybrid import CATEGORIES, Source, Switch, chain_analog, chain_sources, lowpass_of, run_chain

ADDITIVITY_DB = 0.5     # stated tolerance of the power sum against the total
THEORY_DB = 1.0         # a rounding point worse than theory by more than this is flagged
MODEL_DRAWS = 8         # white-noise model runs per source (their spread is the model's uncertainty)


@dataclass
class SourceResult:
    source: Source
    rms: float           # output-referred, port units (physical)
    mean: float
    std: float
    power_share: float   # of the total mean square
    model_rms: float | None = None   # white-noise model, output-referred
    error: np.ndarray | None = None  # output error signal (stored value units)


@dataclass
class TheoryResult:
    source: str
    stage: str
    rounding: str
    q: float
    unit: str
    scale: float
    local_mean_q: float          # measured mean / q
    expected_mean_q: float       # of the configured mode
    local_var_db: float          # measured variance vs q^2/12 (dB)
    local_mse_db: float          # measured mean square vs q^2/12 (dB): what is flagged
    output_rms: float            # physical
    model_output_rms: float      # physical
    output_db: float             # measured vs model at the output (dB)
    model_spread_db: float       # 2 sigma of the model's rms over its draws (dB): the noise of the test
    lf_share: float | None       # share of the local error power inside the chain's output band
    lf_white: float | None       # the same share for white noise (2 f_c / f_s)
    sign_corr: float             # correlation of the local error with the sign of the signal
    gain_after: float            # output rms / local rms
    flagged: bool
    reasons: list[str] = field(default_factory=list)


@dataclass
class Attribution:
    chain: str
    port: str
    unit: str
    scale: float
    samples: int
    total_rms: float
    total_mean: float
    total_std: float
    sensor_noise_rms: float
    hybrid_max_diff: float        # all-on hybrid vs bit-exact, stored units (0: exact)
    sources: list[SourceResult]
    power_sum_db: float           # 10 log10(sum P_i / P_total)
    mean_sum: float               # sum of the source means (physical)
    var_sum_db: float             # 10 log10(sum var_i / var_total)
    superposition_rms: float      # rms of e_total - sum e_i (physical)
    cross_terms: list[tuple[str, str, float]]  # largest 2<e_i e_j> / P_total
    cov_terms: list[tuple[str, str, float]]    # largest 2 cov(e_i, e_j) / var_total
    with_cross_db: float          # 10 log10((sum P_i + all cross terms) / P_total): 0 if superposition holds
    tolerance_db: float = ADDITIVITY_DB
    theory: list[TheoryResult] = field(default_factory=list)
    total_error: np.ndarray | None = None

    @property
    def power_ok(self) -> bool:
        return abs(self.power_sum_db) <= self.tolerance_db

    @property
    def split_ok(self) -> bool:
        mean_ok = abs(self.mean_sum - self.total_mean) <= 0.1 * max(abs(self.total_mean), 1e-3 * self.total_rms) \
            or abs(self.mean_sum - self.total_mean) <= 0.05 * self.total_rms
        return mean_ok and abs(self.var_sum_db) <= self.tolerance_db

    def by_category(self) -> dict[str, float]:
        """Mean square (physical units^2) by category."""
        out = {c: 0.0 for c in CATEGORIES}
        for s in self.sources:
            out[s.source.category] += s.rms**2
        return out

    def explanation(self) -> str:
        if self.power_ok:
            return (f"the one-source powers add up to the total within {self.tolerance_db} dB "
                    f"({self.power_sum_db:+.2f} dB)")
        parts = [f"the plain power sum is {self.power_sum_db:+.2f} dB off the total (tolerance "
                 f"{self.tolerance_db} dB): the sources are correlated."]
        if self.cross_terms:
            top = ", ".join(f"{a} x {b} {c * 100:+.1f} %" for a, b, c in self.cross_terms[:3])
            parts.append(f"Largest cross terms 2<e_i e_j> (share of the total power): {top}.")
        means = sorted(self.sources, key=lambda s: -abs(s.mean))[:2]
        if means and abs(means[0].mean) > 0.3 * self.total_rms:
            parts.append("They are systematic, one-signed errors (" + ", ".join(
                f"{s.source.name} mean {s.mean:+.3g} {self.unit}" for s in means) +
                "): biases add linearly, not in power.")
        if self.cov_terms:
            top = ", ".join(f"{a} x {b} {c * 100:+.1f} %" for a, b, c in self.cov_terms[:3])
            parts.append(f"Largest covariance terms 2 cov(e_i, e_j) (share of the total variance): {top} "
                         f"(sources driven by the same temperature ramp or the same rate steps).")
        parts.append(f"Split check: sum of means {self.mean_sum:+.4g} vs total mean {self.total_mean:+.4g} {self.unit}; "
                     f"sum of variances {self.var_sum_db:+.2f} dB vs the total variance -> "
                     f"{'consistent' if self.split_ok else 'NOT consistent'}.")
        parts.append(f"With every cross term the sum is {self.with_cross_db:+.3f} dB off the total, and the "
                     f"superposition residual (total minus the sum of the one-source errors) is "
                     f"{self.superposition_rms:.3g} {self.unit} rms: the sources superpose linearly, they are "
                     f"only correlated.")
        return " ".join(parts)


def _stimulus(design: Design, chain_name: str, n: int | None, seed_offset: int):
    chain = design.chain(chain_name, "the budget's attribution")
    rng = np.random.default_rng([design.seed, seed_offset, stream_key(chain_name)])
    return chain, chain_analog(chain, rng, n or design.samples), chain_sources(chain), run_chain


def expected_mean_q(rounding: str, x: np.ndarray | None = None) -> float:
    if rounding == "floor":
        return -0.5
    if rounding == "toward_zero":
        return -0.5 * float(np.mean(np.sign(x))) if x is not None and np.size(x) else 0.0
    return 0.0


def check_rounding(residue: np.ndarray, q: float, rounding: str, x: np.ndarray | None = None,
                   limit_db: float = THEORY_DB) -> tuple[dict, list[str]]:
    """Local theory check of one rounding point: residue r - x against q^2/12 and zero mean.
    Returns (numbers, reasons); flagged when the mean square exceeds q^2/12 by more than limit_db."""
    e = np.asarray(residue, dtype=float)
    theory = q * q / 12.0
    mean, var = float(e.mean()), float(e.var())
    mse = float(np.mean(e * e))
    out = {"mean_q": mean / q, "expected_mean_q": expected_mean_q(rounding, x),
           "var_db": 10 * np.log10(max(var, 1e-300) / theory), "mse_db": 10 * np.log10(max(mse, 1e-300) / theory)}
    reasons = []
    if out["mse_db"] > limit_db:
        if abs(out["mean_q"]) > 0.25:
            reasons.append(f"mean {out['mean_q']:+.2f} q: truncation bias ({rounding} drops bits one way; "
                           f"theory for {rounding}: {out['expected_mean_q']:+.2f} q)")
        if out["var_db"] > limit_db:
            reasons.append(f"variance {out['var_db']:+.1f} dB above q^2/12: the error is not uniform over one "
                           f"step (signal not busy, few bits dropped, or several rounding points)")
        if not reasons:
            reasons.append("mean square above q^2/12")
    return out, reasons


# why a flagged source of a kind may be expected, by (kind, what)
_KNOWN = {
    ("sf_divide", "trunc"): "deliberate: the paper's rescale truncates toward zero; ahead of a demodulator its DC "
                            "error is moved to the drive frequency by the mixer and removed by the low-pass",
    ("iir", "round"): "in-loop rounding of a narrow low-pass (gain ~1/(1+a1+a2)); error feedback shapes it",
    ("demod", "lpf_round"): "in-loop rounding of the demodulator low-pass; error feedback shapes it",
}


def attribute(design: Design, chain_name: str, port: str = "rate", n: int | None = None, seed_offset: int = 2000,
              keep_signals: bool = True) -> Attribution:
    chain, stim, sources, run_fn = _stimulus(design, chain_name, n, seed_offset)
    unit, scale = port_unit(design, chain_name, port)
    result = chain.run(**stim["codes"])
    bit = chain.real_outputs(result)[port]
    ref_nodes = run_fn(chain, stim["analog"], Switch())
    ref = ref_nodes[port]
    allon = run_fn(chain, stim["analog"], Switch(on=[s.name for s in sources]))[port]
    clean = run_fn(chain, stim["clean"], Switch())[port]
    lsb = chain.outputs[port].lsb
    hybrid_diff = float(np.abs(allon - bit).max() / lsb)
    e_total = bit - ref
    p_total = float(np.mean(e_total**2))

    results, errors, theory = [], {}, []
    band = _band(design, chain_name, port)
    rng = np.random.default_rng([design.seed, seed_offset, 7])
    for s in sources:
        sw = Switch(on=[s.name])
        nodes = run_fn(chain, stim["analog"], sw)
        e = nodes[port] - ref
        errors[s.name] = e
        sr = SourceResult(s, float(np.sqrt(np.mean(e**2))) * scale, float(e.mean()) * scale, float(e.std()) * scale,
                          float(np.mean(e**2) / p_total) if p_total else 0.0, error=e if keep_signals else None)
        if s.is_rounding and sr.rms > 0:
            draws = np.array([np.mean((run_fn(chain, stim["analog"], Switch(inject=[s.name], rng=rng))[port] - ref)**2)
                              for _ in range(MODEL_DRAWS)])
            sr.model_rms = float(np.sqrt(draws.mean())) * scale
            spread = float(2 * np.std(10 * np.log10(np.maximum(draws, 1e-300)))) if draws.min() > 0 else 0.0
            theory.append(_theory(s, sw, nodes, ref_nodes, sr, unit, scale, spread, band))
        results.append(sr)

    names = [s.name for s in sources]
    cross, cov = [], []
    v_total = float(np.var(e_total))
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            ea, eb = errors[names[a]], errors[names[b]]
            if p_total:
                cross.append((names[a], names[b], 2 * float(np.mean(ea * eb)) / p_total))
            if v_total:
                cov.append((names[a], names[b], 2 * float(np.mean((ea - ea.mean()) * (eb - eb.mean()))) / v_total))
    cross_sum = sum(c for _, _, c in cross) * p_total
    cross.sort(key=lambda t: -abs(t[2]))
    cov.sort(key=lambda t: -abs(t[2]))
    p_sum = sum(float(np.mean(errors[k]**2)) for k in names)
    v_sum = sum(float(np.var(errors[k])) for k in names)
    resid = e_total - np.sum([errors[k] for k in names], axis=0)
    return Attribution(
        chain_name, port, unit, scale, int(e_total.size), float(np.sqrt(p_total)) * scale, float(e_total.mean()) * scale,
        float(e_total.std()) * scale, float(np.std(ref - clean)) * scale, hybrid_diff, results,
        float(10 * np.log10(p_sum / p_total)) if p_total and p_sum else 0.0,
        float(sum(float(errors[k].mean()) for k in names)) * scale,
        float(10 * np.log10(v_sum / np.var(e_total))) if np.var(e_total) and v_sum else 0.0,
        float(np.sqrt(np.mean(resid**2))) * scale, cross[:10], cov[:10],
        float(10 * np.log10((p_sum + cross_sum) / p_total)) if p_total and p_sum + cross_sum > 0 else 0.0,
        theory=theory,
        total_error=e_total if keep_signals else None)


def _band(design: Design, chain_name: str, port: str) -> tuple[float, float] | None:
    """(cut-off, sample rate) of the low-pass that drives the output ``port`` (an iir member, or a
    demodulator's channel filter); None when the output is not filtered."""
    chain = design.chains[chain_name]
    lpf = lowpass_of(chain, chain.netlist.outputs[port].instance)
    if lpf is None:
        return None
    import scipy.signal as sps
    w = np.linspace(0, np.pi, 4097)
    _, h = sps.sosfreqz(lpf.sos, worN=w)
    fs = chain.fs_hz
    fc = float(w[np.argmax(np.abs(h) < 1 / np.sqrt(2))] / (2 * np.pi) * fs)
    return fc, fs


def lf_share(e: np.ndarray, fc: float, fs: float) -> float:
    """Share of the (zero-mean) power of e below fc."""
    e = np.asarray(e, dtype=float) - np.mean(e)
    p = np.abs(np.fft.rfft(e))**2
    f = np.fft.rfftfreq(e.size, 1 / fs)
    return float(p[(f > 0) & (f <= fc)].sum() / p.sum()) if p.sum() else 0.0


def _theory(s: Source, sw: Switch, nodes, ref_nodes, sr: SourceResult, unit: str, scale: float, spread: float,
            band) -> TheoryResult:
    residue = sw.residues.get((s.name, "out"))
    if residue is None:  # recursive stages record per section: the last section feeds the output
        keys = sorted(k for k in sw.residues if k[0] == s.name and k[1].startswith("section"))
        residue = sw.residues[keys[-1]] if keys else nodes[s.node] - ref_nodes[s.node]
    local, reasons = check_rounding(residue, s.q, s.rounding, ref_nodes.get(s.node))
    internal = [k for k in sw.residues if k[0] == s.name and k[1] != "out"]
    local_rms = float(np.sqrt(np.mean((nodes[s.node] - ref_nodes[s.node])**2)))
    out_db = 20 * np.log10(sr.rms / sr.model_rms) if sr.model_rms and sr.rms else 0.0
    sig = ref_nodes.get(s.node)
    r0 = residue - residue.mean()
    sgn = np.sign(sig) if sig is not None and np.size(sig) == np.size(residue) else np.zeros_like(residue)
    sign_corr = float(np.mean(r0 * sgn) / (np.std(r0) * np.std(sgn))) if np.std(r0) and np.std(sgn) else 0.0
    local_err = nodes[s.node] - ref_nodes[s.node]
    lf = lf_share(local_err, *band) if band else None
    lf_white = 2 * band[0] / band[1] if band else None
    flagged = bool(reasons)
    if out_db > THEORY_DB + spread:
        flagged = True
        why = []
        if lf is not None and lf > 3 * lf_white:
            why.append(f"the local error is not white: {lf * 100:.2g} % of its power lies below {band[0]:.0f} Hz "
                       f"(white: {lf_white * 100:.2g} %), e.g. a slow sawtooth from a smooth, noiseless input "
                       f"advancing a near-integer number of steps per sample, which the output low-pass keeps")
        into = sw.residues.get((s.name, "coef_into_acc"))
        if into is not None and np.any(into):
            why.append("a coefficient is rounded into the accumulator (its format has more fraction bits than "
                       "acc_format): a constant error per segment, scaled by the temperature -- deterministic, "
                       "not noise, so the output low-pass keeps it")
        if abs(sign_corr) > 0.1:
            why.append(f"the local error is correlated with the sign of the signal ({sign_corr:+.2f}): a "
                       f"sign-dependent truncation that the mixer rectifies into DC")
        if not why:
            why.append("the error is correlated with the signal or trapped in a recursive stage (limit cycle), "
                       "not white")
        reasons.append(f"output {out_db:+.1f} dB above the white-noise model (model spread {spread:.1f} dB): "
                       + "; ".join(why))
    if internal and flagged:
        reasons.append("the stage's internal accumulator roundings are included in the output figures")
    known = _KNOWN.get((s.kind, s.name.rsplit(".", 1)[-1]))
    if flagged and known:
        reasons.append(known)
    return TheoryResult(s.name, s.stage, s.rounding, s.q, unit, scale, local["mean_q"], local["expected_mean_q"],
                        local["var_db"], local["mse_db"], sr.rms, sr.model_rms or 0.0, float(out_db), spread, lf,
                        lf_white, sign_corr,
                        sr.rms / scale / local_rms if local_rms else 0.0, flagged, reasons)
