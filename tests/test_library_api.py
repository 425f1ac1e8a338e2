"""The library API: ``import fxdsp`` is cheap and exposes build, load_config,
quantize/to_real and the blocks, each documented; real values and stored integers are never mixed
silently; an unknown input is named with the nearest port; the log format ships with the package."""

from __future__ import annotations

import ast
import builtins
import fnmatch
import inspect
import re
import subprocess
import sys
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import fxdsp
from conftest import SHARED, needs_shared

ROOT = Path(__file__).resolve().parents[1]


# ---- import fxdsp: cheap, lazy, documented ----------------------------------------------------------
def _loaded_after(code: str) -> list[str]:
    out = subprocess.run([sys.executable, "-c", code + "\nimport sys\n"
                          "print(sorted(m for m in sys.modules if m.startswith('fxdsp') or m == 'numba'))"],
                         capture_output=True, text=True, check=True, timeout=120).stdout
    return ast.literal_eval(out.strip().splitlines()[-1])


def test_import_fxdsp_loads_neither_numba_nor_the_blocks():
    loaded = _loaded_after("import fxdsp\nnames = dir(fxdsp), fxdsp.__all__, fxdsp.__version__")
    assert loaded == ["fxdsp"], loaded


def test_fxdsp_help_does_not_import_numba():
    code = "from fxdsp.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass"
    loaded = _loaded_after(code)
    assert "numba" not in loaded and "fxdsp.chains" not in loaded, loaded


def test_a_name_loads_on_first_use():
    loaded = _loaded_after("import fxdsp\nfxdsp.Format")
    assert "fxdsp.fixed.format" in loaded and "fxdsp.chains" not in loaded, loaded


EXPECTED = {"build", "load_config", "Config", "quantize", "to_real", "Format", "Rules", "OverflowLog", "Design",
            "Block", "Result", "Rtd", "Lag", "Piecewise", "SfDivide", "Demod", "BiasSubtract", "Iir", "Freq2Temp",
            "Chain"}


def test_every_public_name_is_listed_resolves_and_has_its_own_docstring():
    assert set(fxdsp.__all__) == EXPECTED
    assert EXPECTED <= set(dir(fxdsp))
    from fxdsp.blocks.base import Block

    for name in fxdsp.__all__:
        obj = getattr(fxdsp, name)
        doc = obj.__dict__.get("__doc__") if inspect.isclass(obj) else obj.__doc__
        assert doc and doc.strip() and not doc.startswith(f"{name}("), f"fxdsp.{name} has no docstring"
        if name in ("Rtd", "Lag", "Piecewise", "SfDivide", "Demod", "BiasSubtract", "Iir", "Freq2Temp",
                    "Chain"):
            assert issubclass(obj, Block), name
    from fxdsp.chains import build
    from fxdsp.config import load_config

    assert fxdsp.build is build and fxdsp.load_config is load_config
    with pytest.raises(AttributeError, match="no attribute 'bulid'"):
        fxdsp.bulid  # noqa: B018


# ---- quantize / to_real ---------------------------------------------------------------------------
TIES = np.array([2.5, -2.5, 3.5, -3.5, 2.25, -2.75])      # in LSBs of s16.3 (the values are TIES / 8)
EXPECTED_ROUNDING = {
    "floor": [2, -3, 3, -4, 2, -3],
    "half_up": [3, -2, 4, -3, 2, -3],
    "half_even": [2, -2, 4, -4, 2, -3],
    "toward_zero": [2, -2, 3, -3, 2, -2],
}


@pytest.mark.parametrize("rounding", sorted(EXPECTED_ROUNDING))
def test_quantize_rounds_by_the_config_s_names_without_round(monkeypatch, rounding):
    def refused(*a, **k):
        raise AssertionError("quantize must not use round / np.round")

    fxdsp.quantize(TIES, "s16.0", rounding)   # numba and the kernels loaded (numba's import reads np.rint)
    monkeypatch.setattr(builtins, "round", refused)
    monkeypatch.setattr(np, "round", refused)
    monkeypatch.setattr(np, "around", refused)
    monkeypatch.setattr(np, "rint", refused)
    fmt = fxdsp.Format.parse("s16.3")
    q = fxdsp.quantize(TIES / 8, fmt, rounding)
    assert q.dtype == np.int64 and q.tolist() == EXPECTED_ROUNDING[rounding]
    assert fxdsp.quantize(TIES / 8, "s16.3", rounding).tolist() == EXPECTED_ROUNDING[rounding]  # format by name


