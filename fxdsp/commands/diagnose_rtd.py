"""`fxdsp diagnose-rtd TABLE [--range LO HI]`: a platinum RTD's resistance table read with the linear
law R = R0 (1 + beta T) and with Callendar-Van Dusen (fitted and IEC 60751): the temperature error
of each, and the cause the diagnosis names for the linear readout (see :mod:`fxdsp.diagnose.rtd`)."""

from __future__ import annotations

from fxdsp.commands.options import FINITE
from fxdsp.outputs import IN
from fxdsp.errors import InputError

PATHS = {"table": IN}


def configure(parser) -> None:
    parser.add_argument("table", metavar="TABLE",
                        help="CSV with a header row and columns temperature_c, resistance_ohm, e.g. "
                             "../shared/data/pt100_table/pt100_table.csv")
    parser.add_argument("--range", nargs=2, type=FINITE, default=None, metavar=("LO", "HI"),
                        help="keep only the rows with LO <= temperature_c <= HI")


def run(args) -> int:
    from fxdsp.diagnose.rtd import load_table, rtd_study

    t, r = load_table(args.table)
    if args.range:
        keep = (t >= args.range[0]) & (t <= args.range[1])
        t, r = t[keep], r[keep]
        if t.size < 4:
            raise InputError(f"--range: {t.size} rows of {args.table} in {args.range[0]:g}..{args.range[1]:g} C, "
                             "need at least 4")
    study = rtd_study(t, r)
    for key in ("linear", "cvd_fit", "cvd_iec60751"):
        e = study[key]["error"]
        coefs = {k: v for k, v in study[key].items() if k != "error"}
        print(f"{key:13s} max |error| {e.max_abs_c:9.4f} C  rms {e.rms_c:9.4f} C  {coefs}")
    print("diagnosis of the linear readout:", study["diagnosis"])
    return 0
