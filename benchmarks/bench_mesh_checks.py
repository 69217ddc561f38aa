"""Cost of the mesh checks (warp_cut.mesh.checks.check_mesh) against mesh size.

check_mesh runs after every cut in the tests and at the end of every run, so its cost must
grow linearly with the mesh (it is vectorised: sorts and bincounts, no Python loops over
elements). Meshes: a square grid of nodes in the XY plane, each cell split into two CCW
triangles, springs = the triangle edges, every check on (masses, total mass, reference
normal). Time per call: median (min-max) over repeats, interleaved across sizes so machine
load hits all alike. The growth exponent is the slope of log(time) against log(triangles)
between neighbouring sizes (1 = linear; numpy's sorts add a log factor, ~1.05-1.1).

    python benchmarks/bench_mesh_checks.py [--quick]

Results: benchmarks/results/mesh_checks.csv and .md.
"""

from __future__ import annotations

import math
import os
import sys
import time

import numpy as np
from common import markdown_table, write_csv, write_markdown

from warp_cut.mesh.checks import check_mesh
from warp_cut.mesh.geometry import edges_of

SIDES = (23, 71, 225, 709)
"""Nodes per grid side: ~1k, 10k, 100k, 1M triangles."""


def grid(side: int, h: float = 1e-3) -> dict:
    """A side x side node grid [m] with 2 (side - 1)^2 triangles and its edge springs."""
    j, i = np.divmod(np.arange(side * side), side)
    points = np.column_stack([i * h, j * h, np.zeros(side * side)])
    v00 = (np.arange(side - 1)[None, :] + side * np.arange(side - 1)[:, None]).ravel()
    v10, v01, v11 = v00 + 1, v00 + side, v00 + side + 1
    triangles = np.concatenate([np.column_stack([v00, v10, v11]), np.column_stack([v00, v11, v01])])
    return dict(points=points, triangles=triangles, springs=edges_of(triangles),
                masses=np.full(len(points), 1e-4))


def check(mesh: dict):
    return check_mesh(mesh["points"], mesh["triangles"], mesh["springs"], masses=mesh["masses"],
                      expected_total_mass=1e-4 * len(mesh["points"]), reference_normal=(0, 0, 1))


def run(quick: bool = False) -> list[dict]:
    sides = SIDES[:3] if quick else SIDES
    repeats = 3 if quick else 5
    load = os.getloadavg()[0]
    meshes = {side: grid(side) for side in sides}
    for mesh in meshes.values():  # correctness first: a slow check that is wrong measures nothing
        report = check(mesh)
        if not (report.valid and abs(report.min_angle_deg - 45.0) < 1e-9):
            raise AssertionError(f"benchmark mesh invalid: {report.summary()}")
    times = {side: [] for side in sides}
    for _ in range(repeats):
        for side, mesh in meshes.items():
            start = time.perf_counter()
            check(mesh)
            times[side].append(time.perf_counter() - start)
    rows, previous = [], None
    for side in sides:
        t = np.array(times[side])
        triangles = len(meshes[side]["triangles"])
        row = {"nodes": side * side, "triangles": triangles, "springs": len(meshes[side]["springs"]),
               "median_ms": 1e3 * float(np.median(t)), "min_ms": 1e3 * float(t.min()),
               "max_ms": 1e3 * float(t.max()), "ns_per_triangle": 1e9 * float(np.median(t)) / triangles,
               "growth_exponent": ""}
        if previous is not None:
            row["growth_exponent"] = round(math.log(row["median_ms"] / previous["median_ms"])
                                           / math.log(triangles / previous["triangles"]), 3)
        rows.append(row)
        previous = row
        print(f"  {triangles} triangles: {row['median_ms']:.3g} ms ({row['ns_per_triangle']:.3g} ns/triangle)",
              flush=True)
    write_csv("mesh_checks", rows)
    write_markdown("mesh_checks", "Mesh checks: time against mesh size",
                   f"check_mesh with every check on, grid meshes, {repeats} interleaved repeats "
                   "(median, min, max). growth_exponent: slope of log(time) over log(triangles) "
                   "from the row above (1 = linear). The machine may be shared: 1-minute load average "
                   f"{load:.1f} on {os.cpu_count()} cores when the run started.\n\n" + markdown_table(rows))
    return rows


if __name__ == "__main__":
    run(quick="--quick" in sys.argv[1:])
