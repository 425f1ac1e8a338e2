"""Bad configs: the library raises ValueError/TypeError naming the field; the CLI prints one line
and exits 2, with no traceback."""

from __future__ import annotations

import copy
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import config_leaves, default_data, edited_data, run_cli, without
from fxdsp.errors import InputError
from fxdsp.chains import build
from fxdsp.config import Config


def _edited(edits: dict, delete: tuple = ()) -> dict:
    data = copy.deepcopy(default_data())
    for dotted, value in edits.items():
        node = data
        *parents, key = dotted.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        node[key] = value
    for dotted in delete:
        node = data
        *parents, key = dotted.split(".")
        for p in parents:
            node = node[p]
        del node[key]
    return data


BAD = [
    ({"rtd.lut_index_bitz": 5}, "rtd.lut_index_bitz", "lut_index_bits"),          # typo, with a suggestion
    ({"rtdd": {"law": "linear"}}, "rtdd", None),                                  # unknown table
    ({"rtd.rounding": "half-up"}, "rtd.rounding", "half_up"),                     # unknown rounding name
    ({"iir.overflow": "clip"}, "iir.overflow", "saturate"),
    ({"rtd.temp_format": "s0.0"}, "rtd.temp_format", "wl"),                       # zero word length
    ({"rtd.temp_format": "s-4.2"}, "rtd.temp_format", None),                     # negative word length
    ({"rtd.temp_format": "q16.8"}, "rtd.temp_format", "s16.15"),                 # not a format
    ({"rtd.temp_format": "s64.8"}, "rtd.temp_format", "63"),                     # too wide for int64
    ({"piecewise.sf.breakpoints_c": [20.0, 0.0, 40.0]}, "piecewise.sf.breakpoints_c", "increasing"),
    ({"piecewise.sf.breakpoints_c": [0.0, 20.0, 20.0]}, "piecewise.sf.breakpoints_c", "duplicates"),
    ({"piecewise.sf.breakpoints_c": [0.0, 1e-6, 40.0]}, "piecewise.sf.breakpoints_c", "same code"),
    ({"piecewise.sf.coefficients": [[9.0, 1e-4]] * 4}, "piecewise.sf.coefficients", "coef_format"),
    ({"piecewise.sf.coefficients": [[1.0, 1e-4]] * 3}, "piecewise.sf.coefficients", "segments"),
    ({"piecewise.k0.coefficients": [[1.0, 1.0, 1.0, 1.0, 1.0]]}, "piecewise.k0.coefficients", "order"),
    ({"iir.num_format": "s8.12"}, "iir.num_format", None),                       # coefficients do not fit
    ({"iir.cutoff_hz": 60000.0}, "iir.cutoff_hz", "fs/2"),
    ({"iir.order": "two"}, "iir.order", "integer"),
    ({"sf_divide.guard_bits": 40}, "sf_divide.guard_bits", "32"),
    ({"demod.f_hz": -5.0}, "demod.f_hz", None),
    ({"stimulus.samples": 3}, "stimulus.samples", "16"),
    # a wired format stated anyway must agree with the output it is wired to: the error names both
    ({"iir.data_format": "s20.18"}, "iir.data_format", "bias_subtract.out_format"),
    ({"demod.lpf.data_format": "s22.20"}, "demod.lpf.data_format", "demod.data_format"),
]


@pytest.mark.parametrize("edits,field,hint", BAD, ids=[b[1] + ":" + str(i) for i, b in enumerate(BAD)])
def test_library_names_the_field(edits, field, hint):
    with pytest.raises((ValueError, TypeError)) as info:
        build(Config(_edited(edits), source="<test>"))
    message = str(info.value)
    assert message.startswith(field) or f" {field}" in message or field in message.split(":")[0], message
    if hint:
        assert hint in message, message


def test_missing_required_key_is_named():
    with pytest.raises(InputError, match=r"^iir\.cutoff_hz: missing"):
        build(Config(_edited({}, delete=("iir.cutoff_hz",)), source="<test>"))


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "fxdsp.cli", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=120)