def test_quantize_and_to_real_keep_the_shape_and_round_trip():
    x = np.array([[0.25, -0.5], [1.0 - 2**-15, -1.0]])
    q = fxdsp.quantize(x, "s16.15")
    assert q.shape == (2, 2) and q.tolist() == [[8192, -16384], [32767, -32768]]
    assert np.array_equal(fxdsp.to_real(q, "s16.15"), x)
    s = fxdsp.quantize(0.3, "s8.6")
    assert np.ndim(s) == 0 and int(s) == 19 and float(fxdsp.to_real(s, "s8.6")) == 19 / 64


def test_quantize_overflow_raises_by_default_and_is_counted_when_fitted():
    with pytest.raises(ValueError, match=r"3\.0 \(index 1\) is outside s8\.6 .*overflow='saturate' or 'wrap'"):
        fxdsp.quantize([0.5, 3.0], "s8.6")
    # 1.99 rounds down into range with floor, but up out of it with half_up: the rounded value decides
    assert fxdsp.quantize(1.99, "s8.6", "floor") == 127
    with pytest.raises(ValueError, match="after half_up rounding"):
        fxdsp.quantize(1.995, "s8.6")
    log = fxdsp.OverflowLog()
    assert fxdsp.quantize([0.5, 3.0, -9.0], "s8.6", overflow="saturate", log=log).tolist() == [32, 127, -128]
    assert log == {"quantize": 2}
    wrapped = fxdsp.quantize([3.0], "s8.6", overflow="wrap", log=log, where="adc")
    assert wrapped.tolist() == [192 - 256] and log["adc"] == 1
    with pytest.raises(ValueError, match="NaN"):
        fxdsp.quantize([np.nan], "s8.6")


@pytest.mark.parametrize("kwargs,needle", [
    ({"rounding": "half-up"}, "rounding: unknown rounding 'half-up'; expected one of floor, half_up, half_even, "
                              "toward_zero"),
    ({"overflow": "clip"}, "overflow: unknown overflow 'clip'; expected one of wrap, saturate"),
])
def test_quantize_names_a_bad_mode_with_the_config_s_names(kwargs, needle):
    with pytest.raises(ValueError) as info:
        fxdsp.quantize(0.5, "s8.6", **kwargs)
    assert str(info.value) == needle


def test_to_real_refuses_floats_and_codes_of_another_format():
    with pytest.raises(TypeError, match="stored integers expected, got float64"):
        fxdsp.to_real(np.array([3.0]), "s8.6")
    with pytest.raises(ValueError, match="300 is outside s8.6"):
        fxdsp.to_real([300], "s8.6")


# ---- blocks: stored integers in run, real values in reference, inputs named -----------------------
@pytest.fixture(scope="module")
def built():
    return fxdsp.build()


def test_run_refuses_floats(built):
    iir = built.blocks["iir"]
    with pytest.raises(TypeError) as info:
        iir.run(x=np.full(8, 0.25))
    msg = str(info.value)
    assert msg.startswith("iir.x: stored integers expected") and "quantize" in msg and "run_real" in msg
    with pytest.raises(TypeError, match="stored integers expected"):
        iir.run(x=np.array([1.0, 2.0]))   # integral values in a float array are still not stored integers


def test_reference_refuses_stored_integers_in_every_block_and_chain(built):
    rng = np.random.default_rng(1)
    for name, block in built.all.items():
        stim = block.stimulus(rng, 16)
        with pytest.raises(TypeError, match=r"reference takes real values.*run_float.*to_real") as info:
            block.reference(**stim)
        assert str(info.value).startswith(f"{block.name}.reference: "), name
        # the same codes through run_float: their real values
        real = {k: fxdsp.to_real(v, block.inputs[k]) for k, v in stim.items()}
        ours, theirs = block.run_float(**stim), block.reference(**real)
        assert all(np.array_equal(ours[k], theirs[k], equal_nan=True) for k in ours), name


def test_an_unknown_input_is_named_first_with_the_nearest_port(built):
    iir = built.blocks["iir"]
    codes = fxdsp.quantize(np.full(4, 0.25), iir.inputs["x"])
    for call in (lambda: iir.run(u=codes), lambda: iir.reference(u=np.full(4, 0.25)),
                 lambda: iir.run_float(u=codes), lambda: iir.run_real(u=np.full(4, 0.25))):
        with pytest.raises(ValueError) as info:
            call()
        assert str(info.value) == "iir: unknown input 'u' (did you mean 'x'?); inputs: x"
    chain = built.chains["chain_paper002"]
    with pytest.raises(ValueError, match=r"^chain_paper002: unknown input 'rtd_cod' \(did you mean 'rtd_code'\?\)"):
        chain.run(vsa=np.zeros(4, np.int64), rtd_cod=np.zeros(4, np.int64))
    with pytest.raises(ValueError, match=r"^chain_paper002: missing input 'rtd_code'; inputs: vsa, rtd_code$"):
        chain.run(vsa=np.zeros(4, np.int64))


