"""`fxdsp` command line: one sub-command per job, each in its own module.

Every sub-command module exposes ``configure(parser)`` and ``run(args) -> int``. They are imported
lazily so that a quick command does not pay for numba compilation of the others.

Bad input (ValueError, TypeError, a missing file, a malformed TOML) becomes one line on stderr and
exit status 2; nothing else is caught, so a real bug still shows its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import tomllib

# name -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("fxdsp.commands.demo", "generate the golden vectors on the default config and print a summary"),
    "vectors": ("fxdsp.commands.vectors", "write (or --check) the golden vectors of every block and chain"),
    "bench": ("fxdsp.commands.bench", "throughput of the bit-exact models against fxpmath and apytypes"),
    "simulate": ("fxdsp.sim.cli", "simulate a chamber run and write a canonical log"),
    "calibrate": ("fxdsp.sim.calibrate_cli", "fit the compensation of a paper from a chamber log"),
    "repro": ("fxdsp.repro.cli", "reproduce the papers' experiments on the simulated devices, bit-exact"),
    "diagnose": ("fxdsp.diagnose.cli", "explain where a measured log disagrees with the simulation"),
    "budget": ("fxdsp.budget.cli", "float vs fixed error budget in physical units; word-length exploration"),
    "hdl-gen": ("fxdsp.hdl.gen_cli", "write the Verilog parameter headers and ROM files from the config"),
    "hw-report": ("fxdsp.hdl.report_cli", "synthesise every block for the iCE40UP5K and tabulate the cost"),
}


def _load(name: str):
    module_name, _ = COMMANDS[name]
    return importlib.import_module(module_name)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="fxdsp", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module_name, help_text) in COMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:  # a sub-command still being built is simply not offered
            if exc.name and module_name.startswith(exc.name):
                continue
            raise
        sp = sub.add_parser(name, help=help_text, description=help_text)
        module.configure(sp)
        sp.set_defaults(_module=module)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)  # argparse itself exits 2 with one usage line on bad flags
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    try:
        return int(args._module.run(args) or 0)
    except (ValueError, TypeError, FileNotFoundError, IsADirectoryError, PermissionError,
            tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        message = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
        if isinstance(exc, (FileNotFoundError, IsADirectoryError, PermissionError)) and exc.filename:
            message = f"{exc.strerror}: {exc.filename}"
        print(f"fxdsp {args.command}: error: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
