"""A chain as a config table: its instances, its wires, its inputs and outputs, checked as a netlist.

A ``[chain.<name>]`` table lists

* ``instances``: the block tables it uses (``"rtd"``, ``"piecewise.sf"``, ...), in the order of the
  chain's overflow vector (bit 0 first);
* ``inputs``: ``"<chain input> -> <instance>.<port>"``, one line per instance input it drives (a
  chain input may drive several);
* ``wires``: ``"<instance>.<output> -> <instance>.<input>"``;
* ``outputs``: ``"<instance>.<output> -> <chain output>"``;
* ``sensor`` (optional): the physical stimulus model of its inputs (:mod:`fxdsp.sensors`);
* ``hardware`` (optional): the targets its generated top is judged on by ``fxdsp hw-report``,
  ``{lut4 = .., mac16 = .., bram = .., mhz = ..}`` (any of them; the cycles per sample are always
  judged against the sample period at 40 MHz);
* ``own_multiplier`` (optional): instances whose serial RTL keeps a multiplier of its own in the
  generated top instead of taking turns on the top's shared one, so that it runs beside the other
  members (a drive loop beside its sense path): one more multiplier, its cycles no longer added.

An instance's port is written ``<table>.<port>``: the port is what follows the last dot. Every
instance input must be driven exactly once; nothing may loop. The errors name the chain, the line
(wire) and the field. Formats are checked where the blocks are built (:mod:`fxdsp.chains`): a wired
input's format is the format of the output that drives it.

This module knows names only (no formats, no blocks): :func:`parse` needs each instance's input and
output port names, which :mod:`fxdsp.blocks.kinds` states once per kind of block.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from fxdsp.config import Section, nearest
from fxdsp.errors import InputError
from fxdsp.units import quantity

ARROW = "->"
CHAIN_KEYS = ("sensor", "instances", "inputs", "input_units", "wires", "outputs", "fs_hz", "hardware",
              "own_multiplier")
HARDWARE_KEYS = ("lut4", "mac16", "bram", "mhz")   # the targets a chain's hardware table may set


class WiringError(InputError):
    """A netlist that cannot be a chain: names the chain, the wire and the field."""


@dataclass(frozen=True)
class Endpoint:
    """One port of one instance (``instance`` is its config table, e.g. ``piecewise.sf``)."""

    instance: str
    port: str

    def __str__(self) -> str:
        return f"{self.instance}.{self.port}"


@dataclass(frozen=True)
class Netlist:
    """A chain's wiring. ``drivers`` maps every instance input to what drives it: an instance
    output (:class:`Endpoint`) or a chain input (its name, a str). ``order``: the instances in an
    order that computes every driver before what it drives."""

    name: str                                 # config table, e.g. "chain.paper002"
    instances: tuple[str, ...]
    drivers: dict[Endpoint, Endpoint | str]
    inputs: dict[str, tuple[Endpoint, ...]]   # chain input -> the instance inputs it drives
    outputs: dict[str, Endpoint]              # chain output -> the instance output driving it
    order: tuple[str, ...]
    sensor: str | None = None
    lines: dict[Endpoint, str] | None = None  # driven input -> the config line that wires it (errors)
    hardware: dict[str, float] | None = None  # the hw-report targets of its generated top (HARDWARE_KEYS)
    input_units: dict[str, str] = field(default_factory=dict)  # chain input -> quantity (fxdsp.units)
    fs_hz: float | None = None                # the chain's own sample rate (None: [system].fs_hz)
    own_multiplier: tuple[str, ...] = ()      # members whose serial RTL keeps a multiplier of its own

    @property
    def instance_name(self) -> str:
        return self.name.replace(".", "_")

    def consumers(self, source: Endpoint) -> list[Endpoint]:
        """The instance inputs ``source`` drives."""
        return [dst for dst, src in self.drivers.items() if src == source]

    def driver(self, instance: str, port: str) -> Endpoint | str:
        return self.drivers[Endpoint(instance, port)]

    def upstream(self, instance: str) -> set[str]:
        """The instances wired into ``instance``."""
        return upstream(self.drivers, instance)

    def wire_text(self, dst: Endpoint) -> str:
        return (self.lines or {}).get(dst, f"{self.drivers[dst]} -> {dst}")


# instance -> (inputs, outputs) or (inputs, outputs, optional inputs): an optional input may be
# wired (its table decides whether the block has it) but is not required to be
PortNames = Callable[[str], tuple[tuple[str, ...], ...]]


def _endpoint(text: str, chain: str, field: str, line: str) -> Endpoint:
    head, dot, port = text.strip().rpartition(".")
    if not dot or not head or not port:
        raise WiringError(f"{chain}.{field}: {line!r}: {text.strip()!r} is not <instance>.<port>")
    return Endpoint(head, port)


def _split(line, chain: str, field: str) -> tuple[str, str]:
    if not isinstance(line, str) or line.count(ARROW) != 1:
        raise WiringError(f"{chain}.{field}: {line!r}: expected one \"<from> -> <to>\"")
    a, b = (s.strip() for s in line.split(ARROW))
    if not a or not b:
        raise WiringError(f"{chain}.{field}: {line!r}: expected one \"<from> -> <to>\"")
    return a, b


def chain_inputs_to(data: dict, instance: str, port: str) -> dict[str, str]:
    """``{"chain.<name>": <chain input>}`` for every chain of parsed config ``data`` whose input
    drives ``instance.port``: what a change of that port's unit or format must follow (chains that
    share a block table)."""
    out = {}
    for name, table in (data.get("chain") or {}).items():
        for line in (table.get("inputs") or []) if isinstance(table, dict) else []:
            src, dst = _split(line, f"chain.{name}", "inputs")
            if _endpoint(dst, f"chain.{name}", "inputs", line) == Endpoint(instance, port):
                out[f"chain.{name}"] = src
    return out


def _lines(sec: Section, key: str, required: bool = True) -> list[str]:
    if required and not sec.has(key):
        raise sec._missing(key, "missing (a list of \"<from> -> <to>\" lines)")
    value = sec._get(key, [])
    if not isinstance(value, list):
        raise WiringError(f"{sec.field(key)}: expected a list of \"<from> -> <to>\" lines, got {value!r}")
    return value


def parse(sec: Section, ports: PortNames, known: tuple[str, ...]) -> Netlist:
    """The netlist of the chain table ``sec``; ``ports(instance)`` gives an instance's (input, output)
    port names, ``known`` the block tables of the config. Raises :class:`WiringError`."""
    chain = sec.path
    for key in sec.data:   # a misspelt key would otherwise show as a wire left open
        if key not in CHAIN_KEYS:
            near = nearest(key, [k for k in CHAIN_KEYS if k not in sec.data])
            raise WiringError(f"{sec.field(key)}: unknown key" + (f" (did you mean {near!r}?)" if near else
                                                                  f"; a chain table holds {', '.join(CHAIN_KEYS)}"))
    if not sec.has("instances"):
        raise sec._missing("instances", "missing (the chain's block tables)")
    inst = sec._get("instances", None)
    if not isinstance(inst, list) or not inst or not all(isinstance(i, str) for i in inst):
        raise WiringError(f"{sec.field('instances')}: expected a non-empty list of block tables, got {inst!r}")
    for name in inst:
        if name not in known:
            near = nearest(name, [k for k in known if k not in inst])
            if near is not None and near.count(".") == name.count("."):
                # most likely the table's name is misspelt, not the chain's line: name the table
                raise WiringError(f"{near}: unknown key (did you mean {name.rpartition('.')[2]!r}?)")
            raise WiringError(f"{sec.field('instances')}: {name!r} is not a block table of the config"
                              + (f" (did you mean {near!r}?)" if near else f"; blocks: {', '.join(known)}"))
    if len(set(inst)) != len(inst):
        twice = next(i for i in inst if inst.count(i) > 1)
        raise WiringError(f"{sec.field('instances')}: {twice!r} is listed twice")
    port_names = {i: ports(i) for i in inst}
    optional = {i: tuple(p[2]) if len(p) > 2 else () for i, p in port_names.items()}

    def check(ep: Endpoint, side: int, field: str, line: str) -> Endpoint:
        if ep.instance not in port_names:
            near = nearest(ep.instance, inst)
            raise WiringError(f"{chain}.{field}: {line!r}: {ep.instance!r} is not an instance of the chain "
                              f"({sec.field('instances')})" + (f"; did you mean {near!r}?" if near else ""))
        names = port_names[ep.instance][side]
        if side == 0:   # an optional input may be wired too
            names = names + optional[ep.instance]
        if ep.port not in names:
            kind = "input" if side == 0 else "output"
            near = nearest(ep.port, names)
            raise WiringError(f"{chain}.{field}: {line!r}: {ep.instance} has no {kind} {ep.port!r} "
                              f"({kind}s: {', '.join(names)})" + (f"; did you mean {near!r}?" if near else ""))
        return ep

    drivers: dict[Endpoint, Endpoint | str] = {}
    lines: dict[Endpoint, str] = {}

    def drive(dst: Endpoint, src, field: str, line: str) -> None:
        if dst in drivers:
            raise WiringError(f"{chain}.{field}: {line!r}: {dst} is already driven by {lines[dst]!r}")
        drivers[dst] = src
        lines[dst] = line

    inputs: dict[str, list[Endpoint]] = {}
    for line in _lines(sec, "inputs"):
        a, b = _split(line, chain, "inputs")
        if not a.isidentifier():
            raise WiringError(f"{chain}.inputs: {line!r}: chain input {a!r} must be a plain name")
        dst = check(_endpoint(b, chain, "inputs", line), 0, "inputs", line)
        drive(dst, a, "inputs", line)
        inputs.setdefault(a, []).append(dst)
    for line in _lines(sec, "wires"):
        a, b = _split(line, chain, "wires")
        src = check(_endpoint(a, chain, "wires", line), 1, "wires", line)
        dst = check(_endpoint(b, chain, "wires", line), 0, "wires", line)
        drive(dst, src, "wires", line)
    outputs: dict[str, Endpoint] = {}
    for line in _lines(sec, "outputs"):
        a, b = _split(line, chain, "outputs")
        if not b.isidentifier():
            raise WiringError(f"{chain}.outputs: {line!r}: chain output {b!r} must be a plain name")
        if b in outputs:
            raise WiringError(f"{chain}.outputs: {line!r}: chain output {b!r} is driven twice")
        if b in inputs:
            raise WiringError(f"{chain}.outputs: {line!r}: {b!r} is already a chain input")
        outputs[b] = check(_endpoint(a, chain, "outputs", line), 1, "outputs", line)
    if not outputs:
        raise WiringError(f"{sec.field('outputs')}: the chain has no output")

    for i in inst:
        for port in port_names[i][0]:
            if Endpoint(i, port) not in drivers:
                raise WiringError(f"{sec.field('wires')}: input {i}.{port} is left open: wire an output or a "
                                  f"chain input to it")
    order = _order(chain, inst, drivers, lines)
    sensor = sec._get("sensor", None)
    if sensor is not None and not isinstance(sensor, str):
        raise WiringError(f"{sec.field('sensor')}: expected a name, got {sensor!r}")
    return Netlist(chain, tuple(inst), drivers, {k: tuple(v) for k, v in inputs.items()}, outputs, order,
                   sensor, lines, _hardware(sec), _input_units(sec, inputs), _fs_hz(sec), _own_multiplier(sec, inst))


def _own_multiplier(sec: Section, inst: list[str]) -> tuple[str, ...]:
    """The chain's ``own_multiplier``: instances of the chain, each at most once."""
    names = sec._get("own_multiplier", [])
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise WiringError(f"{sec.field('own_multiplier')}: expected a list of the chain's instances, got {names!r}")
    for k, name in enumerate(names):
        if name not in inst:
            near = nearest(name, inst)
            raise WiringError(f"{sec.field('own_multiplier')}: {name!r} is not an instance of the chain" +
                              (f" (did you mean {near!r}?)" if near else f"; its instances: {', '.join(inst)}"))
        if name in names[:k]:
            raise WiringError(f"{sec.field('own_multiplier')}: {name!r} is listed twice")
    return tuple(names)


