"""The kinds of block a config table can be, stated once: each kind's ports and how its table is
read, given the formats of the inputs the chains wire to it.

A table's kind is its name up to the first dot, without trailing digits (``bias_subtract001`` and
``bias_subtract`` are both ``bias_subtract``); a *family* kind's instances are its sub-tables
(``[piecewise.sf]``, ``[piecewise.k0]``). An input that no chain wires takes its format from the
table key this module names for it (``in_format``, ``temp_format`` ...); a wired one is derived
from the output driving it, and a table that states it anyway must agree.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable

from fxdsp.config import Section
from fxdsp.errors import InputError
from fxdsp.fixed import Format


@dataclass(frozen=True)
class Wired:
    """The format of an input wired by a chain, and the field (``chain.x: 'a.y -> b.x'``) it comes from."""

    format: Format
    source: str


@dataclass(frozen=True)
class Context:
    """What a block's table cannot say by itself: the chains' sample rate, whether a wired format
    must match a stated one (False: block-level work), and whether a chain feeds the block."""

    fs_hz: float
    enforce: bool = True
    in_chain: bool = False
    fs_field: str = "system.fs_hz"   # the field fs_hz comes from (a chain's own fs_hz, errors name it)


def port_format(sec: Section, key: str, port: str, wired: dict[str, Wired], ctx: Context) -> Format:
    """The format of input ``port``: wired (derived; a stated ``key`` must agree) or stated by ``key``."""
    w = wired.get(port)
    if w is None:
        if not sec.has(key):
            raise sec._missing(key, f"missing (input {port!r} of {sec.path} is wired by no chain, so its "
                                    f"format must be stated)")
        return sec.format(key)
    return sec.wired_format(key, w.format, w.source, ctx.enforce)


@dataclass(frozen=True)
class Kind:
    """One kind of block: its class's port names and the reader of its table."""

    name: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    make: Callable[[Section, dict[str, Wired], Context], object]
    output_keys: dict[str, str]   # output port -> the table key its format comes from (errors name it)
    family: bool = False     # the instances are the sub-tables ([piecewise.sf])
    timed: bool = False      # its table is read at the sample rate (a filter design, an NCO, a lag's update rate)
    optional: dict[str, tuple[str, str]] = None   # input a table may add -> the (key, value) that adds it

    def ports(self, table: dict) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
        """(inputs, outputs, optional inputs) of an instance whose table holds ``table``: its
        inputs are the kind's and the optional ones its table enables (each must be wired); the
        others may be wired (building the chain then names the key to set)."""
        enabled = tuple(p for p, (key, value) in (self.optional or {}).items()
                        if isinstance(table, dict) and table.get(key) == value)
        return self.inputs + enabled, self.outputs, tuple(p for p in self.optional or {} if p not in enabled)


def _own_format(block, sec: Section, key: str, port: str, wired: dict[str, Wired], ctx: Context):
    """A block whose input format is its table's own (``key``): a wire to it must bring that format."""
    w = wired.get(port)
    if w is not None and ctx.enforce and w.format != block.inputs[port]:
        raise InputError(f"{sec.field(key)}: {block.inputs[port]} must equal {w.source} ({w.format}) to connect "
                         f"the chain")
    return block


def _rtd(sec, wired, ctx):
    from fxdsp.blocks.rtd import Rtd

    return _own_format(Rtd.from_config(sec), sec, "adc_format", "code", wired, ctx)


def _piecewise(sec, wired, ctx):
    from fxdsp.blocks.piecewise import Piecewise

    return Piecewise.from_config(sec, port_format(sec, "temp_format", "temp", wired, ctx))


def _sf_divide(sec, wired, ctx):
    from fxdsp.blocks.sf_divide import SfDivide

    return SfDivide.from_config(sec, port_format(sec, "in_format", "x", wired, ctx),
                                port_format(sec, "sf_format", "sf", wired, ctx))


