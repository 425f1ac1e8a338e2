"""fxdsp sweep: the same bytes serially and on a real Dask cluster (2 worker processes), a killed
worker's task re-run, a failing task reported by its parameters without losing the others, an
interrupted sweep resumed from its journal, and each sweep kind checked against an independent
computation (the serial implementations it parallelises, textbook order-statistic ranks, the
budget's quasi-static error)."""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import tomllib
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from fxdsp.cli import main
from fxdsp.config import load_config
from fxdsp.owned import RECORD
from fxdsp.sweep import montecarlo as mc
from fxdsp.sweep.engine import JOURNAL, Executor, Sweep, task_seed

MC_ARGS = ["--seeds", "5", "--temps", "2", "--freqs", "1", "--samples", "256"]
FILES = ("results.jsonl", "summary.json", "report.md")


@pytest.fixture(scope="module")
def cluster():
    """One real LocalCluster for the module: 2 worker processes of 1 thread each. Its connect timeout
    is 10 s, not Dask's 30: the killed-worker test fetches a result the killed worker held, and on a
    loaded machine that fetch can, it seems, retry connecting to the dead address for the whole
    timeout before the scheduler recomputes the key (that test took 30-34 s in one of 8 `make test`
    runs and in 1 of 3 runs beside two busy processes, against 2-7 s otherwise)."""
    import dask
    from distributed import LocalCluster

    with dask.config.set({"distributed.comm.timeouts.connect": "10s"}), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                         silence_logs=logging.ERROR) as lc:
        lc.wait_for_workers(2, timeout=120)
        yield lc.scheduler_address, lc


def digests(folder: Path, names=FILES) -> dict[str, str]:
    return {n: hashlib.sha256((folder / n).read_bytes()).hexdigest() for n in names}


def records(folder: Path) -> list[dict]:
    return [json.loads(line) for line in (folder / "results.jsonl").read_text().splitlines()]


def mc_settings(seeds: int = 5):
    data = load_config().data
    temps, freqs = mc.grid(data, 2, 1)
    return mc.settings(data, seeds, temps, freqs, 256)


def mc_sweep(fn, settings, executor, out=None) -> Sweep:
    if out is not None:
        out.mkdir()
    sweep = Sweep("montecarlo", settings, 7, executor, out)
    with executor:
        sweep.map(fn, mc.task_params(settings))
    sweep.close()
    return sweep


# ---- functions the cluster's workers run (importable: the workers inherit this sys.path) ------
def die_once(marker: str, index: int, fn, params, seed):
    """Kill this worker process the first time task ``index`` runs (a marker file remembers)."""
    if params["seed_index"] == index and not os.path.exists(marker):
        Path(marker).write_text("killed\n")
        os._exit(1)
    return fn(params, seed)


def fail_on(index: int, fn, params, seed):
    if params["seed_index"] == index:
        raise ValueError("injected failure")
    return fn(params, seed)


def fail_once(marker: str, fn, params, seed):
    if not os.path.exists(marker):
        Path(marker).write_text("failed\n")
        raise OSError(28, "No space left on device (injected)")
    return fn(params, seed)


# ---- determinism ----------------------------------------------------------------------------------
def test_montecarlo_same_bytes_serial_and_on_the_cluster(tmp_path, cluster, capsys):
    address, _ = cluster
    assert main(["sweep", "montecarlo", *MC_ARGS, "--workers", "0", "--out", str(tmp_path / "serial")]) == 0
    assert main(["sweep", "montecarlo", *MC_ARGS, "--scheduler", address, "--out", str(tmp_path / "dask")]) == 0
    names = FILES + ("montecarlo.png",)
    assert digests(tmp_path / "serial", names) == digests(tmp_path / "dask", names)
    assert not (tmp_path / "serial" / JOURNAL).exists()          # complete: the journal is gone
    recs = records(tmp_path / "serial")
    assert [r["index"] for r in recs] == list(range(5))
    assert len({r["seed"] for r in recs}) == 5
    out = capsys.readouterr().out
    assert "p99 [95 % CI]" in out and "5 tasks run, 0 from the journal, 0 failed" in out


