"""The package's one TOML writer (fxdsp.config.dumps / dumps_value): what it writes, tomllib reads
back to the same data, whatever the nesting, the floats or the characters in strings and keys."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fxdsp.config import default_config_text, dumps, dumps_value

EXAMPLE = {
    "title": 'quote " backslash \\ newline \n tab \t cr \r bell \x07 del \x7f nul \x00 e-acute \u00e9 \U0001f600',
    "flag": True, "off": False, "int": -(2**63), "big": 2**63 - 1,
    "floats": [0.1 + 0.2, math.pi, 1e-300, 5e-324, 1.7976931348623157e308, -0.0, 1e16, 123456789.123456789],
    "matrix": [[1.0, 2.5], [-3.0, 4e-12], []],
    "mixed": [1, "two", [3.0, [4]], {"inline": "table", "n": 1}],
    "a": {"x": 1, "b": {"c": {"deep": [[1, 2], [3]], "s": "ok"}, "empty": {}}},
    "only_tables": {"t1": {"k": 1}, "t2": {"k": 2}},
    "odd keys": {"a.b": 1, "": 2, "with space": 3, "ünï": 4, 'q"uote': 5, "bare-key_09": 6},
}


def test_round_trip_of_nested_tables_arrays_floats_and_escapes():
    text = dumps(EXAMPLE, header="written by a test\n\nsecond line")
    back = tomllib.loads(text)
    assert back == EXAMPLE
    # every float bit for bit (== alone would let -0.0 pass as 0.0)
    for got, want in zip(back["floats"], EXAMPLE["floats"]):
        assert math.copysign(1.0, got) == math.copysign(1.0, want) and got == want
    assert text.startswith("# written by a test\n#\n# second line\n")


def test_the_default_config_round_trips():
    data = tomllib.loads(default_config_text())
    assert tomllib.loads(dumps(data)) == data


def test_numpy_values_are_written_as_plain_toml():
    data = {"t": {"i": np.int64(-7), "f": np.float64(0.1), "b": np.bool_(True), "a": np.array([[1, 2], [3, 4]])}}
    assert tomllib.loads(dumps(data)) == {"t": {"i": -7, "f": 0.1, "b": True, "a": [[1, 2], [3, 4]]}}


@pytest.mark.parametrize("value, error, where", [
    (math.nan, ValueError, "t.v"), (math.inf, ValueError, "t.v"), (None, TypeError, "t.v"),
    ([1.0, -math.inf], ValueError, r"t.v\[1\]"), ({"k": object()}, TypeError, "t.v.k")])
def test_unwritable_values_are_errors_naming_the_key(value, error, where):
    with pytest.raises(error, match=where):
        dumps({"t": {"v": value}})


def test_dumps_value_is_one_line():
    assert dumps_value([[1, 2], ["a\nb"]]) == '[[1, 2], ["a\\nb"]]'
    assert dumps_value(2.0) == "2.0" and dumps_value(1e-5) == "1e-05"


# any data TOML can hold, except datetimes (no config has one)
_scalars = (st.booleans() | st.integers(-(2**63), 2**63 - 1) | st.floats(allow_nan=False, allow_infinity=False)
            | st.text())
_values = st.recursive(_scalars, lambda inner: st.lists(inner, max_size=4), max_leaves=12)
_tables = st.recursive(st.dictionaries(st.text(max_size=8), _values, max_size=5),
                       lambda inner: st.dictionaries(st.text(max_size=8), inner | _values, max_size=4),
                       max_leaves=20)


@settings(max_examples=300, deadline=None)
@given(_tables)
def test_any_toml_data_round_trips(data):
    assert tomllib.loads(dumps(data)) == data
