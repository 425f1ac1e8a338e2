"""What a diagnosis changes in the FPGA, and the compensated-output gain with and without it.

* ``thermal_lag``: the coefficient engine should see the die temperature, not the thermometer's.
  The extension is the bit-exact ``lag`` block (fxdsp/blocks/lag.py: a fixed-point first-order
  filter on the temperature code, alpha as mantissa + shift) with the fitted tau, run at the log's
  sample rate on the temperature code the RTD readout produces (the default config's temp_format).
* ``quadrature_leak``: a demodulation phase error leaks the quadrature channel into the rate
  channel; the extension is a phase trim of -atan(c) on the demodulator's reference (to first
  order: subtracting c * quad).

Gain = held-out rms of the compensated output (a cubic bias and scale-factor polynomial in the
temperature the FPGA sees, fitted on the training folds of the diagnosis's own time-blocked folds)
without / with the extension.
"""

from __future__ import annotations

import numpy as np

from fxdsp.causes import phase_trim_rad
from fxdsp.diagnose.context import Diagnosis
from fxdsp.ramps import sample_interval


def _heldout_rms(y: np.ndarray, temp: np.ndarray, rate: np.ndarray | None, folds: np.ndarray,
                 extra: np.ndarray | None = None) -> float:
    return float(np.sqrt(np.mean(heldout_residual(y, temp, rate, folds, extra) ** 2)))


def heldout_residual(y: np.ndarray, temp: np.ndarray, rate: np.ndarray | None, folds: np.ndarray,
                     extra: np.ndarray | None = None, order: int = 3) -> np.ndarray:
    """Per row: the output minus a bias (and SF, with a rate) polynomial of ``order`` in temp (a cubic
    by default) fitted on the other folds."""
    t = (temp - temp.mean()) / max(temp.std(), 1e-12)
    cols = [np.ones_like(t)] + [t**k for k in range(1, order + 1)]
    if rate is not None and np.any(rate != 0):
        cols += [rate * c for c in cols]
    if extra is not None:
        cols.append(extra)
    X = np.column_stack(cols)
    resid = np.empty_like(y)
    for f in np.unique(folds):
        train, test = folds != f, folds == f
        coef, *_ = np.linalg.lstsq(X[train], y[train], rcond=None)
        resid[test] = y[test] - X[test] @ coef
    return resid


def log_rate_lag(template, tau_s: float, time_s):
    """A config's lag (word lengths, rounding) with alpha for a log's sample interval: the same
    filter as the FPGA's, run once per logged row."""
    from fxdsp.blocks.lag import Lag

    return Lag(template.temp_format, tau_s, 1.0 / sample_interval(np.asarray(time_s, float)), template.alpha_bits,
               template.g, template.rules, name="lag(log rate)")


def lag_extension(diag: Diagnosis, tau_s: float) -> dict:
    from fxdsp.chains import build
    from fxdsp.fixed import Rules, quantize, to_float

    s = diag.context.series
    block = log_rate_lag(build(chains=False).blocks["lag"], tau_s, s.t)
    code = quantize(s.temp, block.temp_format, Rules("half_up", "saturate"))
    te = to_float(block.run(temp=code).outputs["te"], block.temp_format)
    folds = diag.context.blocks.row_fold()
    before = _heldout_rms(s.out, s.temp, s.rate, folds)
    after = _heldout_rms(s.out, te, s.rate, folds)
    return {"extension": "lag", "block": "lag", "tau_s": tau_s, "rate_hz": block.rate_hz,
            "alpha_mantissa": block.m, "alpha_shift": block.s, "temp_format": str(block.temp_format),
            "rms_without": before, "rms_with": after, "ratio": before / after if after > 0 else float("inf"),
            "heldout": True,
            "config": f"[lag] tau_s = {tau_s:.6g}, rate_hz = {block.rate_hz:.6g} (then `fxdsp vectors --config F` "
                      f"for this device's golden vectors)"}


def phase_trim_extension(diag: Diagnosis, c: float) -> dict:
    s = diag.context.series
    folds = diag.context.blocks.row_fold()
    before = _heldout_rms(s.out, s.temp, s.rate, folds)
    after = _heldout_rms(s.out - c * s.quad, s.temp, s.rate, folds)
    return {"extension": "phase_trim", "phase_trim_rad": phase_trim_rad(c), "c": c, "rms_without": before,
            "rms_with": after, "ratio": before / after if after > 0 else float("inf"), "heldout": True}


def fpga_extensions(diag: Diagnosis) -> list[dict]:
    out = []
    if "thermal_lag" in diag.causes and diag.context.series.out is not None:
        out.append(lag_extension(diag, diag.parameters["thermal_lag"]["tau_s"]))
    if "quadrature_leak" in diag.causes and diag.context.series.quad is not None:
        out.append(phase_trim_extension(diag, diag.parameters["quadrature_leak"]["c"]))
    return out
