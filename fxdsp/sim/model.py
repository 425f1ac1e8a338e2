"""The baseline model of the measured-data contract and the model-replay JSON.

Replay format (written by ``fxdsp diagnose``, replayed by ``fxdsp simulate --model``)::

    {"baseline": {"bias_poly": [c0, c1, ...],    # B(Te), ascending powers of (Te - t_ref_c), output unit
                  "sf_poly": [s0, s1, ...],      # S(Te), same powers, output unit per deg/s (per g for paper000)
                  "t_ref_c": 25.0,
                  "f0_hz": 3837.471,             # freq_hz = f0_hz + k_hz_per_c * Te: f0 is the value at Te = 0 C
                  "k_hz_per_c": 0.0536,          #   (the contract's formula, not at t_ref_c)
                  "rtd_offset_c": 0.0,           # optional: temp_c = rtd_offset_c + rtd_gain * T (linear RTD)
                  "rtd_gain": 1.0},              # optional
     "effects": {"thermal_lag": {"tau_s": 7150.0}}}

Other top-level keys (provenance, scenario, ...) are ignored. Unknown ``baseline`` keys and unknown
causes or parameters are errors, so a typo cannot silently replay the wrong model.

Scenario baselines (all polynomials in t = Te - 25 C):

* paper002 (silicon MEMS gyro, integrated RTD; output in mV, 10 mV per deg/s at 25 C): the
  two-mode gyro of :mod:`fxdsp.sim.gyro` (bias ~365 deg/h/C, non-linear; SF ~317 ppm/C over
  -20..60 C, paper 002's uncompensated figures) condensed to cubic B(t) and S(t) by
  least squares over -20..60 C. Drive resonance 8014.3 Hz at 25 C (paper 003's gyro) with silicon's
  -30 ppm/C (w = w0 (1 - a dT / 2), a = 60 ppm/C). RTD readout 0.3 C offset, gain 1.002 (a real,
  uncalibrated bridge).
* paper001 (metal cup gyro; output in deg/h at a nominal 3600 deg/h per deg/s): bias is the paper's
  fit -0.25 T^2 - 36.92 T + 1469.5 deg/h re-expanded about 25 C; SF tempco +100 ppm/C (the paper gives
  none; a typical metal-resonator value); f = 3837.471 + 0.0536 T Hz (the intercept implied by the
  printed f(-10 C) = 3836.9354 Hz, not the rounded 3837.4).
* paper000 (quartz VBA pair; output = difference frequency in Hz; the applied-input column carries
  the tumble's acceleration in g): K0(t), K1(t) and beam 1's linear frequency law from
  :mod:`fxdsp.sim.qvba`.
* ramp, random: the paper002 sensor.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from fxdsp.causes import PARAMETERS, check_parameters
from fxdsp.errors import InputError


@dataclass(frozen=True)
class Baseline:
    bias_poly: tuple[float, ...]
    sf_poly: tuple[float, ...]
    t_ref_c: float = 25.0
    f0_hz: float = 0.0
    k_hz_per_c: float = 0.0
    rtd_offset_c: float = 0.0
    rtd_gain: float = 1.0

    def bias(self, te_c) -> np.ndarray:
        return np.polynomial.polynomial.polyval(np.asarray(te_c, float) - self.t_ref_c, self.bias_poly)

    def sf(self, te_c) -> np.ndarray:
        return np.polynomial.polynomial.polyval(np.asarray(te_c, float) - self.t_ref_c, self.sf_poly)

    def freq(self, te_c) -> np.ndarray:
        return self.f0_hz + self.k_hz_per_c * np.asarray(te_c, float)

    def as_dict(self) -> dict:
        d = asdict(self)
        d["bias_poly"], d["sf_poly"] = list(self.bias_poly), list(self.sf_poly)
        return d


@dataclass(frozen=True)
class Model:
    baseline: Baseline
    effects: dict[str, dict[str, float]] = field(default_factory=dict)
    # baseline fields the replay file gave; the others come from the scenario (a diagnosis omits
    # what its log cannot determine, e.g. sf_poly without a rate column, f0/k without freq_hz)
    given: frozenset = frozenset(("bias_poly", "sf_poly", "t_ref_c", "f0_hz", "k_hz_per_c", "rtd_offset_c",
                                  "rtd_gain"))

    def as_dict(self) -> dict:
        base = {k: v for k, v in self.baseline.as_dict().items() if k in self.given}
        return {"baseline": base, "effects": {k: dict(v) for k, v in self.effects.items()}}


# --- scenario baselines -------------------------------------------------------------------------

PAPER002_FIT_TEMPS_C = np.linspace(-20.0, 60.0, 81)  # the paper's test range


def _paper002() -> Baseline:
    # the two-mode gyro model of fxdsp.sim.gyro, condensed to the contract's polynomials: cubic
    # bias and SF fitted over the paper's range (the fit error is far below the noise)
    from fxdsp.sim.gyro import PAPER002_GYRO as gyro
    t = PAPER002_FIT_TEMPS_C
    bias = np.polynomial.polynomial.polyfit(t - 25.0, gyro.bias_mv(t), 3)
    sf = np.polynomial.polynomial.polyfit(t - 25.0, gyro.sf_mv_per_dps(t), 3)
    k = -gyro.fx_hz * gyro.a_x_per_c / 2.0  # w = w0 (1 - a dT / 2)
    return Baseline(bias_poly=tuple(float(c) for c in bias), sf_poly=tuple(float(c) for c in sf),
                    f0_hz=gyro.fx_hz - 25.0 * k, k_hz_per_c=k, rtd_offset_c=0.3, rtd_gain=1.002)


PAPER001_SF0 = 3600.0  # deg/h of output per deg/s of rate
PAPER001_SF_TEMPCO = 100e-6


def _paper001() -> Baseline:
    from fxdsp.sim.gyro import METAL_GYRO as gyro
    # re-expand the paper's polynomial in T about t_ref = 25 C: exact, it is a change of variable
    shifted = np.polynomial.Polynomial(gyro.bias_poly_deg_h)(np.polynomial.Polynomial([25.0, 1.0]))
    return Baseline(bias_poly=tuple(float(c) for c in shifted.coef),
                    sf_poly=(PAPER001_SF0, PAPER001_SF0 * PAPER001_SF_TEMPCO),
                    f0_hz=gyro.f0_hz, k_hz_per_c=gyro.k_hz_per_c)


def _paper000() -> Baseline:
    from fxdsp.sim import qvba  # local import: the accelerometer model is only needed here
    return qvba.DEFAULT_PAIR.contract_baseline()


_BASELINES = {"paper002": _paper002, "paper001": _paper001, "paper000": _paper000,
              "ramp": _paper002, "random": _paper002, "power_on": _paper001}


def scenario_baseline(scenario: str) -> Baseline:
    if scenario not in _BASELINES:
        raise InputError(f"scenario: unknown name {scenario!r}; expected one of {', '.join(_BASELINES)}")
    return _BASELINES[scenario]()


# --- validation ----------------------------------------------------------------------------------

_REQUIRED = ("bias_poly",)
_OPTIONAL = ("sf_poly", "t_ref_c", "f0_hz", "k_hz_per_c", "rtd_offset_c", "rtd_gain")


def _number(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{name}: must be a finite number, got {value!r}")
    return float(value)


def _poly(name: str, value) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or not value:
        raise InputError(f"{name}: must be a non-empty list of numbers (ascending powers of T - t_ref_c)")
    return tuple(_number(f"{name}[{i}]", v) for i, v in enumerate(value))


def validate_effects(effects, where: str = "effects") -> dict[str, dict[str, float]]:
    """Check cause names and parameters against the contract; 'none' is accepted and dropped."""
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise InputError(f"{where}: must be a mapping cause -> {{parameter: value}}")
    out = {}
    for cause, params in effects.items():
        if cause not in PARAMETERS:
            raise InputError(f"{where}: unknown cause {cause!r}; expected one of {', '.join(PARAMETERS)}")
        if not isinstance(params, dict):
            raise InputError(f"{where}.{cause}: must be a mapping parameter -> value")
        for pname, pvalue in params.items():
            if pname in PARAMETERS[cause]:  # a JSON string or null would otherwise pass float() or fail unnamed
                _number(f"{where}.{cause}.{pname}", pvalue)
        checked = check_parameters(cause, params)
        for pname, value in checked.items():
            if pname == "tau_s" and not value > 0:  # a time constant; the mechanism would divide by it
                raise InputError(f"{where}.{cause}.tau_s: must be > 0, got {value!r}")
        if cause != "none":
            out[cause] = checked
    return out


def model_from_dict(data) -> Model:
    if not isinstance(data, dict):
        raise InputError("model: top level must be a JSON object with 'baseline' and 'effects'")
    if "baseline" not in data:
        raise InputError("model: missing field 'baseline'")
    base = data["baseline"]
    if not isinstance(base, dict):
        raise InputError("baseline: must be a JSON object")
    unknown = sorted(set(base) - set(_REQUIRED) - set(_OPTIONAL))
    if unknown:
        raise InputError(f"baseline.{unknown[0]}: unknown field; expected {', '.join(_REQUIRED + _OPTIONAL)}")
    for name in _REQUIRED:
        if name not in base:
            raise InputError(f"baseline.{name}: missing field")
    kwargs = {"bias_poly": _poly("baseline.bias_poly", base["bias_poly"]),
              "sf_poly": _poly("baseline.sf_poly", base["sf_poly"]) if "sf_poly" in base else ()}
    for name in _OPTIONAL:
        if name in base and name != "sf_poly":
            kwargs[name] = _number(f"baseline.{name}", base[name])
    if "rtd_gain" in kwargs and kwargs["rtd_gain"] == 0:
        raise InputError("baseline.rtd_gain: must be non-zero")
    return Model(Baseline(**kwargs), validate_effects(data.get("effects", {})),
                 given=frozenset(k for k in _REQUIRED + _OPTIONAL if k in base))


def read_model(path) -> Model:
    """Read and validate a model-replay JSON file; ValueError names the offending field."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"model: cannot read {path}: {exc.strerror or exc}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"model: {path} is not valid JSON ({exc.msg}, line {exc.lineno})") from None
    try:
        return model_from_dict(data)
    except InputError as exc:   # the file is named with the field
        raise InputError(f"model: {path}: {str(exc).removeprefix('model: ')}") from None


def write_model(path, model: Model) -> None:
    from fxdsp.outputs import json_text

    Path(path).write_text(json_text(model.as_dict(), "model", indent=2), encoding="utf-8")


def as_model(model) -> Model | None:
    """Accept a Model, a dict in the replay format, or a path to a replay JSON file."""
    if model is None or isinstance(model, Model):
        return model
    if isinstance(model, dict):
        return model_from_dict(model)
    if isinstance(model, (str, Path)):
        return read_model(model)
    raise InputError(f"model: expected a path, a dict or a Model, got {type(model).__name__}")
