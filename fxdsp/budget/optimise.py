"""Item 4: word-length exploration.

Knobs are config fields: a format's word length (its integer bits are kept, so the fraction length
moves with it), or an integer width (LUT address bits, guard bits, phase bits). Coupled fields
(formats that must match to connect the chain) move together.

Algorithm ("min + b", Cantin/Sung style, no grid):

1. each knob's *reachable maximum* (default + ``HEADROOM`` bits, backed off until the design builds);
   the target is unreachable if the all-maximum design misses it (ValueError);
2. each knob's *minimum*: binary search of the smallest width meeting the target with every other
   knob at its maximum;
3. start from all minima and greedily add one bit to the knob with the best error decrease per bit
   of cost until the target is met;
4. greedy removal: try one bit less on every knob, most costly first, keep any step that still meets
   the target, until no step is accepted.

The knobs come from the chain's members by their kind (:data:`KIND_KNOBS`), so any chain of the
config can be searched. The error measured is exactly what ``fxdsp budget`` prints for the chain
(fxdsp.float_vs_fixed's stimulus and seed) and, for a chain with a sensor, the larger of that and the
quasi-static chamber-point error (see :mod:`fxdsp.budget.static`, also printed by ``fxdsp budget``),
so the written config meets the target when re-run. The cost proxy counts bits: registers
and coefficients (word length times instances) and memory (LUT words times word length).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field


from fxdsp.budget import DEFAULT_MARGIN
from fxdsp.chains import build
from fxdsp.config import Config, table_at
from fxdsp.float_vs_fixed import block_errors
from fxdsp.fixed import Format
from fxdsp.budget.static import static_error
from fxdsp.budget.units import Target
from fxdsp.errors import InputError

HEADROOM = 4


@dataclass(frozen=True)
class Knob:
    name: str
    fields: tuple[tuple, ...]      # (section path, key) or (section path, key, index)
    kind: str = "fmt"              # "fmt" (word length) | "int"
    lo: int | None = None
    hi: int | None = None
    instances: tuple | int = 1     # multiplicity of the cost: an int or (rule of _instances, table)


def _get(data: dict, f: tuple):
    v = table_at(data, f[0])[f[1]]
    return v[f[2]] if len(f) == 3 else v


def _set(data: dict, f: tuple, value) -> None:
    node = table_at(data, f[0])
    if len(f) == 3:
        node[f[1]][f[2]] = value
    else:
        node[f[1]] = value


def _sections(order) -> int:
    return -(-int(order) // 2)


def _knobs_rtd(t: str, table: dict) -> list[Knob]:
    return [Knob(f"{t}.temp_format", ((t, "temp_format"),)),
            Knob(f"{t}.lut_format", ((t, "lut_format"),), instances=("rtd_lut", t)),
            Knob(f"{t}.lut_index_bits", ((t, "lut_index_bits"),), "int", 2, 10, instances=("index", t))]


def _knobs_piecewise(t: str, table: dict) -> list[Knob]:
    order = len(table["coef_format"]) if isinstance(table.get("coef_format"), list) else 0
    return [*(Knob(f"{t}.c{k}", ((t, "coef_format", k),), instances=("segments", t)) for k in range(order)),
            Knob(f"{t}.acc_format", ((t, "acc_format"),)), Knob(f"{t}.out_format", ((t, "out_format"),))]


def _knobs_divide(t: str, table: dict) -> list[Knob]:
    return [Knob(f"{t}.guard_bits", ((t, "guard_bits"),), "int", 0, 16), Knob(f"{t}.out_format", ((t, "out_format"),))]


def _knobs_demod(t: str, table: dict) -> list[Knob]:
    n = _sections(table.get("lpf", {}).get("order", 2))   # two channels of n biquads: 3 n and 2 n coefficients each
    # referenced to an input, the accumulator is the reference's (a drive loop's), not a knob of its own
    own = [Knob(f"{t}.phase_bits", ((t, "phase_bits"),), "int", 8, 48)] if table.get("reference", "nco") == "nco" else []
    return [*own,
            Knob(f"{t}.lut_bits", ((t, "lut_bits"),), "int", 6, 16, instances=("index", t)),
            Knob(f"{t}.interp_bits", ((t, "interp_bits"),), "int", 0, 20),
            Knob(f"{t}.lut_format", ((t, "lut_format"),), instances=("nco_lut", t)),
            Knob(f"{t}.data_format", ((t, "data_format"),), instances=2),   # the low-passes follow (wired)
            Knob(f"{t}.lpf.num_format", ((f"{t}.lpf", "num_format"),), instances=6 * n),
            Knob(f"{t}.lpf.den_format", ((f"{t}.lpf", "den_format"),), instances=4 * n)]


def _knobs_iir(t: str, table: dict) -> list[Knob]:
    n = _sections(table.get("order", 2))
    return [Knob(f"{t}.num_format", ((t, "num_format"),), instances=3 * n),
            Knob(f"{t}.den_format", ((t, "den_format"),), instances=2 * n)]


def _knobs_freq2temp(t: str, table: dict) -> list[Knob]:
    # the frequency word is the drive loop's counter, a design choice (not a sensor ADC)
    return [Knob(f"{t}.{k}", ((t, k),)) for k in ("freq_format", "kinv_format", "temp_format")]


def _knobs_lag(t: str, table: dict) -> list[Knob]:
    return [Knob(f"{t}.alpha_bits", ((t, "alpha_bits"),), "int", 4, 32),
            Knob(f"{t}.state_guard_bits", ((t, "state_guard_bits"),), "int", 0, 32)]


def _knobs_subtract(t: str, table: dict) -> list[Knob]:
    return [Knob(f"{t}.out_format", ((t, "out_format"),))]


# every kind's word-length knobs: its own formats and widths; an input format is the wire's (the
# driver's output knob) or a chain input's (the sensor's ADC), never a knob of its own
KIND_KNOBS = {"rtd": _knobs_rtd, "piecewise": _knobs_piecewise, "sf_divide": _knobs_divide, "demod": _knobs_demod,
              "iir": _knobs_iir, "freq2temp": _knobs_freq2temp, "lag": _knobs_lag, "bias_subtract": _knobs_subtract}


def _chain_table(data: dict, chain: str) -> dict:
    name = chain.removeprefix("chain_")
    table = data.get("chain", {}).get(name)
    if not isinstance(table, dict):
        raise InputError(f"--chain: no [chain.{name}] table in the config")
    return table


def chain_members(data: dict, chain: str) -> list[tuple[str, str]]:
    """(table, kind) of each instance of the chain's table, in its order."""
    from fxdsp.blocks.kinds import kind_of

    return [(t, kind_of(t).name) for t in _chain_table(data, chain).get("instances", [])]


