"""The output directory of a batch: one run directory per finished scenario, and results.csv.

Layout of ``DIR``::

    batch.json            the sweep file, its parameters and scenario count
    results.csv           one row per finished scenario (rewritten as each one finishes)
    runs/<id>/            what ``warp-cut run`` writes, plus scenario.json (status, message,
                          parameters, overrides); a failed scenario holds scenario.json only
    .lock                 held while a batch writes here

A run directory is filled under a hidden temporary name and renamed when complete, so
``runs/<id>`` exists only whole; results.csv is rebuilt from the run directories, so it
can never disagree with them for long (an interrupted batch leaves both consistent).
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import tempfile
from pathlib import Path

from ..errors import InputError
from ..io.files import write_csv, write_json
from ..scene import apply_overrides
from .sweep import Scenario, Sweep, toml_value

__all__ = ["BatchStore", "flatten_metrics", "STATUSES", "RECORD_FILE", "RESULTS_FILE",
           "MANIFEST_FILE"]

STATUSES = ("ok", "failed", "unstable")
"""Status of a finished scenario: ran to the end / bad input or an error / numerically unstable."""

RECORD_FILE = "scenario.json"
"""Record of one scenario in its run directory: parameters, status, message, overrides, command."""
RESULTS_FILE = "results.csv"
"""One row per finished scenario, in sweep order."""
MANIFEST_FILE = "batch.json"
"""The sweep file, base scene, swept parameters and scenario count."""
_TEMP_PREFIXES = (".tmp-", ".old-")
_SKIPPED_METRICS = {"name", "scene_file", "usd_file"}


def flatten_metrics(metrics: dict, prefix: str = "") -> dict:
    """Scalar metrics by dotted name, for one results.csv row.

    Nested tables (``cut.deleted_nodes``) are flattened; short lists of scalars become
    ``key.0``, ``key.1``, ...; long lists and the run's name and file paths (scene, USD) are
    left out.

    Args:
        metrics: A run's metrics.json content.
        prefix: Prefix of every name (used for nested tables).

    Returns:
        Dotted name -> scalar (number, string or None).
    """
    flat: dict = {}
    for key, value in metrics.items():
        name = f"{prefix}{key}"
        if not prefix and key in _SKIPPED_METRICS:
            continue
        if isinstance(value, dict):
            flat.update(flatten_metrics(value, f"{name}."))
        elif isinstance(value, list):
            if len(value) <= 4 and all(v is None or isinstance(v, (int, float)) for v in value):
                flat.update({f"{name}.{n}": v for n, v in enumerate(value)})
        elif value is None or isinstance(value, (int, float, str)):
            flat[name] = value
    return flat


def _umask() -> int:
    """The process's file mode creation mask."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _relocate(metrics_json: bytes, worker_out: str | None, run_dir: str) -> bytes:
    """metrics.json with paths into the worker's output directory (``usd_file``, say) pointed
    at the run directory the files now live in.

    Args:
        metrics_json: The worker's metrics.json bytes.
        worker_out: The worker's output directory (None: nothing to move).
        run_dir: The run directory in the batch output.

    Returns:
        The metrics.json bytes to write.
    """
    if not worker_out:
        return metrics_json

    def move(value):
        if isinstance(value, dict):
            return {k: move(v) for k, v in value.items()}
        if isinstance(value, list):
            return [move(v) for v in value]
        if isinstance(value, str) and (value == worker_out or value.startswith(worker_out + os.sep)):
            return run_dir + value[len(worker_out):]
        return value

    return (json.dumps(move(json.loads(metrics_json)), indent=2) + "\n").encode("utf-8")


def _lookup(data: dict, key: str):
    """The value at dotted ``key`` in nested tables, or None."""
    node = data
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


