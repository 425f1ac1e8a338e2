"""The stimuli of the RTL regressions, from the design alone (any config): a block's random stream
with its corners first, its corner stream (rounding ties, saturation, breakpoints, ...), and the
window of a stream that a slow simulator runs of a serial variant.

``fxdsp rtl``, ``fxdsp sweep rtl``, ``fxdsp extend`` and the project's HDL tests draw the same way.
"""

from __future__ import annotations

import numpy as np

from fxdsp.blocks.base import corner_codes, tie_codes
from fxdsp.hdl.schedule import cycles_per_sample

# samples of a random stream per block module (its corners first, then a random tail): the slow ones
# shorter; a chain's from its one-sample-per-clock schedule, CHAIN_CYCLES cycles in all
# (demod 1200: its low-passes settle in ~80 samples; Icarus runs its one-sample-per-clock RTL at ~1.7 k
# samples/s)
MAX_SAMPLES = {"demod": 1200, "iir": 1500, "lag": 2000, "drive": 1500}
CHAIN_CYCLES = 40_000
# A serial variant takes 12-350 cycles per sample and Icarus simulates ~10-15k of its cycles per
# second (it, not the Python driver, is the limit), so its Python-driven Icarus streams are cut to a
# window of at most ICARUS_SERIAL_SAMPLES samples and ICARUS_SERIAL_CYCLES cycles (at least
# ICARUS_MIN_SAMPLES); Verilator runs every stream whole, bit for bit the same RTL.
ICARUS_SERIAL_SAMPLES = 200
ICARUS_SERIAL_CYCLES = 20_000
ICARUS_MIN_SAMPLES = 40


