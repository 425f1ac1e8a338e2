"""Cycles per sample: a block's from its datapath description (each states its module's documented
schedule and latency as functions of the module's parameters, :class:`fxdsp.blocks.datapath.Datapath`),
a generated chain top's (:mod:`fxdsp.hdl.chain_top`) from its netlist and its members'. The
long-stream tests measure the RTL against them, back to back."""

from __future__ import annotations


def ahead_source(design, src) -> str | None:
    """The RTL port holding a wire source's next value ahead of the sample (None: the wire waits for
    its driver's result): a member output declared so by its interface (RtlPorts.ahead)."""
    if isinstance(src, str):   # a chain input
        return None
    return design.instances[src.instance.replace(".", "_")].rtl.ahead_port(src.port)


def waits_on(design, name: str, member: str) -> set[str]:
    """The members of chain ``name`` whose results ``member`` waits for: the drivers of its inputs,
    but not those read ahead (a wire from an output with an ahead port: the top takes that word when
    it accepts the sample, :mod:`fxdsp.hdl.chain_top`)."""
    net = design.chains[name].netlist
    return {src.instance for dst, src in net.drivers.items()
            if dst.instance == member and not isinstance(src, str) and ahead_source(design, src) is None}


def on_shared_multiplier(design, name: str) -> list[str]:
    """The members of chain ``name`` on its serial top's one shared multiplier, in execution order:
    those with a multiplier bundle, but the chain's ``own_multiplier`` ones (a multiplier of their
    own: they run beside the others instead of taking turns)."""
    net = design.chains[name].netlist
    return [m for m in net.order if design.instances[m.replace(".", "_")].rtl.mac_bundle
            and m not in net.own_multiplier]


def mac_operands(design, name: str) -> tuple[int, int]:
    """The widest (a, b) operands instance ``name`` issues on its multiplier bundle at the design's
    parameters (its datapath's :meth:`~fxdsp.blocks.datapath.Datapath.mac_operands`)."""
    from fxdsp.hdl.params import parameters

    return design.instances[name].block.datapath.mac_operands(parameters(design, name))


def member_cycles(design, name: str, arch: int = 1, unroll: int = 1) -> int:
    """A block instance's cycles from its accepting edge to its successor's at the design's parameters:
    ARCH = 1 its serial cycles per sample, ARCH = 0 its latency (``unroll``: the divider's UNROLL),
    each its datapath's (:class:`fxdsp.blocks.datapath.Datapath`)."""
    from fxdsp.hdl.params import parameters

    dp, p = design.instances[name].block.datapath, parameters(design, name)
    return dp.serial_cycles(p, unroll) if arch else dp.latency(p, unroll)


def cycles_per_sample(design, name: str, arch: int = 1, unroll: int = 1) -> int:
    """An instance's cycles per sample (a chain's from its top's schedule, a block's from its module's);
    for a schedule that varies from sample to sample (a decimating lag) the bound every schedule
    must meet: the sample period at 40 MHz."""
    try:
        if design.instances[name].members:
            return chain_schedule(design, name, arch, unroll)[0]
        return member_cycles(design, name, arch, unroll)
    except ValueError:   # the period of the chain's own rate (a block: the system's)
        return int(40e6 // getattr(design.chains.get(name), "fs_hz", design.fs_hz))


def chain_schedule(design, name: str, arch: int = 1, unroll: int = 1) -> tuple[int, dict[str, tuple[int, int]]]:
    """A generated top's schedule, one sample in flight, as the top runs it (:mod:`fxdsp.hdl.chain_top`):
    (cycles per sample, {member: (in_valid cycle, cycles)}), counted from the cycle after the chain's
    accepting edge (cycle 0). A member's start is decided in the cycle after its drivers' results are
    all captured (their in_valid cycle + cycles + 1) and registered: its in_valid comes a cycle later.
    In the serial variant the members on the one multiplier (and the engines they share,
    :mod:`fxdsp.hdl.sharing`) are also started only when no other one is working on it (from its
    in_valid to its result's capture), the earlier in the netlist's order first; a shared set's guest
    pass runs as its host's result leaves. A wire read ahead (:func:`waits_on`) does not wait. Then the out_valid register (busy clears with it and the
    next sample enters as it leaves): cycles per sample = 3 + the last member's in_valid + cycles."""
    net = design.chains[name].netlist
    from fxdsp.hdl.sharing import engine_sharing

    shares = engine_sharing(design, name) if arch else {}
    cycles = {m: member_cycles(design, m.replace(".", "_"), arch, unroll) for m in net.order}
    on_mac = set(on_shared_multiplier(design, name)) if arch else set()
    deps = {m: waits_on(design, name, m) for m in net.order}
    guest_of = {s.host: s.guest for s in shares.values() if s.kind == "set"}
    valid: dict[str, int] = {}   # each member's in_valid cycle
    t = 0
    while len(valid) < len(net.order):
        if t > 1_000_000:
            raise RuntimeError(f"{name}: the schedule does not finish")
        # started (from in_valid) and its result not yet captured (through its out_valid cycle)
        mac_busy = any(valid[u] <= t <= valid[u] + cycles[u] for u in on_mac if u in valid)
        for m in net.order:
            if m in valid or m in guest_of.values():
                continue
            if not all(d in valid and valid[d] + cycles[d] + 1 <= t for d in deps[m]):
                continue
            if m in on_mac:
                if mac_busy:
                    continue
                mac_busy = True     # granted: lower-priority members wait
            valid[m] = t + 1
            if m in guest_of:
                valid[guest_of[m]] = t + 1 + cycles[m]
        t += 1
    return 3 + max(valid[m] + cycles[m] for m in valid), {m: (valid[m], cycles[m]) for m in net.order}