def _fs_hz(sec: Section) -> float | None:
    """The chain's own ``fs_hz`` (a chain fed at another rate than [system].fs_hz, such as a chamber
    log's rows): a positive finite number, or None."""
    if sec._get("fs_hz", None) is None:
        return None
    return sec.number("fs_hz", low=0, low_open=True)


def _input_units(sec: Section, inputs: dict) -> dict[str, str]:
    """The chain's ``input_units``: chain input -> the quantity its real value is in (fxdsp.units),
    for inputs whose unit no port they drive fixes."""
    table = sec._get("input_units", None)
    if table is None:
        return {}
    if not isinstance(table, dict):
        raise WiringError(f"{sec.field('input_units')}: expected a table {{<chain input> = \"<unit>\"}}, got {table!r}")
    for name in table:
        if name not in inputs:
            near = nearest(name, [i for i in inputs if i not in table])
            raise WiringError(f"{sec.field('input_units')}.{name}: unknown key" +
                              (f" (did you mean {near!r}?)" if near else f"; the chain's inputs: {', '.join(inputs)}"))
    return {name: quantity(q, f"{sec.field('input_units')}.{name}") for name, q in table.items()}


def _hardware(sec: Section) -> dict[str, float] | None:
    """The chain's ``hardware`` targets: a table of positive numbers with keys from HARDWARE_KEYS."""
    hw = sec._get("hardware", None)
    if hw is None:
        return None
    if not isinstance(hw, dict) or not hw:
        raise WiringError(f"{sec.field('hardware')}: expected a table of targets ({', '.join(HARDWARE_KEYS)}), "
                          f"got {hw!r}")
    for key, value in hw.items():
        if key not in HARDWARE_KEYS:
            near = nearest(key, [k for k in HARDWARE_KEYS if k not in hw])
            raise WiringError(f"{sec.field('hardware')}.{key}: unknown key" +
                              (f" (did you mean {near!r}?)" if near else f"; one of {', '.join(HARDWARE_KEYS)}"))
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0 or value == float("inf"):
            raise WiringError(f"{sec.field('hardware')}.{key}: expected a positive number, got {value!r}")
    return {k: float(v) for k, v in hw.items()}


