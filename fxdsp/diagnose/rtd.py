"""Platinum RTD: why a linear law R = R0 (1 + beta T) misreads, and the Callendar-Van Dusen fix.

Paper 002 reads its RTD with R = R0 (1 + beta T). A real platinum element follows Callendar-Van
Dusen (IEC 60751): R = R0 [1 + A T + B T^2 + C (T - 100) T^3], the C term only below 0 C. The
difference is a curvature, which is the `rtd_nonlinearity` cause of the measured-data contract:
a linear readout reports T + b (T - 25)^2 (+ offset and gain), b close to B/A.

``rtd_study`` runs the whole argument on a resistance table: linear least-squares law and its
temperature error, the cause named by the diagnosis engine from a log built from the table, a
Callendar-Van Dusen least-squares fit and the IEC 60751 constants, with their temperature errors
(``fxdsp diagnose-rtd TABLE`` prints it). The law is the RTD block's (:func:`cvd_law`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxdsp.blocks.rtd import RtdPhysics
from fxdsp.logfile import lines_and_header
from fxdsp.errors import InputError

IEC60751 = {"R0": 100.0, "A": 3.9083e-3, "B": -5.775e-7, "C": -4.183e-12}


@dataclass
class ErrorStats:
    max_abs_c: float
    rms_c: float

    @classmethod
    def of(cls, error_c: np.ndarray) -> "ErrorStats":
        e = np.asarray(error_c, dtype=float)
        return cls(float(np.max(np.abs(e))), float(np.sqrt(np.mean(e * e))))


def load_table(path) -> tuple[np.ndarray, np.ndarray]:
    """(temperature_c, resistance_ohm) from a CSV with a header row naming those two columns (any
    other table, e.g. a chamber log, is refused by name rather than read as one)."""
    lines, header = lines_and_header(path)
    missing = [c for c in ("temperature_c", "resistance_ohm") if c not in header]
    if missing:
        raise InputError(f"{path}: expected columns temperature_c,resistance_ohm; the header has "
                         f"{', '.join(header) or 'nothing'}")
    try:
        data = np.loadtxt(lines[1:], delimiter=",", ndmin=2, usecols=[header.index("temperature_c"),
                                                                      header.index("resistance_ohm")])
    except ValueError as exc:
        raise InputError(f"{path}: {str(exc).splitlines()[0]}") from None
    if data.shape[0] < 4 or not np.all(np.isfinite(data)):
        raise InputError(f"{path}: need at least 4 rows of finite temperature_c, resistance_ohm")
    return data[:, 0].copy(), data[:, 1].copy()


def fit_linear(temp_c, resistance) -> tuple[float, float]:
    """R0 and beta of R = R0 (1 + beta T), least squares in R."""
    slope, intercept = np.polyfit(np.asarray(temp_c, float), np.asarray(resistance, float), 1)
    return float(intercept), float(slope / intercept)


def linear_temperature(resistance, r0: float, beta: float) -> np.ndarray:
    return (np.asarray(resistance, float) / r0 - 1.0) / beta


def cvd_law(R0: float, A: float, B: float, C: float) -> RtdPhysics:
    """The Callendar-Van Dusen element with these constants, as the RTD block models it (one law for
    the block, the simulator and this study): ``.resistance(T)`` and its inverse ``.temperature(R)``.
    Called as ``cvd_law(**IEC60751)`` or ``cvd_law(**fit_cvd(t, r))``."""
    return RtdPhysics(law="cvd", r0_ohm=R0, cvd_a=A, cvd_b=B, cvd_c=C)


def fit_cvd(temp_c, resistance) -> dict[str, float]:
    """R0, A, B, C of Callendar-Van Dusen by linear least squares in (R0, R0 A, R0 B, R0 C)."""
    t = np.asarray(temp_c, float)
    r = np.asarray(resistance, float)
    cols = [np.ones_like(t), t, t * t]
    has_cold = bool(np.any(t < 0))
    if has_cold:
        cols.append(np.where(t < 0, (t - 100.0) * t ** 3, 0.0))
    x = np.column_stack(cols)
    scale = np.sqrt(np.mean(x * x, axis=0))
    coef = np.linalg.lstsq(x / scale, r, rcond=None)[0] / scale
    r0 = float(coef[0])
    return {"R0": r0, "A": float(coef[1] / r0), "B": float(coef[2] / r0),
            "C": float(coef[3] / r0) if has_cold else 0.0}


def _check_table(t: np.ndarray, r: np.ndarray) -> None:
    """A table the laws can be fitted to: as many distinct temperatures as the Callendar-Van Dusen
    fit has constants (R0, A, B, and C with rows below 0 C), and a resistance that rises with them
    (a flat or falling one gives a linear law with beta <= 0, which reads no temperature; flat: a
    rise of no more than round-off, 1e-9 of R, over the table's span). Fewer, and
    the least-squares fits return numbers that mean nothing."""
    need = 4 if np.any(t < 0) else 3
    distinct = np.unique(t).size
    if distinct < need:
        raise InputError(f"temperature_c: {distinct} distinct temperature{'s' * (distinct != 1)}; the "
                         f"Callendar-Van Dusen fit{' with rows below 0 C' * (need == 4)} needs at least {need}")
    slope = np.polyfit(t, r, 1)[0]
    if not slope * np.ptp(t) > 1e-9 * np.max(np.abs(r)):   # more than round-off over the table's span
        raise InputError(f"resistance_ohm: does not rise with temperature_c (least-squares slope {slope:.4g} "
                         "ohm/C): not a platinum RTD table")


def rtd_study(temp_c, resistance) -> dict:
    """Errors (in C) of the linear law, the fitted CVD law and the IEC 60751 law on a table, and the
    cause the diagnosis engine names for a linear readout of it."""
    t = np.asarray(temp_c, float)
    r = np.asarray(resistance, float)
    _check_table(t, r)
    r0, beta = fit_linear(t, r)
    linear_error = linear_temperature(r, r0, beta) - t
    cvd = fit_cvd(t, r)
    cvd_error = cvd_law(**cvd).temperature(r) - t
    iec_error = cvd_law(**IEC60751).temperature(r) - t
    return {
        "range_c": [float(t.min()), float(t.max())],
        "linear": {"R0": r0, "beta": beta, "error": ErrorStats.of(linear_error)},
        "cvd_fit": {**cvd, "error": ErrorStats.of(cvd_error)},
        "cvd_iec60751": {**IEC60751, "error": ErrorStats.of(iec_error)},
        "diagnosis": diagnose_linear_readout(t, r, r0, beta),
    }


def diagnose_linear_readout(temp_c, resistance, r0: float, beta: float, seed: int = 0) -> dict:
    """Run `fxdsp diagnose` on a log whose temp_c is the linear-law reading of the table and whose
    ref_temp_c is the table's temperature: the engine must name the curvature.

    The table has no sensor output; a flat output with white noise stands in for it, so that the
    output channel has nothing to explain and only the thermometers can disagree.
    """
    from fxdsp.diagnose.api import diagnose_log
    from fxdsp.logfile import Log

    t = np.asarray(temp_c, float)
    rng = np.random.default_rng(seed)
    cols = {"time_s": np.arange(t.size, dtype=float) * 60.0,
            "temp_c": linear_temperature(resistance, r0, beta),
            "ref_temp_c": t,
            "output": 1.0 + 1e-3 * rng.standard_normal(t.size)}
    diag = diagnose_log(Log(columns=cols, source="pt100 table"))
    return {"causes": diag.causes, "parameters": diag.parameters, "gain": diag.gain}
