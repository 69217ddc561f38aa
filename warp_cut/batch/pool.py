"""Batch runs: the scenarios of a sweep on a local process pool or a Dask cluster.

Both backends are ``concurrent.futures`` executors: a ``ProcessPoolExecutor`` here, or the
executor of a ``distributed.Client`` (``--scheduler tcp://host:port``). A worker runs one
scenario as ``warp-cut run BASE --set ...`` into a temporary directory and sends back the files
it wrote, so workers need no shared filesystem; this process alone writes ``DIR`` (see
``warp_cut.batch.store``).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import multiprocessing
import os
import signal
import socket
import sys
import tempfile
import threading
import time
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path

from tqdm import tqdm

from ..errors import InputError, SimulationUnstable
from ..runner import run_to_directory
from ..scene import load_scene
from ..sim.warp_config import quiet_warp
from .store import STATUSES, BatchStore
from .sweep import Sweep

__all__ = ["run_batch", "run_scenario", "BatchSummary", "STATUSES"]

CONNECT_TIMEOUT_S = 30.0
"""How long to try reaching a Dask scheduler before giving up [s]."""

POLL_S = 0.1
"""How often the batch looks for Ctrl-C while it waits for scenarios [s]."""


def _ignore_interrupt() -> None:
    """Initializer of a local worker: Ctrl-C is the batch's to handle (it stops the workers)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class _DeferredInterrupt:
    """Ctrl-C noted by a signal handler and raised only where the batch checks for it.

    A KeyboardInterrupt raised at any bytecode can land inside ``concurrent.futures`` while
    it holds a future's lock, or half-way through writing a result; the batch would then hang
    at exit or leave a half-written file. Here the handler only records the signal and
    ``check`` raises KeyboardInterrupt between two scenarios' results. Off the main thread
    (where no handler can be installed) it does nothing.
    """

    def __init__(self):
        self.raised = False
        self.previous = None

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGINT, self._note)
        return self

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
        return False

    def _note(self, signum, frame) -> None:
        self.raised = True

    def check(self) -> None:
        """Raise KeyboardInterrupt if Ctrl-C came since the batch started."""
        if self.raised:
            raise KeyboardInterrupt


def _scene_file(task: dict, tmp: Path) -> Path:
    """The base scene file on this worker.

    Args:
        task: The scenario task (see ``run_scenario``).
        tmp: A temporary directory of this worker.

    Returns:
        The sweep's own file when it is here unchanged, else a copy of the text it was sent
        under the same file name (so the same scene name).
    """
    original = Path(task["scene_path"])
    with contextlib.suppress(OSError):
        if original.is_file() and original.read_text(encoding="utf-8") == task["scene_text"]:
            return original
    copy = tmp / "scene" / original.name
    copy.parent.mkdir()
    copy.write_text(task["scene_text"], encoding="utf-8")
    return copy


def run_scenario(task: dict) -> dict:
    """Run one scenario (on a worker) exactly as ``warp-cut run SCENE --set ... --out TMP``.

    Args:
        task: ``{"scene_text": base scene TOML, "scene_path": its file (str), "overrides":
            [section.key=value, ...], "usd": write USD (bool, default True)}``.

    Returns:
        ``{"status", "message", "files": {relative path: bytes}, "worker_time_s", "host"}``;
        errors of the scenario become a status, never an exception, so one cannot stop the
        others.
    """
    start = time.perf_counter()
    outcome = {"status": "ok", "message": "", "files": {}, "host": socket.gethostname()}
    try:
        quiet_warp()
        with tempfile.TemporaryDirectory(prefix="warp-cut-run-") as tmp:
            out = Path(tmp) / "run"
            scene = load_scene(_scene_file(task, Path(tmp)), task["overrides"])
            run_to_directory(scene, out, usd=task.get("usd", True))
            outcome["files"] = {p.relative_to(out).as_posix(): p.read_bytes()
                                for p in sorted(out.rglob("*")) if p.is_file()}
            outcome["out_dir"] = str(out)
    except SimulationUnstable as exc:
        outcome.update(status="unstable", message=str(exc))
    except InputError as exc:
        outcome.update(status="failed", message=str(exc))
    except Exception as exc:  # noqa: BLE001 - any error of one scenario is recorded, not fatal
        outcome.update(status="failed", message=f"{type(exc).__name__}: {exc}")
    outcome["worker_time_s"] = time.perf_counter() - start
    return outcome


