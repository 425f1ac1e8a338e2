"""The chain ``fxdsp extend`` calibrates, and the tables of it each step writes, found by role.

A calibration is a procedure of physics, not of a chain's name: it is chosen by the chain's
``sensor`` (:mod:`fxdsp.sensors`), whose model finds its blocks by kind and wiring, so the tables
the calibration and the remedies write are the chain's own, whatever they are called and in
whatever order the chain declares them:

* ``gyro_rtd`` (paper 002's procedure): the SF and bias engines (the one driving the divider's
  ``sf``, the one driving the subtraction's ``bias``) from rate-table sequences; remedies on the
  chain's lag (a netlist edit), its demodulator's phase trim and its RTD table.
* ``gyro_freq`` (paper 001's): the resonator thermometer (``freq2temp`` f0/k) and the bias engine
  from temperature plateaus; the ``order`` remedy on that engine.
* ``thermometer`` (a chain without a sensor whose output is a reading minus a bias polynomial of a
  temperature word, such as an instrument read against a chamber thermometer): the bias engine from
  the log; the lag remedy on its temperature word. Without such a chain in the config, extend writes
  its own ``[chain.thermometer]`` (:func:`fxdsp.extend.configure.thermometer_chain`).

:func:`resolve` picks the chain (``--chain`` NAME, or auto from the log's columns) and returns its
:class:`Roles`: the procedure, the table of each role and the chain input of each input role.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fxdsp.errors import InputError, MissingColumn
from fxdsp.sensors import Sensor

# sensor -> the calibration procedure that reads it (a chain without a sensor: "thermometer")
PROCEDURES = {"gyro_rtd": "gyro_rtd", "gyro_freq": "gyro_freq", None: "thermometer"}
OWN_THERMOMETER = "thermometer"   # the chain extend writes when the config has no thermometer chain
# the blocks a procedure may read, by the sensor model's attribute of each (its role)
ROLES = ("rtd", "sf", "bias", "divide", "subtract", "demod", "lag", "f2t")
# the log column each procedure calibrates from, beyond temp_c and output
NEEDS = {"gyro_rtd": "rate_dps", "gyro_freq": "freq_hz"}


@dataclass(frozen=True)
class Roles:
    chain: str                     # the config chain ("paper002": its table [chain.paper002])
    procedure: str                 # "gyro_rtd", "gyro_freq" or "thermometer"
    tables: dict = field(default_factory=dict)   # role -> config table ("sf" -> "piecewise.sf")
    inputs: dict = field(default_factory=dict)   # role -> chain input ("temp" -> "temp")
    outputs: dict = field(default_factory=dict)  # role -> chain output ("compensated" -> "compensated")
    written: bool = False          # the chain is extend's own, written into the extended config

    @property
    def instance(self) -> str:
        return f"chain_{self.chain}"

    @property
    def netlist_table(self) -> str:
        return f"chain.{self.chain}"

    def table(self, role: str) -> str:
        return self.tables[role]

    def has(self, role: str) -> bool:
        return role in self.tables


class ThermometerShape(Sensor):
    """A chain without a sensor read as reading - bias(T): one subtraction whose bias is a piecewise
    engine, its temperature a chain input (through the chain's lag, if it has one)."""

    name = OWN_THERMOMETER

    def _fail(self, what: str) -> InputError:
        return InputError(f"{self.net.name}: fxdsp extend's thermometer calibration needs {what}")

    def __init__(self, chain):
        super().__init__(chain)
        self.subtract = self.of_kind("bias_subtract")
        self.bias = self.driver(self.subtract, "bias")
        if self.chain.kinds[self.bias.name] != "piecewise":
            raise self._fail(f"a piecewise engine driving {self.subtract.name}.bias, not {self.bias.name}")
        self.lag = self.of_kind("lag", optional=True)
        fed = self.lag if self.lag is not None else self.bias
        if self.lag is not None and self.driver(self.bias, "temp") is not self.lag:
            raise self._fail(f"its lag {self.lag.name} driving {self.bias.name}.temp")
        self.temp, self.reading = self.input_of(fed, "temp"), self.input_of(self.subtract, "x")
        self.compensated = self.output_of(self.subtract, "y")


def _roles(chain_name: str, chain, written: bool = False) -> Roles:
    sensor = chain.sensor
    kind = None if sensor is None else sensor.name
    if kind not in PROCEDURES:
        raise InputError(f"--chain {chain_name}: its sensor {kind!r} has no calibration in fxdsp extend "
                         f"(extend calibrates chains whose sensor is {', '.join(k for k in PROCEDURES if k)}, "
                         "or a reading minus a bias polynomial of a temperature word)")
    procedure = PROCEDURES[kind]
    if procedure == "thermometer":
        sensor = ThermometerShape(chain)
    tables = {role: getattr(sensor, role).name for role in ROLES if getattr(sensor, role, None) is not None}
    inputs = {role: getattr(sensor, role) for role in ("temp", "reading") if hasattr(sensor, role)}
    outputs = {role: getattr(sensor, role) for role in ("compensated",) if hasattr(sensor, role)}
    return Roles(chain_name, procedure, tables, inputs, outputs, written)


def roles_of(design, chain: str) -> Roles:
    """The roles of the config chain ``chain`` (``paper002``) of a built design."""
    return _roles(chain, design.chain(f"chain_{chain}", "fxdsp extend"))


def own_thermometer_roles() -> Roles:
    """The roles of the thermometer chain extend writes (:func:`fxdsp.extend.configure.thermometer_chain`)."""
    return Roles(OWN_THERMOMETER, "thermometer", {"bias": "piecewise.bias001", "subtract": "bias_subtract001",
                                                  "lag": "lag"}, {"temp": "temp", "reading": "reading"},
                 {"compensated": "compensated"}, True)


def _has_rate_steps(columns: dict) -> bool:
    return "rate_dps" in columns and bool(np.any(np.asarray(columns["rate_dps"]) != 0))


def needs_column(roles: Roles, columns: dict, what: str = "log") -> None:
    """InputError when the log (``what``) lacks the column the chain's procedure calibrates from."""
    need = NEEDS.get(roles.procedure)
    if need is not None and need not in columns:
        raise MissingColumn(f"{what}: the {roles.chain} chain ({roles.procedure}) needs the {need} column", need)


def resolve(chain: str, design, columns: dict, config_name: str | None = None) -> Roles:
    """The chain to extend and its roles. ``chain``: a chain of the config (``paper002`` for
    ``[chain.paper002]``), ``thermometer`` (the config's, else the one extend writes), or ``auto``:
    the config's first ``gyro_rtd`` chain when the log has rate-table steps (its calibration needs
    them), else its first ``gyro_freq`` chain when the log has the resonator's frequency, else the
    thermometer chain. ``design``: the base config, built; ``config_name``: how errors name it."""
    config_name = config_name or design.config.name
    chains = {name.removeprefix("chain_"): c for name, c in design.chains.items()}
    if chain == "auto":
        want = "gyro_rtd" if _has_rate_steps(columns) else "gyro_freq" if "freq_hz" in columns else None
        if want is None:
            chain = OWN_THERMOMETER
        else:
            found = [n for n, c in chains.items() if c.sensor is not None and c.sensor.name == want]
            if not found:
                raise InputError(f"--chain auto: the log calls for a chain whose sensor is {want!r}, and "
                                 f"{config_name} has none (its chains: {', '.join(chains) or 'none'}); "
                                 "name one with --chain")
            chain = found[0]
    if chain not in chains:
        if chain == OWN_THERMOMETER:
            return own_thermometer_roles()
        names = ["auto", *chains, *([] if OWN_THERMOMETER in chains else [OWN_THERMOMETER])]
        raise InputError(f"--chain: {chain!r} is not a chain of {config_name}; expected "
                         f"{', '.join(names[:-1])} or {names[-1]}")
    roles = _roles(chain, chains[chain])
    needs_column(roles, columns)
    return roles
