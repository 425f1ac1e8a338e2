"""`fxdsp diagnose-hidden [--per-cause N] [--causes A,B] [--snr LO HI] [--outside KIND]`: simulated
logs with one randomly drawn hidden cause each (and an effect outside the contract's list), diagnosed;
prints the confusion matrix and how often the report says structure remains (see
:mod:`fxdsp.diagnose.hidden` for how the cases are drawn)."""

from __future__ import annotations

from fxdsp.commands.options import FINITE, SEED, count


def configure(parser) -> None:
    from fxdsp.diagnose.hidden import ALL_CAUSES, OUTSIDE, SNR_RANGE

    parser.add_argument("--per-cause", type=count(), default=20, metavar="N", help="cases per cause (default 20)")
    parser.add_argument("--first-seed", type=SEED, default=1000, metavar="S", help="seed of the first case")
    parser.add_argument("--causes", default=",".join(ALL_CAUSES), metavar="A,B",
                        help="comma-separated causes to draw (default: all)")
    parser.add_argument("--snr", type=FINITE, nargs=2, default=SNR_RANGE, metavar=("LO", "HI"),
                        help="effect size range in noise units (default %(default)s)")
    parser.add_argument("--outside", choices=tuple(OUTSIDE),
                        help="add this effect outside the contract's list to every case")


def run(args) -> int:
    from fxdsp.diagnose.hidden import confusion, format_confusion

    causes = tuple(c for c in args.causes.split(",") if c)
    print(format_confusion(confusion(args.per_cause, args.first_seed, causes, snr_range=tuple(args.snr),
                                     outside=args.outside)))
    return 0