def upstream(drivers: dict, instance: str) -> set[str]:
    """The instances whose outputs drive an input of ``instance`` (chain inputs left out)."""
    return {src.instance for dst, src in drivers.items() if dst.instance == instance and isinstance(src, Endpoint)}


def _order(chain: str, inst: list[str], drivers: dict, lines: dict) -> tuple[str, ...]:
    """A topological order of the instances (Kahn's algorithm). Among those ready, the one whose
    first mention in the wiring comes first, so a chain runs in the order its wires are written."""
    first = {}
    for dst, src in drivers.items():
        for name in (getattr(src, "instance", None), dst.instance):
            if name is not None:
                first.setdefault(name, len(first))
    deps = {i: upstream(drivers, i) for i in inst}
    order, stuck = topological(inst, deps, key=lambda i: first.get(i, len(first)))
    if stuck:
        loop = next(dst for dst, src in drivers.items()
                    if dst.instance in stuck and isinstance(src, Endpoint) and src.instance in stuck)
        raise WiringError(f"{chain}.wires: {lines[loop]!r}: closes a loop through {', '.join(stuck)} "
                          f"(a chain is a feed-forward netlist)")
    return tuple(order)


def topological(nodes, deps: dict, key=None) -> tuple[list, list]:
    """Kahn's algorithm: (nodes in an order with every dependency first, the nodes left on a loop).
    Among those ready, the smallest by ``key`` (default: the first in ``nodes``)."""
    done: list = []
    while len(done) < len(nodes):
        ready = [n for n in nodes if n not in done and deps[n] <= set(done)]
        if not ready:
            return done, [n for n in nodes if n not in done]
        done.append(min(ready, key=key) if key is not None else ready[0])
    return done, []


