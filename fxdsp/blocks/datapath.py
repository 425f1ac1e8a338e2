"""The one description of a block's arithmetic: a frozen datapath that the block builds once.

A block's kernel, the Verilog parameter generator (:mod:`fxdsp.hdl.params`) and the error budget
(:mod:`fxdsp.budget.hybrid`) all read the same :class:`Datapath`; none of them re-derives a shift,
a width or a table. Each block declares its own subclass whose fields are, in order, the
parameters of its RTL module: a field ``top_shift`` *is* the Verilog parameter ``TOP_SHIFT``
(one name for one quantity, as in verilog-axis). Field metadata says how a field reaches the RTL:

* a plain int field: ``NAME(value)``;
* ``const()``: a 64-bit two's-complement constant (``64'h...``), for values that may not fit 32 bits;
* ``packed()``: a tuple of small shifts packed 8 bits per element into one 64-bit constant;
* a :class:`~fxdsp.fixed.Rules` field: ``ROUNDING`` and ``OVERFLOW`` codes at its place;
* a :class:`Rom` field: the table of ``$readmemh`` file ``<instance>_<field>.hex`` whose name is
  passed as ``<FIELD>_FILE`` after the module's other parameters;
* a nested datapath with ``nested(prefix)``: its parameters under ``prefix`` (its ROM files named
  ``<instance>_<field>_<rom>.hex``), leaving out the ones the outer module already has;
* ``info()``: Python-side facts (formats, the overflow fields) that are not RTL parameters.

The overflow flag vector of the RTL is described once, as :class:`OvfField`\\ s in bit order (bit 0
first): each field is the flags of one overflow counter of the model, so the width of the ovf
port, the position of a flag in a chain's vector and the counter a flag belongs to all come from it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from fxdsp.fixed import Rules
from fxdsp.fixed.rules import OVERFLOW_CODE, ROUNDING_CODE
from fxdsp.errors import InputError

PARAM, CONST, PACKED, INFO, NESTED = "param", "const", "packed", "info", "nested"


def const(**kw):
    return field(metadata={"kind": CONST}, **kw)


def packed(**kw):
    """An array of shifts, 8 bits each, element k at bits 8k..8k+7 (the RTL unpacks it per term)."""
    return field(metadata={"kind": PACKED}, **kw)


def info(**kw):
    return field(metadata={"kind": INFO}, **kw)


def nested(prefix: str, **kw):
    return field(metadata={"kind": NESTED, "prefix": prefix}, **kw)


def frozen_array(values, dtype=np.int64) -> np.ndarray:
    """A read-only copy: a datapath's tables cannot be changed behind the RTL's back."""
    a = np.array(values, dtype=dtype)
    a.setflags(write=False)
    return a


def signed_width(words, at_least: int = 1) -> int:
    """Bits the widest of ``words`` needs as a signed integer (at least ``at_least``): the word of
    a table the generator writes for the RTL in as few bits as its contents allow."""
    return max([at_least] + [int(w if w >= 0 else -w - 1).bit_length() + 1 for w in np.ravel(words)])


@dataclass(frozen=True, eq=False)
class Rom:
    """A ROM table: stored integers (read-only) and the word width of the RTL memory (whether every
    word fits is checked by the one hex encoder, :func:`fxdsp.fixed.hexfile.hex_words`)."""

    words: np.ndarray
    width: int

    def __post_init__(self):
        object.__setattr__(self, "words", frozen_array(self.words))


@dataclass(frozen=True)
class OvfField:
    """One field of an RTL ovf vector: ``width`` flags counted by the model under ``counter``."""

    counter: str
    width: int


@dataclass(frozen=True)
class RtlPorts:
    """The RTL module's interface beyond clk, rst, in_valid, the data ports, out_valid and ovf: what
    a harness or a generated top must connect (Verilator warns of a missing pin)."""

    ready: bool = False         # an in_ready output whatever the parameters (tied high when one per clock)
    serial: bool = False        # a resource-shared variant selected by ARCH = 1
    mac_bundle: bool = False    # the shared-multiplier bundle (mac_*, fx_mac_port): tied off on its own multiplier
    aux: bool = False           # the auxiliary low-pass channel (aux_*, read only with AUX_LPF = 1)
    second_set: bool = False    # a second coefficient set's outputs (out_valid_1, y_1, ovf_1; SETS = 2)
    reference: bool = False     # the reference input and wave pass ports (ref_phase: phase_bits bits, wave_*):
                                # tied off but for a model input mapped to ref_phase (``names``: REF = 1)
    signed: tuple[str, ...] = ()   # ports the RTL treats as signed (sign-extended, compared, subtracted):
                                   # the model allows an unsigned format there, the RTL does not
    names: tuple[tuple[str, str], ...] = ()   # (model port, RTL port) where they differ (a model name that
                                              # is a Verilog / SystemVerilog keyword, e.g. demod's ref)
    ahead: tuple[tuple[str, str], ...] = ()   # (output, RTL port): the port holds the value the output will
                                              # carry for the NEXT sample, whenever no sample is in flight
                                              # (a loop's state word, known before the sample is taken)

    def port(self, name: str) -> str:
        """The RTL port of the model's port ``name``."""
        return dict(self.names).get(name, name)

    def ahead_port(self, output: str) -> str | None:
        """The RTL port holding output ``output``'s next value ahead of the sample (None: none)."""
        return dict(self.ahead).get(output)

    def variant(self) -> dict | None:
        """The parameters selecting the serial variant (None: the module has none)."""
        return {"ARCH": 1} if self.serial else None


