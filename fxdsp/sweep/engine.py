"""The sweep engine: a list of tasks run in this process or on Dask, each result journaled as it
arrives, the whole returned in task order.

Why these rules:

* **Deterministic.** A task is ``(index, seed, params)``; its seed is derived from the sweep seed
  and its index alone (:func:`task_seed`, numpy's SeedSequence), never from a shared random stream,
  a worker, a clock or the order in which tasks finish. Results are ordered by index. So the same
  sweep gives the same bytes run serially, on 2 local workers or on a cluster (same software and
  CPU type on every node: the arithmetic is the same only then). Results are canonical JSON (numpy
  scalars made plain, tuples lists, non-finite floats refused), so a result read back from the
  journal is the same value as a freshly computed one.
* **Existing engine.** ``workers=0`` runs in this process (no Dask); ``workers=N`` starts a Dask
  ``LocalCluster`` of N single-threaded worker processes (nothing to start beforehand);
  ``scheduler=ADDRESS`` uses a running Dask cluster (``dask scheduler`` + ``dask worker``,
  dask-jobqueue, SSH, ...). A worker that dies has its tasks re-run elsewhere by the scheduler (up to
  ``distributed.scheduler.allowed-failures`` deaths per task); a task that raises is re-run
  ``retries`` times (a transient fault such as a full scratch disk on one node).
* **Nothing lost.** A task that still fails becomes an *error record* (its index, seed, params and
  the exception's one-line message); the other tasks go on. Every record is appended to the journal
  (``journal.jsonl`` in the output folder, one JSON line, flushed and fsync'ed) by the client as it
  arrives. Re-running the same sweep reads the journal back and runs only the tasks without a
  result (never run, interrupted, or failed); a journal written by different settings (another
  config, seed or grid: compared by a hash in its first line) is refused, not mixed in. A line torn
  by a crash mid-write is dropped.

Library code only: returns and raises; ``fxdsp sweep`` (cli.py) prints.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import uuid
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fxdsp import owned
from fxdsp.outputs import plain
from fxdsp.errors import InputError

JOURNAL = "journal.jsonl"
JOURNAL_VERSION = 1


def task_seed(sweep_seed: int, index: int) -> int:
    """64-bit seed of task ``index`` of a sweep seeded ``sweep_seed``: independent streams for
    every index, the same wherever and whenever the task runs."""
    if isinstance(sweep_seed, bool) or not isinstance(sweep_seed, (int, np.integer)) or sweep_seed < 0:
        raise InputError(f"--seed: must be an integer >= 0, got {sweep_seed!r}")
    a, b = np.random.SeedSequence([int(sweep_seed), int(index)]).generate_state(2)
    return int(a) | (int(b) << 32)


def canonical(value) -> str:
    """The one text of a JSON value (sorted keys, no spaces): what is hashed, compared and written."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)


def settings_hash(kind: str, settings: dict) -> str:
    return hashlib.sha256(canonical({"kind": kind, "settings": plain(settings)}).encode()).hexdigest()


@dataclass(frozen=True)
class Task:
    index: int
    seed: int
    params: dict


def _call(fn: Callable[[dict, int], dict], params: dict, seed: int):
    """What a worker runs: the task's function, its result made plain JSON data."""
    return plain(fn(params, seed))