def chain_only(data: dict, chain: str) -> dict:
    """A copy of config ``data`` with only the chain, the chains that share a block table with it
    (and those that share one with them), their tables and every section that is not a block table
    (system, stimulus, sensors). An evaluation builds this: a knob of the chain changes only its
    tables, whose build and error depend on their own table, their wired inputs and their chains'
    rates, and a table two chains share is checked against both wirings (freq2temp's input format
    against paper 001's and its loop's drive). The tables left out build the same at any value,
    as they do in the config the search starts from (Evaluator prunes only a config that builds
    whole). A build of the whole default config for each
    of a search's ~460 candidates was three quarters of the search; the config the search writes is
    the whole one."""
    from fxdsp.blocks.kinds import block_tables

    nets = {name: set(t.get("instances", [])) for name, t in data.get("chain", {}).items() if isinstance(t, dict)}
    keep = {chain.removeprefix("chain_")}
    while True:
        tables = set().union(*(nets[n] for n in keep))
        more = {n for n, members in nets.items() if members & tables} - keep
        if not more:
            break
        keep |= more
    out = copy.deepcopy(data)
    for table in block_tables(data):
        if table not in tables:
            *parents, key = table.split(".")
            node = table_at(out, ".".join(parents)) if parents else out
            del node[key]
            if parents and not any(isinstance(v, dict) for v in node.values()):   # a family left empty
                (table_at(out, ".".join(parents[:-1])) if len(parents) > 1 else out).pop(parents[-1])
    out["chain"] = {n: t for n, t in out["chain"].items() if n in keep}
    return out


