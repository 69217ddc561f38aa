"""Per-stage latency of a cut event on skin patches of about 1k, 10k and 100k nodes.

The same 4 cm straight incision (tool radius 1 mm, 2 mm spacing) is cut into each patch
through the Cutter's API, one event every 0.33 mm of tool travel (2 cm/s at 60 cut events per
second), with the tissue at rest, so only the edit is timed. Repeated ``--repeats`` times;
the table gives the median over repeats of each run's p50 and p99 [ms]; ``total``: the whole
event (the sum of its stages), the figure the 3 ms (p50) and 15 ms (p99) targets are for.

    python benchmarks/bench_cut_latency.py [--repeats 3] [--out benchmarks/results]
"""

from __future__ import annotations

import argparse
import csv
import pathlib
import sys
import time

import numpy as np

from warp_cut import Simulator, TissueModel
from warp_cut.cut.settings import CutSettings
from warp_cut.cut.tally import STAGES
from warp_cut.sim.warp_config import quiet_warp

SIZES = {"1k": (0.07, 0.05), "10k": (0.22, 0.16), "100k": (0.70, 0.50)}


def one_run(size) -> tuple[int, dict]:
    model = TissueModel.from_patch(size, 0.002)
    sim = Simulator(model, dt=1e-3, gravity=None, cutting=CutSettings())
    cutter = sim.cutter
    y = 0.5 * (model.points[1, 1] - model.points[0, 1]) + 1e-4  # off the lattice rows
    start, end = np.array([-0.02, y, 0.0]), np.array([0.02, y, 0.0])
    cutter.start_incision(sim, start, [0, 0, 1], 0.001)
    steps = int(np.ceil(0.04 / 0.00033))
    for k in range(1, steps + 1):
        cutter.extend_incision(sim, start + (end - start) * k / steps)
    summary = cutter.latency_summary()
    total = cutter.event_latency_ms()
    summary["total"] = {"p50_ms": float(np.percentile(total, 50)), "p99_ms": float(np.percentile(total, 99)),
                        "events": int(len(total))}
    return model.active_node_count, summary


def run(quick: bool = False, repeats: int = 3, out=None) -> list[dict]:
    """Measure and write cut_latency.csv / .md (``quick``: one repeat)."""
    repeats = 1 if quick else repeats
    out = pathlib.Path(out or pathlib.Path(__file__).parent / "results")
    rows = []
    for label, size in SIZES.items():
        runs = []
        for _ in range(repeats):
            t = time.perf_counter()
            nodes, summary = one_run(size)
            runs.append(summary)
            print(f"{label}: {nodes} nodes, run {time.perf_counter() - t:.1f} s", file=sys.stderr)
        for stage in (*STAGES, "total"):
            p50 = [r[stage]["p50_ms"] for r in runs]
            p99 = [r[stage]["p99_ms"] for r in runs]
            rows.append({"patch": label, "nodes": nodes, "stage": stage,
                         "p50_ms_median": float(np.median(p50)), "p99_ms_median": float(np.median(p99)),
                         "p99_ms_min": float(np.min(p99)), "p99_ms_max": float(np.max(p99)),
                         "events": runs[0][stage]["events"], "repeats": repeats})
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "cut_latency.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = ["| patch | nodes | stage | p50 [ms] | p99 [ms] (median of repeats) | p99 range [ms] |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['patch']} | {r['nodes']} | {r['stage']} | {r['p50_ms_median']:.2f} | "
                     f"{r['p99_ms_median']:.2f} | {r['p99_ms_min']:.2f}-{r['p99_ms_max']:.2f} |")
    (out / "cut_latency.md").write_text("# Cut event latency per stage\n\n" + __doc__.split("\n\n")[1]
                                        + "\n\n" + "\n".join(lines) + "\n")
    print("\n".join(lines))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(pathlib.Path(__file__).parent / "results"))
    args = parser.parse_args(argv)
    quiet_warp()
    run(repeats=args.repeats, out=args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
