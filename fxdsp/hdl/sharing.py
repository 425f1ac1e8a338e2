"""Engines two members of a chain can share in the serial variant (ARCH = 1), found from the netlist
and the members' RTL parameters, never from their names:

* ``set``: two piecewise members that read the same temperature and differ only in their coefficients
  and output stage (every other RTL parameter and the breakpoints equal) are the two coefficient sets
  of ONE piecewise engine (piecewise.v ``SETS = 2``): the guest's pass starts as the host's result
  leaves, as an engine of its own would start on it;
* ``aux``: an iir member with the format of a demodulator member's low-pass (every iir parameter but
  the coefficients equal) is the third channel of that demodulator's filter engine (demod.v
  ``AUX_LPF = 1``), run while the demodulator is idle.

The generated top (:mod:`fxdsp.hdl.chain_top`) instantiates the shared engines, the schedule
(:mod:`fxdsp.hdl.schedule`) counts them, and :func:`roms` writes their coefficient-set files.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxdsp.fixed.hexfile import hex_words

# the piecewise parameters a second coefficient set has of its own (piecewise.v SETS = 2: the "_1"
# parameters); the files are each set's ROMs
SET_OWN = ("COEF_ALIGN", "OUT_SHIFT", "OUT_W", "OUT_SIGNED", "ACOEF_W")
SET_FILES = ("COEF_FILE", "BP_FILE", "ACOEF_FILE")
LPF_FILES = ("COEF_FILE", "ACOEF_FILE")


@dataclass(frozen=True)
class Shared:
    """``guest`` runs on ``host``'s engine (member names as in the netlist)."""

    kind: str    # "set" (a second piecewise coefficient set) or "aux" (demod's third filter channel)
    host: str
    guest: str
    file: str    # the engine's coefficient-set ROM (every set, host's first)


def _v(name: str) -> str:
    return name.replace(".", "_")


def _params_but(dp, skip) -> dict:
    """A datapath's RTL parameters but those named in ``skip``: what two uses of one engine share."""
    return {k: v for k, v in dp.verilog("engine")[0].items() if k not in skip}


def _datapath(design, member: str):
    return design.instances[_v(member)].block.datapath


def sets_compatible(design, host: str, guest: str) -> bool:
    """Whether two piecewise members can be the two coefficient sets of one engine: every RTL parameter
    equal but the coefficients and the output stage (:data:`SET_OWN`), and the same breakpoints (the
    segment compares are the engine's)."""
    a, b = _datapath(design, host), _datapath(design, guest)
    skip = SET_OWN + SET_FILES
    return _params_but(a, skip) == _params_but(b, skip) and np.array_equal(a.bp.words, b.bp.words)


def aux_compatible(design, demod: str, iir: str) -> bool:
    """Whether an iir member has the format of a demodulator member's low-pass (every iir parameter but
    the coefficients equal): then the demodulator's filter engine runs it as its third channel."""
    return _params_but(_datapath(design, iir), LPF_FILES) == _params_but(_datapath(design, demod).lpf, LPF_FILES)


def engine_sharing(design, name: str) -> dict[str, Shared]:
    """The shared engines of chain ``name``'s serial top, by guest member. Pairs are taken greedily in
    the netlist's instance order: a host has one guest."""
    net = design.chains[name].netlist
    members = list(net.instances)
    module = {m: design.instances[_v(m)].module for m in members}
    out: dict[str, Shared] = {}
    hosts: set[str] = set()
    for i, guest in enumerate(members):
        for host in members[:i]:
            if host in hosts or host in out:
                continue
            if module[host] == module[guest] == "piecewise":
                same_t = net.driver(host, "temp") == net.driver(guest, "temp")
                if same_t and sets_compatible(design, host, guest):
                    out[guest] = Shared("set", host, guest, f"{name}_{_v(host)}_sets.hex")
            elif module[host] == "demod" and module[guest] == "iir" and aux_compatible(design, host, guest):
                out[guest] = Shared("aux", host, guest, f"{name}_{_v(host)}_lpf_sets.hex")
            if guest in out:
                hosts.add(host)
                break
    return out


def set_parameters(design, share: Shared) -> dict[str, int]:
    """The guest set's own piecewise parameters, as the host's ``<NAME>_1`` overrides."""
    p = _datapath(design, share.guest).verilog(_v(share.guest))[0]
    return {f"{k}_1": p[k] for k in SET_OWN}


def rom(design, share: Shared) -> str:
    """The shared engine's coefficient-set ROM, as the serial engine reads it: ``set``: the host's
    ACOEF words, then the guest's, in the wider word; ``aux``: the demodulator's low-pass set for I
    and for Q, then the iir's (iir ``COEF_SETS = CHANNELS``)."""
    if share.kind == "set":
        a, b = (_datapath(design, m).acoef for m in (share.host, share.guest))
        return hex_words(np.concatenate([a.words.ravel(), b.words.ravel()]), max(a.width, b.width))
    lpf = _datapath(design, share.host).lpf.acoef
    out = _datapath(design, share.guest).acoef
    return hex_words(np.concatenate([lpf.words.ravel(), lpf.words.ravel(), out.words.ravel()]), lpf.width)


def roms(design, name: str) -> dict[str, str]:
    """Every coefficient-set file of chain ``name``'s shared engines."""
    return {s.file: rom(design, s) for s in engine_sharing(design, name).values()}
