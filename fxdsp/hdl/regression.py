"""The RTL regression of one design (any config): what ``fxdsp rtl`` runs.

Every DUT of the design (each block instance and chain top, or those named) in each of its variants
(the one-sample-per-clock RTL, and the resource-shared serial one where its module has one) gets
four streams, all compared word for word with the bit-exact model of the same design, overflow
flags against the model's count:

* ``golden``: the design's golden vectors (the very files written beside the report);
* ``random``: the block's random stimulus, corners first, with idle input cycles (gapped valid);
* ``corners``: its corner stream three times: a reset with samples in flight, back to back, gapped;
* ``long``: a long stream through the file-driven harness (the simulator at its own speed);
* ``closed_loop`` (drive loops only): the RTL closed on the simulated resonator from power-on
  (:mod:`fxdsp.hdl.cosim`), every word against the model's closed loop: on Verilator through the
  acquisition (the model's lock time) and one second of lock, on Icarus (~100 times slower) its first
  :data:`ICARUS_LOOP_S` seconds; the serial variant (~400 cycles a sample) its first
  :data:`SERIAL_LOOP_S` seconds, the report says so.

The first three are Python-driven (cocotb), one after another in one simulator run per DUT (their
records as if each had run alone); a serial variant on Icarus runs a window of each
(:data:`fxdsp.hdl.stimuli.ICARUS_SERIAL_SAMPLES`), on Verilator the whole. Every module runs at
its hardware setting (the divider one quotient bit per cycle).

A failing stream is re-run in the file-driven harness from reset with a waveform of a window around
its first mismatch (``waves/<dut>_<stream>.vcd``); ``waves=True`` writes one for every DUT's
golden stream (its first samples) as well.
"""

from __future__ import annotations

import shutil
import tempfile
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fxdsp.blocks.drive import Drive
from fxdsp.errors import InputError
from fxdsp.fixed.hexfile import word_value
from fxdsp.hdl import harness as hh
from fxdsp.hdl import stimuli

STREAMS = ("golden", "random", "corners", "long", "closed_loop")
LOOP_STREAM = "closed_loop"
ICARUS_LOOP_S = 0.05   # the closed loop's run on Icarus: the PLL's first 40 ms
LOCKED_S = 1.0         # ... on Verilator: the acquisition and this much of lock
# the serial variant's closed loop (~400 cycles a sample: ~900 samples/s on Verilator under cocotb
# with a Python clock): the PLL's and the AGC's first updates, not the lock (the
# default variant's run covers the lock; both variants' words are the same on every open stream)
SERIAL_LOOP_S = {"verilator": 0.25, "icarus": 0.01}
# samples of the long stream per simulator and variant (the serial one takes 12-350 cycles a sample)
LONG_SAMPLES = {("verilator", False): 100_000, ("verilator", True): 100_000,
                ("icarus", False): 20_000, ("icarus", True): 2_000}
RANDOM_GAP = 0.25
WAVE_BEFORE, WAVE_AFTER = 48, 16     # outputs of the waveform window around a first mismatch
WAVE_GOLDEN = 64                     # outputs of a --waves window of a passing golden stream


@dataclass
class Dut:
    name: str                 # instance or chain top
    extra: dict | None        # module parameters of the variant (None: the default RTL)

    @property
    def label(self) -> str:
        return self.name + (" (serial)" if self.extra else "")

    @property
    def slug(self) -> str:
        return self.name + ("_serial" if self.extra else "")