@dataclass
class BatchSummary:
    """Counts of a batch.

    Attributes:
        total: Scenarios in the sweep.
        skipped: Scenarios found finished in the output directory.
        counts: Status -> scenarios (found finished and run now).
        lost: (id, message) of scenarios whose worker was lost; they run again on the next call.
    """

    total: int
    skipped: int = 0
    counts: dict = field(default_factory=lambda: dict.fromkeys(STATUSES, 0))
    lost: list = field(default_factory=list)

    @property
    def all_ok(self) -> bool:
        """True if every scenario of the sweep finished with status ``ok``."""
        return self.counts["ok"] == self.total

    def line(self) -> str:
        """One-line summary: counts by status, lost scenarios."""
        parts = [f"{self.counts[s]} {s}" for s in STATUSES]
        if self.lost:
            parts.append(f"{len(self.lost)} lost (rerun to retry)")
        return (f"{self.total} scenarios ({self.skipped} already done): " + ", ".join(parts))


def _open_executor(workers: int | None, scheduler: str | None):
    """(executor, close) for the local pool or a Dask cluster.

    Raises:
        InputError: Dask is not installed, the scheduler cannot be reached, or workers < 1.
    """
    if scheduler:
        try:
            from distributed import Client  # noqa: PLC0415 - optional dependency (cluster extra)
        except ImportError:
            raise InputError("--scheduler needs Dask: pip install 'warp-cut[cluster]'") from None
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"--scheduler {scheduler}: cannot connect ({exc})") from exc

        def close(wait: bool) -> None:
            client.close()

        return client.get_executor(pure=False), close
    if workers is not None and workers < 1:
        raise InputError(f"--workers must be >= 1, got {workers}")
    workers = workers or os.cpu_count() or 1
    # spawn: a fresh interpreter per worker, never a fork of a process with Warp initialised
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                                  initializer=_ignore_interrupt)

    def close(wait: bool) -> None:
        processes = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=wait, cancel_futures=True)
        if not wait:  # interrupted: stop the scenarios still running (the interpreter's exit
            for process in processes:  # would otherwise wait for them to end)
                process.terminate()

    return pool, close


class _Progress:
    """done / failed / remaining: a tqdm bar on a terminal, else one line per scenario."""

    def __init__(self, total: int, done: int, failed: int, enabled: bool):
        self.total, self.done, self.failed = total, done, failed
        self.enabled = enabled
        self.bar = None
        if enabled and sys.stderr.isatty():
            self.bar = tqdm(total=total, initial=done, unit="scenario", desc="batch")
            self.bar.set_postfix_str(self._text())

    def _text(self) -> str:
        """``done N, failed N, remaining N``."""
        return f"done {self.done}, failed {self.failed}, remaining {self.total - self.done}"

    def update(self, scenario_id: str, status: str) -> None:
        """Count one finished scenario."""
        self.done += 1
        self.failed += status != "ok"
        if self.bar is not None:
            self.bar.set_postfix_str(self._text(), refresh=False)
            self.bar.update(1)
        elif self.enabled:
            print(f"[{self.done}/{self.total}] {status:8s} {scenario_id}  ({self._text()})",
                  file=sys.stderr, flush=True)

    def close(self) -> None:
        """Close the bar (if any)."""
        if self.bar is not None:
            self.bar.close()


def run_batch(sweep: Sweep, out_dir, *, workers: int | None = None, scheduler: str | None = None,
              retry_failed: bool = False, usd: bool = True, progress: bool = False) -> BatchSummary:
    """Run every scenario of ``sweep`` not already finished in ``out_dir``.

    Results land in ``out_dir`` as each scenario finishes; on KeyboardInterrupt the finished
    ones are kept and the rest are cancelled. A local worker process that dies breaks the
    pool, which fails every scenario it held: they run again on a fresh pool (see
    ``_run_scenarios``); a Dask cluster reschedules them itself.

    Args:
        sweep: The expanded sweep.
        out_dir: The batch output directory.
        workers: Local process pool size (default: the number of cores).
        scheduler: A Dask scheduler address, used instead of the pool.
        retry_failed: Run failed and unstable scenarios again.
        usd: The runs write USD (``warp-cut batch --no-usd`` turns it off).
        progress: Show done / failed / remaining on stderr.

    Returns:
        The counts of the batch.

    Raises:
        InputError: Bad options, or the directory is in use by another batch.
    """
    summary = BatchSummary(total=len(sweep.scenarios))
    store = BatchStore(out_dir, sweep)
    pool = _Executor(workers, scheduler)  # bad options fail before any write
    finished = False
    try:
        with store, _DeferredInterrupt() as interrupt:
            todo = store.load_finished(retry_failed=retry_failed)
            store.write_results()
            summary.skipped = summary.total - len(todo)
            for record in store.records.values():
                summary.counts[record["status"]] += 1
            bar = _Progress(summary.total, summary.skipped,
                            summary.skipped - summary.counts["ok"], progress)
            try:
                _run_scenarios(_Round(sweep, pool, store, summary, bar, usd, interrupt), todo)
            finally:
                bar.close()
        finished = True
    finally:
        pool.close(wait=finished)  # after Ctrl-C, do not wait for scenarios still running
    return summary