def test_task_seeds_depend_on_sweep_seed_and_index_only():
    s = mc_settings(3)
    a = mc_sweep(mc.task_function(s), s, Executor(0)).records
    b = mc_sweep(mc.task_function(mc_settings(5)), mc_settings(5), Executor(0)).records
    assert [a[i]["result"] for i in range(3)] == [b[i]["result"] for i in range(3)]   # a prefix of the longer sweep
    assert a[0]["result"] != a[1]["result"]
    assert task_seed(7, 1) == a[1]["seed"] and task_seed(8, 1) != task_seed(7, 1)
    with pytest.raises(ValueError, match="--seed"):
        task_seed(-1, 0)


# ---- robustness -----------------------------------------------------------------------------------
def test_a_killed_worker_has_its_task_rerun_and_the_result_is_complete_and_identical(tmp_path, cluster):
    address, lc = cluster
    s = mc_settings(6)
    serial = mc_sweep(mc.task_function(s), s, Executor(0))
    marker = tmp_path / "killed"
    killed = mc_sweep(partial(die_once, str(marker), 2, mc.task_function(s)), s, Executor(scheduler=address),
                      tmp_path / "out")
    assert marker.exists(), "no worker was killed: the test proves nothing"
    assert killed.failures() == []
    assert killed.results_text() == serial.results_text()
    # every task journaled once, as it finished
    lines = (tmp_path / "out" / JOURNAL).read_text().splitlines()[1:]
    assert sorted(json.loads(x)["index"] for x in lines) == list(range(6))
    lc.wait_for_workers(2, timeout=120)   # the nanny restarts the killed worker for the next tests


def test_a_failing_task_is_reported_with_its_parameters_and_the_others_are_kept(tmp_path, cluster):
    address, _ = cluster
    s = mc_settings(4)
    serial = mc_sweep(mc.task_function(s), s, Executor(0))
    broken = mc_sweep(partial(fail_on, 1, mc.task_function(s)), s, Executor(scheduler=address, retries=1))
    [failed] = broken.failures()
    assert failed["index"] == 1 and failed["params"] == {"seed_index": 1}
    assert failed["error"] == "ValueError: injected failure"
    for i in (0, 2, 3):
        assert broken.records[i] == serial.records[i]


def test_dask_retries_a_task_that_raised_once(tmp_path, cluster):
    address, _ = cluster
    s = mc_settings(2)
    serial = mc_sweep(mc.task_function(s), s, Executor(0))
    marker = tmp_path / "failed"
    retried = mc_sweep(partial(fail_once, str(marker), mc.task_function(s)), s, Executor(scheduler=address, retries=1))
    assert marker.exists() and retried.failures() == []
    assert retried.results_text() == serial.results_text()
    marker.unlink()
    no_retry = mc_sweep(partial(fail_once, str(marker), mc.task_function(s)), s, Executor(0, retries=0))
    assert len(no_retry.failures()) == 1


