"""Random-parameter RTL regressions as a sweep: one shard is one randomly drawn parameter set, built
and simulated block by block in its own directory.

Why: the cocotb regressions of ``tests/hdl`` check three hand-picked parameter sets; the RTL must
match the model bit for bit on *every* config the generator accepts. A shard draws (from its task
seed) a rounding mode and an overflow mode for every table of the config, the order of the two
low-passes, and small word-length changes (-2..+2 bits) on a random subset of the word-length
search's knobs (the widths the optimiser may move), redrawing until the design builds and the RTL
generator accepts it. Each block (and both chain tops) of the shard is then streamed through its
RTL under Icarus through the package's harness (:mod:`fxdsp.hdl.harness`: the generic cocotb
driver, gapped valid), against the bit-exact model's outputs and overflow count.

Every shard builds in ``<build root>/shard_NNNN/<block>``: a fresh temporary folder on the worker
(removed afterwards), or ``--build-dir`` to keep them. The RTL is the package's (or ``--rtl``); on a
cluster every worker needs the same package. A shard's result records every setting it drew that
differs from the base config (``changes``, listed per shard in the report) and, per block,
pass/fail, cycles and the driver's first errors: no path, time or host.
"""

from __future__ import annotations

import copy
import json
import shutil
import tempfile
from functools import partial
from pathlib import Path

import numpy as np

from fxdsp.errors import InputError
from fxdsp.hdl.harness import RTL_DIR  # noqa: F401  (the default --rtl of `sweep rtl`)
ROUNDINGS = ("floor", "half_up", "half_even", "toward_zero")
OVERFLOWS = ("wrap", "saturate")
ORDERS = (2, 4)
KNOB_PROBABILITY = 0.3
KNOB_DELTA = (-2, 2)
MAX_DRAWS = 200
# a divider's quotient bits per cycle in a shard (a few per cycle: the Icarus runs stay short), as a
# block's UNROLL or as a chain top's DIV_UNROLL (every chain with a divider member)
DIV_UNROLL = {"sf_divide": ("UNROLL", 3), "chain": ("DIV_UNROLL", 14)}
GAP = 0.25


def unroll_params(design, name: str) -> dict | None:
    """The divider setting of a shard run of ``name`` (:data:`DIV_UNROLL`): a divider's UNROLL, a
    chain top's DIV_UNROLL when one of its members is a divider; None for anything else."""
    from fxdsp.hdl.chain_top import has_divider

    inst = design.instances[name]
    key = "chain" if inst.members and has_divider(design, name) else inst.module
    return dict([DIV_UNROLL[key]]) if key in DIV_UNROLL else None


def check_tools(rtl_dir: Path, sim: str = "icarus") -> None:
    """InputError when this machine cannot run a shard (it is the one that checks, before work)."""
    from fxdsp.hdl.simulators import require_simulator

    require_simulator(sim)
    if not sorted(Path(rtl_dir).glob("*.v")):
        raise InputError(f"--rtl: no Verilog sources (*.v) in {rtl_dir}")


def instance_names(config_data: dict) -> list[str]:
    """Every block and chain of the config: what a shard runs by default (``--blocks``)."""
    from fxdsp.chains import build
    from fxdsp.config import Config

    return list(build(Config(copy.deepcopy(config_data), source="<sweep rtl>")).hardware)


def settings(config_data: dict, shards: int, blocks, rtl_dir: Path) -> dict:
    if shards < 1:
        raise InputError(f"--shards: need at least 1 shard, got {shards}")
    names = instance_names(config_data)
    blocks = list(names if blocks is None else blocks)
    unknown = [b for b in blocks if b not in names]
    if unknown or not blocks:
        raise InputError(f"--blocks: unknown block {unknown[0] if unknown else ''!r}; expected some of "
                         f"{', '.join(names)}")
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
    """(config data, design, changes from ``base`` as
    {dotted path: value}, draws needed) of a random parameter set that builds and that the RTL
    generator accepts."""
    from fxdsp.budget.optimise import _field_defaults, knob_value, knobs_of, set_knob
    from fxdsp.chains import build
    from fxdsp.config import Config
    from fxdsp.hdl import params as hp

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
        for chain in (f"chain_{n}" for n in base.get("chain", {})):   # every chain's word-length knobs
            defaults = _field_defaults(base, chain)
            for knob in knobs_of(base, chain):
                if rng.random() < KNOB_PROBABILITY:
                    delta = int(rng.integers(KNOB_DELTA[0], KNOB_DELTA[1] + 1))
                    value = max(1, knob_value(base, knob) + delta)
                    if knob.kind == "int":
                        value = min(max(value, knob.lo), knob.hi)
                    set_knob(data, knob, value, defaults)
        try:
            design = build(Config(data, source="<sweep rtl>"))
            hp.generate(design)     # the RTL generator must accept the draw too
        except (ValueError, TypeError, AssertionError, OverflowError, ZeroDivisionError):
            continue
        before = dict(_leaves(base))
        changes = {k: v for k, v in _leaves(data) if before.get(k) != v}
        return data, design, changes, attempt
    raise InputError(f"rtl: no parameter set that builds in {MAX_DRAWS} draws (seed {seed})")