def knobs_of(data: dict, chain: str) -> list[Knob]:
    """The chain's word-length knobs, from its members' kinds (``KIND_KNOBS``), in the order of its
    instances."""
    out = []
    for table, kind in chain_members(data, chain):
        out += KIND_KNOBS.get(kind, lambda *_: [])(table, table_at(data, table))
    return out


def demod_of(data: dict, chain: str) -> str:
    """The chain's demodulator table (whose f_hz a drive sweep moves): the one lookup of the budget,
    its optimiser and the sweeps."""
    found = [t for t, kind in chain_members(data, chain) if kind == "demod"]
    if len(found) != 1:
        raise InputError(f"--drive-band: {chain} has {len(found)} demodulators, the drive sweep needs one")
    return found[0]


def _instances(knob: Knob, data: dict) -> tuple[int, bool]:
    """(multiplicity, is_memory) of a knob's bits in the design described by ``data``."""
    rule = knob.instances
    if isinstance(rule, int):
        return rule, False
    kind, table = rule
    if kind == "rtd_lut":
        return 2 ** int(_get(data, (table, "lut_index_bits"))) + 1, True
    if kind == "nco_lut":  # one quarter-wave sine table
        return 2 ** (int(_get(data, (table, "lut_bits"))) - 2), True
    if kind == "segments":
        return len(_get(data, (table, "coefficients"))), True
    return 0, False  # index widths: their cost is carried by the table they address


def cost(data: dict, chain: str) -> dict[str, int]:
    """Bits of the chain's knobs: registers/coefficients, memory (LUT and coefficient ROM words)."""
    reg = mem = 0
    for knob in knobs_of(data, chain):
        v = _get(data, knob.fields[0])
        wl = Format.parse(v).wl if knob.kind == "fmt" else int(v)
        n, is_mem = _instances(knob, data)
        if knob.kind == "int" and knob.instances == 1:
            n = 1
        if is_mem:
            mem += n * wl
        else:
            reg += n * wl
    return {"register_bits": reg, "memory_bits": mem, "total_bits": reg + mem}


def knob_value(data: dict, knob: Knob) -> int:
    v = _get(data, knob.fields[0])
    return Format.parse(v).wl if knob.kind == "fmt" else int(v)


def set_knob(data: dict, knob: Knob, value: int, defaults: dict) -> None:
    for f in knob.fields:
        if knob.kind == "fmt":
            d = Format.parse(defaults[f])
            delta = value - d.wl
            _set(data, f, str(Format(d.signed, value, d.fl + delta)))
        else:
            _set(data, f, int(value))


def _field_defaults(data: dict, chain: str) -> dict:
    return {f: _get(data, f) for k in knobs_of(data, chain) for f in k.fields}


# what a build of a candidate config raises when the config does not build (a bad value, a format
# that does not connect, a table too narrow for its coefficients): an infinite error, not a failure
NOT_BUILT = (ValueError, TypeError, AssertionError)


