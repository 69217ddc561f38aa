"""Error against wall time on the width-time curve of an incision (the paper's Fig. 6 scene).

``scenes/paper_width_curve.toml`` (6 x 4 cm patch, 2 mm, Table 1, a 2 cm cut, 4 s): for each
integrator and step choice, the incision width sampled every output frame is compared with a
reference run (semi-implicit Euler at 0.05 x its stable step, same mesh) by the RMS difference
over the frames where both have a width [m]; wall time is the whole run. The mesh is the same in
every run, so this is the time-stepping part of the trade (the hanging sheet in
``bench_pareto.py`` has the mesh part).

    python benchmarks/bench_pareto_incision.py
"""

from __future__ import annotations

import sys
import time

import numpy as np
from common import markdown_table, write_csv, write_markdown

from warp_cut.runner import run_scene
from warp_cut.scene import load_scene
from warp_cut.sim.warp_config import quiet_warp

CASES = [  # (integrator, overrides)
    ("semi_implicit", ["solver.safety=0.9"]),
    ("semi_implicit", ["solver.safety=0.5"]),
    ("semi_implicit", ["solver.safety=0.25"]),
    ("implicit_euler", ["solver.substeps=1"]),
    ("xpbd", ["solver.substeps=1"]),
    ("xpbd", ["solver.substeps=4"]),
]
REFERENCE = ("semi_implicit", ["solver.safety=0.05"])


def width_curve(integrator, overrides):
    scene = load_scene("paper_width_curve", [f'solver.integrator="{integrator}"'] + overrides)
    start = time.perf_counter()
    result = run_scene(scene)
    wall = time.perf_counter() - start
    return result.columns["incision_width_m"], wall, result.metrics


def run(quick: bool = False):
    ref, ref_wall, ref_m = width_curve(*REFERENCE)
    rows = [{"integrator": REFERENCE[0], "setting": " ".join(REFERENCE[1]) + " (reference)",
             "substeps": ref_m["substeps"], "wall_s": ref_wall, "rms_error_mm": 0.0,
             "plateau_mm": ref_m["width_curve"]["plateau_m"] * 1e3}]
    for integrator, overrides in (CASES[:2] if quick else CASES):
        w, wall, m = width_curve(integrator, overrides)
        both = np.isfinite(w) & np.isfinite(ref)
        err = float(np.sqrt(np.mean((w[both] - ref[both]) ** 2))) if both.any() else float("nan")
        plateau = (m.get("width_curve") or {}).get("plateau_m")
        rows.append({"integrator": integrator, "setting": " ".join(overrides),
                     "substeps": m["substeps"], "wall_s": wall, "rms_error_mm": err * 1e3,
                     "plateau_mm": plateau * 1e3 if plateau is not None else float("nan")})
        print(f"  {integrator} {' '.join(overrides)}: {err * 1e3:.4f} mm RMS in {wall:.2f} s",
              flush=True)
    write_csv("pareto_incision", rows)
    write_markdown("pareto_incision", "Error against wall time: the incision's width curve",
                   __doc__.split("\n\n")[1] + "\n\n" + markdown_table(rows))
    return rows


if __name__ == "__main__":
    quiet_warp()
    run("--quick" in sys.argv[1:])
