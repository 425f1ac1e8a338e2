"""`fxdsp sweep KIND --out DIR [--workers N | --scheduler ADDR] [--retries R] [--fresh] ...`: the
sweeps that outgrow one machine, on Dask (see :mod:`fxdsp.sweep.engine`).

* ``montecarlo``: error budget of any chain's output (chain_paper002.rate by default) over seeds x
  chamber temperatures x drive frequencies, percentiles with confidence intervals, and a plot;
* ``wordlength``: ``budget --optimise``'s word-length search with its candidates evaluated in parallel;
* ``hidden``: ``diagnose-hidden``'s confusion matrix, one case per task;
* ``rtl``: random-parameter RTL regressions, one parameter set per shard, each in its own build folder.

``--workers N`` (default: one per CPU) starts a local Dask cluster of N processes that lives as long
as the command; ``--workers 0`` runs serially in this process; ``--scheduler ADDR`` uses a running
Dask cluster (its workers need this package, the same version). The results are
the same bytes in every case.

Outputs in DIR: ``results.jsonl`` (one line per task, in task order: index, seed, params and result
or error), ``summary.json``, ``report.md`` (and ``montecarlo.png``, ``optimised.toml``), staged and
moved into place together at the end (:mod:`fxdsp.outputs`). ``journal.jsonl`` is the one file
written while the sweep runs, a line per finished task: after an interrupt (or with failed tasks)
it stays, and the same command run again resumes from it, running only the missing or failed tasks;
it is removed when every task has succeeded. Exit status 0, 1 when a task failed (listed by its
parameters; the others' results are kept and written) or an RTL shard mismatched, 2 on bad input.
"""

from __future__ import annotations

import os
import sys
import time
from functools import partial
from pathlib import Path

from fxdsp.budget import DEFAULT_MARGIN
from fxdsp.commands.options import FINITE, NATURAL, SEED, count
from fxdsp.outputs import IN, IN_DIR, OUT_DIR

PATHS = {"--out": OUT_DIR, "--config": IN, "--rtl": IN_DIR, "--build-dir": OUT_DIR}


# a running cluster has its own workers: a worker count beside its address is refused (fxdsp.cli),
# for every kind of sweep
ONLY_WITH = {"--workers": ("not --scheduler",)}


def _common(p, config: bool = True, seed: bool = True) -> None:
    p.add_argument("--out", required=True, metavar="DIR", help="folder of the results (and of the journal)")
    p.add_argument("--workers", type=NATURAL, metavar="N",
                   help="local Dask worker processes (default: one per CPU; 0: serial, in this process)")
    p.add_argument("--scheduler", metavar="ADDR", help="address of a running Dask scheduler (tcp://host:8786)")
    p.add_argument("--retries", type=NATURAL, default=2, metavar="R",
                   help="re-runs of a task that raises (default 2); a dead worker's tasks are re-run anyway")
    p.add_argument("--fresh", action="store_true", help="discard the journal of an earlier run instead of resuming")
    if config:
        p.add_argument("--config", help="TOML config (default: the built-in one)")
    if seed:
        p.add_argument("--seed", type=SEED, metavar="S", help="sweep seed (default: the config's stimulus seed)")