@dataclass
class Evaluator:
    base: dict
    chain: str
    port: str
    metric: str = "rms"
    samples: int | None = None
    mean_weight: float = 0.0        # |mean| x this joins the error: target / the bias limit (0: no limit)
    frequencies: tuple = ()         # further f_hz of the chain's demodulator at which the same error is measured
    evaluations: int = 0
    cache: dict = field(default_factory=dict)

    def __post_init__(self):
        self.knobs = knobs_of(self.base, self.chain)
        self.defaults = _field_defaults(self.base, self.chain)
        self.demod = demod_of(self.base, self.chain) if self.frequencies else None
        self.built = self._pruned()   # what an evaluation builds

    def _pruned(self) -> dict:
        """chain_only's data when the whole base config builds; else the whole (every evaluation
        then fails as the whole config does, and the search reports its target unreachable)."""
        try:
            build(Config(self.base, source="<optimise>"))
        except NOT_BUILT:
            return self.base
        return chain_only(self.base, self.chain)

    def data(self, values: dict[str, int], base: dict | None = None) -> dict:
        """The config data at ``values`` (the whole config's, or ``base``'s)."""
        d = copy.deepcopy(self.base if base is None else base)
        for knob in self.knobs:
            if knob.name in values:
                set_knob(d, knob, values[knob.name], self.defaults)
        return d

    @staticmethod
    def key(values: dict[str, int], seed_offset: int = 1000) -> tuple:
        """The cache key of an evaluation."""
        return tuple(sorted(values.items())), seed_offset

    def error(self, values: dict[str, int], seed_offset: int = 1000) -> float:
        """The chain port's error in physical units (inf if the config does not build): the larger of
        the metric and ``mean_weight`` x |mean|, at the config's drive frequency and at each of
        ``frequencies``."""
        key = self.key(values, seed_offset)
        if key in self.cache:
            return self.cache[key]
        self.evaluations += 1
        data = self.data(values, self.built)
        err = 0.0
        for f_hz in (None, *self.frequencies):
            if f_hz is not None:
                table_at(data, self.demod)["f_hz"] = float(f_hz)
            try:
                design = build(Config(data, source="<optimise>"))
            except NOT_BUILT:
                err = math.inf
                break
            err = max(err, self._error_of(design, seed_offset))
            if math.isinf(err):
                break
        self.cache[key] = float(err)
        return float(err)

    def _error_of(self, design, seed_offset: int) -> float:
        stats = {s.port: s for s in block_errors(design, self.chain, self.samples, seed_offset=seed_offset)}
        s = stats[self.port]
        if s.overflows:  # saturating on the nominal stimulus: not an acceptable word length
            return math.inf
        err = max((s.rms if self.metric == "rms" else s.max_abs), self.mean_weight * abs(s.mean)) * s.scale
        if design.chains[self.chain].sensor is not None:  # and the quasi-static chamber points (static.py)
            st = static_error(design, self.chain, self.port)
            if st["overflows"]:
                return math.inf
            err = max(err, (st["rms"] if self.metric == "rms" else st["max_abs"]) * s.scale,
                      self.mean_weight * abs(st["mean"]) * s.scale)
        return float(err)


@dataclass
class OptResult:
    target: Target
    metric: str
    default_values: dict[str, int]
    values: dict[str, int]
    default_error: float
    error: float
    independent_error: float
    default_cost: dict[str, int]
    cost: dict[str, int]
    evaluations: int
    data: dict
    log: list[str] = field(default_factory=list)

    def as_dict(self, **extra) -> dict:
        """The result as JSON data (``extra``, such as the budget's synthesis estimate, before the log)."""
        return {"values": self.values, "default_values": self.default_values, "error": self.error,
                "default_error": self.default_error, "independent_seed_error": self.independent_error,
                "cost": self.cost, "default_cost": self.default_cost, "evaluations": self.evaluations,
                **extra, "log": self.log}


def format_result(result: OptResult, brief: bool = False) -> str:
    """Every knob's default -> new width (``*``: changed) and the error; then the cost in full, or
    (``brief``) the total bits on the error line."""
    t, dc, nc = result.target, result.default_cost, result.cost
    lines = [f"  {k:30s} {result.default_values[k]:3d} -> {v:3d}{'' if v == result.default_values[k] else '  *'}"
             for k, v in result.values.items()]
    if brief:
        lines.append(f"  error {result.default_error:.4g} -> {result.error:.4g} {t.unit} (independent seed "
                     f"{result.independent_error:.4g}); total bits {dc['total_bits']} -> {nc['total_bits']}")
    else:
        lines.append(f"  error {result.default_error:.4g} -> {result.error:.4g} {t.unit} (target {t.value:.4g}; "
                     f"independent seed {result.independent_error:.4g})")
        lines.append(f"  cost: register/coefficient bits {dc['register_bits']} -> {nc['register_bits']}, memory bits "
                     f"{dc['memory_bits']} -> {nc['memory_bits']}, total {dc['total_bits']} -> {nc['total_bits']}")
    return "\n".join(lines)