def insert_stage(net: dict, after: str, stage: str, stage_in: str, stage_out: str,
                 keep: tuple[str, ...] = ()) -> dict:
    """A netlist edit on a chain table (as data): put the instance ``stage`` between the output
    ``after`` (``"rtd.temp"``) and every instance input it drove (except the chain outputs and the
    inputs listed in ``keep``, which stay on ``after``). ``stage`` joins ``instances`` right after
    the instance of ``after``. Returns the edited table (the argument is not changed)."""
    out = {k: (list(v) if isinstance(v, list) else v) for k, v in net.items()}
    if stage in out["instances"]:
        return out
    wires = []
    for line in out.get("wires", []):
        a, b = (s.strip() for s in line.split(ARROW))
        wires.append(f"{stage}.{stage_out} -> {b}" if a == after and b not in keep else line)
    wires.insert(0, f"{after} -> {stage}.{stage_in}")
    out["wires"] = wires
    at = out["instances"].index(after.rpartition(".")[0]) + 1
    out["instances"].insert(at, stage)
    return out


def remove_stage(net: dict, stage: str, stage_in: str, stage_out: str) -> dict:
    """The inverse of :func:`insert_stage`: what drove ``stage``'s input drives what its output drove."""
    out = {k: (list(v) if isinstance(v, list) else v) for k, v in net.items()}
    if stage not in out["instances"]:
        return out
    pairs = [tuple(s.strip() for s in line.split(ARROW)) for line in out.get("wires", [])]
    ins = [tuple(s.strip() for s in line.split(ARROW)) for line in out.get("inputs", [])]
    source = next((a for a, b in pairs if b == f"{stage}.{stage_in}"), None)
    if source is None:   # the stage after a chain input (insert_stage_at_input): the input drives its readers
        name = next(a for a, b in ins if b == f"{stage}.{stage_in}")
        out["inputs"] = [f"{a} -> {b}" for a, b in ins if b != f"{stage}.{stage_in}"]
        out["inputs"] += [f"{name} -> {b}" for a, b in pairs if a == f"{stage}.{stage_out}"]
        out["wires"] = [f"{a} -> {b}" for a, b in pairs if a != f"{stage}.{stage_out}"]
        out["instances"].remove(stage)
        return out
    out["wires"] = [f"{source if a == f'{stage}.{stage_out}' else a} -> {b}" for a, b in pairs
                    if b != f"{stage}.{stage_in}"]
    out["outputs"] = [line.replace(f"{stage}.{stage_out} ", f"{source} ") for line in out["outputs"]]
    out["instances"].remove(stage)
    return out


