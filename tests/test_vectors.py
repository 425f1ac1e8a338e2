"""Golden vectors: committed set matches the models, any one changed hex digit is caught, output is
deterministic, hex encoding round-trips, and the stimuli contain the corner cases."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from fxdsp.chains import build
from fxdsp.cli import main
from fxdsp.fixed import Format
from fxdsp.vectors import check, from_hex_lines, generate, load, to_hex_lines, write_or_check

ROOT = Path(__file__).parents[1]
VECTORS = ROOT / "vectors"


@pytest.fixture(scope="module")
def files():
    return generate(build())


def test_committed_vectors_match_the_models(files):
    assert check(files, VECTORS) == []


def test_check_command_exit_codes(tmp_path: Path, capsys):
    copy = tmp_path / "v"
    shutil.copytree(VECTORS, copy)
    assert main(["vectors", "--out", str(copy), "--check"]) == 0
    # change one hex digit of one expected output
    target = copy / "chain_paper002" / "rate.hex"
    lines = target.read_text().splitlines(keepends=True)
    k = len(lines) // 2
    digit = lines[k][0]
    lines[k] = ("0" if digit != "0" else "1") + lines[k][1:]
    target.write_text("".join(lines))
    assert main(["vectors", "--out", str(copy), "--check"]) == 1
    err = capsys.readouterr().err
    assert "chain_paper002/rate.hex" in err and f"line {k + 1}" in err


def test_check_compares_contents_not_the_configs_name(tmp_path: Path, capsys):
    """The committed sets (vectors, generated headers), checked against the built-in config written
    elsewhere and reformatted (parsed and dumped again: no comments, another layout), match: the
    manifest's config name is a name, not content. One value changed and the check fails, naming the
    first file it changes."""
    import tomllib

    from fxdsp.config import default_config_text, dumps

    data = tomllib.loads(default_config_text())
    moved = tmp_path / "elsewhere" / "mine.toml"
    moved.parent.mkdir()
    moved.write_text(dumps(data), encoding="utf-8")
    assert moved.read_text() != default_config_text()
    assert main(["vectors", "--config", str(moved), "--out", str(VECTORS), "--check"]) == 0
    assert main(["hdl-gen", "--config", str(moved), "--out", str(ROOT / "hdl" / "gen"), "--check"]) == 0
    data["bias_subtract"]["rounding"] = "floor" if data["bias_subtract"].get("rounding") != "floor" else "half_up"
    moved.write_text(dumps(data), encoding="utf-8")
    capsys.readouterr()
    assert main(["vectors", "--config", str(moved), "--out", str(VECTORS), "--check"]) == 1
    assert "differs: bias_subtract/y.hex" in capsys.readouterr().err


def test_check_reports_missing_and_unexpected_files(tmp_path: Path, files):
    copy = tmp_path / "v"
    shutil.copytree(VECTORS, copy)
    (copy / "rtd" / "temp.hex").unlink()
    (copy / "rtd" / "stray.hex").write_text("00\n")
    problems = check(files, copy)
    assert "missing: rtd/temp.hex" in problems and "unexpected: rtd/stray.hex" in problems


def test_write_or_check_returns_the_differences_and_prints_nothing(tmp_path: Path, files, capsys):
    out = tmp_path / "v"
    assert write_or_check(files, out, check_only=True) == [f"missing: {rel}" for rel in sorted(files)]
    assert not out.exists()  # a check never writes
    assert write_or_check(files, out, check_only=False) == []
    assert write_or_check(files, out, check_only=True) == []
    (out / "rtd" / "stray.hex").write_text("00\n")
    assert write_or_check(files, out, check_only=True) == ["unexpected: rtd/stray.hex"]
    assert capsys.readouterr() == ("", "")  # reporting is the command's job


def test_deterministic(files):
    again = generate(build())
    assert again == files


def test_manifest_hashes_and_formats(files):
    manifest = json.loads(files["manifest.json"])
    assert manifest["seed"] == build().seed
    for name, entry in manifest["blocks"].items():
        n = entry["samples"]
        for kind in ("inputs", "outputs"):
            for port, spec in entry[kind].items():
                text = files[spec["file"]]
                assert hashlib.sha256(text.encode()).hexdigest() == spec["sha256"]
                assert len(text.splitlines()) == n, (name, port)
                digits = {len(line) for line in text.splitlines()}
                assert digits == {-(-spec["wl"] // 4)}


@pytest.mark.parametrize("fmt", ["s16.15", "u12.0", "s63.10", "u62.3", "s5.9", "s2.1"])
def test_hex_round_trip(fmt):
    f = Format.parse(fmt)
    rng = np.random.default_rng(1)
    q = np.concatenate([[f.min_int, f.max_int, 0], rng.integers(f.min_int, f.max_int, 200, endpoint=True)])
    text = to_hex_lines(q, f)
    assert np.array_equal(from_hex_lines(text, f), q)
    # independent encoding: two's complement by Python ints
    assert text.splitlines()[0] == format(int(q[0]) % (1 << f.wl), f"0{-(-f.wl // 4)}x")


def test_stimuli_cover_the_corners():
    d = build()
    ins, _, entry = load(VECTORS, "rtd")
    fmt = d.blocks["rtd"].adc_format
    assert {fmt.min_int, fmt.max_int, 0} <= set(ins["code"].tolist())
    ins, _, _ = load(VECTORS, "sf_divide")
    assert 0 in set(ins["sf"].tolist()) and 1 in set(ins["sf"].tolist())
    f = d.blocks["sf_divide"].in_format
    assert {f.min_int, f.max_int} <= set(ins["x"].tolist())
    ins, _, entry = load(VECTORS, "piecewise_sf")
    assert set(d.blocks["piecewise_sf"].breakpoints.tolist()) <= set(ins["temp"].tolist())
    for name in ("iir", "bias_subtract", "sf_divide"):
        _, _, entry = load(VECTORS, name)
        assert sum(entry["overflows"].values()) > 0, f"{name}: the vectors must exercise saturation"


def test_a_chains_corner_stream_carries_its_members_corners():
    """A chain input takes the corner cases of the member input it drives (the rounding ties of the
    RTD, the divider's full-scale numerators), so a user's chain is tested on its blocks' corners."""
    from fxdsp.hdl.stimuli import _block_corners, corners

    d = build()
    for name, chain in d.chains.items():
        stim = corners(d, name, np.random.default_rng(3))
        for inp, dsts in chain.netlist.inputs.items():
            own = _block_corners(d, dsts[0].instance.replace(".", "_")).get(dsts[0].port)
            if own is not None and len(own):
                assert set(own.tolist()) <= set(stim[inp].tolist()), f"{name}.{inp}: a member corner missing"
