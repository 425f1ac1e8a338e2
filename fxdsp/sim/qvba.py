"""Quartz vibrating-beam accelerometer pair (paper 000).

Two double-ended tuning-fork beams, one put in tension and one in compression by the proof mass.
Each beam's frequency is ``f_i(T, a) = f0_i + P_i(t) + k_i(T) a + q_i a^2`` with t = T - 25 C, P_i a
cubic temperature law (no constant term) and k_i(T) = k_i (1 + c_k t) its load sensitivity. The output
is the difference frequency ``Df = f_t - f_c = K0(T) + K1(T) a + K2 a^2``:

* K1 = k_t - k_c ~ 52 Hz/g (the paper's value), rising linearly with temperature by 1.2e-5 /C, i.e.
  a relative change of 1.2e-3 over -40..60 C, inside the paper's 8e-4 .. 1.6e-3;
* K0 = f0_t - f0_c + P_t(t) - P_c(t): the beams differ by 120 Hz at rest (kept apart so they do not
  lock) and their temperature laws differ by 0.01 Hz/C, -2e-5 Hz/C^2 and 1e-7 Hz/C^3. Over -40..60 C
  that moves K0 by about 1.1 Hz = 21 mg, inside the paper's 10..35 mg before compensation;
* K2 = q_t - q_c = 0.01 Hz/g^2 (beam non-linearity that the differential pair mostly cancels).

Temperature laws of a beam (paper 000's two findings):

* a free beam is a parabola with a turnover point: ``FREE_BEAM`` changes by 7.2 Hz over -40..80 C,
  turnover at 20 C (the paper: less than 8 Hz);
* the bonded beam is nearly linear, tens of Hz over the range and steeper when hot: 0.30 Hz/C at 25 C
  plus 0.0015 Hz/C^2 gives 0.105 Hz/C at -40 C, 0.465 Hz/C at 80 C and 34 Hz over -40..80 C.

The tumble (input axis in the vertical plane, ``a = g cos(theta + delta)`` with a 1 mrad fixture
misalignment delta) gives E0, E90, E180, E270, from which
K0 = (E90 + E270)/2, K1 = (E0 - E180)/(2g), K2 = (E0 + E180 - E90 - E270)/(2 g^2); the misalignment
cancels in all three to first order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxdsp.sim.model import Baseline

T_REF_C = 25.0


@dataclass(frozen=True)
class Beam:
    f0_hz: float  # at rest and 25 C
    temp_poly: tuple[float, ...]  # Hz, ascending powers of t = T - 25 starting at t^1
    k_hz_per_g: float  # load sensitivity at 25 C; > 0 for the tension beam, < 0 for compression
    k_tempco_per_c: float = 0.0
    q_hz_per_g2: float = 0.0

    def thermal(self, temp_c) -> np.ndarray:
        t = np.asarray(temp_c, float) - T_REF_C
        return np.polynomial.polynomial.polyval(t, (0.0, *self.temp_poly))

    def sensitivity(self, temp_c) -> np.ndarray:
        return self.k_hz_per_g * (1.0 + self.k_tempco_per_c * (np.asarray(temp_c, float) - T_REF_C))

    def frequency(self, temp_c, accel_g=0.0) -> np.ndarray:
        a = np.asarray(accel_g, float)
        return self.f0_hz + self.thermal(temp_c) + self.sensitivity(temp_c) * a + self.q_hz_per_g2 * a * a


# free (unbonded) beam: parabola with turnover at 20 C, -2e-3 Hz/C^2 -> 7.2 Hz over -40..80 C
FREE_BEAM = Beam(38000.0, (-2.0e-3 * 2 * (T_REF_C - 20.0), -2.0e-3), 0.0)


@dataclass(frozen=True)
class BeamPair:
    tension: Beam
    compression: Beam
    misalignment_rad: float = 1e-3

    def difference(self, temp_c, accel_g) -> np.ndarray:
        return self.tension.frequency(temp_c, accel_g) - self.compression.frequency(temp_c, accel_g)

    def k0(self, temp_c) -> np.ndarray:
        return self.difference(temp_c, 0.0)

    def k1(self, temp_c) -> np.ndarray:
        return self.tension.sensitivity(temp_c) - self.compression.sensitivity(temp_c)

    def k2(self) -> float:
        return self.tension.q_hz_per_g2 - self.compression.q_hz_per_g2

    def tumble(self, temp_c, angle_deg) -> np.ndarray:
        """Difference frequency at tumble angle(s) theta: input a = g cos(theta + delta), in g."""
        a = np.cos(np.deg2rad(np.asarray(angle_deg, float)) + self.misalignment_rad)
        return self.difference(temp_c, a)

    def contract_baseline(self) -> Baseline:
        """The pair as the contract's baseline: B = K0, S = K1 (per g), freq = the tension beam's
        linear temperature law (its curvature is the contract's frequency_nonlinearity)."""
        t, c = self.tension, self.compression
        n = max(len(t.temp_poly), len(c.temp_poly))
        tp = np.pad(t.temp_poly, (0, n - len(t.temp_poly)))
        cp = np.pad(c.temp_poly, (0, n - len(c.temp_poly)))
        k0 = (t.f0_hz - c.f0_hz, *(tp - cp))
        k1 = (t.k_hz_per_g - c.k_hz_per_g,
              t.k_hz_per_g * t.k_tempco_per_c - c.k_hz_per_g * c.k_tempco_per_c)
        slope = t.temp_poly[0]
        return Baseline(bias_poly=tuple(float(v) for v in k0), sf_poly=tuple(float(v) for v in k1),
                        t_ref_c=T_REF_C, f0_hz=t.f0_hz - slope * T_REF_C, k_hz_per_c=slope)


DEFAULT_PAIR = BeamPair(
    tension=Beam(38000.0, (0.30, 0.0015, 0.0), 26.0, 1.2e-5, 0.10),
    compression=Beam(37880.0, (0.29, 0.00152, -1e-7), -25.9, 1.2e-5, 0.09),
)


def tumble_run(pair: BeamPair, temps_c, rng: np.random.Generator, noise_hz: float = 2e-4,
               runs: int = 2, k0_repeatability_hz: float = 5e-3) -> list[dict]:
    """Simulated tumble calibration: at each temperature, E at 0/90/180/270 deg, ``runs`` times.

    Each reading is the mean of a 10-minute position, so its noise is small (``noise_hz``); a
    run-to-run K0 shift (``k0_repeatability_hz``, 0.1 mg) models the turn-on repeatability that makes
    "coefficients of run 1 applied to run 2" a real test.
    """
    records = []
    for run in range(1, runs + 1):
        shift = k0_repeatability_hz * rng.standard_normal()
        for temp in temps_c:
            e = {int(ang): float(pair.tumble(temp, ang) + shift + noise_hz * rng.standard_normal())
                 for ang in (0, 90, 180, 270)}
            records.append({"run": run, "temp_c": float(temp), "E": e})
    return records
