"""The one ``$readmemh`` encoder (fxdsp.fixed.hexfile): exact words, range errors, round trip.
(The committed vectors and hdl/gen files staying byte-identical is checked by test_vectors.py and
tests/hdl.)"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxdsp.fixed.hexfile import hex_words, read_hex_words


def test_words_are_twos_complement_in_ceil_wl_over_4_lower_case_digits():
    assert hex_words([0, 1, -1, -2048, 2047, 4095], 12) == "000\n001\nfff\n800\n7ff\nfff\n"
    assert hex_words(np.array([-1, 10], dtype=np.int64), 5) == "1f\n0a\n"
    assert hex_words([-(2**63), 2**63 - 1], 64) == "8000000000000000\n7fffffffffffffff\n"
    assert hex_words([2**69, -1], 70) == "200000000000000000\n3fffffffffffffffff\n"  # wider than int64
    assert hex_words([], 8) == ""


@pytest.mark.parametrize("value, wl", [(-2049, 12), (4096, 12), (-2, 1), (2**64, 64)])
def test_a_word_that_does_not_fit_is_an_error(value, wl):
    with pytest.raises(ValueError, match=f"{value} does not fit {wl} bits"):
        hex_words([value], wl)


def test_bad_word_length_is_an_error_naming_it():
    with pytest.raises(ValueError, match="wl"):
        hex_words([0], 0)


@given(st.integers(1, 80).flatmap(lambda wl: st.tuples(
    st.just(wl), st.lists(st.integers(-(1 << (wl - 1)), (1 << (wl - 1)) - 1), max_size=20))))
def test_signed_round_trip(case):
    wl, values = case
    text = hex_words(values, wl)
    assert all(len(line) == -(-wl // 4) for line in text.splitlines())
    if wl <= 63:  # read back into int64
        assert read_hex_words(text, wl, signed=True).tolist() == values


def test_reader_skips_comments_and_rejects_wide_words():
    assert read_hex_words("// header\n0f\n\nff // -1\n", 8, signed=True).tolist() == [15, -1]
    assert read_hex_words("ff\n", 8, signed=False).tolist() == [255]
    with pytest.raises(ValueError, match="line 2"):
        read_hex_words("00\n100\n", 8, signed=False)
    with pytest.raises(ValueError, match="not a hex word"):
        read_hex_words("0g\n", 8, signed=False)
