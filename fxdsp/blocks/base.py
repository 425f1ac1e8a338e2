"""What every block shares: named, formatted ports; a bit-exact ``run`` on stored integers; a float
``reference`` on real values; and a stimulus that always includes the corner cases.

The two kinds of value are never mixed silently: ``run`` refuses floats (stored integers are
expected: quantise real values first, or call ``run_real``), ``reference`` refuses integer arrays
(real values are expected: ``run_float`` feeds it the real values of stored integers), and an
unknown input name is named with the nearest port."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from fxdsp.config import nearest
from fxdsp.fixed import Format, OverflowLog, check_in_format, to_float
from fxdsp.errors import InputError


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

    def __init_subclass__(cls, **kwargs):
        # every block's own float reference gets the same guard on its inputs (see _checked_reference)
        super().__init_subclass__(**kwargs)
        if "reference" in cls.__dict__:
            cls.reference = _checked_reference(cls.__dict__["reference"])

    def _check_names(self, given, what: str = "input") -> None:
        """An unknown input is named first, with the nearest port; then a missing one."""
        extra = [k for k in given if k not in self.inputs]
        if extra:
            near = nearest(extra[0], self.inputs)
            hint = f" (did you mean {near!r}?)" if near else ""
            raise InputError(f"{self.name}: unknown {what} {extra[0]!r}{hint}; inputs: {', '.join(self.inputs)}")
        missing = [k for k in self.inputs if k not in given]
        if missing:
            raise InputError(f"{self.name}: missing {what} {missing[0]!r}; inputs: {', '.join(self.inputs)}")

    def run(self, log: OverflowLog | None = None, state=None, **inputs) -> Result:
        """Bit-exact model: stored integers in, stored integers out (every input checked against
        its port format, so a caller cannot feed an out-of-range word silently), from the reset
        state or from ``state`` (a previous result's ``state``). Floats are refused: quantise real
        values first (:func:`fxdsp.quantize` with the port's format, ``block.inputs[name]``) or call
        :meth:`run_real`."""
        self._check_names(inputs)
        for k, v in inputs.items():
            kind = np.asarray(v).dtype.kind
            if kind in "fc":
                raise TypeError(f"{self.name}.{k}: stored integers expected, got {np.asarray(v).dtype} values; "
                                f"quantize real values first (fxdsp.quantize(values, {str(self.inputs[k])!r})) "
                                f"or call {self.name}.run_real({k}=...)")
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

    def run_real(self, rounding: str = "half_up", overflow: str | None = None, log: OverflowLog | None = None,
                 state=None, **real) -> Result:
        """``run`` on real values: each input quantised into its port format by :func:`fxdsp.quantize`
        (``rounding``; ``overflow`` None: a value outside the port's range is an error naming it,
        ``saturate`` or ``wrap``: fitted and counted in the result's overflows under
        ``<block>.<input>``). Outputs are stored integers as from ``run``: ``real_outputs(result)``
        gives their real values."""
        from fxdsp.api import quantize

        self._check_names(real)
        log = OverflowLog() if log is None else log
        stored = {k: quantize(v, self.inputs[k], rounding, overflow, log=log, where=f"{self.name}.{k}")
                  for k, v in real.items()}
        return self.run(log=log, state=state, **stored)

    def run_float(self, **inputs) -> dict[str, np.ndarray]:
        """The float reference fed with the real values of the same stored inputs."""
        self._check_names(inputs)
        real = {k: to_float(check_in_format(v, self.inputs[k], f"{self.name}.{k}"), self.inputs[k])
                for k, v in inputs.items()}
        return self.reference(**real)

    def real_outputs(self, result: Result) -> dict[str, np.ndarray]:
        """The real values of a run's stored outputs (stored integer x 2**-fl of each port's format)."""
        return {k: to_float(v, self.outputs[k]) for k, v in result.outputs.items()}

    def reset(self) -> None:
        """Internal state back to power-on (blocks with memory override this)."""

    def get_state(self):
        """A copy of the internal state (None for a block without memory)."""
        return None

    def set_state(self, state) -> None:
        if state is not None:
            raise InputError(f"{self.name}: state: this block has no memory, got {type(state).__name__}")

    def stream_outputs(self, log: OverflowLog, wanted: set[str], **inputs) -> dict[str, np.ndarray]:
        """``stream`` when a chain reads only the outputs ``wanted`` (a block that can skip the work of
        the others overrides it; the bits of the wanted ones are the same)."""
        return self.stream(log, **inputs)

    # --- to implement ---
    def stream(self, log: OverflowLog, **inputs) -> dict[str, np.ndarray]:  # pragma: no cover
        """Continue from the current internal state, inputs unchecked (``run`` checks them)."""
        raise NotImplementedError

    def reference(self, **inputs) -> dict[str, np.ndarray]:  # pragma: no cover
        """The float model on real values (floats, in the ports' units), not stored integers."""
        raise NotImplementedError

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:  # pragma: no cover
        raise NotImplementedError

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """In-range signals for error statistics (the vectors' stimulus adds corners and saturation)."""
        return self.stimulus(rng, n)

    def parameters(self) -> dict:
        """What the vectors' manifest records about this block (formats, rules, coefficients)."""
        return {}


def _checked_reference(method):
    """A block's ``reference`` behind the guard every block shares: inputs by name (an unknown one
    named with the nearest port) and real values only. An integer array is refused: it is most
    likely a run's stored integers, which ``reference`` would read 2**fl times too large."""

    @functools.wraps(method)
    def reference(self, *args, **inputs):
        if args:
            raise TypeError(f"{self.name}.reference: pass the inputs by name ({', '.join(self.inputs)})")
        self._check_names(inputs)
        for k, v in inputs.items():
            dtype = np.asarray(v).dtype
            if dtype.kind in "biu":
                raise TypeError(f"{self.name}.reference: {k!r} holds integers ({dtype}): reference takes real "
                                f"values as floats; for stored integers call run_float(...), or convert them "
                                f"with fxdsp.to_real(stored, {str(self.inputs[k])!r})")
        return method(self, **inputs)

    return reference


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
