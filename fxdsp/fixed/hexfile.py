"""The ``$readmemh`` word format, written and read in one place.

One word per line, two's complement in ceil(wl/4) lower-case hex digits: exactly what ``$readmemh``
loads into a ``reg [wl-1:0] mem [0:n-1]``. The golden vectors (:mod:`fxdsp.vectors`) and the ROM
files of the RTL (:mod:`fxdsp.hdl.params`) are both this format, so they share this encoder: a
change of padding or case would otherwise make the two disagree about the same words.
"""

from __future__ import annotations

import numpy as np
from fxdsp.errors import InputError


def hex_words(values, wl: int) -> str:
    """Integers -> ``$readmemh`` text, one ``wl``-bit two's-complement word per line.

    A value must fit ``wl`` bits read either as signed or as unsigned (-2**(wl-1) .. 2**wl - 1);
    anything else is a ValueError rather than a silently truncated word. Python ints of any size
    are taken, so words wider than 64 bits are written exactly."""
    if not isinstance(wl, (int, np.integer)) or wl < 1:
        raise InputError(f"wl: word length must be an integer >= 1, got {wl!r}")
    digits = -(-int(wl) // 4)
    mask = (1 << wl) - 1
    lo, hi = -(1 << (wl - 1)), 1 << wl
    lines = []
    # an array's words as Python ints at once (int() of each numpy scalar was most of the time)
    for v in values.tolist() if isinstance(values, np.ndarray) else values:
        v = int(v)
        if not lo <= v < hi:
            raise InputError(f"values: word {v} does not fit {wl} bits")
        lines.append(f"{v & mask:0{digits}x}\n")
    return "".join(lines)


def read_hex_words(text: str, wl: int, signed: bool) -> np.ndarray:
    """``$readmemh`` text -> int64 words (sign-extended when ``signed``); ``//`` comments and blank
    lines are skipped like ``$readmemh`` does. A word wider than ``wl`` bits is a ValueError."""
    vals = []
    for ln, line in enumerate(text.splitlines(), 1):
        line = line.split("//")[0].strip()
        if not line:
            continue
        try:
            w = int(line, 16)
        except ValueError:
            raise InputError(f"line {ln}: {line!r} is not a hex word") from None
        if w >> wl:
            raise InputError(f"line {ln}: {line!r} does not fit {wl} bits")
        vals.append(word_value(w, wl, signed))
    return np.array(vals, dtype=np.int64)


def word_value(word: int, wl: int, signed: bool) -> int:
    """A ``wl``-bit word (bits above it ignored) as the integer it stores: sign-extended when ``signed``."""
    w = int(word) & ((1 << wl) - 1)
    return w - (1 << wl) if signed and w >> (wl - 1) else w