def configure(parser) -> None:
    from fxdsp.diagnose.hidden import ALL_CAUSES, OUTSIDE, SNR_RANGE
    from fxdsp.sweep.montecarlo import CHAIN

    sub = parser.add_subparsers(dest="kind", metavar="KIND", required=True)
    mc = sub.add_parser("montecarlo", help="error budget over seeds x temperatures x drive frequencies",
                        description="a chain output's error over seeds x chamber temperatures (x drive "
                                    "frequencies, for a chain with a demodulator): percentiles with 95 %% "
                                    "confidence intervals, and a plot")
    _common(mc)
    mc.add_argument("--seeds", type=count(), default=1000, metavar="N", help="Monte-Carlo samples (default 1000)")
    mc.add_argument("--temps", type=count(), default=16, metavar="N", help="chamber temperatures (default 16)")
    mc.add_argument("--chain", default=CHAIN, help=f"a chain with a sensor (default: {CHAIN})")
    mc.add_argument("--port", help="the chain output to budget (default: its one output that is not a temperature)")
    mc.add_argument("--temp-range", type=FINITE, nargs=2, metavar=("LO", "HI"),
                    help="range of the temperatures, C (default: the chain's sensor's chamber range, -20 60 "
                         "for paper 002)")
    mc.add_argument("--freqs", type=count(), metavar="N",
                    help="drive frequencies evenly across the drive band, plus the demodulator's f_hz (default 2; "
                         "1: f_hz only; a chain without a demodulator has none)")
    mc.add_argument("--samples", type=count(), default=2048, metavar="M",
                    help="measured samples per point after the filters' settling (default 2048)")

    wl = sub.add_parser("wordlength", help="word-length search with its candidates in parallel",
                        description="fxdsp budget --optimise with the candidate evaluations spread over workers")
    _common(wl, seed=False)
    wl.add_argument("--target", required=True, help="error target, <value><unit> as for fxdsp budget")
    wl.add_argument("--chain", default="chain_paper002", help="chain of --target (default: chain_paper002)")
    wl.add_argument("--metric", default="rms", choices=("rms", "max"), help="error measure of --target")
    wl.add_argument("--cost", default="total_bits", choices=("total_bits", "register_bits"),
                    help="cost the search minimises (default total_bits)")
    wl.add_argument("--margin", type=FINITE, default=DEFAULT_MARGIN,
                    help=f"optimise to (1 - margin) x target (default {DEFAULT_MARGIN})")
    wl.add_argument("--max-mean", help="also keep |mean| of the --target output within this")
    wl.add_argument("--drive-band", action="store_true", help="meet the target across the drive band too")

    hd = sub.add_parser("hidden", help="confusion matrix of the diagnosis on simulated hidden-cause logs",
                        description="fxdsp diagnose-hidden with one task per case")
    _common(hd, config=False, seed=False)
    hd.add_argument("--per-cause", type=count(), default=20, metavar="N", help="cases per cause (default 20)")
    hd.add_argument("--first-seed", type=SEED, default=1000, metavar="S", help="seed of the first case")
    hd.add_argument("--causes", default=",".join(ALL_CAUSES), metavar="A,B", help="causes to draw (default: all)")
    hd.add_argument("--snr", type=FINITE, nargs=2, default=SNR_RANGE, metavar=("LO", "HI"),
                    help="effect size range in noise units (default %(default)s)")
    hd.add_argument("--outside", choices=tuple(OUTSIDE), help="add this effect outside the contract's list to every case")

    rt = sub.add_parser("rtl", help="random-parameter RTL regressions (cocotb on Icarus), one set per shard",
                        description="RTL vs model on random parameter sets, one per shard, each built in its "
                                    "own folder")
    _common(rt)
    rt.add_argument("--shards", type=count(), default=8, metavar="N", help="random parameter sets (default 8)")
    rt.add_argument("--blocks", metavar="A,B", help="blocks and chains to run per shard (default: all)")
    rt.add_argument("--rtl", metavar="DIR", help="Verilog sources (default: the RTL shipped in the package)")
    rt.add_argument("--build-dir", metavar="DIR", help="keep every shard's build here (default: temporary)")


def _progress():
    from tqdm import tqdm

    return partial(tqdm, disable=None, file=sys.stderr, mininterval=0.5)  # a bar on a terminal only


def run(args) -> int:
    from fxdsp.outputs import staged
    from fxdsp.sweep.engine import Executor, Sweep

    t0 = time.perf_counter()
    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    prepare = {"montecarlo": _prepare_montecarlo, "wordlength": _prepare_wordlength, "hidden": _prepare_hidden,
               "rtl": _prepare_rtl}[args.kind]
    job = prepare(args)   # every check of the input before anything is created or started
    out = Path(args.out)
    executor = Executor(workers, args.scheduler, args.retries)
    with staged() as stage:
        sweep = Sweep(args.kind, job["settings"], job["seed"], executor, out, args.fresh, _progress())
        try:
            if sweep.previous:
                print(f"resuming: {sweep.previous} finished tasks in {out / 'journal.jsonl'}")
            with executor:
                status = job["run"](sweep, stage, out)
        finally:
            sweep.close()
        failed = sweep.failures()
        if not failed:
            stage.remove(out / "journal.jsonl")
    where = f"scheduler {args.scheduler}" if args.scheduler else (f"{workers} local workers" if workers else "serial")
    print(f"\n{sweep.computed} tasks run, {sweep.resumed} from the journal, {len(failed)} failed; "
          f"{time.perf_counter() - t0:.1f} s ({where}); results in {out}")
    for rec in failed[:10]:
        from fxdsp.sweep.engine import failure_line

        print(f"fxdsp sweep {args.kind}: failed {failure_line(rec)}", file=sys.stderr)
    return 1 if failed else status


def _write(stage, out: Path, sweep, summary: dict, report: str) -> None:
    from fxdsp.outputs import json_text, plain

    stage.write_text(out / "results.jsonl", sweep.results_text())
    stage.write_text(out / "summary.json", json_text(plain(summary), "summary.json", indent=1, sort_keys=True))
    stage.write_text(out / "report.md", report)