# the stages a netlist edit may insert: stage -> (its input port, its output port, the kind of the
# output it goes after, that output's port). The lag goes after the thermometer, before what reads it.
STAGES = {"lag": ("temp", "te", ("rtd", "freq2temp"), "temp")}


def insert_stage_at_input(net: dict, name: str, stage: str, stage_in: str, stage_out: str) -> dict:
    """:func:`insert_stage` after the chain input ``name``: it drives ``stage`` alone, and ``stage``
    what it drove. Returns the edited table (the argument is not changed)."""
    out = {k: (list(v) if isinstance(v, list) else v) for k, v in net.items()}
    if stage in out["instances"]:
        return out
    pairs = [tuple(s.strip() for s in line.split(ARROW)) for line in out.get("inputs", [])]
    moved = [b for a, b in pairs if a == name]
    if not moved:
        raise InputError(f"{stage}: the chain has no input {name!r} to put the {stage} after")
    out["inputs"] = [line for line, (a, _) in zip(out["inputs"], pairs) if a != name] + [f"{name} -> {stage}.{stage_in}"]
    out["wires"] = [f"{stage}.{stage_out} -> {b}" for b in moved] + list(out.get("wires", []))
    out["instances"].insert(0, stage)
    return out


def with_stage(net: dict, stage: str, instance: str | None = None, chain_input: str | None = None) -> dict:
    """``net`` (a chain table as data) with ``stage`` inserted after its thermometer (or after
    ``instance``'s output, or after the chain input ``chain_input``): the chain's own outputs stay
    where they were."""
    stage_in, stage_out, kinds, port = STAGES[stage]
    if chain_input is not None:
        return insert_stage_at_input(net, chain_input, stage, stage_in, stage_out)
    if instance is None:
        instance = next((i for i in net["instances"] if i.split(".")[0] in kinds), None)
        if instance is None:
            raise InputError(f"{stage}: the chain ({', '.join(net['instances'])}) has no {' or '.join(kinds)} "
                             f"to put the {stage} after")
    return insert_stage(net, f"{instance}.{port}", stage, stage_in, stage_out)


def without_stage(net: dict, stage: str) -> dict:
    stage_in, stage_out, _, _ = STAGES[stage]
    return remove_stage(net, stage, stage_in, stage_out)
