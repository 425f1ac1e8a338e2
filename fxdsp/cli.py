"""`fxdsp` command line: one sub-command per job, each in its own module.

Every sub-command module exposes ``configure(parser)`` and ``run(args) -> int``. Only the module of
the command being run is imported, so that a quick command does not pay for the imports of the
others (numba and the blocks); ``fxdsp --help`` lists every command from COMMANDS without importing
any. A module that fails to import is an error (its traceback), never a silently missing command.

An option a command takes only beside another (its module's ``ONLY_WITH``: ``--margin`` only with
``--optimise``) is refused when given without it, rather than accepted and left unused
(:func:`fxdsp.commands.options.check_only_with`). Every path option a command declares (its
module's ``PATHS``) is checked before the command runs
(:func:`fxdsp.outputs.check_paths`) and declared for its writes (:mod:`fxdsp.owned`: a folder output
replaces only the files fxdsp wrote there). Bad input (:class:`~fxdsp.errors.InputError`, an OSError
such as a missing or unwritable file or a full disk, a malformed TOML, undecodable text) becomes one
line on stderr and exit status 2; an interrupt (Ctrl-C) one line and 130, with the outputs left as
they were (they are staged, :mod:`fxdsp.outputs`). Any other exception is a bug: its traceback and
exit status 70.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import tomllib
import traceback
import warnings
from collections.abc import Iterable

from fxdsp.threads import one_blas_thread

one_blas_thread()   # before any command imports numpy: fxdsp.threads says why

from fxdsp.errors import InputError  # noqa: E402
from fxdsp.interrupts import interrupts_held  # noqa: E402

# name -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("fxdsp.commands.demo", "generate the golden vectors on the default config and print a summary"),
    "vectors": ("fxdsp.commands.vectors", "write (or --check) the golden vectors of every block and chain"),
    "bench": ("fxdsp.commands.bench", "throughput of the bit-exact models against fxpmath and apytypes"),
    "simulate": ("fxdsp.commands.simulate", "simulate a chamber run and write a canonical log"),
    "calibrate": ("fxdsp.commands.calibrate", "fit the compensation of a paper from a chamber log"),
    "repro": ("fxdsp.commands.repro", "reproduce the papers' experiments on the simulated devices, bit-exact"),
    "diagnose": ("fxdsp.commands.diagnose", "explain where a measured log disagrees with the simulation"),
    "budget": ("fxdsp.commands.budget", "float vs fixed error budget in physical units; word-length exploration"),
    "rtl": ("fxdsp.commands.rtl", "RTL regression of a config: vectors, headers, every block and chain simulated "
                                 "against the model, report"),
    "formal": ("fxdsp.commands.formal", "formal proofs of every serial block's and chain top's handshake, latency "
                                       "and shared-multiplier rules (yosys-smtbmc)"),
    "hdl-gen": ("fxdsp.commands.hdl_gen", "write the Verilog parameter headers and ROM files from the config"),
    "hw-report": ("fxdsp.commands.hw_report", "synthesise every block for the iCE40UP5K and tabulate the cost"),
    "diagnose-bench": ("fxdsp.commands.diagnose_bench", "seconds to diagnose simulated logs of given sizes"),
    "diagnose-hidden": ("fxdsp.commands.diagnose_hidden",
                        "confusion matrix of the diagnosis on simulated logs with a random hidden cause"),
    "diagnose-rtd": ("fxdsp.commands.diagnose_rtd",
                     "linear RTD law vs Callendar-Van Dusen on a resistance table, and its diagnosis"),
    "extend": ("fxdsp.commands.extend", "diagnose a log, extend the compensation with hardware remedies, write the config, "
                                   "vectors, RTL headers, cocotb regression and report"),
    "sweep": ("fxdsp.commands.sweep", "Monte-Carlo budget, word-length search, confusion matrix, RTL regressions "
                                 "on Dask workers"),
}


# what the user controls and got wrong: one line naming it and exit 2. InputError is raised by the
# validation of options, configs, logs and paths; an OSError is about a path (the user's, or a tool's
# that is missing); a TOML or UTF-8 decode error is a file the user gave
BAD_INPUT = (InputError, OSError, tomllib.TOMLDecodeError, UnicodeDecodeError)
BUG = 70   # any other exception: a bug, with its traceback (EX_SOFTWARE of sysexits.h)


class _Parser(argparse.ArgumentParser):
    """argparse with its errors on one line (no usage block): ``fxdsp X: error: ...``, exit 2."""

    def error(self, message):
        hint = " (a value starting with '-': write --option=VALUE)" if "expected one argument" in message else ""
        self.exit(2, f"{self.prog}: error: {message}{hint}\n")


def build_parser(load: Iterable[str] | None = None) -> argparse.ArgumentParser:
    """The parser with every command. The modules of the commands in ``load`` (default: all) are
    imported and configure their options; the others are listed only. Import errors propagate."""
    parser = _Parser(prog="fxdsp", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module_name, help_text) in COMMANDS.items():
        sp = sub.add_parser(name, help=help_text, description=help_text)
        if load is None or name in load:
            # SIGINT held during the import: a Ctrl-C landing inside importlib's own callbacks is
            # printed as an ignored exception (a traceback) and lost; held, it interrupts right after
            with interrupts_held():
                module = importlib.import_module(module_name)
            module.configure(sp)
            sp.set_defaults(_module=module)
            for leaf in _leaf_parsers(sp):   # the parser whose defaults an option is checked against
                leaf.set_defaults(_parser=leaf)
    return parser


def _leaf_parsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """``parser`` or, for a command with kinds (sweep montecarlo, ...), each kind's own parser."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return [leaf for s in subs for p in dict.fromkeys(s.choices.values()) for leaf in _leaf_parsers(p)] or [parser]


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except KeyboardInterrupt:  # while the command's modules were still being imported
        print("fxdsp: interrupted", file=sys.stderr)
        return 130