def _error_text(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__


# ----------------------------------------------------------------------------------------------
# The journal
# ----------------------------------------------------------------------------------------------
class Journal:
    """Append-only record of a sweep's finished tasks, read back to resume it (module docstring)."""

    def __init__(self, path: Path, kind: str, settings: dict, fresh: bool = False):
        self.path = Path(path)
        self.header = {"fxdsp_sweep_journal": JOURNAL_VERSION, "kind": kind,
                       "settings_sha256": settings_hash(kind, settings)}
        self.done: dict[int, dict] = {}    # index -> record with a result, from a previous run
        self._kept: list[str] = []
        if self.path.exists() and not fresh:
            self._kept = self._read()
        self._file = None    # nothing is written before the first task has finished

    def _open(self) -> None:
        """Rewrite the journal (header + every sound line of the previous one: a torn tail goes),
        then keep it open for appending."""
        self.path.parent.mkdir(exist_ok=True)
        owned.claim(self.path)   # a file of that name that fxdsp did not write is refused, never replaced
        tmp = self.path.with_name(self.path.name + ".tmp")
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(canonical(self.header) + "\n")
            f.writelines(line + "\n" for line in self._kept)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path)
        self._file = open(self.path, "a", encoding="utf-8")

    def _read(self) -> list[str]:
        raw = self.path.read_text(encoding="utf-8").split("\n")
        complete = raw[:-1]            # text after the last newline is a torn write
        if not complete:
            return []
        try:
            header = json.loads(complete[0])
        except json.JSONDecodeError:
            header = None
        if header != self.header:
            raise InputError(f"--out: {self.path} is the journal of a different sweep (other kind, config, seed "
                             f"or grid); pass --fresh to discard it, or another --out")
        kept = []
        for n, line in enumerate(complete[1:], start=2):
            try:
                rec = json.loads(line)
                index = rec["index"]
            except (json.JSONDecodeError, KeyError, TypeError):
                raise InputError(f"--out: {self.path} line {n} is damaged; pass --fresh to discard the journal") \
                    from None
            kept.append(line)
            if "result" in rec:
                self.done[index] = rec
            else:
                self.done.pop(index, None)
        return kept

    def append(self, record: dict) -> None:
        if self._file is None:
            self._open()
        self._file.write(canonical(record) + "\n")
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        if self._file is not None and not self._file.closed:
            self._file.close()


# ----------------------------------------------------------------------------------------------
# Where tasks run
# ----------------------------------------------------------------------------------------------
class Executor:
    """Runs tasks in this process (``workers=0``), on a LocalCluster of ``workers`` processes, or on
    the Dask scheduler at ``scheduler``. A context manager: the cluster lives inside the ``with``."""

    def __init__(self, workers: int = 0, scheduler: str | None = None, retries: int = 2):
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 0:
            raise InputError(f"--workers: must be an integer >= 0, got {workers!r}")
        if not isinstance(retries, int) or retries < 0:
            raise InputError(f"--retries: must be an integer >= 0, got {retries!r}")
        if scheduler is not None and not scheduler.strip():
            raise InputError("--scheduler: empty address")
        self.workers, self.scheduler, self.retries = workers, scheduler, retries
        self.client = None
        self._cluster = None
        self._levels: dict[str, int] = {}

    @property
    def serial(self) -> bool:
        return self.scheduler is None and self.workers == 0

    def __enter__(self) -> "Executor":
        if self.serial:
            return self
        from distributed import Client, LocalCluster

        # worker deaths and restarts are handled here; Dask's own warnings about them would bury
        # the one line the command prints
        for name in ("distributed", "tornado"):
            self._levels[name] = logging.getLogger(name).level
            logging.getLogger(name).setLevel(logging.ERROR)
        try:
            if self.scheduler is not None:
                self.client = Client(self.scheduler, timeout="20s")
            else:
                self._cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True,
                                             dashboard_address=":0", silence_logs=logging.ERROR)
                self.client = Client(self._cluster)
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self.client is not None:
                self.client.close()
            if self._cluster is not None:
                self._cluster.close()
        finally:
            self.client = self._cluster = None
            for name, level in self._levels.items():
                logging.getLogger(name).setLevel(level)
            self._levels.clear()

    def run(self, fn: Callable[[dict, int], dict], tasks: list[Task]) -> Iterator[tuple[Task, object, str | None]]:
        """(task, result, None) or (task, None, error text) for every task, as they finish."""
        if self.serial:
            for task in tasks:
                for attempt in range(self.retries + 1):
                    try:
                        yield task, _call(fn, task.params, task.seed), None
                        break
                    except Exception as exc:  # noqa: BLE001 - a task's failure is a result here
                        if attempt == self.retries:
                            yield task, None, _error_text(exc)
            return
        if self.client is None:
            raise RuntimeError("Executor.run outside its with-block")
        from distributed import as_completed

        prefix = f"fxdsp-sweep-{uuid.uuid4().hex}"   # task keys only: nothing of it reaches a result
        futures = {self.client.submit(_call, fn, t.params, t.seed, key=f"{prefix}-{t.index}", pure=False,
                                      retries=self.retries): t for t in tasks}
        try:
            for fut in as_completed(futures):
                task = futures[fut]
                if fut.status == "finished":
                    yield task, fut.result(), None
                elif fut.status == "error":   # raised retries + 1 times, or its workers kept dying (KilledWorker)
                    yield task, None, _error_text(fut.exception())
                else:
                    # "lost": it finished, but the worker holding its result died before the
                    # result was fetched (another task killed it). The scheduler recomputes a
                    # key a client still holds, so wait for that rather than report a failure
                    try:
                        result, error = fut.result(), None
                    except Exception as exc:  # noqa: BLE001 - a task's failure is a result here
                        result, error = None, f"task {fut.status} by the cluster: {_error_text(exc)}"
                    yield task, result, error
                fut.release()
        finally:
            for fut in futures:
                if not fut.done():
                    fut.cancel()


