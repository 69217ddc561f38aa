"""Batch runs: wall time of a 16-scenario sweep on 1 and 2 workers, local pool against Dask.

    .venv/bin/python benchmarks/bench_batch.py      # writes benchmarks/results/bench_batch.{csv,md}

* ``press``: 16 scenarios (a 4 x 4 grid of stiffness and damping) of the full press scene
  (10 x 6 cm patch, 1 s simulated; about a second of work each here, USD and pictures
  included), on 1 and 2 workers: the speed-up.
* ``tiny16`` and ``tiny64``: 16 and 64 scenarios of a 2 x 2 cm patch for 10 ms (the work is
  then mostly the run's pictures and USD), on 1 worker. ``wall = start + N (work + overhead)``, so the
  difference of the two gives the marginal cost of a scenario beyond its own work:
  ``overhead per scenario = ((wall64 - wall16) - (work64 - work16)) / 48``, and what is left of
  wall16 is the fixed start-up (process start or scheduler connection, imports, kernel loads).

Each runs on the local process pool and on a Dask ``LocalCluster`` (processes, one thread each,
loopback), as Dask comes (``dask``) and with the workers' statistical profiler off
(``dask-noprofile``; it samples the running thread every 10 ms, which slows a loop of many
short kernel launches from Python). ``wall_s`` is the whole ``run_batch`` call; the cluster's own start-up is reported
apart (a real cluster is already up). ``work_s`` sums the time workers spent inside
``run_scenario`` (scene, run, outputs). Every measurement is repeated and the fastest kept,
since the machine may be shared; the 1-minute load average is recorded beside it.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

from warp_cut.batch.pool import run_batch
from warp_cut.batch.store import BatchStore
from warp_cut.batch.sweep import load_sweep
from warp_cut.io.files import atomic_path, write_csv

RESULTS = Path(__file__).resolve().parent / "results"
_TINY = '[set]\n"tissue.size" = [0.02, 0.02]\nduration = 0.01\n'
SWEEPS = {
    "press": ('base = "skin_press"\n[grid]\n"material.stiffness" = [80.0, 120.0, 160.0, 240.0]\n'
              '"material.damping" = [1.0, 2.0, 3.0, 4.0]\n', (1, 2)),
    "tiny16": ('base = "skin_press"\n' + _TINY + '[grid]\n"material.stiffness" = [80.0, 120.0, 160.0, 240.0]\n'
               '"material.damping" = [1.0, 2.0, 3.0, 4.0]\n', (1,)),
    "tiny64": ('base = "skin_press"\n' + _TINY + '[grid]\n"material.stiffness" = '
               '[60.0, 80.0, 100.0, 120.0, 160.0, 200.0, 240.0, 320.0]\n'
               '"material.damping" = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]\n', (1,)),
}
"""name -> (sweep file text, worker counts)"""
BACKENDS = ("pool", "dask", "dask-noprofile")
COLUMNS = ["sweep", "backend", "workers", "scenarios", "wall_s", "work_s", "cluster_start_s",
           "load_avg_1min"]


def _work_seconds(out: Path, sweep) -> float:
    store = BatchStore(out, sweep)
    with store:
        store.load_finished()
    return sum(r["worker_time_s"] for r in store.records.values())


def _once(sweep_path: Path, backend: str, workers: int, out: Path) -> dict:
    sweep = load_sweep(sweep_path)
    cluster, start_s = None, None
    load = os.getloadavg()[0]
    try:
        if backend.startswith("dask"):
            import dask
            from distributed import LocalCluster

            t0 = time.perf_counter()
            with dask.config.set({"distributed.worker.profile.enabled": backend == "dask"}):
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=None)
            start_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        summary = run_batch(sweep, out, workers=None if cluster else workers,
                            scheduler=cluster.scheduler_address if cluster else None)
        wall = time.perf_counter() - t0
    finally:
        if cluster is not None:
            cluster.close()
    if not summary.all_ok:
        raise SystemExit(f"{sweep_path.stem}/{backend}/{workers}: {summary.line()}")
    return {"sweep": sweep_path.stem, "backend": backend, "workers": workers,
            "scenarios": len(sweep.scenarios), "wall_s": wall, "work_s": _work_seconds(out, sweep),
            "cluster_start_s": start_s, "load_avg_1min": load}


def _row(rows, sweep, backend, workers):
    return next((r for r in rows if (r["sweep"], r["backend"], r["workers"]) == (sweep, backend, workers)), None)


def _markdown(rows: list[dict], repeats: int) -> str:
    lines = [f"# Batch runs: local process pool against Dask ({os.cpu_count()} cores, "
             f"Python {platform.python_version()}; fastest of {repeats})", "",
             "| sweep | backend | workers | scenarios | wall [s] | work in workers [s] "
             "| cluster start [s] | load avg |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        start = f"{r['cluster_start_s']:.2f}" if r["cluster_start_s"] is not None else "-"
        lines.append(f"| {r['sweep']} | {r['backend']} | {r['workers']} | {r['scenarios']} | "
                     f"{r['wall_s']:.2f} | {r['work_s']:.2f} | {start} | {r['load_avg_1min']:.1f} |")
    lines.append("")
    for backend in BACKENDS:
        one, two = _row(rows, "press", backend, 1), _row(rows, "press", backend, 2)
        if one and two:
            lines.append(f"- press, {backend}: 1 worker {one['wall_s']:.2f} s, 2 workers "
                         f"{two['wall_s']:.2f} s, speed-up {one['wall_s'] / two['wall_s']:.2f}x")
        a, b = _row(rows, "tiny16", backend, 1), _row(rows, "tiny64", backend, 1)
        if a and b:
            per = ((b["wall_s"] - a["wall_s"]) - (b["work_s"] - a["work_s"])) / (b["scenarios"] - a["scenarios"])
            start = a["wall_s"] - a["work_s"] - a["scenarios"] * per
            lines.append(f"- {backend}: overhead per scenario {1e3 * per:.1f} ms beyond its work; "
                         f"fixed start-up {start:.2f} s")
    lines += ["", "The machine may be shared with other work: `load avg` is the 1-minute load average "
                  "when the kept run started (this batch's own workers count in it). Run it again to "
                  "see the spread.", "",
              "Made by `.venv/bin/python benchmarks/bench_batch.py`; definitions in its docstring."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sweeps", nargs="+", default=list(SWEEPS), choices=list(SWEEPS))
    parser.add_argument("--backends", nargs="+", default=list(BACKENDS), choices=BACKENDS)
    parser.add_argument("--repeats", type=int, default=3, help="keep the fastest of this many")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-batch-") as tmp:
        tmp = Path(tmp)
        for name in args.sweeps:
            text, worker_counts = SWEEPS[name]
            sweep_path = tmp / f"{name}.toml"
            sweep_path.write_text(text)
            for backend in args.backends:
                for workers in worker_counts:
                    runs = [_once(sweep_path, backend, workers, tmp / f"{name}-{backend}-{workers}-{k}")
                            for k in range(args.repeats)]
                    best = min(runs, key=lambda r: r["wall_s"])
                    print(" ".join(f"{k}={v:.3f}" if isinstance(v, float) else f"{k}={v}"
                                   for k, v in best.items()), file=sys.stderr, flush=True)
                    rows.append(best)
    write_csv(args.out / "bench_batch.csv", COLUMNS, ([r[c] for c in COLUMNS] for r in rows))
    with atomic_path(args.out / "bench_batch.md") as tmp_md:
        tmp_md.write_text(_markdown(rows, args.repeats), encoding="utf-8")
    print(_markdown(rows, args.repeats))
    return 0


if __name__ == "__main__":
    sys.exit(main())