class BatchStore:
    """The files of one batch output directory (see the module docstring).

    Open it as a context manager: it takes the directory's lock (another batch writing to
    the same directory is an InputError) and removes temporaries an interrupted batch left.

    Args:
        out_dir: The batch output directory.
        sweep: The sweep it holds.

    Attributes:
        root: The output directory.
        runs: Its ``runs/`` directory.
        sweep: The sweep.
        records: Scenario id -> record of each finished scenario (with its metrics if ok).

    Raises:
        InputError: ``out_dir`` exists and is not a directory, or another batch holds its lock.
    """

    def __init__(self, out_dir, sweep: Sweep):
        self.root = Path(out_dir)
        self.runs = self.root / "runs"
        self.sweep = sweep
        self.records: dict[str, dict] = {}
        self._lock = None
        if self.root.exists() and not self.root.is_dir():
            raise InputError(f"--out {self.root}: exists and is not a directory")

    def __enter__(self) -> BatchStore:
        self.runs.mkdir(parents=True, exist_ok=True)
        self._lock = open(self.root / ".lock", "w")
        try:
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._lock.close()
            raise InputError(f"--out {self.root}: another warp-cut batch is writing there") from None
        for entry in self.runs.iterdir():
            if entry.name.startswith(_TEMP_PREFIXES):
                shutil.rmtree(entry, ignore_errors=True)
        write_json(self.root / MANIFEST_FILE, {
            "sweep": str(self.sweep.path), "base": str(self.sweep.base_path),
            "parameters": self.sweep.parameters, "scalar_parameters": self._scalar_parameters(),
            "scenarios": len(self.sweep.scenarios),
            "results": RESULTS_FILE})
        return self

    def _scalar_parameters(self) -> list[str]:
        """Swept keys whose values are all scalars (the ones a plot can use as an axis)."""
        return [k for k in self.sweep.parameters
                if not any(isinstance(s.params.get(k), (list, dict)) for s in self.sweep.scenarios)]

    def __exit__(self, *exc) -> None:
        self._lock.close()  # closing releases the lock

    def load_finished(self, *, retry_failed: bool = False) -> list[Scenario]:
        """Read the run directories of this sweep into ``records``.

        A run directory counts as finished when its record matches the scenario's current
        fingerprint (base scene, overrides, repeat).

        Args:
            retry_failed: Only successes count as finished.

        Returns:
            The scenarios still to run, in sweep order.
        """
        todo = []
        for scenario in self.sweep.scenarios:
            record = self._read_record(scenario)
            if record is None or (retry_failed and record["status"] != "ok"):
                todo.append(scenario)
            else:
                self.records[scenario.id] = record
        return todo

    def _read_record(self, scenario: Scenario) -> dict | None:
        """The scenario's record if its run directory is finished and current, else None."""
        run = self.runs / scenario.id
        with contextlib.suppress(OSError, ValueError, KeyError, TypeError):
            record = json.loads((run / RECORD_FILE).read_text(encoding="utf-8"))
            if (record["fingerprint"] != self.sweep.fingerprint(scenario)
                    or record["status"] not in STATUSES):
                return None
            if record["status"] == "ok":
                record["metrics"] = json.loads((run / "metrics.json").read_text(encoding="utf-8"))
            return record
        return None

    def commit(self, scenario: Scenario, outcome: dict) -> dict:
        """Write a finished scenario's run directory atomically and rewrite results.csv.

        Args:
            scenario: The scenario.
            outcome: What ``run_scenario`` returned (status, message, files, worker_time_s,
                host).

        Returns:
            The record kept for results.csv.

        Raises:
            ValueError: An output file would land outside the run directory.
        """
        record = {
            "id": scenario.id, "rep": scenario.rep, "params": scenario.params,
            "status": outcome["status"], "message": outcome["message"],
            "fingerprint": self.sweep.fingerprint(scenario),
            "base": "inline" if self.sweep.base_inline else str(self.sweep.base_path),
            "overrides": self.sweep.overrides(scenario), "command": self.sweep.command(scenario),
            "worker_time_s": outcome.get("worker_time_s"), "host": outcome.get("host"),
        }
        tmp = Path(tempfile.mkdtemp(prefix=f".tmp-{scenario.id[:40]}-", dir=self.runs))
        try:
            os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp's private 0700 is not meant for results
            files = dict(outcome.get("files", {}))
            if "metrics.json" in files:
                files["metrics.json"] = _relocate(files["metrics.json"], outcome.get("out_dir"),
                                                  str(self.runs / scenario.id))
            for name, data in files.items():
                target = (tmp / name).resolve()
                if tmp.resolve() not in target.parents:
                    raise ValueError(f"{scenario.id}: output file {name!r} is outside its run directory")
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(data)
            write_json(tmp / RECORD_FILE, record)
            self._replace(tmp, self.runs / scenario.id)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        if record["status"] == "ok":
            record["metrics"] = json.loads(files["metrics.json"])
        self.records[scenario.id] = record
        self.write_results()
        return record

    def _replace(self, tmp: Path, target: Path) -> None:
        """Move the finished directory ``tmp`` onto ``target``, replacing a stale run."""
        if not target.exists():
            os.rename(tmp, target)
            return
        # a stale run (its scene changed, or a retried failure) is swapped out, then removed
        old = Path(tempfile.mkdtemp(prefix=".old-", dir=self.runs))
        os.rename(target, old / "run")
        os.rename(tmp, target)
        shutil.rmtree(old, ignore_errors=True)

    def write_results(self) -> Path:
        """Rewrite results.csv atomically: finished scenarios in sweep order.

        Returns:
            The path of results.csv.
        """
        params = self.sweep.parameters
        base = self._base_values()
        rows, metric_names = [], {}
        for scenario in self.sweep.scenarios:
            record = self.records.get(scenario.id)
            if record is None:
                continue
            flat = flatten_metrics(record.get("metrics") or {})
            metric_names.update(dict.fromkeys(flat))
            values = [self._cell(scenario.params[k]) if k in scenario.params else base[k]
                      for k in params]
            rows.append(([scenario.id, record["status"], *values, scenario.rep], flat,
                         [record.get("worker_time_s"), record["message"]]))
        names = list(metric_names)
        header = ["id", "status", *params, "rep", *names, "worker_time_s", "message"]
        path = self.root / RESULTS_FILE
        write_csv(path, header, (head + [flat.get(n) for n in names] + tail
                                 for head, flat, tail in rows))
        return path

    def _base_values(self) -> dict:
        """Each swept key's value in the base scene after ``[set]`` ('' where the scene
        default applies)."""
        data = apply_overrides(self.sweep.base_data, list(self.sweep.settings), self.sweep.path)
        return {k: self._cell(_lookup(data, k)) for k in self.sweep.parameters}

    @staticmethod
    def _cell(value):
        """A parameter value as a results.csv cell (lists and tables in TOML form, None as '')."""
        if value is None:
            return ""
        return toml_value(value) if isinstance(value, (list, dict)) else value