def icarus_samples(design, name: str) -> int:
    """The window of an instance's serial stream on Icarus, from its cycles per sample."""
    per = cycles_per_sample(design, name, 1)
    return int(min(ICARUS_SERIAL_SAMPLES, max(ICARUS_MIN_SAMPLES, ICARUS_SERIAL_CYCLES // per)))


def max_samples(design, name: str) -> int | None:
    """The longest random stream of an instance (None: its whole stimulus); a chain's no longer than
    its slowest member's (a drive loop's one-sample-per-clock RTL is as slow to simulate in a top)."""
    inst = design.instances[name]
    if inst.members:
        own = max(400, CHAIN_CYCLES // cycles_per_sample(design, name, 0))
        caps = [MAX_SAMPLES[m] for m in (design.instances[v.replace(".", "_")].module for v in inst.members)
                if m in MAX_SAMPLES]
        return min([own, *caps])
    return MAX_SAMPLES.get(inst.module)


def icarus_window(inputs: dict[str, np.ndarray], n: int = ICARUS_SERIAL_SAMPLES) -> dict[str, np.ndarray]:
    """``n`` samples of a stream for a serial DUT on Icarus: its first n/2 from a few samples before the
    first change of any input (a golden set may open with silence: its prefix would test nothing;
    a random or corner stream opens with its corners) and its last n/2 (a random stream's random
    tail, a golden set's last features). The caller runs the model on the window, from reset."""
    changes = [int(np.flatnonzero(v != v[0])[0]) for v in inputs.values() if np.any(v != v[0])]
    start = max(0, min(changes, default=0) - 4)
    size = len(next(iter(inputs.values())))
    if size - start <= n:
        return {k: v[start:] for k, v in inputs.items()}
    return {k: np.r_[v[start:start + n // 2], v[size - (n - n // 2):]] for k, v in inputs.items()}


def random_stimulus(design, name: str, seed: int) -> dict:
    """The block's stimulus (corners first) cut to MAX_SAMPLES: the head and a random tail."""
    block = design.all[name]
    rng = np.random.default_rng(seed)
    stim = block.stimulus(rng, 400)
    n = len(next(iter(stim.values())))
    m = max_samples(design, name) or n
    if n > m:  # keep the head (corners) and a random tail
        keep = np.r_[np.arange(m // 2), np.sort(rng.choice(np.arange(m // 2, n), m - m // 2, replace=False))]
        stim = {k: v[keep] for k, v in stim.items()}
    return stim


def _chain_corners(d, name: str) -> dict[str, np.ndarray]:
    """Each chain input: the corners of the first member input it drives (full-scale codes when that
    member has none for it), all repeated to the longest."""
    chain = d.chains[name]
    parts = {}
    for inp, dsts in chain.netlist.inputs.items():
        dst = dsts[0]
        own = _block_corners(d, dst.instance.replace(".", "_")).get(dst.port)
        parts[inp] = own if own is not None and len(own) else corner_codes(chain.inputs[inp])
    m = max(len(v) for v in parts.values())
    return {k: np.resize(v, m).astype(np.int64) for k, v in parts.items()}


def _block_corners(d, name: str) -> dict[str, np.ndarray]:
    """A block's corner cases by its RTL module (the inputs it has them for)."""
    block = d.all[name]
    module = d.instances[name].module
    extra: dict[str, np.ndarray] = {}
    if module == "rtd":
        # rounding ties, then the first LUT segments' boundaries from the lowest code
        fc, s = block.adc_format, block.datapath.frac_bits
        ends = (np.arange(min(32, 1 << (fc.wl - s))) << s) + fc.min_int
        extra = {"code": np.r_[rtd_ties(block), ends].astype(np.int64)}
    elif module == "piecewise":
        bp = block.breakpoints
        t0 = int(block.t0[0])
        fmt = block.temp_format
        vals = np.concatenate([bp, bp - 1, bp + 1, [t0 - 1, t0, t0 + 1], corner_codes(fmt)])
        extra = {"temp": np.clip(vals, fmt.min_int, fmt.max_int).astype(np.int64)}
    elif module == "sf_divide":
        cx = corner_codes(block.in_format)
        fs = block.sf_format
        sfs = np.array([0, 1, 2, 3, fs.max_int, fs.max_int - 1, 1 << fs.fl, (1 << fs.fl) + 1]
                       + ([-1, -2, fs.min_int] if fs.signed else []), dtype=np.int64)
        sfs = sfs[(sfs >= fs.min_int) & (sfs <= fs.max_int)]
        extra = {"x": np.repeat(cx, sfs.size), "sf": np.tile(sfs, cx.size)}
    elif module == "bias_subtract":
        ties = tie_codes(block.in_format, 2)
        extra = {"x": ties, "bias": np.zeros(ties.size, np.int64)}
    elif module == "freq2temp":
        f0 = block.f0
        extra = {"f": np.r_[corner_codes(block.freq_format), [f0 - 2, f0 - 1, f0, f0 + 1, f0 + 2]].astype(np.int64)}
    elif module == "lag":
        # starts away from 0 and from where the aborted first stream leaves the state, so the
        # state must be primed again on the first sample after the reset; full-scale alternation
        # and steps (slew over the whole range), then +-1 code steps (rounding of tiny d)
        fmt = block.temp_format
        alt = np.where(np.arange(200) % 2 == 0, fmt.max_int, fmt.min_int)
        small = np.repeat(np.array([1, 0, -1, 0, 2, -2, 0]), 12)
        extra = {"temp": np.r_[np.full(20, 3 * fmt.max_int // 4), alt, np.full(60, fmt.max_int),
                               np.full(60, fmt.min_int), np.full(30, 0), small].astype(np.int64)}
    elif module in ("iir", "demod"):
        fmt = block.inputs["x"]
        alt = np.where(np.arange(600) % 2 == 0, fmt.max_int, fmt.min_int)
        steps = np.r_[np.full(300, fmt.max_int), np.full(300, fmt.min_int), np.full(50, 0)]
        extra = {"x": np.r_[alt, steps].astype(np.int64)}
    return extra


def rtd_ties(block) -> np.ndarray:
    """Every ADC code whose exact interpolated value sits on a rounding tie (searched exhaustively)."""
    fmt, s, shift = block.adc_format, block.datapath.frac_bits, block.datapath.shift
    code = np.arange(fmt.min_int, fmt.max_int + 1, dtype=np.int64)
    u = code - fmt.min_int
    idx = u >> s
    base = block.lut[idx]
    exact = (base << s) + (block.lut[idx + 1] - base) * (u & ((1 << s) - 1))
    if shift <= 0:
        return code[:0]
    tie = (exact & ((1 << shift) - 1)) == (1 << (shift - 1))
    return code[tie][:200]


def corners(d, name, rng) -> dict[str, np.ndarray]:
    """The instance's corner stream: the cases that tell its arithmetic rules apart (rounding ties,
    saturation, breakpoints, SF at and near zero, f0, full-scale steps), by its RTL module; a chain's
    inputs take the corners of the member inputs they drive; then the head of its own stimulus (whose
    corners open it)."""
    block = d.all[name]
    head = {k: v[:400] for k, v in block.stimulus(rng, 32).items()}
    extra = _chain_corners(d, name) if d.instances[name].members else _block_corners(d, name)
    out = {}
    for k, v in head.items():
        e = extra.get(k)
        out[k] = np.concatenate([e, v]) if e is not None and len(e) else v
    n = min(len(v) for v in out.values())
    return {k: v[:n] for k, v in out.items()}
