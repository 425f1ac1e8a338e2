"""Random-parameter RTL regressions as a sweep: one shard is one randomly drawn parameter set, built
and simulated block by block in its own directory.

Why: the cocotb regressions of ``tests/hdl`` check three hand-picked parameter sets; the RTL must
match the model bit for bit on *every* config the generator accepts. A shard draws (from its task
seed) a rounding mode and an overflow mode for every table of the config, the order of the two
low-passes, and small word-length changes (-2..+2 bits) on a random subset of the word-length
search's knobs (the widths the optimiser may move), redrawing until the design builds and the RTL
generator accepts it. Each block (and both chain tops) of the shard is then streamed through its
RTL under Icarus with the generic cocotb driver of ``tests/hdl/cocotb_stream.py`` (gapped valid),
against the bit-exact model's outputs and overflow count.

Every shard builds in ``<build root>/shard_NNNN/<block>``: a fresh temporary folder on the worker
(removed afterwards), or ``--build-dir`` to keep them. The RTL and the driver are read from the
checkout this package runs from (``hdl/rtl``, ``tests/hdl``), as ``fxdsp hw-report`` reads ``hdl/``;
on a cluster every worker needs the same checkout. A shard's result records the drawn changes and,
per block, pass/fail, cycles and the driver's first errors: no path, time or host.
"""

from __future__ import annotations

import copy
import importlib.util
import json
import shutil
import sys
import tempfile
from functools import partial
from pathlib import Path

import numpy as np

CHECKOUT = Path(__file__).resolve().parents[2]
RTL_DIR = CHECKOUT / "hdl" / "rtl"
DRIVER_DIR = CHECKOUT / "tests" / "hdl"     # cocotb_stream.py
ROUNDINGS = ("floor", "half_up", "half_even", "toward_zero")
OVERFLOWS = ("wrap", "saturate")
ORDERS = (2, 4)
KNOB_PROBABILITY = 0.3
KNOB_DELTA = (-2, 2)
MAX_DRAWS = 200
BLOCKS = ("rtd", "iir", "demod", "piecewise_sf", "piecewise_bias", "piecewise_bias001", "piecewise_k0", "sf_divide",
          "bias_subtract", "bias_subtract001", "freq2temp", "lag", "chain_paper001", "chain_paper002")
MAX_SAMPLES = {"chain_paper002": 1200, "demod": 2500, "iir": 3000, "lag": 4000}
EXTRA = {"chain_paper002": {"DIV_UNROLL": 14}, "sf_divide": {"UNROLL": 3}}
GAP = 0.25


def check_tools(rtl_dir: Path) -> None:
    """ValueError when this machine cannot run a shard (it is the one that checks, before work)."""
    if shutil.which("iverilog") is None or shutil.which("vvp") is None:
        raise ValueError("rtl: iverilog (Icarus Verilog) is not installed: `make hdl-tools` or apt-get install iverilog")
    if importlib.util.find_spec("cocotb_tools") is None:
        raise ValueError("rtl: cocotb is not installed (pip install -e '.[test]')")
    if not sorted(Path(rtl_dir).glob("*.v")):
        raise ValueError(f"--rtl: no Verilog sources (*.v) in {rtl_dir}")
    if not (DRIVER_DIR / "cocotb_stream.py").exists():
        raise ValueError(f"rtl: the cocotb driver {DRIVER_DIR / 'cocotb_stream.py'} is missing (needs a checkout)")


def settings(config_data: dict, shards: int, blocks, rtl_dir: Path) -> dict:
    if shards < 1:
        raise ValueError(f"--shards: need at least 1 shard, got {shards}")
    blocks = list(blocks)
    unknown = [b for b in blocks if b not in BLOCKS]
    if unknown or not blocks:
        raise ValueError(f"--blocks: unknown block {unknown[0] if unknown else ''!r}; expected some of "
                         f"{', '.join(BLOCKS)}")
    sources = {p.name: p.read_text(encoding="utf-8") for p in sorted(Path(rtl_dir).glob("*.v"))}
    import hashlib

    rtl_hash = hashlib.sha256(json.dumps(sources, sort_keys=True).encode()).hexdigest()
    # the RTL's hash joins the settings: a journal of other sources is not resumed
    return {"config": copy.deepcopy(config_data), "shards": int(shards), "blocks": blocks, "rtl_sha256": rtl_hash}


def task_params(settings: dict) -> list[dict]:
    return [{"shard": i} for i in range(settings["shards"])]


def task_function(settings: dict, rtl_dir: Path, build_root: Path | None):
    return partial(_task, settings, str(rtl_dir), None if build_root is None else str(build_root))


