"""Heat path chamber air -> package -> die as two first-order stages (optional physics).

The contract's baseline is isothermal (the sensing element is at the temperature the RTD reads), so
:func:`fxdsp.sim.generate_log` uses no chain unless one is passed. With a chain the resonator sits
on the die, the reference probe in the air and the RTD at a configurable node: paper 002's integrated
RTD is on the die (``rtd_node="die"``), its external sensor on the package (``"package"``) or in the
air next to it (``"air"``).

Default time constants: package (with its fixture) from chamber air 900 s, 10..20 min being typical
of a sensor on a rate-table fixture in still chamber air; die from package 60 s (die attach and the
vacuum cavity conduct heat poorly, but the die's heat capacity is tiny). In a long ramp of rate r a
stage lags its input by r tau: at 0.5 C/min the package trails the air by 7.5 C and the die trails the
package by 0.5 C. The second lag is the one that lets paper 002's external (package) sensor lose to
the integrated RTD: the compensation evaluates B(T) at the wrong temperature while the chamber moves.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxdsp.mechanisms import first_order_lag
from fxdsp.errors import InputError

NODES = ("air", "package", "die")


@dataclass(frozen=True)
class ThermalChain:
    tau_package_s: float = 900.0
    tau_die_s: float = 60.0
    rtd_node: str = "die"

    def __post_init__(self):
        if self.rtd_node not in NODES:
            raise InputError(f"rtd_node: expected one of {', '.join(NODES)}, got {self.rtd_node!r}")
        for name in ("tau_package_s", "tau_die_s"):
            if not getattr(self, name) > 0:
                raise InputError(f"{name}: must be > 0")

    def temperatures(self, time_s, air_c) -> dict[str, np.ndarray]:
        """Node temperatures, starting in equilibrium with the air at power-on."""
        package = first_order_lag(time_s, air_c, self.tau_package_s)
        # the die follows the package; the package is no longer piecewise-linear, but sampled every
        # few seconds against minutes of time constant the first-order hold error is negligible
        die = first_order_lag(time_s, package, self.tau_die_s)
        return {"air": np.asarray(air_c, float), "package": package, "die": die}
