"""``make bench``: every benchmark, results in benchmarks/results/ (CSV, markdown, PNG).

    python benchmarks/run_all.py [--quick]

--quick measures the small sizes only (a smoke run). A full run takes a few minutes on one
CPU core.
"""

from __future__ import annotations

import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import warp as wp  # noqa: E402

from warp_cut.sim.warp_config import quiet_warp  # noqa: E402

quiet_warp()

import bench_background_quality  # noqa: E402
import bench_compile  # noqa: E402
import bench_cut_latency  # noqa: E402
import bench_event_travel  # noqa: E402
import bench_haptic  # noqa: E402
import bench_live  # noqa: E402
import bench_mesh_checks  # noqa: E402
import bench_pace  # noqa: E402
import bench_pareto  # noqa: E402
import bench_pareto_incision  # noqa: E402
import bench_realtime  # noqa: E402
import bench_stable_step  # noqa: E402
import bench_throughput  # noqa: E402
from common import RESULTS  # noqa: E402


def main(argv=None) -> int:
    quick = "--quick" in (argv if argv is not None else sys.argv[1:])
    wp.init()
    start = time.perf_counter()
    parts = [("throughput", bench_throughput), ("pareto (hanging sheet)", bench_pareto),
             ("pareto (incision width curve)", bench_pareto_incision),
             ("stable step", bench_stable_step), ("real time (skin patch)", bench_realtime),
             ("compile time", bench_compile), ("cut event latency", bench_cut_latency),
             ("cut events by travel", bench_event_travel),
             ("mesh checks", bench_mesh_checks), ("haptic rate (1 ms ticks)", bench_haptic),
             ("live cutting (warp-cut live)", bench_live), ("paced runs (--pace)", bench_pace),
             ("cut quality, cut in the background", bench_background_quality)]
    for name, module in parts:
        print(f"{name}:", flush=True)
        module.run(quick=quick)
    write_summary(time.perf_counter() - start)
    print(f"results in {RESULTS}")
    return 0


def write_summary(seconds: float | None = None) -> None:
    """results/summary.md: the machine and every benchmark's markdown, in one page."""
    device = wp.get_device("cpu")
    summary = [f"Machine: {platform.processor() or platform.machine()}, {device.name}, "
               f"Python {platform.python_version()}, Warp {wp.__version__}."]
    if seconds is not None:
        summary.append(f"Total benchmark time: {seconds:.0f} s.")
    summary.append("")
    for md in ("throughput", "realtime", "pareto_hanging_sheet", "stable_step", "compile", "mesh_checks",
               "haptic"):
        summary.append((RESULTS / f"{md}.md").read_text())
    (RESULTS / "summary.md").write_text("\n".join(summary))


if __name__ == "__main__":
    sys.exit(main())