# ----------------------------------------------------------------------------------------------
# Drawing a parameter set
# ----------------------------------------------------------------------------------------------
def _tables(node: dict, path: str = ""):
    """Every config table (dotted path, table) at any depth."""
    yield path, node
    for k, v in node.items():
        if isinstance(v, dict):
            yield from _tables(v, f"{path}.{k}" if path else k)


def _leaves(node, path=""):
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _leaves(v, f"{path}.{k}" if path else k)
    else:
        yield path, node


def draw(base: dict, seed: int):
    """(config data, design, its generated RTL files {relative path: text}, changes from ``base`` as
    {dotted path: value}, draws needed) of a random parameter set that builds and that the RTL
    generator accepts."""
    from ..budget.optimise import KNOBS, _field_defaults, knob_value, set_knob
    from ..chains import build
    from ..config import Config
    from ..hdl import params as hp

    rng = np.random.default_rng([seed, 0])
    for attempt in range(1, MAX_DRAWS + 1):
        data = copy.deepcopy(base)
        for _, table in _tables(data):
            if "rounding" in table:
                table["rounding"] = str(rng.choice(ROUNDINGS))
            if "overflow" in table:
                table["overflow"] = str(rng.choice(OVERFLOWS))
        for table in (data["iir"], data["demod"]["lpf"]):
            table["order"] = int(rng.choice(ORDERS))
        for chain in ("chain_paper002", "chain_paper001"):
            defaults = _field_defaults(base, chain)
            for knob in KNOBS[chain]:
                if rng.random() < KNOB_PROBABILITY:
                    delta = int(rng.integers(KNOB_DELTA[0], KNOB_DELTA[1] + 1))
                    value = max(1, knob_value(base, knob) + delta)
                    if knob.kind == "int":
                        value = min(max(value, knob.lo), knob.hi)
                    set_knob(data, knob, value, defaults)
        try:
            design = build(Config(data, source="<sweep rtl>"))
            files = hp.generate(design)
        except (ValueError, TypeError, AssertionError, OverflowError, ZeroDivisionError):
            continue
        before = dict(_leaves(base))
        changes = {k: v for k, v in _leaves(data) if before.get(k) != v}
        return data, design, files, changes, attempt
    raise ValueError(f"rtl: no parameter set that builds in {MAX_DRAWS} draws (seed {seed})")


