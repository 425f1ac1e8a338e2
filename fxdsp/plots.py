"""One way to write a report's figure: log axes labelled in plain text, laid out tight, saved at 110
dpi and closed. matplotlib's default log-axis labels are mathtext (10 with a raised exponent); their
layout was most of a report's time (13 s of the 20 s of ``fxdsp budget --report`` for the default
config's 33 figures), and 1e-03 reads as well to an engineer."""

from __future__ import annotations

from pathlib import Path

DPI = 110


# beyond this many decades the log scale's minor locator puts its ticks on the decades alone, where
# the majors already are, and matplotlib drops them as it draws; computing and laying them out was a
# third of a budget report's figure time (15.1 -> 10.9 s for its 33 figures, every pixel the same)
MINOR_DECADES = 10


def plain_log_labels(fig) -> None:
    """Every log axis of ``fig`` labelled 1e-03, 10, 1e+05 (matplotlib's LogFormatter) instead of
    mathtext, majors and minors as the log scale's defaults choose them (no minors computed on an
    axis of more than MINOR_DECADES decades, which would show none)."""
    import math

    from matplotlib.ticker import LogFormatter, NullLocator

    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() == "log":
                axis.set_major_formatter(LogFormatter())
                lo, hi = sorted(abs(v) for v in axis.get_view_interval())
                if lo > 0 and math.log10(hi / lo) > MINOR_DECADES:
                    axis.set_minor_locator(NullLocator())
                else:
                    axis.set_minor_formatter(LogFormatter(labelOnlyBase=False))


def pyplot():
    """matplotlib.pyplot on the Agg backend (files only: no display is needed or opened), imported
    when a figure is drawn rather than when a report module is: matplotlib was 0.6 s of every
    `fxdsp budget` start, its --help and its refusals included."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path | str, **savefig_kw) -> None:
    """``fig`` with plain log labels, tight layout, written to ``path`` and closed."""
    plt = pyplot()

    plain_log_labels(fig)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI, **savefig_kw)
    plt.close(fig)
