"""What every block shares: named, formatted ports; a bit-exact ``run`` on stored integers; a float
``reference`` on real values; and a stimulus that always includes the corner cases."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..fixed import Format, OverflowLog, check_in_format, to_float


@dataclass
class Result:
    """Outputs of a bit-exact run (stored integers by port), the overflow counts it made, and the
    state after the last sample (scipy's ``zf``: pass it as ``state`` to continue the stream)."""

    outputs: dict[str, np.ndarray]
    overflows: OverflowLog = field(default_factory=OverflowLog)
    state: object = None


class Block:
    """Base of all blocks. Subclasses set ``name`` (their config table), ``inputs`` and ``outputs``
    (port -> Format), build ``datapath`` (their arithmetic, :mod:`fxdsp.blocks.datapath`) and
    implement ``stream(log, **stored) -> dict`` and ``reference(**real) -> dict``.

    State contract (scipy's ``zi``/``zf``): ``run`` and ``reference`` are pure. ``run(state=None)``
    starts from the reset state, ``run(state=previous.state)`` continues a stream; calling either
    twice on the same input gives the same output. ``stream`` is the building block the chains use:
    it continues from the block's current internal state, which only ``run`` and ``reset`` set.
    Blocks with memory override ``get_state``/``set_state``/``reset``."""

    name: str = "block"
    inputs: dict[str, Format]
    outputs: dict[str, Format]

    def run(self, log: OverflowLog | None = None, state=None, **inputs) -> Result:
        """Bit-exact model: stored integers in, stored integers out (every input checked against
        its port format, so a caller cannot feed an out-of-range word silently), from the reset
        state or from ``state`` (a previous result's ``state``)."""
        missing = set(self.inputs) - set(inputs)
        if missing:
            raise ValueError(f"{self.name}: missing input {sorted(missing)[0]!r}")
        extra = set(inputs) - set(self.inputs)
        if extra:
            raise ValueError(f"{self.name}: unknown input {sorted(extra)[0]!r}")
        checked = {k: check_in_format(v, self.inputs[k], f"{self.name}.{k}") for k, v in inputs.items()}
        log = OverflowLog() if log is None else log
        self.reset()
        if state is not None:
            self.set_state(state)
        try:
            outputs = self.stream(log, **checked)
            final = self.get_state()
        finally:
            self.reset()
        return Result(outputs, log, final)

    def run_float(self, **inputs) -> dict[str, np.ndarray]:
        """The float reference fed with the real values of the same stored inputs."""
        real = {k: to_float(v, self.inputs[k]) for k, v in inputs.items()}
        return self.reference(**real)

    def real_outputs(self, result: Result) -> dict[str, np.ndarray]:
        return {k: to_float(v, self.outputs[k]) for k, v in result.outputs.items()}

    def reset(self) -> None:
        """Internal state back to power-on (blocks with memory override this)."""

    def get_state(self):
        """A copy of the internal state (None for a block without memory)."""
        return None

    def set_state(self, state) -> None:
        if state is not None:
            raise ValueError(f"{self.name}: state: this block has no memory, got {type(state).__name__}")

    # --- to implement ---
    def stream(self, log: OverflowLog, **inputs) -> dict[str, np.ndarray]:  # pragma: no cover
        """Continue from the current internal state, inputs unchecked (``run`` checks them)."""
        raise NotImplementedError

    def reference(self, **inputs) -> dict[str, np.ndarray]:  # pragma: no cover
        raise NotImplementedError

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:  # pragma: no cover
        raise NotImplementedError

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """In-range signals for error statistics (the vectors' stimulus adds corners and saturation)."""
        return self.stimulus(rng, n)

    def parameters(self) -> dict:
        """What the vectors' manifest records about this block (formats, rules, coefficients)."""
        return {}


def corner_codes(fmt: Format) -> np.ndarray:
    """Full scale, minimum negative, zero and their neighbours."""
    lo, hi = fmt.min_int, fmt.max_int
    vals = [lo, lo + 1, lo + 2, -2, -1, 0, 1, 2, hi - 2, hi - 1, hi]
    return np.array(sorted({v for v in vals if lo <= v <= hi}), dtype=np.int64)


def random_codes(rng: np.random.Generator, fmt: Format, n: int) -> np.ndarray:
    return rng.integers(fmt.min_int, fmt.max_int, size=n, endpoint=True, dtype=np.int64)


def tie_codes(fmt: Format, drop_bits: int) -> np.ndarray:
    """Codes that sit exactly half an output LSB between two outputs when ``drop_bits`` are rounded
    away: the cases that tell floor, half_up, half_even and toward_zero apart."""
    if drop_bits <= 0:
        return np.zeros(0, dtype=np.int64)
    half = 1 << (drop_bits - 1)
    step = 1 << drop_bits
    ks = np.array([-3, -2, -1, 0, 1, 2, 3], dtype=np.int64)
    vals = ks * step + half
    return vals[(vals >= fmt.min_int) & (vals <= fmt.max_int)]
