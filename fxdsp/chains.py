"""Chains composed from the blocks by the netlists the config declares, and the design built from one config.

A chain is a ``[chain.<name>]`` table (:mod:`fxdsp.netlist`): its instances (block tables), wires,
inputs and outputs. :class:`Chain` runs any valid netlist as one block: bit-exact ``run`` on stored
integers, the float ``reference`` composed from the blocks' own references, and the stimulus of
its ``sensor`` (:mod:`fxdsp.sensors`). The papers' chains are configs in the built-in default:

* ``chain.paper002`` (RTD path, its figure 4): RTD code -> temperature -> SF(T) -> sense / SF(T)
  -> demod (I) -> I - bias(T) -> final low-pass -> rate; the thermal lag is a netlist edit
  (:func:`fxdsp.netlist.insert_stage`: rtd.temp -> lag -> the SF and bias engines);
* ``chain.paper001`` (frequency path): frequency word -> T = (f - f0)/k -> q(T) -> rate - q(T);
* ``chain.paper000`` (QVBA): temperature -> K0(t), K1(t) cubic in t = T - 25 C -> (Df - K0) / K1 in g.
"""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass, field

import numpy as np

from fxdsp.blocks.base import Block
from fxdsp.blocks.datapath import RtlPorts
from fxdsp.blocks.kinds import Context, Wired, block_tables, kind_of
from fxdsp.config import Config, load_config, one_edit, register_design_builder, table_at
from fxdsp.errors import InputError
from fxdsp.fixed import Format, OverflowLog
from fxdsp.netlist import STAGES, Endpoint, Netlist, WiringError, parse, topological
from fxdsp.units import display, instance_units, quantity