@dataclass
class DutResult:
    dut: str
    module: str
    streams: dict = field(default_factory=dict)    # stream -> {samples, cycles, ok, errors}
    first_mismatch: dict | None = None
    waves: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return all(s["ok"] for s in self.streams.values())

    def as_dict(self) -> dict:
        samples = sum(s["samples"] for s in self.streams.values())
        cycles = [s["cycles"] for s in self.streams.values() if s.get("cycles")]
        # cycles per sample of the back-to-back long stream (the cocotb streams include resets and gaps)
        timed = [self.streams[s] for s in ("long", "golden") if self.streams.get(s, {}).get("cycles")]
        per = timed[0]["cycles"] / timed[0]["samples"] if timed and timed[0]["samples"] else None
        return {"dut": self.dut, "module": self.module, "passed": self.ok, "samples": samples,
                "cycles": int(sum(cycles)), "cycles_per_sample": round(per, 3) if per else None,
                "streams": self.streams, "first_mismatch": self.first_mismatch, "waves": self.waves}


def duts(design, only=None) -> list[Dut]:
    """Every DUT of the design (``only``: those instances), each default variant then its serial one.
    InputError naming an unknown instance, with the nearest; an instance without RTL is not a DUT."""
    names = list(design.hardware)
    if only:
        import difflib

        for n in only:
            if n in design.all and n not in design.hardware:
                raise InputError(f"--only: {n!r} has no RTL yet; the instances with RTL: {', '.join(names)}")
            if n not in design.all:
                near = difflib.get_close_matches(n, names, n=1)
                raise InputError(f"--only: no block or chain {n!r} in this config"
                                 + (f" (did you mean {near[0]!r}?)" if near else "") + f"; one of {', '.join(names)}")
        names = [n for n in names if n in set(only)]
    out = []
    for n in names:
        out.append(Dut(n, None))
        serial = hh.serial_variant(design, n)
        if serial:
            out.append(Dut(n, serial))
    return out