DEFAULT_TEXT = (Path(__file__).parents[1] / "fxdsp" / "configs" / "default.toml").read_text()


@pytest.mark.parametrize("text,needle", [
    (DEFAULT_TEXT.replace("[rtd]\n", "[rtd]\nbogus = 1\n", 1), "rtd.bogus: unknown key"),
    ("this is not toml = = 3\n", "not valid TOML"),
    (DEFAULT_TEXT.replace('law = "linear"', 'law = "linear"\nrounding_mode = "floor"', 1), "did you mean 'rounding'"),
    (DEFAULT_TEXT.replace('lut_index_bits = ', 'lut_index_bits = 5.5 #', 1), "rtd.lut_index_bits"),
])
def test_cli_bad_config_one_line_exit_2(tmp_path: Path, text, needle):
    assert text != DEFAULT_TEXT
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    r = _cli("vectors", "--config", str(cfg), "--out", str(tmp_path / "v"))
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "v").exists(), "nothing is written on bad input"


def test_cli_missing_config_file(tmp_path: Path):
    r = _cli("vectors", "--config", str(tmp_path / "nope.toml"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "nope.toml" in r.stderr


def test_cli_unknown_flag_exits_2():
    r = _cli("vectors", "--frobnicate")
    assert r.returncode == 2 and "Traceback" not in r.stderr


# ---- fuzz: one leaf of the shipped config replaced by a value of another kind ----------------------
_LEAVES = sorted(config_leaves(default_data()))
_VALUES = [-1, 0, 10**9, -1e300, 1.5, float("nan"), float("inf"), "", "s99.98", "u1.0", "s24", "floor", [],
           [1, 2], [[1.0]], True, {"x": 1}]


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(leaf=st.sampled_from(_LEAVES), value=st.sampled_from(_VALUES))
def test_fuzz_one_bad_leaf_is_one_line_or_a_working_config(leaf, value):
    from fxdsp.config import dumps

    data = edited_data(**{".".join(leaf): value})
    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "c.toml"
        try:
            cfg.write_text(dumps(data))
        except (ValueError, TypeError):
            return   # not expressible in TOML (e.g. nan in some writers): nothing to feed the CLI
        rc, err = run_cli(["hdl-gen", "--config", str(cfg), "--out", str(Path(tmp) / "gen")])
        assert rc in (0, 2), err
        if rc == 2:
            assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
            assert str(cfg) in err, err   # the file is named with the field
            assert not (Path(tmp) / "gen").exists()


# ---- every key of the shipped config misspelt: the error names the typo and suggests the key ------
def _misspelt(key: str, siblings) -> str:
    """``key`` with its first two different neighbouring characters swapped (``in_format`` ->
    ``ni_format``, ``sf`` -> ``fs``), never another key of the same table."""
    for i in range(len(key) - 1):
        if key[i] != key[i + 1]:
            typo = key[:i] + key[i + 1] + key[i] + key[i + 2:]
            if typo not in siblings:
                return typo
    raise AssertionError(f"no misspelling of {key!r}")


def _node(data, path):
    for p in path:
        data = data[p]
    return data


def _every_key(node, prefix=()):
    """(table path, key) of every key of every table, sub-table names included, at every depth."""
    for k, v in node.items():
        yield prefix, k
        if isinstance(v, dict):
            yield from _every_key(v, prefix + (k,))


# a chain's table name is the user's own name for it (a renamed chain is another valid chain): its
# keys are checked, its name is not a key to misspell
_KEYS = [(p, k) for p, k in _every_key(default_data()) if p != ("chain",)]


def test_the_generated_cases_cover_every_table_and_every_leaf():
    tables = {p for p, _ in _KEYS} - {()}
    assert {p + (k,) for p, k in _KEYS} >= set(config_leaves(default_data()))
    assert len(tables) >= 15 and ("demod", "lpf") in tables and ("piecewise", "k0") in tables


@pytest.mark.parametrize("path,key", _KEYS, ids=[".".join(p + (k,)) for p, k in _KEYS])
def test_every_misspelt_key_is_named_with_the_right_one(path, key):
    data = copy.deepcopy(default_data())
    table = data
    for p in path:
        table = table[p]
    typo = _misspelt(key, table)
    # same position in the table (a rename keeps the order of the keys after it)
    items = list(table.items())
    table.clear()
    table.update((typo if k == key else k, v) for k, v in items)
    field = ".".join(path + (typo,))
    with pytest.raises(InputError) as info:
        build(Config(data, source="<test>"), chains=False)
    assert str(info.value) == f"{field}: unknown key (did you mean {key!r}?)"


@pytest.mark.parametrize("edit,message", [
    # a required key misspelt, which used to read "sf_divide.in_format: missing"
    (("sf_divide", "in_format", "in_fromat"), "sf_divide.in_fromat: unknown key (did you mean 'in_format'?)"),
    # a misspelt nested table (checked with its parent: a typo inside [demod.lpf] was ignored before)
    (("demod", "lpf", "lpff"), "demod.lpff: unknown key (did you mean 'lpf'?)"),
    # a table whose name is misspelt
    ((None, "stimulus", "stimulsu"), "stimulsu: unknown key (did you mean 'stimulus'?)"),
    # a chain table's key misspelt (else it would read as a wire left open)
    (("chain.paper002", "wires", "wrese"), "chain.paper002.wrese: unknown key (did you mean 'wires'?)"),
    # a name far from every key: the missing key is named, and the stray one beside it
    (("iir", "num_format", "numerator"), "iir.num_format: missing (the table has the unknown key 'numerator')"),
])
def test_a_renamed_key_is_reported_as_a_typo_not_as_missing(edit, message):
    table_name, key, typo = edit
    data = copy.deepcopy(default_data())
    table = data
    for part in (table_name or "").split(".") if table_name else ():
        table = table[part]
    table[typo] = table.pop(key)
    with pytest.raises(InputError) as info:
        build(Config(data, source="<test>"))
    assert str(info.value) == message


def test_a_valid_sibling_is_never_taken_for_a_typo():
    # r2_ohm and out_format are close to the missing r1_ohm / in_format, but they are valid keys
    for table, key in (("rtd", "r1_ohm"), ("sf_divide", "in_format"), ("iir", "num_format")):
        data = copy.deepcopy(default_data())
        del data[table][key]
        if table == "rtd":   # r1_ohm has a default: make a required key missing beside a near valid one
            data[table]["temp_fromat"] = data[table].pop("temp_format")
            with pytest.raises(InputError, match=r"^rtd\.temp_fromat: unknown key \(did you mean 'temp_format'\?\)$"):
                build(Config(data, source="<test>"))
            continue
        with pytest.raises(InputError, match=rf"^{table}\.{key}: missing( \(input '\w+' of {table} is wired by no "
                                             rf"chain, so its format must be stated\))?$"):
            build(Config(data, source="<test>"))


def test_a_stray_key_in_a_nested_table_is_an_error():
    with pytest.raises(InputError, match=r"^demod\.lpf\.bogus: unknown key"):
        build(Config(_edited({"demod.lpf.bogus": 1}), source="<test>"))


# ---- every table of the shipped config deleted (every chain too): built, or InputError --------------
# (each leaf deleted: test_datapath.test_no_code_default_shadows_the_shipped_config)
_TABLES = [(p, k) for p, k in _every_key(default_data()) if isinstance(_node(default_data(), p + (k,)), dict)]


@pytest.mark.parametrize("path,key", _TABLES, ids=[".".join(p + (k,)) for p, k in _TABLES])
def test_every_deleted_table_is_bad_input_or_a_working_config(path, key):
    """A table the user left out is their config's fault: InputError naming it (one line, exit 2), not
    a ValueError the command line takes for a bug. A config without some chain (a block then wired
    by none) once failed so, with exit 70."""
    try:
        build(Config(without(*path, key), source="<test>"))
    except InputError as exc:
        assert str(exc).strip() and "\n" not in str(exc).strip()