def test_an_interrupted_sweep_resumes_from_its_journal(tmp_path, monkeypatch, capsys):
    argv = ["sweep", "montecarlo", *MC_ARGS, "--workers", "0"]
    assert main([*argv, "--out", str(tmp_path / "whole")]) == 0
    out = tmp_path / "cut"
    calls = {"n": 0}
    original = mc._task

    def interrupted(settings, params, seed):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return original(settings, params, seed)

    monkeypatch.setattr(mc, "_task", interrupted)
    assert main([*argv, "--out", str(out)]) == 130
    monkeypatch.setattr(mc, "_task", original)
    # no partial results: only the journal, listed as fxdsp's own in the folder's record
    assert sorted(p.name for p in out.iterdir()) == [RECORD, JOURNAL]
    journal = (out / JOURNAL).read_text().splitlines()
    assert len(journal) == 3                                       # header + the 2 finished tasks
    # a result read back is used, not recomputed: a marked value comes through
    rec = json.loads(journal[2])
    rec["result"]["overflows"] = 12345
    journal[2] = json.dumps(rec)
    (out / JOURNAL).write_text("\n".join(journal) + "\n" + '{"index": 4, "se')   # and a torn last write
    capsys.readouterr()
    assert main([*argv, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "resuming: 2 finished tasks" in text and "3 tasks run, 2 from the journal" in text
    assert records(out)[1]["result"]["overflows"] == 12345
    # resumed without the mark: the same bytes as the uninterrupted sweep
    assert main([*argv, "--out", str(out), "--fresh"]) == 0
    assert digests(out) == digests(tmp_path / "whole")


def test_failed_tasks_keep_the_journal_and_a_rerun_completes_them(tmp_path, monkeypatch, capsys):
    argv = ["sweep", "montecarlo", *MC_ARGS, "--workers", "0", "--retries", "0"]
    assert main([*argv, "--out", str(tmp_path / "whole")]) == 0
    original = mc._task
    monkeypatch.setattr(mc, "_task", lambda s, p, seed: fail_on(3, partial(original, s), p, seed))
    out = tmp_path / "out"
    assert main([*argv, "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert 'task 3 {"seed_index":3}: ValueError: injected failure' in err
    recs = records(out)
    assert "error" in recs[3] and all("result" in r for i, r in enumerate(recs) if i != 3)
    assert json.loads((out / "summary.json").read_text())["failed"][0]["params"] == {"seed_index": 3}
    assert (out / JOURNAL).exists()
    monkeypatch.setattr(mc, "_task", original)
    assert main([*argv, "--out", str(out)]) == 0
    assert "1 tasks run, 4 from the journal, 0 failed" in capsys.readouterr().out
    assert digests(out) == digests(tmp_path / "whole") and not (out / JOURNAL).exists()


@pytest.mark.parametrize("argv, word", [
    (["--seeds", "0"], "--seeds"),
    (["--temps", "0"], "--temps"),
    (["--workers", "-1"], "--workers"),
    (["--samples", "4"], "--samples"),
    (["--seed", "-3"], "--seed"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "--workers"),
])
def test_bad_input_is_one_line_and_creates_nothing(tmp_path, argv, word, capsys):
    assert main(["sweep", "montecarlo", *argv, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and word in err[0] and "Traceback" not in err[0]
    assert not (tmp_path / "o").exists()


def test_a_journal_of_another_sweep_is_refused(tmp_path, capsys, monkeypatch):
    out = tmp_path / "o"
    monkeypatch.setattr(mc, "_task", lambda s, p, seed: (_ for _ in ()).throw(KeyboardInterrupt)
                        if p["seed_index"] == 1 else mc.point_errors(s, seed))
    assert main(["sweep", "montecarlo", *MC_ARGS, "--workers", "0", "--out", str(out)]) == 130
    capsys.readouterr()
    assert main(["sweep", "montecarlo", *MC_ARGS, "--seed", "99", "--workers", "0", "--out", str(out)]) == 2
    assert "--fresh" in capsys.readouterr().err


# ---- the Monte-Carlo figures ------------------------------------------------------------------------
def test_order_statistic_confidence_ranks_match_the_textbook():
    # n = 100, median: the distribution-free 95 % interval is [x(40), x(61)] (Conover, Practical
    # Nonparametric Statistics, table A3)
    q = mc.quantile_ci(np.arange(1.0, 101.0), 0.5)
    assert q["ci_ranks"] == [40, 61] and q["ci"] == [40.0, 61.0] and q["value"] == 50.0
    assert mc.quantile_ci(np.arange(1.0, 101.0), 0.9)["value"] == 90.0
    # 6 samples cannot bound a 99th percentile from above at 95 %
    assert mc.quantile_ci(np.arange(6.0), 0.99)["ci"][1] is None


def test_montecarlo_error_agrees_with_the_budget_and_follows_the_config():
    """The sweep's median error at held temperatures is of the size the budget's quasi-static
    chamber test measures (another stimulus, another code path); a 5-bit-coarser temperature word
    must show up as a larger error."""
    from fxdsp.budget.static import static_error
    from fxdsp.chains import build
    from fxdsp.config import Config
    from conftest import edited_data

    cfg = load_config()
    design = build(cfg)
    static = static_error(design, "chain_paper002", "rate")["rms"] * design.rate_full_scale_dps * 3600.0
    s = mc.settings(cfg.data, 4, [-10.0, 10.0, 30.0, 50.0], [8000.0], 1024)
    fine = mc.summarise(s, list(mc_sweep(mc.task_function(s), s, Executor(0)).records.values()))
    assert static / 3 < fine["pooled"]["rms"]["p50"]["value"] < static * 3
    coarse_cfg = Config(edited_data(**{"rtd.temp_format": "s17.8"}), source="<test>")
    c = mc.settings(coarse_cfg.data, 4, [-10.0, 10.0, 30.0, 50.0], [8000.0], 1024)
    coarse = mc.summarise(c, list(mc_sweep(mc.task_function(c), c, Executor(0)).records.values()))
    assert coarse["pooled"]["rms"]["p50"]["value"] > 3 * fine["pooled"]["rms"]["p50"]["value"]


# the papers' other chains, in the units the papers state their errors in
OTHER_CHAINS = {"chain_paper001": ("rate", "deg/h"), "chain_paper000": ("accel", "mg")}


@pytest.mark.parametrize("chain", sorted(OTHER_CHAINS))
def test_montecarlo_runs_any_chain_with_a_sensor_in_its_outputs_unit(chain, tmp_path, capsys):
    """A chain without a demodulator has no drive frequency; its output and unit are found from the
    chain, and its median error is of the size the budget's chamber test measures on that chain."""
    from fxdsp.budget.static import static_error
    from fxdsp.chains import build

    port, unit = OTHER_CHAINS[chain]
    out = tmp_path / "o"
    assert main(["sweep", "montecarlo", "--chain", chain, "--seeds", "4", "--temps", "3", "--samples", "256",
                 "--workers", "0", "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert (s["chain"], s["port"], s["unit"], s["freqs_hz"]) == (chain, port, unit, [None])
    design = build()
    static = static_error(design, chain, port)["rms"] * design.instances[chain].ports[port].scale
    assert static / 3 < s["pooled"]["rms"]["p50"]["value"] < static * 3
    assert f"{chain}.{port} error ({unit}" in (out / "report.md").read_text()
    capsys.readouterr()
    assert main(["sweep", "montecarlo", "--chain", chain, "--freqs", "2", "--out", str(tmp_path / "f")]) == 2
    assert "no demodulator" in capsys.readouterr().err and not (tmp_path / "f").exists()
    assert main(["sweep", "montecarlo", "--chain", chain, "--port", "nosuch", "--out", str(tmp_path / "p")]) == 2
    assert "--port" in capsys.readouterr().err and not (tmp_path / "p").exists()


# ---- the other sweep kinds --------------------------------------------------------------------------
def test_hidden_confusion_on_the_cluster_is_diagnose_hiddens_matrix(tmp_path, cluster, capsys):
    from fxdsp.diagnose.hidden import confusion

    address, _ = cluster
    # every case with a step outside the contract's list: the report must say structure remains
    argv = ["sweep", "hidden", "--per-cause", "1", "--causes", "none,hysteresis", "--first-seed", "1000",
            "--outside", "step"]
    # the cluster against the serial implementation (`diagnose-hidden`'s); the same bytes serially and
    # on the cluster are the engine's, for every kind: test_montecarlo_same_bytes_serial_and_on_the_cluster
    assert main([*argv, "--scheduler", address, "--out", str(tmp_path / "dask")]) == 0
    capsys.readouterr()
    got = json.loads((tmp_path / "dask" / "summary.json").read_text())
    ref = confusion(1, 1000, ("none", "hysteresis"), outside="step")
    assert got["matrix"] == ref.matrix.tolist() and got["outside"] == "step"
    assert got["params_ok"] == ref.params_ok and got["gain_ok"] == ref.gain_ok
    assert got["remaining_significant"] == ref.flagged == {"none": 1, "hysteresis": 1}


def test_wordlength_search_on_local_workers_finds_what_budget_optimise_finds(tmp_path, capsys):
    """``--workers 2``: the engine's own LocalCluster (the default path)."""
    from fxdsp.budget import optimise as opt
    from fxdsp.budget.units import parse_target
    from fxdsp.chains import build

    # against the search of `budget --optimise` (the same bytes serially and on a cluster: the engine's,
    # test_montecarlo_same_bytes_serial_and_on_the_cluster)
    argv = ["sweep", "wordlength", "--chain", "chain_paper001", "--target", "1deg/h"]
    assert main([*argv, "--workers", "2", "--out", str(tmp_path / "dask")]) == 0
    capsys.readouterr()
    cfg = load_config()
    ref = opt.optimise(cfg, parse_target("1deg/h", build(cfg), "chain_paper001"))
    got = json.loads((tmp_path / "dask" / "summary.json").read_text())
    assert got["values"] == ref.values and got["error"] == ref.error
    assert tomllib.loads((tmp_path / "dask" / "optimised.toml").read_text()) == ref.data   # the config written
    assert got["cost"]["total_bits"] < got["default_cost"]["total_bits"]
    evaluated = sum(len(r["params"]["candidates"]) for r in records(tmp_path / "dask"))
    # every candidate went through the engine, none on the client (and no speculative extra on this chain)
    assert evaluated == got["evaluations"] == ref.evaluations


@pytest.mark.hdl
def test_rtl_shards_build_apart_match_serially_and_on_the_cluster_and_catch_a_mutation(tmp_path, cluster, capsys):
    from fxdsp.sweep import rtl

    if shutil.which("iverilog") is None:
        pytest.skip("iverilog (Icarus Verilog) is not installed")
    address, _ = cluster
    argv = ["sweep", "rtl", "--shards", "2", "--blocks", "bias_subtract"]
    assert main([*argv, "--scheduler", address, "--out", str(tmp_path / "dask"),
                 "--build-dir", str(tmp_path / "builds")]) == 0
    assert main([*argv, "--workers", "0", "--out", str(tmp_path / "serial")]) == 0
    assert digests(tmp_path / "dask") == digests(tmp_path / "serial")
    for shard in ("shard_0000", "shard_0001"):       # each shard in its own folder
        assert (tmp_path / "builds" / shard / "bias_subtract" / "summary.json").exists()
    recs = records(tmp_path / "serial")
    assert recs[0]["result"]["changes"] != recs[1]["result"]["changes"]   # two different parameter sets
    # the report says what each shard verified: every randomised setting, with its value, per shard
    page = (tmp_path / "serial" / "report.md").read_text()
    for rec in recs:
        section = page.split(f"### Shard {rec['params']['shard']} ")[1].split("### Shard")[0]
        assert rec["result"]["changes"], "a shard that changed nothing verified the config itself"
        for key, value in rec["result"]["changes"].items():
            assert f"- `{key}` = `{value}`" in section
    mutated = tmp_path / "rtl"
    shutil.copytree(rtl.RTL_DIR, mutated)
    src = mutated / "bias_subtract.v"
    text = src.read_text()
    assert "- (be <<< B_ALIGN)" in text
    src.write_text(text.replace("- (be <<< B_ALIGN)", "+ (be <<< B_ALIGN)"))
    capsys.readouterr()
    assert main([*argv, "--workers", "0", "--rtl", str(mutated), "--out", str(tmp_path / "mutant")]) == 1
    out = capsys.readouterr().out
    assert "0 shards pass, 2 fail" in out and "bias_subtract: segment 0 port y" in out
