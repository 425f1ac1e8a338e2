"""The package as a user gets it: a wheel built from this source, installed into a fresh venv outside
the checkout, its commands run from another folder. Every command must find what it needs in the
installed package (the RTL, the cocotb driver, the hardware report, the log format), never in a
checkout: the test asserts the package imported is the wheel's.

The fresh venv takes the wheel alone (``pip install --no-deps --no-index``); its third-party
dependencies are this test environment's, reached through a ``.pth`` line (a plain path: the
editable install's finder there is not activated), so the test needs no network and no minutes of
downloads. The simulators and synthesis tools are the machine's; each step that needs one is
skipped with the reason when it is absent, the others still run.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
from user_configs import adc18_text

ROOT = Path(__file__).resolve().parents[1]


def _run(cmd, cwd, env, timeout=600) -> subprocess.CompletedProcess:
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{' '.join(map(str, cmd))}: exit {proc.returncode}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


def _seed_numba_cache(checkout: Path, installed: Path) -> None:
    """The checkout's compiled numba kernels (what this run's other tests have compiled so far)
    beside the installed package's identical sources, each source given the checkout copy's
    modification time: numba keys a cached kernel on its source file's mtime and size, so the
    installed package's commands load them instead of compiling every kernel again (~20 s of this
    file). Anything not compiled yet, or any source that differs, is compiled as a user's first run
    would; the commands' results cannot depend on it."""
    for cache in checkout.rglob("__pycache__"):
        kernels = [f for f in cache.iterdir() if f.suffix in (".nbi", ".nbc")]
        folder = installed / cache.parent.relative_to(checkout)
        if not kernels or not folder.is_dir():
            continue
        (folder / "__pycache__").mkdir(exist_ok=True)
        for f in kernels:
            shutil.copyfile(f, folder / "__pycache__" / f.name)
        for source in folder.glob("*.py"):
            mine = cache.parent / source.name
            if mine.is_file() and mine.read_bytes() == source.read_bytes():
                st = mine.stat()
                os.utime(source, ns=(st.st_atime_ns, st.st_mtime_ns))


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(venv bin folder, environment, a work folder outside the checkout) with the wheel installed."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"   # the package's sources alone (links resolved), so the build writes nothing here
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copyfile(ROOT / name, src / name)
    shutil.copytree(ROOT / "fxdsp", src / "fxdsp", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    dist = tmp / "dist"
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", str(dist), str(src)],
         cwd=tmp, env=dict(os.environ))
    wheel = next(dist.glob("fxdsp-*.whl"))
    venv = tmp / "venv"
    # no pip of its own (ensurepip was ~6 s of the fixture): this environment's pip installs into it
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], cwd=tmp, env=dict(os.environ))
    py = venv / "bin" / "python"
    purelib = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                  capture_output=True, text=True, check=True).stdout.strip())
    (purelib / "_fxdsp_test_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    _run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", "--no-index", str(wheel)],
         cwd=tmp, env=dict(os.environ))
    _seed_numba_cache(ROOT / "fxdsp", Path(purelib) / "fxdsp")
    work = tmp / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = os.pathsep.join([str(venv / "bin"), env.get("PATH", "")])
    env["XDG_CACHE_HOME"] = str(tmp / "cache")
    where = _run([str(py), "-c", "import fxdsp, sys; print(fxdsp.__file__)"], cwd=work, env=env).stdout.strip()
    assert Path(where).is_relative_to(venv) and not Path(where).is_relative_to(ROOT), where
    return venv / "bin", env, work, wheel


def fxdsp(installed, *args, timeout=600) -> subprocess.CompletedProcess:
    bin_dir, env, work, _ = installed
    return _run([str(bin_dir / "fxdsp"), *map(str, args)], cwd=work, env=env, timeout=timeout)


def test_the_wheel_carries_the_rtl_the_report_and_the_log_format(installed):
    import zipfile

    names = zipfile.ZipFile(installed[3]).namelist()
    rtl = sorted(n for n in names if n.startswith("fxdsp/hdl/rtl/") and n.endswith(".v"))
    assert [Path(n).name for n in rtl] == sorted(p.name for p in (ROOT / "fxdsp" / "hdl" / "rtl").glob("*.v"))
    assert "fxdsp/hdl/cocotb_stream.py" in names and "fxdsp/hdl/HW_REPORT.json" in names
    assert "fxdsp/docs/log-format.md" in names
    with zipfile.ZipFile(installed[3]) as z:
        assert json.loads(z.read("fxdsp/hdl/HW_REPORT.json"))["rows"]       # the report's content, not a link
    assert not any(n.startswith("tests/") for n in names)


