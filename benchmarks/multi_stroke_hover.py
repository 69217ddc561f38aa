"""Multi-stroke sets with the tool left hovering near the skin after every stroke.

Each stroke of ``multi_stroke.py``'s T, X, excision, recut and tight arc, on the cylinder, the
dome, the brain mesh, the Delaunay disk and the flat grid with the tool lowered straight down,
is followed by ``HOVER`` seconds with the tool held at its lifted pose (0.5 mm clear of every
node) before it is let go. Holes are counted while it hovers (border loops beyond one per
incision) and after; every invariant is checked after every edit.

    python benchmarks/multi_stroke_hover.py

Prints one line per stroke (mesh, set, stroke, events, hard violations, exception, holes while
hovering, holes after, coverage, smallest rest / current angle of the cut's triangles, wound
against, folded, island) and the totals.
"""

from __future__ import annotations

import math

import multi_stroke as ms
import numpy as np

from warp_cut.mesh.triangulate import border_loop_count
from warp_cut.verify.cut_judge import judge
from warp_cut.verify.stroke_check import run_stroke

HOVER = 0.3
"""How long [s] the tool hovers at its lifted pose after each stroke."""
MESHES = ("cylinder", "dome", "brain", "flat_lowered", "delaunay")
SETS = ("t", "x", "excision", "recut", "tight_arc")


class Hovering:
    """A stroke followed by ``HOVER`` seconds at its last (lifted) pose."""

    def __init__(self, stroke):
        self.stroke = stroke
        self.duration = stroke.duration + HOVER

    def pose(self, t):
        return self.stroke.pose(min(t, self.stroke.duration))

    def __getattr__(self, name):
        return getattr(self.stroke, name)


class HoleCount:
    """A post-step hook: the holes (border loops beyond one per incision) at the last step of
    the hover, while the tool is still there."""

    def __init__(self, sim, end_time: float):
        self.end_time, self.holes = end_time, None
        self.loops, self.incisions = border_loop_count(sim.model.triangles), len(sim.cutter.incisions)

    def __call__(self, sim) -> None:
        if self.holes is None and sim.time >= self.end_time - 0.5 * sim.dt - 1e-12:
            added = len(sim.cutter.incisions) - self.incisions
            self.holes = max(0, border_loop_count(sim.model.triangles) - self.loops - added)


def run_set(mesh: str, set_name: str) -> list[tuple]:
    """One row per stroke of ``set_name`` cut into ``mesh`` with a hover after each."""
    surface, incisions, sim, base, border = ms.make_case(mesh, set_name)
    rows = []
    for k, stroke in enumerate(incisions.strokes):
        count = HoleCount(sim, sim.time + stroke.duration + HOVER)
        sim.post_step_hooks.append(count)
        result = run_stroke(sim, Hovering(stroke), surface, border_keys=border, check=True)
        sim.post_step_hooks.remove(count)
        last = k == len(incisions.strokes) - 1
        j = judge(sim.model, sim.positions, surface, base, wounds=incisions.wounds[k],
                  outline=incisions.island_outline if last else None).as_row()
        hard = sum(1 for name in result.violations if not name.startswith("tri_flipped"))
        rows.append((mesh, set_name, k, result.events, hard, result.exception is not None, count.holes,
                     result.unfilled_holes, result.coverage, j["min_rest_angle_deg"], j["min_current_angle_deg"],
                     j["wound_against"], j["folded"], j.get("island", "")))
        print(*[f"{v:.3f}" if isinstance(v, float) else v for v in rows[-1]], flush=True)
    return rows


def main() -> None:
    rows = [row for mesh in MESHES for set_name in SETS for row in run_set(mesh, set_name)]
    later = [r[8] for r in rows if r[2] > 0 and r[1] != "recut" and not math.isnan(r[8])]
    print(f"strokes {len(rows)}, events {sum(r[3] for r in rows)}, hard violations {sum(r[4] for r in rows)}, "
          f"exceptions {sum(r[5] for r in rows)}, holes while hovering {sum(r[6] for r in rows)}, holes after "
          f"{sum(r[7] for r in rows)}, later strokes' coverage median {np.median(later):.3f} (min {min(later):.3f}), "
          f"smallest angle at rest {min(r[9] for r in rows):.1f} deg, as the skin lies {min(r[10] for r in rows):.1f} "
          f"deg, wound against {sum(r[11] for r in rows)}, folded {sum(r[12] for r in rows)}")


if __name__ == "__main__":
    main()