def test_run_real_is_run_on_the_quantised_inputs(built):
    sub = built.blocks["bias_subtract"]
    x, bias = np.linspace(-0.5, 0.5, 33), np.full(33, 0.01)
    q = {"x": fxdsp.quantize(x, sub.inputs["x"]), "bias": fxdsp.quantize(bias, sub.inputs["bias"])}
    assert np.array_equal(sub.run_real(x=x, bias=bias).outputs["y"], sub.run(**q).outputs["y"])
    with pytest.raises(ValueError, match=r"^bias_subtract\.x: 5\.0 is outside"):
        sub.run_real(x=[5.0], bias=[0.0])
    res = sub.run_real(x=[5.0], bias=[0.0], overflow="saturate")
    assert res.overflows["bias_subtract.x"] == 1


def test_the_readme_library_example_runs():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("\n## Library\n", 1)[1].split("\n## ", 1)[0]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    assert 5 <= len([ln for ln in code.splitlines() if ln.strip()]) <= 8
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)
    y, ref = scope["y"], scope["ref"]
    assert y.dtype == float and ref.dtype == float and np.max(np.abs(y - ref)) < 1e-5


# ---- the log format: in the repository and in the package ---------------------------------------
def _log_doc() -> str:
    return resources.files("fxdsp").joinpath("docs", "log-format.md").read_text(encoding="utf-8")


def test_the_log_format_ships_in_the_package_and_docs_links_it():
    doc = _log_doc()
    assert (ROOT / "docs" / "log-format.md").resolve() == (ROOT / "fxdsp" / "docs" / "log-format.md").resolve()
    package_data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["fxdsp"]
    assert any(fnmatch.fnmatch("docs/log-format.md", pattern) for pattern in package_data), package_data
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "](docs/log-format.md)" in readme
    assert "shared/spec/measured-data.md" in doc   # the contract it restates stays the reference


def test_the_log_format_names_every_column_the_reader_knows():
    from fxdsp.logfile import OPTIONAL, REQUIRED, SENTINEL_ABS

    doc = _log_doc()
    rows = dict(re.findall(r"^\| `(\w+)` \|[^|]*\| (required|optional) \|", doc, re.M))
    assert rows == {**{c: "required" for c in REQUIRED}, **{c: "optional" for c in OPTIONAL}}
    assert "exit status 2" in doc and "--map" in doc and "--time-format" in doc and "#" in doc
    assert f"{SENTINEL_ABS:.0e}".replace("+", "") in doc   # 1e30: the sentinel threshold the reader uses


@needs_shared("spec/measured-data.md")
def test_the_log_format_agrees_with_the_contract_in_its_own_words():
    contract = (SHARED / "spec" / "measured-data.md").read_text(encoding="utf-8")
    section = contract.split("## 1.", 1)[1].split("\n## ", 1)[0]
    columns = dict(re.findall(r"^\| `(\w+)` \| [^|]* \| (yes|no) \|", section, re.M))
    doc = _log_doc()
    rows = dict(re.findall(r"^\| `(\w+)` \|[^|]*\| (required|optional) \|", doc, re.M))
    assert columns and {c: ("required" if r == "yes" else "optional") for c, r in columns.items()} == rows
    # not a copy: no sentence-long stretch of the contract's text appears in the page
    words = re.findall(r"\S+", section)
    spans = {" ".join(words[i:i + 8]) for i in range(len(words) - 8)}
    flat = " ".join(re.findall(r"\S+", doc))
    assert not [s for s in spans if s in flat]


def test_quantize_names_a_value_beyond_the_widest_format_and_keeps_its_ends():
    """The range check holds at the 63-bit ends too (values no narrower format can hold)."""
    lo = -(2 ** 62)
    assert int(fxdsp.quantize(float(lo), "s63.0")) == lo                     # the format's own end
    assert int(fxdsp.quantize(2.0 ** 62 - 1024, "s63.0")) == 2 ** 62 - 1024   # the largest float inside
    for v in (2.0 ** 62, -(2.0 ** 62) - 1024, 1e30):
        with pytest.raises(ValueError, match="outside s63.0"):
            fxdsp.quantize(v, "s63.0")
    with pytest.raises(ValueError, match="index 1"):
        fxdsp.quantize([0.5, 4.0, 9.0], "s4.1")                               # 4.0 is 8 LSBs: s4 ends at 7