def test_demo_vectors_and_hdl_gen_from_another_folder(installed):
    work = installed[2]
    fxdsp(installed, "demo")
    assert (work / "vectors" / "manifest.json").is_file()
    # the installed package's demo writes the committed default set, byte for byte
    assert (work / "vectors" / "manifest.json").read_bytes() == (ROOT / "vectors" / "manifest.json").read_bytes()
    fxdsp(installed, "hdl-gen", "--out", "gen")
    assert sorted(p.name for p in (work / "gen").glob("*.vh")) == sorted(p.name for p in (ROOT / "hdl" / "gen").glob("*.vh"))


def test_rtl_of_a_users_config_with_a_faulty_rtl_from_the_installed_package(installed):
    """From the installed package: a user's config (the sense ADC at 18 bits) and
    the packaged RTL with a fault injected (a copy, --rtl): exit 1 naming the DUT and its first
    mismatch, with a waveform. (The same regression passing: the extend test below, whose RTL run is
    bit-exact; the user's config passing in process, with both variants: tests/hdl/test_rtl_command.py.)"""
    if shutil.which("iverilog") is None:
        pytest.skip("iverilog (Icarus Verilog) is not installed")
    bin_dir, env, work, _ = installed
    (work / "adc18.toml").write_text(adc18_text())
    # the RTL the installed package carries, with the subtraction's sign flipped
    rtl = work / "faulty_rtl"
    packaged = Path(_run([str(bin_dir / "python"), "-c", "from fxdsp.hdl import RTL_DIR; print(RTL_DIR)"],
                         cwd=work, env=env).stdout.strip())
    assert packaged.is_relative_to(bin_dir.parent)
    shutil.copytree(packaged, rtl)
    src = rtl / "bias_subtract.v"
    assert src.read_text().count("- (be <<< B_ALIGN)") == 1
    src.write_text(src.read_text().replace("- (be <<< B_ALIGN)", "+ (be <<< B_ALIGN)"))
    proc = subprocess.run([str(bin_dir / "fxdsp"), "rtl", "--config", "adc18.toml", "--only", "bias_subtract",
                           "--rtl", str(rtl), "--long", "150", "--out", "faulty"], cwd=work, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    report = json.loads((work / "faulty" / "report.json").read_text())
    row = report["duts"][0]
    m = row["first_mismatch"]
    assert f"MISMATCH bias_subtract: {m['stream']} stream, sample {m['sample']}, port {m['port']}" in proc.stdout
    assert row["waves"] and (work / "faulty" / row["waves"][0]["file"]).stat().st_size > 1000
    # what it simulated is the user's design: its vectors are the 18-bit config's
    manifest = json.loads((work / "faulty" / "vectors" / "manifest.json").read_text())
    assert manifest["blocks"]["sf_divide"]["inputs"]["x"]["format"] == "s18.17"


def test_extend_of_a_thermometer_log_from_the_installed_package(installed):
    work = installed[2]
    # a thermometer-chain log (a chamber ramp, no rate table, no frequency): a lag to compensate
    fxdsp(installed, "simulate", "--scenario", "ramp", "--effect", "thermal_lag.tau_s=1500", "--columns",
          "ref_temp_c", "--seed", "1", "--out", "log.csv")
    # with the RTL regression where Icarus is installed (its generated thermometer-chain top among the
    # DUTs), else without (--no-rtl, which test_extend.py runs in process as well)
    rtl = shutil.which("iverilog") is not None
    proc = fxdsp(installed, "extend", "log.csv", *([] if rtl else ["--no-rtl"]), "--out", "ext")
    report = json.loads((work / "ext" / "report.json").read_text())
    assert "lag" in [r["stage"] for r in report["remedies"]]
    if not rtl:
        assert report["regression"] is None
        pytest.skip("iverilog (Icarus Verilog) is not installed: extend without RTL only")
    assert report["regression"]["passed"] and "chain_thermometer" in report["regression"]["blocks"], proc.stdout
    assert "RTL bit-exact" in proc.stdout


def test_hw_report_of_one_small_block(installed):
    missing = [t for t in ("yosys", "nextpnr-ice40") if shutil.which(t) is None]
    if missing:
        pytest.skip(f"{' and '.join(missing)} not installed: no synthesis here")
    fxdsp(installed, "hw-report", "--only", "bias_subtract", "--no-xc7", "--out", "HW.md", timeout=900)
    rows = {r["name"]: r for r in json.loads((installed[2] / "HW.json").read_text())["rows"]}
    assert rows["bias_subtract"]["LUT"] and rows["bias_subtract"]["fmax"]