# ----------------------------------------------------------------------------------------------
# One block through the RTL
# ----------------------------------------------------------------------------------------------
def run_block(design, name: str, build: Path, rtl_dir: Path, seed: int) -> dict:
    """Stream the block's random stimulus (:func:`fxdsp.hdl.stimuli.random_stimulus`, gapped valid)
    through its RTL on Icarus in ``build`` (the harness writes the design's headers there); pass/fail,
    samples, cycles, first errors (a DUT that does not build is a failure, named)."""
    from fxdsp.hdl import harness as hh
    from fxdsp.hdl.stimuli import random_stimulus

    extra = unroll_params(design, name)
    stim = random_stimulus(design, name, seed)
    seg = hh.segment(design, name, stim)
    samples = len(next(iter(seg["outputs"].values())))
    build = Path(build)
    build.mkdir(parents=True, exist_ok=True)
    try:
        got = hh.run_cocotb(design, name, [seg], build, gap=GAP, seed=int(seed % 2**31),
                            extra_params=extra, sim="icarus", rtl=Path(rtl_dir))
    except hh.BuildFailed as e:
        return {"ok": False, "samples": samples, "cycles": None,
                "errors": ["build failed: " + _strip(e.reason, rtl_dir, build)[:300]]}
    errors = [_strip(e, rtl_dir, build) for e in got["errors"][:3]]
    return {"ok": not got["errors"], "samples": samples, "cycles": got["cycles"], "errors": errors}


def _strip(line: str, rtl_dir, build: Path) -> str:
    """``line`` without the folder names of this run (a shard's record names no path)."""
    for folder in (str(Path(rtl_dir).resolve()), str(Path(rtl_dir)), str(build)):
        line = line.replace(folder + "/", "").replace(folder, "")
    return line.strip()


def _task(settings: dict, rtl_dir: str, build_root: str | None, params: dict, seed: int) -> dict:
    """One shard: draw its parameter set, run every block of ``settings["blocks"]``."""
    data, design, changes, draws = draw(settings["config"], seed)
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
            blocks[name] = run_block(design, name, d, Path(rtl_dir), block_seed)
    finally:
        if build_root is None:
            shutil.rmtree(root, ignore_errors=True)
    return {"passed": all(v["ok"] for v in blocks.values()), "draws": draws, "changes": changes, "blocks": blocks}


def summarise(settings: dict, records: list[dict]) -> dict:
    from fxdsp.sweep.engine import failed_records

    good = [r for r in records if "result" in r]
    return {"shards": settings["shards"], "blocks": settings["blocks"],
            "passed": sum(r["result"]["passed"] for r in good),
            "failed_shards": [{"index": r["index"], "shard": r["params"]["shard"], "changes": r["result"]["changes"],
                               "blocks": {k: v["errors"] for k, v in r["result"]["blocks"].items() if not v["ok"]}}
                              for r in good if not r["result"]["passed"]],
            "failed": failed_records(records),
            # what each shard verified: every setting it drew that differs from the config given
            "shard_settings": [{"shard": r["params"]["shard"], "passed": r["result"]["passed"],
                                "changes": r["result"]["changes"]} for r in good]}


def format_summary(s: dict) -> str:
    lines = [f"RTL vs model on {s['shards']} random parameter sets x {len(s['blocks'])} blocks: {s['passed']} shards "
             f"pass, {len(s['failed_shards'])} fail, {len(s['failed'])} did not run"]
    for f in s["failed_shards"]:
        for block, errors in f["blocks"].items():
            lines.append(f"  shard {f['shard']} {block}: {errors[0] if errors else 'failed'}")
    for f in s["failed"]:
        lines.append(f"  task {f['index']} {f['params']}: {f['error']}")
    return "\n".join(lines)


def settings_markdown(s: dict) -> str:
    """Every setting each shard randomised (it verified that design, not the config given), as Markdown."""
    lines = ["## Settings drawn per shard", "",
             "Each shard verifies the config given with these settings changed (rounding and overflow of "
             "every table, the low-pass orders, word lengths of a random subset of the optimiser's knobs).", ""]
    for sh in s.get("shard_settings", []):
        lines.append(f"### Shard {sh['shard']} ({'pass' if sh['passed'] else 'FAIL'}): "
                     f"{len(sh['changes'])} settings changed")
        lines.append("")
        lines += [f"- `{k}` = `{v}`" for k, v in sorted(sh["changes"].items())] or ["- none"]
        lines.append("")
    return "\n".join(lines)