def config_header(result: OptResult, cmd: str, source: str, changes: bool = True) -> str:
    """The header of an optimised config: the command (``cmd`` and the search's options), where it
    started (``source``), the error and bits reached and (``changes``) the word lengths changed."""
    t = result.target
    header = (f"{cmd} --target {t.text} --chain {t.chain} --metric {result.metric}\n"
              f"from {source}; {t.port} {result.metric} error {result.error:.4g} {t.unit} "
              f"(default {result.default_error:.4g}); total bits {result.cost['total_bits']} "
              f"(default {result.default_cost['total_bits']})")
    if changes:
        header += "\nchanged word lengths:\n" + "\n".join(
            f"  {k}: {result.default_values[k]} -> {v}" for k, v in result.values.items()
            if v != result.default_values[k])
    return header


def check_search(chain: str, margin: float | None = None, *, chains=None, search: bool = True,
                 cost_model: str = "total_bits", target: Target | None = None, max_mean: Target | None = None,
                 drive_band: bool = False) -> None:
    """ValueError naming the option when a word-length search cannot run as asked: ``chain`` not one of
    ``chains`` (the design's, when given), ``margin`` outside [0, 0.5) (when given); with ``search``:
    an unknown cost model, a chain without knobs, a ``max_mean`` not on ``target``'s output, a drive
    band on a chain without a drive frequency. The CLIs call it before any work, :func:`optimise` again."""
    if chains is not None and chain not in chains:
        raise InputError(f"--chain: unknown chain {chain!r}; expected one of {', '.join(chains)}")
    if margin is not None and not 0 <= margin < 0.5:
        raise InputError(f"--margin: must be within [0, 0.5), got {margin}")
    if not search:
        return
    if cost_model not in ("total_bits", "register_bits"):
        raise InputError(f"--cost: unknown cost model {cost_model!r}; expected total_bits or register_bits")
    if max_mean is not None and target is not None and (max_mean.port != target.port or max_mean.chain != chain):
        raise InputError(f"--max-mean: must be on {chain}.{target.port}, like --target, got "
                         f"{max_mean.chain}.{max_mean.port}")
    if drive_band and chains is not None and "demod" not in chains[chain].kinds.values():
        raise InputError(f"--drive-band: {chain} has no demodulator, so no drive frequency")


def _unreachable(ev: Evaluator, values: dict, error: float, goal: float, target: Target,
                 max_mean: Target | None) -> InputError:
    """The refusal of a search whose every-knob-at-its-maximum design misses its goal, naming the
    option that cannot be met. With a bias limit the search's error is max(metric, |mean| x target /
    limit): the design is measured again without the bias term, and --max-mean is named when the
    target alone is met (with |mean| there), else --target (with the metric's own error)."""
    where = f"{ev.chain}.{target.port}"
    if max_mean is not None and not math.isinf(error):
        alone = Evaluator(ev.base, ev.chain, ev.port, metric=ev.metric, samples=ev.samples, mean_weight=0.0,
                          frequencies=ev.frequencies).error(values)
        if alone <= goal:
            return InputError(f"--max-mean: {max_mean.text} is unreachable on {where} beside --target {target.text}: "
                              f"even with every word length at its maximum |mean| is "
                              f"{error / ev.mean_weight:.4g} {target.unit}")
        error = alone
    return InputError(f"--target: {target.text} is unreachable on {where}: even with every word length at its "
                      f"maximum the {ev.metric} error is {error:.4g} {target.unit}")