def _demod(sec, wired, ctx):
    from fxdsp.blocks.demod import Demod

    # a wired reference (enabled: chains._check_optional) brings its accumulator's width (phase_bits,
    # derived; a stated one must agree)
    ref = wired.get("ref")
    bits = None
    if ref is not None:
        if ref.format.signed or ref.format.fl != ref.format.wl:
            raise InputError(f"{sec.path}.ref: {ref.source} is {ref.format}; a reference is an accumulator's phase "
                             f"word in turns (u<bits>.<bits>, such as a drive loop's nco)")
        bits = ref.format.wl
        if sec.has("phase_bits") and ctx.enforce and sec.integer("phase_bits") != bits:
            raise InputError(f"{sec.field('phase_bits')}: {sec.integer('phase_bits')} must equal the width of "
                             f"{ref.source} ({ref.format}: {bits} bits) to connect the chain")
    return Demod.from_config(sec, ctx.fs_hz, port_format(sec, "in_format", "x", wired, ctx), ctx.enforce, bits)



def _bias_subtract(sec, wired, ctx):
    from fxdsp.blocks.bias_subtract import BiasSubtract

    return BiasSubtract.from_config(sec, port_format(sec, "in_format", "x", wired, ctx),
                                    port_format(sec, "bias_format", "bias", wired, ctx))


def _iir(sec, wired, ctx):
    from fxdsp.blocks.iir import Iir

    return Iir.from_config(sec, ctx.fs_hz, port_format(sec, "data_format", "x", wired, ctx), sec.path)


def _freq2temp(sec, wired, ctx):
    from fxdsp.blocks.freq2temp import Freq2Temp

    return Freq2Temp.from_config(sec, sec.format("temp_format"), port_format(sec, "freq_format", "f", wired, ctx))


def _drive(sec, wired, ctx):
    from fxdsp.blocks.drive import Drive

    return _own_format(Drive.from_config(sec, ctx.fs_hz, sec.format("in_format")), sec, "in_format", "x", wired, ctx)


def _lag(sec, wired, ctx):
    from fxdsp.blocks.lag import Lag

    # in a chain, the lag's input arrives once per chain sample and it updates at its rate_hz
    rate = (ctx.fs_hz, ctx.fs_field, ctx.enforce) if ctx.in_chain else ()
    return Lag.from_config(sec, port_format(sec, "temp_format", "temp", wired, ctx), *rate)


KINDS: dict[str, Kind] = {k.name: k for k in (
    Kind("rtd", ("code",), ("temp",), _rtd, {"temp": "temp_format"}),
    Kind("lag", ("temp",), ("te",), _lag, {"te": "temp_format"}, timed=True),
    Kind("piecewise", ("temp",), ("y",), _piecewise, {"y": "out_format"}, family=True),
    Kind("sf_divide", ("x", "sf"), ("y",), _sf_divide, {"y": "out_format"}),
    Kind("demod", ("x",), ("i", "q", "amp", "phase"), _demod,
         {"i": "data_format", "q": "data_format", "amp": "data_format", "phase": "angle_format"}, timed=True,
         optional={"ref": ("reference", "input")}),
    Kind("bias_subtract", ("x", "bias"), ("y",), _bias_subtract, {"y": "out_format"}),
    Kind("iir", ("x",), ("y",), _iir, {"y": "data_format"}, timed=True),
    Kind("freq2temp", ("f",), ("temp",), _freq2temp, {"temp": "temp_format"}),
    Kind("drive", ("x",), ("dac", "f", "amp", "phase", "nco"), _drive,
         {"dac": "dac_format", "f": "freq_format", "amp": "data_format", "phase": "angle_format",
          "nco": "phase_bits"}, timed=True),
)}


def kind_of(table: str) -> Kind | None:
    """The kind of the block table ``table`` (``piecewise.sf`` -> piecewise), None for a table that
    is not a block (``system``, ``chain.paper002``)."""
    head = table.split(".")[0]
    return KINDS.get(re.sub(r"\d+$", "", head))


def block_tables(data: dict) -> list[str]:
    """Every block table of a config's data, in the file's order."""
    out = []
    for key, value in data.items():
        kind = kind_of(key)
        if kind is None or not isinstance(value, dict):
            continue
        if kind.family:
            out += [f"{key}.{sub}" for sub, v in value.items() if isinstance(v, dict)]
        else:
            out.append(key)
    return out