def _stream(design, dut: Dut, stream: str, files: dict, sim: str, seed: int, long_n: int | None):
    """(segments, their stored inputs, gap) of one Python-driven stream, or the long stream's stored
    inputs alone as (None, inputs, 0.0)."""
    from fxdsp.vectors import load_generated

    name = dut.name
    window = dut.extra is not None and sim == "icarus"

    def cut(stim):
        return stimuli.icarus_window(stim, stimuli.icarus_samples(design, name)) if window else stim

    if stream == "golden":
        ins, outs, entry = load_generated(files, name)
        if window:   # the model runs on the window
            ins = cut(ins)
            return [hh.segment(design, name, ins)], [ins], 0.0
        return [hh.segment(design, name, ins, outs, sum(entry["overflows"].values()))], [ins], 0.0
    if stream == "random":
        stim = cut(stimuli.random_stimulus(design, name, seed))
        return [hh.segment(design, name, stim)], [stim], RANDOM_GAP
    if stream == "corners":
        stim = cut(stimuli.corners(design, name, np.random.default_rng(seed)))
        n = len(next(iter(stim.values())))
        first = {k: v[: max(8, n // 3)] for k, v in stim.items()}
        return ([hh.segment(design, name, first, abort_after=max(4, n // 4)),   # reset with samples in flight
                 hh.segment(design, name, stim, gap=0.0),                       # back to back from reset
                 hh.segment(design, name, stim, gap=0.5)],                      # gapped valid from reset
                [first, stim, stim], 0.0)
    n = long_n or LONG_SAMPLES[(sim, dut.extra is not None)]
    stim = design.all[name].stimulus(np.random.default_rng([seed, 2026]), n)
    return None, [{k: v[:n] for k, v in stim.items()}], 0.0


def _long(design, dut: Dut, inputs: dict, d: Path, models, sim: str, rtl) -> tuple[dict, dict | None]:
    """The long stream through the file-driven harness: (stream record, first mismatch or None)."""
    expected, ovf_model = hh.model_run(design, dut.name, inputs)
    n = len(next(iter(inputs.values())))
    try:
        got, ovf_rtl, cycles, _, _ = hh.run_harness(design, dut.name, inputs, d, models, sim=sim, extra=dut.extra,
                                                    rtl=rtl)
    except hh.HarnessTimeout as e:
        return {"samples": n, "cycles": None, "ok": False, "errors": [f"timeout: {str(e).splitlines()[0]}"]}, None
    except hh.UndefinedWord as e:
        return {"samples": n, "cycles": None, "ok": False, "errors": [f"undefined output word ({e})"]}, None
    errors, mismatch = [], None
    for port, want in expected.items():
        bad = np.flatnonzero(got[port] != want)
        if bad.size:
            errors.append(f"port {port}: {bad.size} mismatch(es) of {n}, first at sample {bad[0]}")
            if mismatch is None or bad[0] < mismatch["sample"]:
                i = int(bad[0])
                mismatch = {"segment": 0, "port": port, "sample": i, "got": int(got[port][i]),
                            "expected": int(want[i]), "count": int(bad.size), "of": n}
    if ovf_rtl != ovf_model:
        errors.append(f"{ovf_rtl if ovf_rtl >= 0 else 'x'} overflow flags, model counted {ovf_model}")
    return {"samples": n, "cycles": cycles, "ok": not errors, "errors": errors[:5]}, mismatch


# the Python-driven streams: one cocotb run per DUT takes them all (an Icarus build, the simulator's
# and cocotb's start-up: about half a second each time here; `fxdsp rtl --only iir,lag` on Icarus
# went from 20.7 to 17.2 s with its DUTs' three runs made one)
PY_STREAMS = ("golden", "random", "corners")


def _py_streams(design, dut: Dut, names: list[str], files: dict, sim: str, seeds: dict, d: Path, models,
                rtl) -> dict[str, tuple[dict, dict | None, dict, bool]]:
    """The Python-driven streams ``names`` of one DUT in one cocotb run, their segments one after
    another (each from its own reset, with its own gap and its stream's draws): per stream (record,
    first mismatch or None, the inputs of the segment that failed first, whether it was gapped), as
    if each had run alone: its samples, its cycles, its errors with its own segment numbers."""
    segments, owner = [], []     # owner: (stream, the segment's number within it, its stored inputs)
    for stream in names:
        segs, stored, gap = _stream(design, dut, stream, files, sim, seeds[stream], None)
        for i, (seg, ins) in enumerate(zip(segs, stored)):
            segments.append({**seg, "gap": seg.get("gap", gap), "label": f"segment {i}"})
            owner.append((stream, i, ins))
    seed = zlib.crc32(":".join(f"{n}={seeds[n]}" for n in names).encode()) & 0x7FFFFFFF
    summary = hh.run_cocotb(design, dut.name, segments, d, models, seed=seed, extra_params=dut.extra, sim=sim,
                            rtl=rtl)
    cycles = summary.get("segment_cycles") or []
    where = summary.get("error_segments")
    out = {}
    for stream in names:
        mine = [k for k, o in enumerate(owner) if o[0] == stream]
        if where is None:   # no summary (the run ended early): its errors are every stream's
            errors = summary["errors"]
        else:
            errors = [e for e, k in zip(summary["errors"], where) if owner[k][0] == stream]
        record = {"samples": sum(len(next(iter(owner[k][2].values()))) for k in mine),
                  "cycles": sum(cycles[k] for k in mine) if len(cycles) == len(owner) else None,
                  "ok": not errors, "errors": errors[:5]}
        wrong = [dict(m, segment=owner[m["segment"]][1]) for m in summary["mismatches"]
                 if owner[m["segment"]][0] == stream]
        mismatch = min(wrong, key=lambda m: (m["segment"], m["sample"]), default=None)
        at = next(k for k in mine if owner[k][1] == mismatch["segment"]) if mismatch else mine[-1]
        out[stream] = (record, mismatch, owner[at][2], bool(segments[at]["gap"]))
    return out


def _closed_loop(design, dut: Dut, d: Path, models, sim: str, rtl, seed: int) -> tuple[dict, dict | None, dict]:
    """The closed-loop co-simulation of a drive loop: (stream record, first mismatch or None, the
    ADC codes up to a little after it: the RTL fed them open loop gives the same words, so the
    waveform's re-run shows the mismatch). On Verilator the model's acquisition time plus
    :data:`LOCKED_S`; on Icarus :data:`ICARUS_LOOP_S`; the serial variant :data:`SERIAL_LOOP_S`."""
    from fxdsp.hdl.cosim import acquisition_s, run_loop_cosim

    block = design.all[dut.name]
    lock = None
    if dut.extra:
        seconds = SERIAL_LOOP_S[sim]
    elif sim == "verilator":
        lock = acquisition_s(block, seed=seed)
        if lock is None:
            return ({"samples": 0, "cycles": None, "ok": False,
                     "errors": ["the model's loop never locks on its mode: nothing to co-simulate"]}, None, {})
        seconds = lock + LOCKED_S
    else:
        seconds = ICARUS_LOOP_S
    s = run_loop_cosim(design, dut.name, d, models, seconds=seconds, seed=seed, sim=sim, rtl=rtl, extra=dut.extra)
    record = {"samples": s["samples"], "cycles": s["cycles"], "ok": not s["errors"], "errors": s["errors"][:5],
              "seconds_simulated": round(s["expected_samples"] / block.fs_hz, 4),
              "lock_s": None if lock is None else round(lock, 4),
              "scope": ("the serial variant's first updates; through the lock: the default variant's run"
                        if dut.extra else None),
              "samples_per_s": None if s["samples_per_s"] is None else round(s["samples_per_s"])}
    m = s["mismatch"]
    if m is None:
        return record, None, {}
    mismatch = {"segment": 0, "sample": m["sample"], "port": m["port"], "got": m["got"], "expected": m["expected"],
                "count": len(m["ports"]), "of": len(block.outputs)}
    codes = np.load(d / "expected.npz")["codes"][: m["sample"] + WAVE_AFTER]
    return record, mismatch, {"x": codes}


def _fresh(d: Path) -> Path:
    """``d``, a folder of this run's own work folder (``<dut>_<stream>``, ``<dut>_cocotb``), emptied."""
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir(parents=True)
    return d


def run_dut(design, dut: Dut, files: dict, sim: str, work: Path, models: Path | None, out: Path, seed: int = 1,
            waves: bool = False, rtl: Path | None = None, long_n: int | None = None, streams=STREAMS,
            progress=None) -> DutResult:
    """Run the streams of one DUT; the result says per stream whether it matched, and where first not.
    A DUT that does not build fails its streams with the simulator's words (never an exception)."""
    block = design.all[dut.name]
    res = DutResult(dut.label, design.instances[dut.name].module)
    seeds = {stream: zlib.crc32(f"{seed}:{dut.slug}:{stream}".encode()) & 0x7FFFFFFF for stream in streams}
    py = [s for s in streams if s in PY_STREAMS]
    py_results, py_failed = {}, None
    if py:
        try:
            py_results = _py_streams(design, dut, py, files, sim, seeds, _fresh(Path(work) / f"{dut.slug}_cocotb"),
                                     models, rtl)
        except hh.BuildFailed as e:
            py_failed = e
    for k, stream in enumerate(streams):
        if progress is not None:
            progress.set_postfix_str(stream)
        d = Path(work) / f"{dut.slug}_{stream}"
        if stream == LOOP_STREAM and not isinstance(block, Drive):
            if progress is not None:
                progress.update(1)
            continue   # not a loop: nothing to close
        _fresh(d)
        try:
            if stream in PY_STREAMS:
                if py_failed is not None:
                    raise py_failed
                record, mismatch, failing_inputs, failing_gap = py_results[stream]
            elif stream == LOOP_STREAM:
                record, mismatch, failing_inputs = _closed_loop(design, dut, d, models, sim, rtl, seeds[stream])
                failing_gap = False
            else:
                _, stored, _ = _stream(design, dut, stream, files, sim, seeds[stream], long_n)
                record, mismatch = _long(design, dut, stored[0], d, models, sim, rtl)
                failing_inputs, failing_gap = stored[0], False
        except hh.BuildFailed as e:
            res.streams[stream] = {"samples": 0, "cycles": None, "ok": False,
                                   "errors": [f"build failed: {e.reason}"]}
            if progress is not None:
                progress.update(1)
            continue
        res.streams[stream] = record
        if mismatch is not None:
            fmt = block.outputs[mismatch["port"]]
            mismatch = {"dut": dut.label, "stream": stream, **mismatch,
                        "got_value": word_value(mismatch["got"], fmt.wl, fmt.signed),
                        "expected_value": word_value(mismatch["expected"], fmt.wl, fmt.signed)}
            res.first_mismatch = res.first_mismatch or mismatch
        if (not record["ok"] and failing_inputs) or (waves and stream == "golden"):
            # around the first mismatch; a pass (--waves) or a failure without a wrong word: the start
            window = (max(0, mismatch["sample"] - WAVE_BEFORE), mismatch["sample"] + WAVE_AFTER) if mismatch \
                else (0, WAVE_GOLDEN)
            path = _waves(design, dut, failing_inputs, failing_gap, window, d, models, sim, rtl, out, stream)
            if path is not None:
                res.waves.append({"stream": stream, "file": path, "outputs": list(window)})
        if progress is not None:
            progress.update(1)
    return res


def _waves(design, dut: Dut, inputs, gap: bool, window, d: Path, models: Path | None, sim: str, rtl, out: Path,
           stream: str) -> str | None:
    """Re-run ``inputs`` from reset in the file-driven harness with every DUT signal dumped over the
    window of outputs; the VCD goes to ``out/waves/``; returns its path relative to ``out``."""
    wd = d / "waves"
    wd.mkdir(exist_ok=True)
    n = len(next(iter(inputs.values())))
    last = min(int(window[1]), max(n - 1, 0))
    try:
        hh.run_harness(design, dut.name, inputs, wd, models, gap=gap, sim=sim, extra=dut.extra, rtl=rtl,
                       waves=(int(window[0]), last))
    except hh.BuildFailed:
        return None
    vcd = wd / "waves.vcd"
    if not vcd.exists():
        return None
    rel = Path("waves") / f"{dut.slug}_{stream}.vcd"
    (out / rel).parent.mkdir(parents=True, exist_ok=True)
    shutil.move(str(vcd), out / rel)
    return rel.as_posix()


def regression(design, vectors: dict[str, str], out: Path, sim: str = "icarus", only=None, waves: bool = False,
               rtl: Path | None = None, models: Path | None = None, seed: int = 1, long_n: int | None = None,
               streams=STREAMS, show_progress: bool | None = None) -> dict:
    """Run every DUT of the design (or ``only``) on ``sim``, its golden stream from ``vectors`` (the
    set :func:`fxdsp.vectors.generate` made of it); waveforms into ``out/waves``. Returns the report
    as data: per DUT the samples, cycles per sample, pass/fail, first mismatch and waveforms."""
    from tqdm import tqdm

    from fxdsp.hdl.simulators import require_simulator

    require_simulator(sim)
    todo = duts(design, only)
    out = Path(out)
    t_start = time.perf_counter()
    results = []
    with tempfile.TemporaryDirectory(prefix="fxdsp-rtl-") as tmp:
        if models is None and sim == "verilator":
            models = Path(tmp) / "models"
        for dut in todo:
            t0 = time.perf_counter()
            with tqdm(total=len(streams), desc=dut.label, unit="stream", leave=True,
                      disable=None if show_progress is None else not show_progress) as bar:
                r = run_dut(design, dut, vectors, sim, Path(tmp) / "runs", models, out, seed, waves, rtl, long_n,
                            streams, bar)
            row = r.as_dict()
            row["seconds"] = round(time.perf_counter() - t0, 1)
            results.append(row)
    return {"generator": "fxdsp rtl", "config": design.config.name, "simulator": sim, "seed": seed,
            "streams": list(streams), "passed": all(r["passed"] for r in results),
            "duts": results, "seconds": round(time.perf_counter() - t_start, 1)}


def markdown(report: dict) -> str:
    """The report as a Markdown page: a row per DUT, then the first mismatch of each failing one."""
    L = [f"# RTL regression of `{report['config']}`", "",
         f"Simulator {report['simulator']}, seed {report['seed']}, streams: {', '.join(report['streams'])}. "
         f"Verdict: **{'every DUT bit-exact' if report['passed'] else 'MISMATCH'}**.", "",
         "| DUT | module | samples | cycles/sample | " + " | ".join(report["streams"]) + " | verdict |",
         "|---|---|--:|--:|" + "---|" * len(report["streams"]) + "---|"]
    for r in report["duts"]:
        cps = "-" if r["cycles_per_sample"] is None else f"{r['cycles_per_sample']:g}"
        cells = ["-" if s not in r["streams"] else "pass" if r["streams"][s]["ok"] else "**FAIL**"
                 for s in report["streams"]]
        L.append(f"| {r['dut']} | {r['module']} | {r['samples']} | {cps} | " + " | ".join(cells)
                 + f" | {'pass' if r['passed'] else '**FAIL**'} |")
    loops = [(r["dut"], r["streams"][LOOP_STREAM]) for r in report["duts"] if LOOP_STREAM in r["streams"]]
    if loops:
        L += ["", "Closed loops on their modes (every output word of every sample against the model's closed "
              "loop):", ""]
        for dut, v in loops:
            lock = f", the model locks at {v['lock_s']:g} s" if v.get("lock_s") is not None else ""
            speed = f", {v['samples_per_s']} samples/s" if v.get("samples_per_s") else ""
            scope = f" ({v['scope']})" if v.get("scope") else ""
            L.append(f"- {dut}: {v['samples']} samples of {v.get('seconds_simulated', 0):g} s from power-on "
                     f"{'bit for bit' if v['ok'] else 'until the first wrong word'}{lock}{speed}{scope}")
    failing = [r for r in report["duts"] if not r["passed"]]
    if failing:
        L += ["", "## First mismatches", ""]
        for r in failing:
            m = r["first_mismatch"]
            if m and m["stream"] == LOOP_STREAM:
                L.append(f"- **{r['dut']}**, closed loop on its mode: sample {m['sample']}, port `{m['port']}`: got "
                         f"{m['got_value']} (0x{m['got']:x}), expected {m['expected_value']} (0x{m['expected']:x}); "
                         f"{m['count']} of {m['of']} ports wrong there (the run stops at the first wrong sample)")
            elif m:
                L.append(f"- **{r['dut']}**, {m['stream']} stream, segment {m['segment']}: sample {m['sample']}, port "
                         f"`{m['port']}`: got {m['got_value']} (0x{m['got']:x}), expected {m['expected_value']} "
                         f"(0x{m['expected']:x}); {m['count']} of {m['of']} words wrong")
            for s, v in r["streams"].items():
                if not v["ok"] and not (m and m["stream"] == s):
                    L.append(f"- **{r['dut']}**, {s} stream: {'; '.join(v['errors'][:2])}")
    waves = [(r["dut"], w) for r in report["duts"] for w in r["waves"]]
    if waves:
        L += ["", "## Waveforms", ""]
        L += [f"- {dut}, {w['stream']} stream, outputs {w['outputs'][0]}-{w['outputs'][1]}: `{w['file']}`"
              for dut, w in waves]
    L += ["", f"{len(report['duts'])} DUTs in {report['seconds']} s.", ""]
    return "\n".join(L)
