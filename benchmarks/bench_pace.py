"""Paced runs: how close ``warp-cut run --cut-in-background --pace X`` gets to X times real time.

    python benchmarks/bench_pace.py [--quick] [--repeats 3]

The pacer holds the loop to X steps per step dt of wall time, so a run is never faster than
X times real time (``tests/test_cli.py`` checks that, and that every tick waits for its
deadline). How much of X a run reaches depends on the machine and its load: a tick whose step
takes longer than dt / X falls behind. That is measured here, not asserted in a test.

The straight incision on a 3 x 2 cm patch (the CLI test's run) and on the scene's own
10 x 6 cm patch, 0.5 s simulated, cut in a worker, paced at 1x, 3x and 10x real time. Writes
results/pace.csv and results/pace.md with the load average before and after.
"""

from __future__ import annotations

import argparse
import os

import numpy as np
from common import markdown_table, write_csv, write_markdown

from warp_cut.runner import run_scene
from warp_cut.scene import load_scene
from warp_cut.sim.warp_config import quiet_warp

PATCHES = {"3 x 2 cm": ["tissue.size=[0.03,0.02]"], "10 x 6 cm": []}
"""Patch label -> scene overrides of the straight incision."""
PACES = (1.0, 3.0, 10.0)
DURATION = 0.5
"""Simulated time of each run [s]."""


def paced_run(overrides: list[str], pace: float) -> dict:
    """The metrics of one paced run with the cut in a worker."""
    scene = load_scene("straight_incision", overrides + [f"duration={DURATION}"])
    return run_scene(scene, cut_in_background=True, pace=pace).metrics


def measure(patch: str, pace: float, repeats: int) -> dict:
    runs = [paced_run(PATCHES[patch], pace) for _ in range(repeats)]
    factors = np.array([m["realtime_factor"] for m in runs])
    return {"patch": patch, "nodes": runs[0]["nodes"], "pace": pace,
            "realtime_factor_median": float(np.median(factors)),
            "realtime_min": float(factors.min()), "realtime_max": float(factors.max()),
            "share_of_pace": float(np.median(factors) / pace),
            "tick_p99_ms": float(np.median([m["tick_ms"]["p99"] for m in runs])),
            "ticks_over_budget": int(np.median([m["tick_ms"]["over_budget"] for m in runs])),
            "incisions": int(min(m["cut"]["incisions"] for m in runs)), "repeats": repeats}


def run(quick: bool = False, repeats: int = 3) -> list[dict]:
    load_before = os.getloadavg()
    rows = []
    for patch in (("3 x 2 cm",) if quick else tuple(PATCHES)):
        for pace in PACES:
            row = measure(patch, pace, 1 if quick else repeats)
            rows.append(row)
            print(f"  {patch}, pace {pace:g}: {row['realtime_factor_median']:.3g} x real time "
                  f"({row['share_of_pace']:.0%} of the pace)", flush=True)
    load_after = os.getloadavg()
    write_csv("pace", rows)
    write_markdown("pace", "Paced runs: the real-time factor a pace reaches", _report(rows, load_before, load_after))
    return rows


def _report(rows: list[dict], load_before, load_after) -> str:
    loads = ", ".join(f"{v:.2f}" for v in load_before), ", ".join(f"{v:.2f}" for v in load_after)
    return (f"`warp-cut run straight_incision --cut-in-background --pace X`, {DURATION:g} s simulated, "
            "median (min, max) over `repeats` runs. `realtime_factor`: simulated over wall time of "
            "the stepping; the pacer caps it at `pace`; `share_of_pace`: the median over the pace. "
            "`tick_p99_ms`, `ticks_over_budget`: the steps' wall times against the step dt (1 ms), "
            "not dt / X. A pace the machine cannot keep shows as a share below 1.\n\n"
            f"Load average (1, 5, 15 min) {loads[0]} before and {loads[1]} after (2 cores).\n\n"
            + markdown_table(rows))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the small patch, one run each")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    quiet_warp()
    run(quick=args.quick, repeats=args.repeats)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
