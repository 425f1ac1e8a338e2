"""One way to write a report's figure: log axes labelled in plain text, laid out tight, saved at 110
dpi and closed. matplotlib's default log-axis labels are mathtext (10 with a raised exponent); their
layout was most of a report's time (13 s of the 20 s of ``fxdsp budget --report`` for the default
config's 33 figures), and 1e-03 reads as well to an engineer."""

from __future__ import annotations

from pathlib import Path

DPI = 110


def plain_log_labels(fig) -> None:
    """Every log axis of ``fig`` labelled 1e-03, 10, 1e+05 (matplotlib's LogFormatter) instead of
    mathtext, majors and minors as the log scale's defaults choose them."""
    from matplotlib.ticker import LogFormatter

    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() == "log":
                axis.set_major_formatter(LogFormatter())
                axis.set_minor_formatter(LogFormatter(labelOnlyBase=False))


def save_figure(fig, path: Path | str, **savefig_kw) -> None:
    """``fig`` with plain log labels, tight layout, written to ``path`` and closed."""
    import matplotlib.pyplot as plt

    plain_log_labels(fig)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI, **savefig_kw)
    plt.close(fig)
