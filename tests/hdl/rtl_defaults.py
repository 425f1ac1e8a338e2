"""Static check that the RTL's parameter defaults describe the default design, not an old one.

A parameter default is what a reader of ``hdl/rtl/*.v`` takes for the design, and what a simulation
or synthesis of a module without overrides builds. Two rules, read from the Verilog text and from
the generator (never from a list in this file):

* **a block's defaults are the generator's values** for the default config: every parameter the
  generator writes for a module (``fxdsp.hdl.params``) has, as its default, the value written for the
  module's representative instance (the instance named as the module, else the config's first
  instance of it);
* **a submodule's parameter fed by one block keeps that block's default**: a module no config
  instantiates (a part of a block) whose parameter P every instance fills from the same parameter Q
  of the same parent (``.P(Q)``) has Q's default (mix_lpf's ``MIX_SHIFT`` is demod's), so it reads as
  the default design too. A primitive fed by several blocks (fx_round's ``SHIFT``) keeps a neutral
  default: no one design is its own.

Only literal defaults are compared; a default that is an expression of other parameters is derived,
not described.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import rtl_rules


@dataclass(frozen=True)
class Default:
    module: str
    file: str
    name: str
    text: str        # the default as written (a literal, a string in quotes, or an expression)


_HEADER = re.compile(r"\bmodule\s+(\w+)\s*#\s*\(")
_PARAM = re.compile(r"\bparameter\s+(?:integer\s+|signed\s+|\[[^\]]*\]\s*)*(\w+)\s*=\s*")


def _group_end(code: str, open_at: int) -> int:
    """Index of the parenthesis closing the one at ``open_at``."""
    depth = 0
    for i in range(open_at, len(code)):
        depth += {"(": 1, ")": -1}.get(code[i], 0)
        if depth == 0:
            return i
    raise ValueError("unbalanced parentheses")


def _value_end(code: str, i: int, stop: int) -> int:
    """End of one default: the next top-level comma of the parameter list, or its end."""
    depth = 0
    while i < stop:
        c = code[i]
        if c == '"':
            i = code.index('"', i + 1)
        elif c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        elif c == "," and depth == 0:
            break
        i += 1
    return i


def defaults(rtl: Path) -> dict[str, dict[str, Default]]:
    """Module -> parameter -> its default, for every ``module name #( parameter ... )`` header."""
    out: dict[str, dict[str, Default]] = {}
    for path in sorted(rtl.glob("*.v")):
        code = rtl_rules.strip_comments(path.read_text(encoding="utf-8"), strings=True)
        for h in _HEADER.finditer(code):
            stop = _group_end(code, h.end() - 1)
            params = out.setdefault(h.group(1), {})
            for p in _PARAM.finditer(code, h.end(), stop):
                text = code[p.end():_value_end(code, p.end(), stop)].strip()
                params[p.group(1)] = Default(h.group(1), path.name, p.group(1), text)
    return out


def value(text: str) -> int | str | None:
    """A literal's value (an integer, or a string's contents); None for an expression."""
    if len(text) >= 2 and text[0] == text[-1] == '"':
        return text[1:-1]
    t = text.replace(" ", "")
    negative = t.startswith("-")
    v = rtl_rules.literal_value(t[1:] if negative else t)
    return None if v is None else (-v if negative else v)


def representatives(design) -> dict[str, str]:
    """Module -> the instance whose generated values its defaults must be: the instance named as the
    module, else the config's first instance of it."""
    out: dict[str, str] = {}
    for name, inst in design.hardware.items():
        if inst.members:
            continue
        module = inst.block.datapath.MODULE
        if name == module or module not in out:
            out[module] = name
    return out


def pass_throughs(rtl: Path) -> list[tuple[str, str, str, str]]:
    """(parent, parameter of the parent, child, parameter of the child) for every ``.P(Q)``
    connection, in a module's instance list, of a child parameter P to a parent parameter Q."""
    own = {m: set(p) for m, p in defaults(rtl).items()}
    out = set()
    for path in sorted(rtl.glob("*.v")):
        for mod in rtl_rules.modules_of(path):
            for child, conns, _ in rtl_rules._Body(mod).instances():
                for p, q in conns.items():
                    if child in own and p in own[child] and q in own.get(mod.name, ()):
                        out.add((mod.name, q, child, p))
    return sorted(out)


def problems(rtl: Path, design) -> list[str]:
    """Every default that breaks one of the two rules, as readable lines."""
    from fxdsp.hdl.params import instance, literal

    found = defaults(rtl)
    lines = []
    for module, name in representatives(design).items():
        inst = instance(design, name)
        for p, v in inst.params.items():
            d = found.get(module, {}).get(p)
            want = literal(inst, p, v)
            if d is None:
                lines.append(f"{module}: the generator writes {p} but the module declares no default for it")
            elif value(d.text) != value(want) and not (isinstance(v, int) and value(d.text) == v):
                lines.append(f"{d.file}: {module}.{p} = {d.text}; the generator writes {want} for {name}")
    fed: dict[tuple[str, str], set[tuple[str, str]]] = {}
    for parent, q, child, p in pass_throughs(rtl):
        fed.setdefault((child, p), set()).add((parent, q))
    configured = set(representatives(design))
    for (child, p), sources in sorted(fed.items()):
        if child in configured or len(sources) != 1:
            continue
        (parent, q), = sources
        a, b = found[parent][q], found[child][p]
        va, vb = value(a.text), value(b.text)
        if va is not None and vb is not None and va != vb:
            lines.append(f"{b.file}: {child}.{p} = {b.text}, but {parent} passes its {q} = {a.text} on")
    return lines