# ----------------------------------------------------------------------------------------------
# A sweep: tasks numbered in the order they are asked for, journaled, returned in index order
# ----------------------------------------------------------------------------------------------
class Sweep:
    """One sweep of ``kind`` with ``settings`` (everything that determines its results: config,
    seed, grid). :meth:`map` may be called several times (the word-length search asks batch after
    batch); tasks are numbered across calls, so a deterministic caller asks the same tasks under
    the same numbers on every run and a resumed run finds them in the journal."""

    def __init__(self, kind: str, settings: dict, seed: int, executor: Executor, out: str | Path | None = None,
                 fresh: bool = False, progress=None):
        task_seed(seed, 0)  # validates the seed
        self.kind, self.settings, self.seed = kind, plain(settings), int(seed)
        self.executor, self.progress = executor, progress
        self.journal = Journal(Path(out) / JOURNAL, kind, {"seed": self.seed, "settings": self.settings},
                               fresh) if out is not None else None
        self.records: dict[int, dict] = {}
        self.next_index = 0
        self.resumed = 0      # tasks whose result came from the journal
        self.computed = 0

    @property
    def previous(self) -> int:
        """Results the journal held when the sweep started."""
        return len(self.journal.done) if self.journal else 0

    def map(self, fn: Callable[[dict, int], dict], params: Iterable[dict], desc: str | None = None) -> list[dict]:
        """Run ``fn(params, seed)`` for every params (a JSON-able dict); the records, in order:
        ``{"index", "seed", "params", "result"}`` or ``{..., "error"}``."""
        params = [plain(p) for p in params]
        tasks = [Task(i, task_seed(self.seed, i), p) for i, p in enumerate(params, start=self.next_index)]
        self.next_index += len(tasks)
        todo = []
        for t in tasks:
            old = self.journal.done.get(t.index) if self.journal else None
            if old is not None and old.get("seed") == t.seed and canonical(old.get("params")) == canonical(t.params):
                self.records[t.index] = old
                self.resumed += 1
            else:
                todo.append(t)
        bar = self.progress(total=len(tasks), initial=len(tasks) - len(todo), desc=desc or f"sweep {self.kind}",
                            unit="task") if self.progress and tasks else None
        try:
            for task, result, error in self.executor.run(fn, todo):
                rec = {"index": task.index, "seed": task.seed, "params": task.params}
                if error is None:
                    try:
                        canonical(result)
                        rec["result"] = result
                    except (TypeError, ValueError) as exc:
                        rec["error"] = f"result not JSON data: {exc}"
                else:
                    rec["error"] = error
                if self.journal:
                    self.journal.append(rec)
                self.records[task.index] = rec
                self.computed += 1
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
        return [self.records[t.index] for t in tasks]

    def failures(self) -> list[dict]:
        return [r for _, r in sorted(self.records.items()) if "error" in r]

    def results_text(self) -> str:
        """Every record, one canonical JSON line each, in index order (the ``results.jsonl`` file)."""
        return "".join(canonical(r) + "\n" for _, r in sorted(self.records.items()))

    def close(self) -> None:
        if self.journal:
            self.journal.close()


def failed_records(records: Iterable[dict]) -> list[dict]:
    """The failed tasks of ``records`` as a summary lists them: index, params and error."""
    return [{"index": r["index"], "params": r["params"], "error": r["error"]} for r in records if "error" in r]


def failure_line(rec: dict) -> str:
    """One line naming a failed task by its parameters."""
    return f"task {rec['index']} {canonical(rec['params'])}: {rec['error']}"