def _main(argv: list[str] | None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    # the command is the first argument (fxdsp has no options of its own but --help): load only it
    parser = build_parser(load=argv[:1] if argv and argv[0] in COMMANDS else ())
    try:
        args = parser.parse_args(argv)  # bad flags and values: one line and exit 2 (_Parser.error)
    except SystemExit as exc:           # returned, as every other status is (--help: 0)
        return exc.code if isinstance(exc.code, int) else 0 if exc.code is None else 2
    # numpy's overflow / invalid-value warnings would add lines to the one an error gives: a result
    # that overflowed is refused where it is written (fxdsp.outputs.non_finite_value), naming it
    warnings.filterwarnings("ignore", message="(overflow|invalid value|divide by zero) encountered",
                            category=RuntimeWarning)
    warnings.filterwarnings("ignore", message="The fit may be poorly conditioned")   # numpy's RankWarning
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    try:
        from fxdsp.commands.options import check_only_with
        from fxdsp.outputs import check_paths
        from fxdsp.owned import declaring

        check_only_with(args, args._parser, getattr(args._module, "ONLY_WITH", {}))
        with declaring(check_paths(args, getattr(args._module, "PATHS", {}))):
            return int(args._module.run(args) or 0)
    except KeyboardInterrupt:
        print(f"fxdsp {args.command}: interrupted; outputs left as they were", file=sys.stderr)
        return 130
    except BAD_INPUT as exc:
        message = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
        if isinstance(exc, OSError) and exc.filename:
            message = f"{exc.strerror or exc.__class__.__name__}: {exc.filename}"
        elif isinstance(exc, UnicodeDecodeError):
            message = f"not UTF-8 text ({exc.reason} at byte {exc.start})"
        print(f"fxdsp {args.command}: error: {message}", file=sys.stderr)
        return 2
    except Exception:   # noqa: BLE001 - anything else is a bug of fxdsp, not of the user's input
        traceback.print_exc()
        print(f"fxdsp {args.command}: internal error: a bug in fxdsp, not in the input (the traceback above); "
              f"exit status {BUG}", file=sys.stderr)
        return BUG


if __name__ == "__main__":
    sys.exit(main())