def optimise(config: Config, target: Target, metric: str = "rms", margin: float = DEFAULT_MARGIN,
             samples: int | None = None,
             progress=None, cost_model: str = "total_bits", max_mean: Target | None = None,
             frequencies: tuple = (), prefetch=None) -> OptResult:
    """``cost_model``: "total_bits" (registers, coefficients and memory) or "register_bits" (memory free).
    ``max_mean``: a limit on |mean| (a bias) of the same port, met together with the target;
    ``frequencies``: drive frequencies (of the chain's demodulator) at which both must hold as well.
    ``prefetch(evaluator, candidates, seed_offset)``: called with every batch of candidates the search
    is about to read (independent of each other) so that they can be evaluated in parallel into
    ``evaluator.cache`` (``fxdsp sweep wordlength``); the search reads the same values either way, so
    the result does not depend on it. Only stage 4 asks speculatively (the rest of a pass)."""
    chain = target.chain
    check_search(chain, cost_model=cost_model, target=target, max_mean=max_mean, drive_band=bool(frequencies))
    weight = target.value / max_mean.value if max_mean is not None else 0.0
    ev = Evaluator(copy.deepcopy(config.data), chain, target.port, metric, samples, weight, tuple(frequencies))
    knobs = ev.knobs
    if not knobs:
        raise InputError(f"--chain: no word-length knobs for {chain}")
    goal = target.value * (1.0 - margin)
    default = {k.name: knob_value(ev.base, k) for k in knobs}

    def ask(candidates, seed_offset: int = 1000) -> None:
        if prefetch is not None:
            prefetch(ev, list(candidates), seed_offset)

    def top_of(k: Knob) -> int:
        return min(k.hi, default[k.name] + HEADROOM + (8 if k.kind == "int" else 0)) if k.kind == "int" \
            else default[k.name] + HEADROOM

    ask([default] + [{**default, k.name: top_of(k)} for k in knobs])
    e_default = ev.error(default)
    log = [f"default: {target.port} {metric} error {e_default:.4g} {target.unit}; goal {goal:.4g} {target.unit} "
           f"(target {target.value:.4g} less a {margin * 100:.0f} % margin)"]
    bar = None

    def lo_of(k: Knob) -> int:
        if k.kind == "int":
            return k.lo
        return max(2, Format.parse(ev.defaults[k.fields[0]]).wl - 24)

    # 1. reachable maxima
    hi = {}
    for k in knobs:
        v = top_of(k)
        while v > default[k.name]:
            ask([{**default, k.name: v}])   # the top was asked above: a step down only when it does not build
            if not math.isinf(ev.error({**default, k.name: v})):
                break
            v -= 1
        hi[k.name] = v
    values_hi = dict(hi)
    ask([values_hi])
    while math.isinf(ev.error(values_hi)) and any(values_hi[n] > default[n] for n in values_hi):
        values_hi = {n: max(default[n], v - 1) for n, v in values_hi.items()}
        ask([values_hi])
    e_hi = ev.error(values_hi)
    log.append(f"every knob at its maximum: {e_hi:.4g} {target.unit}")
    if not e_hi <= goal:
        raise _unreachable(ev, values_hi, e_hi, goal, target, max_mean)

    bar = progress(total=len(knobs) * 2, desc="word-length search", unit="knob") if progress else None
    # 2. per-knob minimum with the others at their maximum (binary search, error ~ monotone in width);
    # the knobs' searches are independent, so they step together, one batch of midpoints at a time
    bounds = {k.name: [lo_of(k), values_hi[k.name]] for k in knobs}
    ask([{**values_hi, k.name: bounds[k.name][0]} for k in knobs])
    for k in knobs:
        if ev.error({**values_hi, k.name: bounds[k.name][0]}) <= goal:
            bounds[k.name][1] = bounds[k.name][0]
    active = [k for k in knobs if bounds[k.name][1] - bounds[k.name][0] > 1]
    bar and bar.update(len(knobs) - len(active))
    while active:
        mids = {k.name: sum(bounds[k.name]) // 2 for k in active}
        ask([{**values_hi, k.name: mids[k.name]} for k in active])
        for k in active:
            bounds[k.name][1 if ev.error({**values_hi, k.name: mids[k.name]}) <= goal else 0] = mids[k.name]
        done = [k for k in active if bounds[k.name][1] - bounds[k.name][0] <= 1]
        active = [k for k in active if k not in done]
        bar and bar.update(len(done))
    minimum = {k.name: bounds[k.name][1] for k in knobs}

    # 3. greedy addition from the minima
    values = dict(minimum)
    ask([values])
    e = ev.error(values)
    c_now = cost(ev.data(values), chain)[cost_model]
    steps = 0
    while not e <= goal:
        best = None
        ask([{**values, k.name: values[k.name] + 1} for k in knobs if values[k.name] < values_hi[k.name]])
        for k in knobs:
            if values[k.name] >= values_hi[k.name]:
                continue
            trial = {**values, k.name: values[k.name] + 1}
            et = ev.error(trial)
            if math.isinf(et):
                continue
            dc = max(cost(ev.data(trial), chain)[cost_model] - c_now, 1)
            gain = ((e if math.isfinite(e) else 1e300) ** 2 - et**2) / dc
            if best is None or gain > best[0]:
                best = (gain, k.name, et)
        if best is None:
            values, e = dict(values_hi), e_hi
            log.append("greedy addition stalled: fell back to the maxima")
            break
        values[best[1]] += 1
        e = best[2]
        c_now = cost(ev.data(values), chain)[cost_model]
        steps += 1
        log.append(f"+1 bit {best[1]} -> {values[best[1]]}: error {e:.4g}")
    for _ in knobs:
        bar and bar.update(1)

    # 4. greedy removal, most costly knob first, until no step is accepted
    changed = True
    while changed:
        changed = False
        order = sorted(knobs, key=lambda k: -((_instances(k, ev.data(values))[0] or 1)
                                              if cost_model == "total_bits" or not _instances(k, ev.data(values))[1]
                                              else 0))
        ahead = True   # ask for the rest of the pass from the current values (again after a change)
        for i, k in enumerate(order):
            if ahead:
                ask([{**values, q.name: values[q.name] - 1} for q in order[i:] if values[q.name] > lo_of(q)])
                ahead = False
            if values[k.name] <= lo_of(k):
                continue
            trial = {**values, k.name: values[k.name] - 1}
            et = ev.error(trial)
            if et <= goal:
                values, e, changed, ahead = trial, et, True, True
                log.append(f"-1 bit {k.name} -> {values[k.name]}: error {e:.4g}")
    if bar:
        bar.close()
    data = ev.data(values)
    ask([values], 4242)
    independent = ev.error(values, seed_offset=4242)
    return OptResult(target, metric, default, values, e_default, e, independent, cost(ev.base, chain), cost(data, chain),
                     ev.evaluations, data, log)


def sweep(config: Config, chain: str, port: str, metric: str = "rms", span: int = 8, step: int = 2,
          knobs: list[str] | None = None, progress=None) -> dict[str, list[tuple[int, float]]]:
    """Error vs word length, one knob at a time around the default (others at default)."""
    ev = Evaluator(copy.deepcopy(config.data), chain, port, metric)
    default = {k.name: knob_value(ev.base, k) for k in ev.knobs}
    chosen = [k for k in ev.knobs if knobs is None or k.name in knobs]
    out = {}
    it = progress(chosen, desc="error vs word length", unit="knob") if progress else chosen
    for k in it:
        d = default[k.name]
        widths = sorted({w for w in range(d - span, d + 3, step)} | {d})
        if k.kind == "int":
            widths = [w for w in widths if k.lo <= w <= k.hi]
        pts = []
        for w in widths:
            if w < 1:
                continue
            err = ev.error({**default, k.name: w})
            if math.isfinite(err):
                pts.append((w, err))
        out[k.name] = pts
    return out


# --------------------------------------------------------------------------------------------
# The synthesis report (the optimised config is written by fxdsp.config.dumps)
# --------------------------------------------------------------------------------------------
def synth_estimate(rows: dict | None, members: tuple[str, ...], bits_default: int, bits_new: int) -> dict | None:
    """Synthesised LUT/MAC16 of a chain's member instances (``design.instances[chain].members``) at
    the default widths, and an estimate for the new widths scaled by the register-bit ratio (MAC16
    count kept: a re-synthesis is the real answer)."""
    if not rows:
        return None
    keys = [k for k in members if k in rows]
    if not keys:
        return None
    lut = sum(rows[k]["lut"] for k in keys)
    mac = sum(rows[k]["mac16"] for k in keys)
    ratio = bits_new / bits_default if bits_default else 1.0
    return {"blocks": keys, "lut_default": lut, "mac16_default": mac, "lut_estimate": lut * ratio,
            "mac16_estimate": mac}