class Chain(Block):
    """A netlist of blocks as one block: its inputs and outputs are the netlist's, its overflow
    counters its members' (members in the order of ``instances``, which is the RTL ovf order)."""

    def __init__(self, netlist: Netlist, blocks: dict[str, Block], kinds: dict[str, str], fs_hz: float):
        from fxdsp.sensors import sensor_for

        self.netlist = netlist
        self.fs_hz = fs_hz   # its sample rate: its own fs_hz, else [system].fs_hz
        self.name = netlist.instance_name
        self.members = {p: blocks[p] for p in netlist.instances}
        self.kinds = {p: kinds[p] for p in netlist.instances}
        self.MEMBERS = tuple(p.replace(".", "_") for p in netlist.instances)
        self.inputs = {n: self.members[dsts[0].instance].inputs[dsts[0].port] for n, dsts in netlist.inputs.items()}
        self.outputs = {n: self.members[e.instance].outputs[e.port] for n, e in netlist.outputs.items()}
        self._stateful = {p: b for p, b in self.members.items() if type(b).get_state is not Block.get_state}
        self.sensor = sensor_for(self)

    def wanted(self) -> dict[str, set[str]]:
        """The outputs of each member that something reads (the rest need not be computed)."""
        wanted: dict[str, set[str]] = {p: set() for p in self.netlist.instances}
        for src in [*self.netlist.drivers.values(), *self.netlist.outputs.values()]:
            if isinstance(src, Endpoint):
                wanted[src.instance].add(src.port)
        return wanted

    def evaluate(self, step, inputs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Run the netlist with ``step(instance, block, inputs, wanted) -> outputs`` for each member in
        order: the one composition behind ``stream``, ``reference`` and the budget's hybrid runs."""
        values: dict[Endpoint, np.ndarray] = {}
        wanted = self.wanted()
        for inst in self.netlist.order:
            block = self.members[inst]
            ins = {}
            for port in block.inputs:
                src = self.netlist.driver(inst, port)
                ins[port] = inputs[src] if isinstance(src, str) else values[src]
            outs = step(inst, block, ins, wanted[inst])
            values.update({Endpoint(inst, p): outs[p] for p in wanted[inst]})
        return {name: values[e] for name, e in self.netlist.outputs.items()}

    def stream(self, log: OverflowLog, **inputs) -> dict[str, np.ndarray]:
        return self.evaluate(lambda inst, b, ins, wanted: b.stream_outputs(log, wanted, **ins), inputs)

    def reference(self, **inputs) -> dict[str, np.ndarray]:
        return self.evaluate(lambda inst, b, ins, wanted: b.reference(**ins), inputs)

    def reset(self) -> None:
        for block in self._stateful.values():
            block.reset()

    def get_state(self) -> dict | None:
        return {p.replace(".", "_"): b.get_state() for p, b in self._stateful.items()} or None

    def set_state(self, state) -> None:
        keys = {p.replace(".", "_") for p in self._stateful}
        if not keys:
            return super().set_state(state)
        if not isinstance(state, dict) or set(state) != keys:
            raise InputError(f"{self.name}: state: expected a previous result's state {{{', '.join(sorted(keys))}}}")
        for p, block in self._stateful.items():
            block.set_state(state[p.replace(".", "_")])

    @functools.cached_property
    def counters(self) -> frozenset[str]:
        """The overflow counters a run counts: not those of member outputs nothing reads (e.g. the
        demodulator's amp when the chain uses I only). One run of a sample, once per chain."""
        return frozenset(self.run(**{k: np.zeros(1, np.int64) for k in self.inputs}).overflows)

    @property
    def stages(self) -> tuple[str, ...]:
        """The insertable stages (:data:`fxdsp.netlist.STAGES`) the netlist has."""
        return tuple(s for s in STAGES if any(self.kinds[p] == s for p in self.members))

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        if self.sensor is not None:
            return self.sensor.nominal_stimulus(rng, n)
        return self._port_stimulus(rng, n, nominal=True)

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        if self.sensor is not None:
            return self.sensor.stimulus(rng, n)
        return self._port_stimulus(rng, n, nominal=False)

    def _port_stimulus(self, rng: np.random.Generator, n: int, nominal: bool) -> dict[str, np.ndarray]:
        """Without a sensor: each chain input gets the stimulus of the first block input it drives,
        all cut to the shortest."""
        out = {}
        for name, dsts in self.netlist.inputs.items():
            block = self.members[dsts[0].instance]
            stim = block.nominal_stimulus(rng, n) if nominal else block.stimulus(rng, n)
            out[name] = stim[dsts[0].port]
        m = min(len(v) for v in out.values())
        return {k: v[:m] for k, v in out.items()}

    def parameters(self) -> dict:
        return {"blocks": [self.members[p].name for p in self.netlist.order]}


@dataclass(frozen=True)
class Port:
    """One port of an instance: its format and the physical unit its real value is read in."""

    name: str
    format: Format
    unit: str = ""        # physical unit of the table rows ("C", "deg/h", "ppm", ...)
    scale: float = 1.0    # real value x scale = value in ``unit``
    quantity: str | None = None   # what the real value measures (fxdsp.units: "C", "FS", "rad", ...)


@dataclass(frozen=True)
class Instance:
    """One row of the design's instance table: everything outside a block needs to know about it.

    ``name`` is the one name of the instance (vectors directory, RTL instance and parameter header,
    budget rows, hardware report); it is its config table with the dots spelled as underscores
    (``piecewise.sf`` -> ``piecewise_sf``), and the model's overflow counters are named after the
    table (``piecewise.sf.acc``). A chain's ovf vector is its members' vectors, bit 0 first."""

    name: str
    config_path: str
    block: Block
    module: str                       # RTL module
    inputs: tuple[Port, ...]
    outputs: tuple[Port, ...]
    members: tuple[str, ...] = ()     # a chain's member instances, in ovf bit order
    hardware: bool = True             # it has RTL (a block whose datapath states an RTL interface; a chain
                                      # whose members all have): the HDL commands and tests take only these

    @property
    def has_ready(self) -> bool:
        """The RTL module has an in_ready output whatever its parameters."""
        return self.rtl.ready

    @property
    def ports(self) -> dict[str, Port]:
        return {p.name: p for p in (*self.inputs, *self.outputs)}

    def rtl_port(self, port: str) -> str:
        """The RTL port of the model's port ``port`` (a generated top's: the chain's own name)."""
        return port if self.members else self.rtl.port(port)

    @property
    def rtl(self) -> RtlPorts:
        """The RTL interface: a block's is its datapath's; a chain top (generated)
        takes one sample at a time (in_ready) and has a serial variant (ARCH = 1), no bundle."""
        if not self.hardware:
            raise InputError(f"{self.name}: has no RTL (its datapath states no RTL interface)")
        if self.members:
            return RtlPorts(ready=True, serial=True)
        return self.block.datapath.RTL


@dataclass
class Design:
    """Every block and chain of one config, and the instance table that names them."""

    config: Config
    seed: int
    samples: int
    fs_hz: float
    rate_full_scale_dps: float
    blocks: dict[str, Block] = field(default_factory=dict)
    chains: dict[str, Block] = field(default_factory=dict)
    instances: dict[str, Instance] = field(default_factory=dict)

    @property
    def all(self) -> dict[str, Block]:
        return {**self.blocks, **self.chains}

    @property
    def hardware(self) -> dict[str, Instance]:
        """The instances that have RTL: what the HDL commands (hdl-gen, rtl, formal, hw-report) and
        their tests work on."""
        return {n: i for n, i in self.instances.items() if i.hardware}

    def with_rtl(self) -> dict[str, Instance]:
        """``hardware`` for an HDL command; a design without any instance with RTL is bad input (the
        command would write, prove or verify nothing and say it succeeded)."""
        if not self.hardware:
            raise InputError(f"{self.config.name}: no block or chain has RTL (none yet for "
                             f"{', '.join(self.instances) or 'its tables'}); nothing to generate, prove or verify")
        return self.hardware

    def chain(self, name: str, purpose: str) -> Chain:
        """The chain ``name``; a config that does not declare it is bad input naming what needs it."""
        if name not in self.chains:
            raise InputError(f"[chain.{name.removeprefix('chain_')}]: {purpose} needs it, and {self.config.name} "
                             f"declares no such chain (its chains: {', '.join(self.chains) or 'none'})")
        return self.chains[name]

    def ovf_fields(self, name: str) -> list[tuple[str, str, int]]:
        """The RTL ovf vector of an instance, bit 0 first: (member instance, counter, width) per field.
        A block's counters are its config path + field counter (``demod.lpf_i.section0``)."""
        inst = self.instances[name]
        out = []
        for member in inst.members or (name,):
            m = self.instances[member]
            out += [(member, f"{m.config_path}.{f.counter}", f.width) for f in m.block.datapath.ovf]
        return out

    def ovf_width(self, name: str) -> int:
        return sum(w for _, _, w in self.ovf_fields(name))

    def ovf_bit(self, name: str, counter: str) -> int:
        """Bit position of the first flag of ``counter`` in the ovf vector of instance ``name``."""
        bit = 0
        for _, c, w in self.ovf_fields(name):
            if c == counter:
                return bit
            bit += w
        raise ValueError(f"{name}: no ovf field counts {counter!r}")


Quantities = dict[str, dict[str, "str | None"]]   # instance or chain -> port -> quantity (fxdsp.units)


def _quantities(design: "Design", tables: list[str], nets: dict[str, Netlist]) -> Quantities:
    """The quantity of every port of every block table (:mod:`fxdsp.units`), propagated through each
    chain in its order; a table's ports take the quantities of the first chain it is a member of, a
    table in no chain its own. A chain that joins ports of different quantities is an error naming
    the chain and the wires. Keyed by instance name; a chain's own ports under its instance name."""
    cfg = design.config
    declared = {}
    for t in tables:   # a piecewise table states its coefficients' unit (read whether present or not:
        sec = cfg.section(t)   # a misspelt "unit" is then named as such)
        unit = sec._get("unit", None) if kind_of(t).name == "piecewise" else None
        declared[t] = {"y": quantity(unit, sec.field("unit"))} if unit is not None else {}
    out: Quantities = {}
    chains: Quantities = {}
    for net in nets.values():
        at: dict[Endpoint, str | None] = {}
        for inst in net.order:
            fed = {dst.port: src for dst, src in net.drivers.items() if dst.instance == inst}
            known = {p: (at.get(src) if isinstance(src, Endpoint) else net.input_units.get(src))
                     for p, src in fed.items()}
            def where(port, inst=inst, fed=fed):
                if port in fed:
                    field_ = "wires" if isinstance(fed[port], Endpoint) else "inputs"
                    return f"{net.name}.{field_}: {net.wire_text(Endpoint(inst, port))!r}"
                return f"{net.name}: {inst}.{port}"
            u = instance_units(kind_of(inst).name, known, declared[inst], where)
            for p, q in u.items():
                at[Endpoint(inst, p)] = q
            out.setdefault(inst.replace(".", "_"), u)
        ports = {}
        for name, dsts in net.inputs.items():   # a chain input nothing declares takes its ports' unit
            qs = {at.get(d) for d in dsts} - {None}
            if len(qs) > 1:
                raise WiringError(f"{net.name}.inputs: chain input {name!r} drives ports in {', '.join(sorted(qs))}")
            ports[name] = net.input_units.get(name) or next(iter(qs), None)
        chains[net.instance_name] = {**ports, **{name: at.get(src) for name, src in net.outputs.items()}}
    for t in tables:
        out.setdefault(t.replace(".", "_"), instance_units(kind_of(t).name, {}, declared[t]))
    return {**out, **chains}


def _instance_table(design: "Design", quantities: Quantities) -> dict[str, Instance]:
    table = {}
    for name, block in design.all.items():
        q = quantities.get(name, {})
        ports = [tuple(Port(p, f, *display(q.get(p), design.rate_full_scale_dps), q.get(p)) for p, f in ports.items())
                 for ports in (block.inputs, block.outputs)]
        members = getattr(block, "MEMBERS", ())
        module = name if members else block.datapath.MODULE
        if name != block.name.replace(".", "_"):
            raise AssertionError(f"instance {name} is not named after its config table {block.name}")
        hardware = all(table[m].hardware for m in members) if members else block.datapath.RTL is not None
        table[name] = Instance(name, block.name, block, module, ports[0], ports[1], members, hardware)
    return table


# Every instance's random streams (vectors, budget) are keyed by its name. The instances of the
# first releases keep the position they were generated at, so their committed vectors stay as they
# were; any other instance gets a key from its name: adding, removing or reordering tables never
# changes another instance's streams.
FIRST_STREAMS = ("rtd", "iir", "demod", "piecewise_sf", "piecewise_bias", "piecewise_bias001", "piecewise_k0",
                 "piecewise_k1", "sf_divide", "bias_subtract", "bias_subtract001", "freq2temp", "lag",
                 "chain_paper002", "chain_paper001")


def stream_key(name: str) -> int:
    """The integer that, with the seed, keys instance ``name``'s random streams."""
    if name in FIRST_STREAMS:
        return FIRST_STREAMS.index(name)
    return int.from_bytes(hashlib.sha256(name.encode()).digest()[:4], "little") + len(FIRST_STREAMS)


def _check_top_level(cfg: Config, tables: list[str]) -> None:
    """A top-level table that is no block, chain or system table is a typo: named (with the table it
    most likely meant) before the chains are read, which would only say that a block is missing."""
    from fxdsp.config import default_config_text, nearest
    import tomllib

    known = {"system", "stimulus", "chain"} | {t.split(".")[0] for t in tables}
    for key in cfg.data:
        if key not in known:
            near = nearest(key, [k for k in tomllib.loads(default_config_text()) if k not in cfg.data])
            raise InputError(f"{key}: unknown key" + (f" (did you mean {near!r}?)" if near else ""))


def _netlists(cfg: Config, tables: list[str]) -> dict[str, Netlist]:
    sec = cfg.optional_section("chain")
    if sec is None:
        return {}
    def ports(table: str):
        return kind_of(table).ports(table_at(cfg.data, table))
    out = {}
    for key, value in sec.data.items():
        if not isinstance(value, dict):
            raise WiringError(f"{sec.field(key)}: expected a chain table [chain.{key}]")
        out[f"chain.{key}"] = parse(sec.sub(key), ports, tuple(tables))
    return out


def _sample_rates(nets: dict[str, Netlist], fs: float) -> dict[str, tuple[float, str]]:
    """table -> (the sample rate of the chains it is a member of, the field that states it): a chain's
    own ``fs_hz`` or [system].fs_hz. A table whose reading depends on the rate (a filter, an NCO, a
    lag) in two chains of different rates is an error naming both."""
    out: dict[str, tuple[float, str]] = {}
    for net in nets.values():
        rate = (net.fs_hz, f"{net.name}.fs_hz") if net.fs_hz is not None else (fs, "system.fs_hz")
        for table in net.instances:
            have = out.setdefault(table, rate)
            if have[0] != rate[0] and kind_of(table).timed:
                raise WiringError(f"{table}: a member of chains at {have[1]} = {have[0]:g} and {rate[1]} = "
                                  f"{rate[0]:g}; its {kind_of(table).name} reads one sample rate")
    return out


def _build_order(tables: list[str], nets: dict[str, Netlist]) -> list[str]:
    """The block tables in an order that builds every driver before what it drives (over all chains)."""
    deps = {t: set() for t in tables}
    for net in nets.values():
        for dst, src in net.drivers.items():
            if isinstance(src, Endpoint):
                deps[dst.instance].add(src.instance)
    order, stuck = topological(tables, deps)
    if stuck:
        raise WiringError(f"chain: the chains together wire a loop through {', '.join(stuck)}")
    return order


def _wired(table: str, nets: dict[str, Netlist], built: dict[str, Block]) -> dict[str, Wired]:
    """The formats of ``table``'s inputs that chains wire from block outputs; two chains that drive
    one input from outputs of different formats are an error naming both wires."""
    out: dict[str, Wired] = {}
    for net in nets.values():
        for dst, src in net.drivers.items():
            if dst.instance != table or not isinstance(src, Endpoint):
                continue
            key = kind_of(src.instance).output_keys[src.port]
            w = Wired(built[src.instance].outputs[src.port],
                      f"{src.instance}.{key} (wired by {net.name}.wires: {net.wire_text(dst)!r})")
            if dst.port in out and out[dst.port].format != w.format:
                raise WiringError(f"{w.source} ({w.format}) and {out[dst.port].source} ({out[dst.port].format}) "
                                  f"drive {dst} with different formats")
            out.setdefault(dst.port, w)
    return out


def _check_optional(table: str, nets: dict[str, Netlist], cfg: Config) -> None:
    """A wire or chain input to an optional input its table does not enable (before the table is
    read): the key that enables it is named, missing, misspelt or set otherwise."""
    kind = kind_of(table)
    for net in nets.values():
        for dst in net.drivers:
            if dst.instance == table and dst.port in (kind.optional or {}):
                _enabled(table, dst.port, f"{net.name}: {net.wire_text(dst)!r}", cfg)


def _enabled(table: str, port: str, line: str, cfg: Config) -> None:
    """Optional input ``port`` of ``table``, which ``line`` drives, must be enabled by its key."""
    key, value = kind_of(table).optional[port]
    data = table_at(cfg.data, table)
    if data.get(key) != value:
        why = f"{line} drives it; {port} is an input when {key} = {value!r}"
        if key in data:
            raise InputError(f"{table}.{key}: {data[key]!r}: {why}")
        typo = next((k for k in data if one_edit(k, key)), None)
        if typo is not None:
            raise InputError(f"{table}.{typo}: unknown key (did you mean {key!r}?)")
        raise InputError(f"{table}.{key}: missing ({why})")


def _check_formats(net: Netlist, blocks: dict[str, Block]) -> None:
    """Every wire joins equal formats, and a chain input drives inputs of one format."""
    for dst, src in net.drivers.items():
        want = blocks[dst.instance].inputs[dst.port]
        if isinstance(src, Endpoint):
            got = blocks[src.instance].outputs[src.port]
            if got != want:
                raise WiringError(f"{net.name}.wires: {net.wire_text(dst)!r}: {src} is {got}, {dst} is {want}")
        else:
            first = net.inputs[src][0]
            have = blocks[first.instance].inputs[first.port]
            if have != want:
                raise WiringError(f"{net.name}.inputs: {net.wire_text(dst)!r}: chain input {src!r} drives "
                                  f"{first} ({have}) and {dst} ({want}): one input, one format")


def build(config: Config | str | None = None, chains: bool = True) -> Design:
    """Build every block table and every chain of a config (path, Config, or None for the built-in
    default). Any unknown key or table anywhere in the config is an error naming it; a wiring error
    names the chain, the wire and the fields. Every format an input is wired to is derived from the
    output that drives it. ``chains=False`` builds the blocks alone (a stated format is taken as
    given where it disagrees with its wire), for block-level work on formats the chains could not connect."""
    cfg = config if isinstance(config, Config) else load_config(config)
    with cfg.naming_the_file():
        return _build(cfg, chains)


def _build(cfg: Config, chains: bool) -> Design:
    stim = cfg.section("stimulus")
    system = cfg.section("system")
    fs = system.number("fs_hz", low=0, low_open=True)
    design = Design(cfg, seed=stim.integer("seed", low=0), samples=stim.integer("samples", low=16, high=10**7),
                    fs_hz=fs, rate_full_scale_dps=system.number("rate_full_scale_dps", low=0, low_open=True))
    tables = block_tables(cfg.data)
    _check_top_level(cfg, tables)
    nets = _netlists(cfg, tables)
    in_chain = {i for net in nets.values() for i in net.instances}
    rates = _sample_rates(nets, fs)
    built: dict[str, Block] = {}
    for table in _build_order(tables, nets):
        rate, rate_field = rates.get(table, (fs, "system.fs_hz"))
        ctx = Context(rate, enforce=chains, in_chain=table in in_chain, fs_field=rate_field)
        _check_optional(table, nets, cfg)
        block = kind_of(table).make(cfg.section(table), _wired(table, nets, built), ctx)
        block.name = table   # its overflow counters and errors are named after its table
        built[table] = block
    names = sorted((t.replace(".", "_") for t in tables),   # the first releases' order, then the file's
                   key=lambda n: FIRST_STREAMS.index(n) if n in FIRST_STREAMS else len(FIRST_STREAMS))
    design.blocks = {n: built[next(t for t in tables if t.replace(".", "_") == n)] for n in names}
    if chains:
        kinds = {t: kind_of(t).name for t in tables}
        for net in nets.values():
            _check_formats(net, built)
            design.chains[net.instance_name] = Chain(net, built, kinds, net.fs_hz or fs)
    design.instances = _instance_table(design, _quantities(design, tables, nets))
    cfg.check_all_read()
    return design


register_design_builder(build)   # the config learns the keys a table may hold from the design, for its hints
