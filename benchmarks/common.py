"""Shared helpers of the benchmarks: timing with repeats, tables, the meshes measured."""

from __future__ import annotations

import argparse
import csv
import math
import os
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"


def timed(fn, calls: int) -> float:
    """Seconds per call of ``fn`` over ``calls`` calls (one measurement)."""
    start = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - start) / calls


def interleaved(fns: dict, calls: dict, repeats: int) -> dict:
    """Time each fn ``repeats`` times, interleaved (so machine load hits all alike). Each
    timing follows one untimed call, so no implementation pays for the caches the previous
    one left cold. Returns name -> array (repeats,) of seconds per call."""
    for fn in fns.values():  # compile, record
        fn()
    out = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            fn()
            out[name].append(timed(fn, calls[name]))
    return {name: np.array(v) for name, v in out.items()}


def spread(values) -> str:
    """'median (min-max)' of a sample."""
    v = np.asarray(values, dtype=float)
    return f"{np.median(v):.4g} ({v.min():.3g}-{v.max():.3g})"


def patch_for_springs(target: int):
    """(size, spacing) of a 5:3 skin patch with about ``target`` springs (3 per node)."""
    nodes = target / 3.0
    width = 0.10 * math.sqrt(nodes / 1890.0)  # the default patch: 1890 nodes at 2 mm
    return (width, 0.6 * width), 0.002


def write_csv(name: str, rows: list[dict]) -> Path:
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.csv"
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return path


def markdown_table(rows: list[dict], columns: list[str] | None = None) -> str:
    columns = columns or list(rows[0])
    def fmt(v):
        return f"{v:.4g}" if isinstance(v, float) else str(v)
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(fmt(r[c]) for c in columns) + " |" for r in rows]
    return "\n".join(lines)


def write_markdown(name: str, title: str, text: str) -> Path:
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.md"
    path.write_text(f"# {title}\n\n{text}\n")
    return path


@contextmanager
def pinned_to(cpu: int | None):
    """Run the block pinned to one CPU (the last allowed when None); yields it, or None where
    affinity cannot be set. The previous affinity is restored after."""
    if not hasattr(os, "sched_setaffinity"):
        yield None
        return
    before = os.sched_getaffinity(0)
    cpu = max(before) if cpu is None else cpu
    os.sched_setaffinity(0, {cpu})
    try:
        yield cpu
    finally:
        os.sched_setaffinity(0, before)


def pinned_cli(doc: str, quick_help: str, repeats_help: str, unpinned_help: str | None = None) -> argparse.Namespace:
    """The command line of a benchmark pinned to one CPU: --quick, --cpu N, --repeats N (>= 1),
    and with ``unpinned_help`` also --unpinned."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=quick_help)
    parser.add_argument("--cpu", type=int, default=None, help="CPU to pin the loop to (default: the last allowed)")
    parser.add_argument("--repeats", type=int, default=3, help=repeats_help)
    if unpinned_help is not None:
        parser.add_argument("--unpinned", action="store_true", help=unpinned_help)
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")
    return args