# ----------------------------------------------------------------------------------------------
# One block through the RTL
# ----------------------------------------------------------------------------------------------
def random_stimulus(design, name: str, seed: int) -> dict:
    """The block's stimulus (corners first) cut to MAX_SAMPLES: the head and a random tail."""
    block = design.all[name]
    rng = np.random.default_rng(seed)
    stim = block.stimulus(rng, 400)
    n = len(next(iter(stim.values())))
    m = MAX_SAMPLES.get(name, n)
    if n > m:  # keep the head (corners) and a random tail
        keep = np.r_[np.arange(m // 2), np.sort(rng.choice(np.arange(m // 2, n), m - m // 2, replace=False))]
        stim = {k: v[keep] for k, v in stim.items()}
    return stim


def _unsigned(values, wl: int) -> list[int]:
    mask = (1 << wl) - 1
    return [int(v) & mask for v in np.asarray(values, dtype=np.int64)]


def run_block(design, files: dict, name: str, build: Path, rtl_dir: Path, seed: int) -> dict:
    """Stream the block's stimulus through its RTL in ``build`` (``files``: the design's generated
    RTL files, as :func:`draw` returns them); pass/fail, cycles, first errors."""
    from cocotb_tools.runner import get_runner

    from ..hdl import params as hp

    block = design.all[name]
    inst = design.instances[name]
    stim = random_stimulus(design, name, seed)
    res = block.run(**stim)
    seg = {"inputs": {p: _unsigned(stim[p], block.inputs[p].wl) for p in block.inputs},
           "outputs": {p: _unsigned(res.outputs[p], block.outputs[p].wl) for p in block.outputs},
           "ovf_total": int(res.overflows.total)}
    build.mkdir(parents=True, exist_ok=True)
    for rel, text in files.items():
        (build / rel).write_text(text, encoding="ascii")
    # the paper 002 top raises the demod's amp flags; the model never computes amp there
    ignore = (1 << design.ovf_bit(name, "demod.amp")) if name == "chain_paper002" else 0
    spec = {"segments": [seg], "inputs": [p.name for p in inst.inputs], "outputs": [p.name for p in inst.outputs],
            "ready": inst.has_ready, "gap": GAP, "seed": int(seed % 2**31), "ovf_ignore": ignore,
            "summary": str(build / "summary.json")}
    (build / "spec.json").write_text(json.dumps(spec))
    params = dict(EXTRA.get(name, {}))
    if not inst.members:
        params = {**hp.iverilog_params(hp.instance(design, name)), **params}
    runner = get_runner("icarus")
    samples = len(seg["outputs"][spec["outputs"][0]])
    try:
        runner.build(sources=sorted(Path(rtl_dir).glob("*.v")), hdl_toplevel=inst.module, includes=[build],
                     build_dir=build, parameters=params, always=True, build_args=["-Wall"],
                     timescale=("1ns", "1ps"), log_file=build / "build.log")
    except (RuntimeError, SystemExit):
        return {"ok": False, "samples": samples, "cycles": None,
                "errors": ["build failed: " + _first_error(build / "build.log", rtl_dir, build)]}
    env = {"FXDSP_SPEC": str(build / "spec.json"), "COCOTB_REWRITE_ASSERTION_FILES": ""}
    # the runner hands this process' sys.path to the simulator's Python as its PYTHONPATH
    added = [p for p in (str(DRIVER_DIR), str(CHECKOUT)) if p not in sys.path]
    sys.path[:0] = added
    try:
        runner.test(test_module="cocotb_stream", hdl_toplevel=inst.module, build_dir=build, test_dir=build,
                    extra_env=env, log_file=build / "sim.log")
    except (RuntimeError, SystemExit):
        pass   # a failing stream (under pytest the runner exits): the driver's summary says why
    finally:
        for p in added:
            sys.path.remove(p)
    summary = build / "summary.json"
    if not summary.exists():
        return {"ok": False, "samples": samples, "cycles": None,
                "errors": ["the simulation ended without a summary: " + _first_error(build / "sim.log", rtl_dir,
                                                                                      build)]}
    got = json.loads(summary.read_text())
    return {"ok": not got["errors"], "samples": samples, "cycles": got["cycles"], "errors": got["errors"][:3]}


def _first_error(log: Path, rtl_dir, build: Path) -> str:
    """The first line of a tool's log that looks like an error, without folder names."""
    text = log.read_text(errors="replace") if log.exists() else ""
    lines = [line for line in text.splitlines() if "error" in line.lower()] or text.splitlines()[-1:] or ["no log"]
    line = lines[0]
    for folder in (str(Path(rtl_dir).resolve()), str(Path(rtl_dir)), str(build)):
        line = line.replace(folder + "/", "")
    return line.strip()[:300]


def _task(settings: dict, rtl_dir: str, build_root: str | None, params: dict, seed: int) -> dict:
    """One shard: draw its parameter set, run every block of ``settings["blocks"]``."""
    data, design, files, changes, draws = draw(settings["config"], seed)
    shard = f"shard_{params['shard']:04d}"
    if build_root is None:
        root = Path(tempfile.mkdtemp(prefix=f"fxdsp-rtl-{shard}-"))
    else:
        root = Path(build_root) / shard
    try:
        blocks = {}
        for b, name in enumerate(settings["blocks"]):
            d = root / name
            if d.exists():
                shutil.rmtree(d)
            block_seed = int(np.random.SeedSequence([seed, b + 1]).generate_state(1)[0])
            blocks[name] = run_block(design, files, name, d, Path(rtl_dir), block_seed)
    finally:
        if build_root is None:
            shutil.rmtree(root, ignore_errors=True)
    return {"passed": all(v["ok"] for v in blocks.values()), "draws": draws, "changes": changes, "blocks": blocks}


def summarise(settings: dict, records: list[dict]) -> dict:
    from .engine import failed_records

    good = [r for r in records if "result" in r]
    return {"shards": settings["shards"], "blocks": settings["blocks"],
            "passed": sum(r["result"]["passed"] for r in good),
            "failed_shards": [{"index": r["index"], "shard": r["params"]["shard"], "changes": r["result"]["changes"],
                               "blocks": {k: v["errors"] for k, v in r["result"]["blocks"].items() if not v["ok"]}}
                              for r in good if not r["result"]["passed"]],
            "failed": failed_records(records)}


def format_summary(s: dict) -> str:
    lines = [f"RTL vs model on {s['shards']} random parameter sets x {len(s['blocks'])} blocks: {s['passed']} shards "
             f"pass, {len(s['failed_shards'])} fail, {len(s['failed'])} did not run"]
    for f in s["failed_shards"]:
        for block, errors in f["blocks"].items():
            lines.append(f"  shard {f['shard']} {block}: {errors[0] if errors else 'failed'}")
    for f in s["failed"]:
        lines.append(f"  task {f['index']} {f['params']}: {f['error']}")
    return "\n".join(lines)