# ----------------------------------------------------------------------------------------------
def _prepare_montecarlo(args) -> dict:
    from fxdsp.config import load_config
    from fxdsp.sweep import montecarlo as mc

    cfg = load_config(args.config)
    temps, freqs = mc.grid(cfg.data, args.temps, args.freqs, args.temp_range, args.chain)
    settings = mc.settings(cfg.data, args.seeds, temps, freqs, args.samples, args.chain, args.port)
    seed = args.seed if args.seed is not None else int(cfg.data["stimulus"]["seed"])

    def go(sweep, stage, out):
        records = sweep.map(mc.task_function(settings), mc.task_params(settings))
        s = mc.summarise(settings, records)
        text = mc.format_summary(s)
        print(text)
        summary = {"kind": "montecarlo", "config": cfg.name, "seed": seed, **s}
        report = (f"# Monte-Carlo error budget\n\nConfig `{cfg.name}`, sweep seed {seed}.\n\n```\n{text}\n```\n\n"
                  "![p50 and p99 vs temperature](montecarlo.png)\n")
        _write(stage, out, sweep, summary, report)
        mc.plot(s, stage.path(out / "montecarlo.png"))
        return 0

    return {"settings": settings, "seed": seed, "run": go}


def _prepare_wordlength(args) -> dict:
    from fxdsp.budget.floor import demod_f_hz, drive_frequencies
    from fxdsp.budget.optimise import check_search, config_header
    from fxdsp.budget.units import parse_target
    from fxdsp.chains import build
    from fxdsp.config import dumps, load_config
    from fxdsp.sweep import wordlength as wl

    cfg = load_config(args.config)
    design = build(cfg)
    check_search(args.chain, args.margin, chains=design.chains, cost_model=args.cost, drive_band=args.drive_band)
    noise = {}
    if "noise" in args.target or (args.max_mean and "noise" in args.max_mean):
        from fxdsp.budget.attribution import attribute

        noise = {p: attribute(design, args.chain, p).sensor_noise_rms for p in design.chains[args.chain].outputs}
    target = parse_target(args.target, design, args.chain, noise)
    max_mean = parse_target(args.max_mean, design, args.chain, noise, "--max-mean") if args.max_mean else None
    check_search(args.chain, target=target, max_mean=max_mean)
    freqs = tuple(drive_frequencies(demod_f_hz(cfg, design, args.chain))) if args.drive_band else ()
    settings = wl.settings(cfg.data, target, args.metric, args.margin, args.cost, max_mean, freqs)

    def go(sweep, stage, out):
        try:
            result = wl.search(sweep, cfg, target, args.metric, args.margin, args.cost, max_mean, freqs)
        except wl.TaskFailed:
            return 1   # the search cannot go on without it: the failed task is listed, the journal kept
        text = wl.format_summary(result)
        print(text)
        summary = {"kind": "wordlength", "config": cfg.name, **wl.summary(result, settings)}
        _write(stage, out, sweep, summary, f"# Word-length search\n\nConfig `{cfg.name}`.\n\n```\n{text}\n```\n")
        header = config_header(result, "fxdsp sweep wordlength", cfg.name, changes=False)
        stage.write_text(out / "optimised.toml", dumps(result.data, header))
        return 0

    return {"settings": settings, "seed": 0, "run": go}


def _prepare_hidden(args) -> dict:
    from fxdsp.sweep import hidden as hd

    settings = hd.settings(args.per_cause, args.first_seed, [c for c in args.causes.split(",") if c], args.snr,
                           args.outside)

    def go(sweep, stage, out):
        t = time.perf_counter()
        records = sweep.map(hd.task_function(settings), hd.task_params(settings))
        print(hd.format_report(settings, records, time.perf_counter() - t))
        summary = {"kind": "hidden", **hd.summarise(settings, records)}
        _write(stage, out, sweep, summary, "# Hidden-effect confusion matrix\n\n```\n"
               + hd.format_report(settings, records) + "\n```\n")
        return 0

    return {"settings": settings, "seed": settings["first_seed"], "run": go}


def _prepare_rtl(args) -> dict:
    from fxdsp.config import load_config
    from fxdsp.sweep import rtl

    cfg = load_config(args.config)
    rtl_dir = Path(args.rtl) if args.rtl else rtl.RTL_DIR
    rtl.check_tools(rtl_dir)
    blocks = [b for b in args.blocks.split(",") if b] if args.blocks else None   # None: every instance
    settings = rtl.settings(cfg.data, args.shards, blocks, rtl_dir)
    seed = args.seed if args.seed is not None else int(cfg.data["stimulus"]["seed"])
    build_root = Path(args.build_dir).resolve() if args.build_dir else None

    def go(sweep, stage, out):
        if build_root is not None:
            build_root.mkdir(exist_ok=True)
        records = sweep.map(rtl.task_function(settings, rtl_dir.resolve(), build_root), rtl.task_params(settings))
        s = rtl.summarise(settings, records)
        text = rtl.format_summary(s)
        print(text)
        _write(stage, out, sweep, {"kind": "rtl", "config": cfg.name, "seed": seed, **s},
               f"# Random-parameter RTL regressions\n\nConfig `{cfg.name}`, sweep seed {seed}.\n\n```\n{text}\n```\n\n"
               + rtl.settings_markdown(s))
        return 1 if s["failed_shards"] else 0

    return {"settings": settings, "seed": seed, "run": go}
