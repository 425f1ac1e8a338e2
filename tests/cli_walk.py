"""Every command and every option, read from the argparse parsers (not a hand list): the probes of
the command line are generated from these, so a new command or option is covered without a new probe.
"""

from __future__ import annotations

import argparse
import functools
from dataclasses import dataclass
from pathlib import Path

from fxdsp.cli import COMMANDS, build_parser
from fxdsp.outputs import IN, IN_DIR


@dataclass(frozen=True)
class Leaf:
    """A runnable command: its words (``("sweep", "rtl")``), parser, module and path table."""
    words: tuple[str, ...]
    parser: argparse.ArgumentParser
    module: object

    @property
    def name(self) -> str:
        return " ".join(self.words)

    def options(self) -> list[argparse.Action]:
        return [a for a in self.parser._actions
                if not isinstance(a, (argparse._HelpAction, argparse._SubParsersAction))]

    def paths(self) -> dict[str, str]:
        """option -> kind, at the parser's defaults (a PATHS that depends on a flag, such as
        ``--check`` turning an output folder into an input, is read without it)."""
        options = {flag(a) for a in self.options()}
        return {o: k for o, k in paths_of(self.module, self.parser, False).items() if o in options}


def flag(action: argparse.Action) -> str:
    """The option as the user types it (a positional: its name)."""
    return action.option_strings[0] if action.option_strings else action.dest


def _below(words: list[str], parser):
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield words, parser
        return
    for word, sp in subs[0].choices.items():
        yield from _below(words + [word], sp)


@functools.cache
def leaves() -> tuple[Leaf, ...]:
    """Every runnable command (read once per process: the parsers are only read, never changed)."""
    out = []
    for name in COMMANDS:
        top = next(a for a in build_parser(load=[name])._actions if isinstance(a, argparse._SubParsersAction))
        module = top.choices[name].get_default("_module")   # a subcommand's too (``sweep rtl``)
        out += [Leaf(tuple(words), sp, module) for words, sp in _below([name], top.choices[name])]
    return tuple(out)


def paths_of(module, parser, flags: bool) -> dict:
    """The command's PATHS (a function of its arguments: called with the parser's defaults, or with
    every boolean flag set)."""
    paths = getattr(module, "PATHS", {})
    if not callable(paths):
        return paths
    return paths(argparse.Namespace(**{a.dest: (True if flags and isinstance(a, argparse._StoreTrueAction)
                                                 else a.default) for a in parser._actions}))


def path_options() -> list[tuple[Leaf, str, str]]:
    """(command, option, kind) of every path option of every command."""
    return [(leaf, o, k) for leaf in leaves() for o, k in leaf.paths().items()]


def only_with(leaf: Leaf) -> dict[str, tuple[str, ...]]:
    """The command's ONLY_WITH (fxdsp.cli), for the options this command (or kind of sweep) has:
    option -> the conditions one of which it needs."""
    have = {flag(a) for a in leaf.options()}
    return {o: c for o, c in getattr(leaf.module, "ONLY_WITH", {}).items() if o in have}


def companions(leaf: Leaf, probes: dict[str, list[str]]) -> dict[str, list[str] | None]:
    """What the probed options need beside them (each one's first ONLY_WITH condition): ``--sim=verilator``
    as that value; None for a flag or an option given a value of its kind (:func:`argv_for`)."""
    out = {}
    for opt in probes:
        for cond in only_with(leaf).get(opt, ())[:1]:
            if cond.startswith("not "):   # what it needs is something left out
                continue
            name, _, value = cond.partition("=")
            if name not in probes:
                out[name] = [value] if value else None
    return out


def argv_for(leaf: Leaf, tmp: Path, probes: dict[str, list[str]] | None = None) -> list[str]:
    """A command line with every required argument given a value of its kind (an input file, an
    input folder, a fresh output under ``tmp``; a choice; "1"), each option of ``probes`` given
    its values, and what a probed option needs beside it (:func:`companions`)."""
    probes = probes or {}
    need = companions(leaf, probes)
    paths = leaf.paths()
    (tmp / "in.txt").write_text("x\n")
    (tmp / "in_dir").mkdir(exist_ok=True)
    argv = list(leaf.words)
    for a in leaf.options():
        opt = flag(a)
        if opt not in probes and opt not in need and not a.required and a.option_strings:
            continue
        if opt in probes:
            values = probes[opt]
        elif a.nargs == 0:   # a flag a probed option needs: given alone
            values = []
        elif need.get(opt):  # a value it needs (--sim=verilator)
            values = need[opt]
        elif opt in paths:
            kind = paths[opt]
            values = [str(tmp / ("in.txt" if kind == IN else "in_dir" if kind == IN_DIR else f"out_{a.dest}"))]
        elif a.choices:
            values = [str(sorted(a.choices)[0])]
        else:
            values = ["1"]
        if a.nargs not in (None, "?", "*", "+") and isinstance(a.nargs, int) and len(values) == 1:
            values = values * a.nargs
        argv += ([opt] if a.option_strings else []) + values
    return argv