class _Executor:
    """The executor of ``_open_executor`` and its size, reopened when a local pool breaks."""

    def __init__(self, workers: int | None, scheduler: str | None):
        self.options = (workers, scheduler)
        self.size = workers or os.cpu_count() or 1
        self.executor, self.close = _open_executor(workers, scheduler)

    def reopen(self) -> None:
        self.close(wait=True)
        self.executor, self.close = _open_executor(*self.options)


@dataclass
class _Round:
    """What running a list of scenarios needs: where to send them and where results go."""

    sweep: Sweep
    pool: _Executor
    store: BatchStore
    summary: BatchSummary
    bar: _Progress
    usd: bool
    interrupt: _DeferredInterrupt

    def run(self, scenarios: list) -> list:
        """Submit ``scenarios``, commit each outcome as it arrives; return those failed by a
        broken local pool, in submission order (others a worker lost are recorded lost)."""
        futures, broken = {}, set()  # futures filled one by one: if a submit fails, those
        try:                          # already sent are cancelled
            for s in scenarios:
                futures[self.pool.executor.submit(run_scenario, {
                    "scene_text": self.sweep.base_text, "scene_path": str(self.sweep.base_path),
                    "overrides": self.sweep.overrides(s), "usd": self.usd})] = s
            for future in self._completed(futures):
                self.interrupt.check()
                self.collect(futures.pop(future), future, broken)
        finally:
            for future in futures:
                future.cancel()
        return [s for s in scenarios if s.id in broken]

    def _completed(self, futures: dict):
        """Yield ``futures`` as they finish (in submission order when several do at once),
        checking for Ctrl-C every ``POLL_S``."""
        pending = set(futures)
        order = {future: i for i, future in enumerate(futures)}
        while pending:
            done, pending = cf.wait(pending, timeout=POLL_S, return_when=cf.FIRST_COMPLETED)
            self.interrupt.check()
            yield from sorted(done, key=order.__getitem__)

    def collect(self, scenario, future, broken: set) -> None:
        """Commit the outcome of a finished ``future``, or note why it has none."""
        try:
            outcome = future.result()
        except BrokenProcessPool:
            broken.add(scenario.id)
        except Exception as exc:  # noqa: BLE001 - the worker, not the scenario, failed
            self.lost(scenario, f"{type(exc).__name__}: {exc}")
        else:
            self.store.commit(scenario, outcome)
            self.summary.counts[outcome["status"]] += 1
            self.bar.update(scenario.id, outcome["status"])

    def lost(self, scenario, message: str) -> None:
        self.summary.lost.append((scenario.id, message))
        self.bar.update(scenario.id, "lost")


def _run_scenarios(runner: _Round, todo: list) -> None:
    """Run ``todo``, replacing the local pool whenever a worker process dies.

    The pool runs scenarios in submission order, so when it breaks the first (size + 1) it
    had not finished are the ones that may have been running (or queued in a worker); each
    of these runs again alone on a fresh pool, so that a break then has one cause and that
    scenario is reported lost. The rest were waiting: they go round again with the others.
    """
    queue, suspects = list(todo), []
    while queue or suspects:
        alone = bool(suspects)
        if alone:
            scenarios = [suspects.pop(0)]
        else:
            scenarios, queue = queue, []
        broken = runner.run(scenarios)
        if not broken:
            continue
        runner.pool.reopen()
        if alone:
            runner.lost(broken[0], "BrokenProcessPool: its worker process died (it ran alone)")
            continue
        n = runner.pool.size + 1
        suspects, queue = suspects + broken[:n], broken[n:] + queue