def whole_limbs(w: int) -> int:
    """A multiplier operand's width for ``w`` bits: whole 16-bit limbs, at least one."""
    return max(16, -(-w // 16) * 16)


def limbs(a_w: int, b_w: int) -> int:
    """16 x 16 limb products of an a_w x b_w-bit product on the shared multiplier (fx_mac_serial)."""
    return (a_w + 15) // 16 * ((b_w + 15) // 16)


@dataclass(frozen=True, eq=False)
class Datapath:
    """Base of every block's datapath description (subclasses add the fields).

    Beside the arithmetic, each subclass states its RTL's timing once, as functions of the module's
    parameters ``p`` (the generated header's values, :meth:`verilog`): the one-sample-per-clock
    variant's latency, the serial variant's cycles per sample (its header's documented schedule)
    and the widest operands it issues on a shared multiplier. The long-stream tests measure the RTL
    against them, and the chain tops' schedules are built from them (:mod:`fxdsp.hdl.schedule`)."""

    MODULE = ""   # the RTL module (class attribute of each subclass); every subclass has ``ovf``
    RTL = RtlPorts()   # its interface (class attribute of each subclass)
    LATENCY = 1   # ARCH = 0: edges from the accepting edge to out_valid (the header's "Latency")

    @classmethod
    def latency(cls, p: dict, unroll: int = 1) -> int:
        """The one-sample-per-clock variant's latency at parameters ``p``."""
        return cls.LATENCY

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """ARCH = 1: edges from a sample's accepting edge to its successor's, back to back."""
        raise ValueError("the module has no serial variant")

    @staticmethod
    def mac_operands(p: dict) -> tuple[int, int]:
        """The widest (a, b) operands the serial variant issues on its multiplier bundle (the
        header's fx_mac_port A_W / B_W): what a multiplier shared by several blocks must take."""
        raise ValueError("the module has no multiplier bundle")

    def verilog(self, instance: str) -> tuple[dict[str, int | str], dict[str, Rom], set[str]]:
        """The RTL module's parameters in declaration order, the ROMs by file name and the names
        of the 64-bit constants: a plain mapping of the fields, nothing computed."""
        params: dict[str, int | str] = {}
        roms: dict[str, Rom] = {}
        consts: set[str] = set()
        self._emit(instance, "", params, roms, consts, outer={})
        return params, roms, consts

    def _emit(self, instance, prefix, params, roms, consts, outer) -> None:
        files: list[tuple[str, str, Rom]] = []
        own = {f.name.upper(): getattr(self, f.name) for f in dataclasses.fields(self)}
        for f in dataclasses.fields(self):
            kind = f.metadata.get("kind", PARAM)
            value = getattr(self, f.name)
            name = prefix + f.name.upper()
            if kind == INFO:
                continue
            if kind in (PARAM, CONST) and not isinstance(value, (Rules, Rom)) and f.name.upper() in outer:  # shared with the outer module
                if outer[f.name.upper()] != value:
                    raise InputError(f"hdl: {instance}: {f.name.upper()} = {value} differs from the outer "
                                     f"module's {outer[f.name.upper()]}")
                continue
            if isinstance(value, Rules):
                params[prefix + "ROUNDING"] = ROUNDING_CODE[value.rounding]
                params[prefix + "OVERFLOW"] = OVERFLOW_CODE[value.overflow]
            elif isinstance(value, Rom):
                files.append((name + "_FILE", f"{instance}_{f.name}.hex", value))
            elif kind == NESTED:
                value._emit(f"{instance}_{f.name}", f.metadata["prefix"], params, roms, consts, outer=own)
            elif kind == PACKED:
                word = 0
                for k, v in enumerate(value):
                    if not 0 <= int(v) <= 255:
                        raise InputError(f"hdl: {instance}: {f.name}[{k}] = {int(v)} outside 0..255")
                    word |= int(v) << (8 * k)
                params[name] = word
                consts.add(name)
            else:
                params[name] = int(value)
                if kind == CONST:
                    consts.add(name)
        for pname, fname, rom in files:
            params[pname] = fname
            roms[fname] = rom
