"""Would a cut edit prepared on a thread beside the 1 kHz loop keep the ticks on time?

The loop steps the README's patch (10 x 6 cm, 2 mm, Table 1) with the scalpel pressed in, one
``sim.step`` per 1 ms tick, while a second thread of the same process does what a cut edit's host
work does: small numpy operations and Python bookkeeping, without pause. Each tick's wall time is
measured with and without that thread, for several ``sys.setswitchinterval`` values (how long a
thread may hold the interpreter lock before it is asked to give it up). Writes
``benchmarks/results/edit_thread.md`` (+ .csv).

    python benchmarks/bench_edit_thread.py
"""

from __future__ import annotations

import csv
import sys
import threading
import time
from pathlib import Path

import numpy as np
import warp as wp

import warp_cut as wc

HERE = Path(__file__).resolve().parent
TICKS = 1000
AXIS = np.array([-0.5, 0.0, 0.866])


def tool(k: int) -> wc.Tool:
    """The scalpel going 4 mm in along its axis over 200 ticks, then held."""
    tip = np.array([0.0, 0.0, 0.004]) - min(k, 200) / 200 * 0.004 * AXIS
    return wc.Tool(p0=tip, p1=tip + 0.04 * AXIS, radius=0.001)


def host_work(stop: threading.Event) -> None:
    """Python-bound work like a cut edit's (many small numpy calls), until ``stop``."""
    rng = np.random.default_rng(0)
    x = rng.random((200, 3))
    while not stop.is_set():
        for _ in range(200):
            a = x[rng.integers(0, 200, 3)]
            np.cross(a[1] - a[0], a[2] - a[0])


def run(switch_s: float, beside: bool) -> dict:
    """Tick wall times [ms] of TICKS one-step calls at 1 kHz, with or without the thread."""
    sys.setswitchinterval(switch_s)
    sim = wc.Simulator(wc.TissueModel.from_patch((0.10, 0.06), 0.002), dt=1e-3)
    for k in range(50):
        sim.step(tool=tool(k))
    stop = threading.Event()
    worker = threading.Thread(target=host_work, args=(stop,), daemon=True)
    if beside:
        worker.start()
    ticks = []
    for k in range(50, 50 + TICKS):
        start = time.perf_counter()
        sim.step(tool=tool(k))
        ticks.append(1e3 * (time.perf_counter() - start))
        while time.perf_counter() - start < 1e-3:
            pass
    stop.set()
    if beside:
        worker.join()
    t = np.asarray(ticks)
    return {"switch_interval_ms": 1e3 * switch_s, "thread_beside": "yes" if beside else "no",
            "tick_p50_ms": float(np.percentile(t, 50)), "tick_p99_ms": float(np.percentile(t, 99)),
            "tick_max_ms": float(t.max()), "ticks_over_1ms": int((t > 1.0).sum()), "ticks": TICKS}


def main() -> int:
    wp.config.quiet = True
    default = sys.getswitchinterval()
    rows = [run(default, False)] + [run(s, True) for s in (0.005, 0.0005, 0.0001)]
    sys.setswitchinterval(default)
    out = HERE / "results" / "edit_thread"
    with open(out.with_suffix(".csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = ["# A cut edit on a thread beside the 1 kHz loop", "",
             __doc__.split("\n\n")[1].replace("\n", " "), "",
             "| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0])]
    lines += ["| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in r.values()) + " |"
              for r in rows]
    lines += ["", "Command: `python benchmarks/bench_edit_thread.py`."]
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    for r in rows:
        print(r)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
