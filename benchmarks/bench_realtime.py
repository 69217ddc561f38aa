"""Real-time factor of the paper's skin patch (Table 1, 10 x 6 cm) at 2 mm and 1 mm spacing.

Two bundled scenes: ``skin_press`` (scalpel pressing 4 mm deep at 30 degrees, 0.25 s) and
``straight_incision`` (the whole 3 s scene: a 4 cm cut with its cut events, then settling).
Simulated time over wall time, every output frame read back as the run loop does (positions
are not copied; tool force, contacts, kinetic energy are).
"""

from __future__ import annotations

import time

import numpy as np
from common import markdown_table, write_csv, write_markdown

from warp_cut.runner import prepare_simulation
from warp_cut.scene import load_scene

SCENES = {"skin_press": 0.25, "straight_incision": None}
"""Scene -> simulated duration [s] (None: the scene's own)."""


def measure(spacing, integrator, scene_name="skin_press", repeats=3):
    overrides = [f"tissue.spacing={spacing}", f"solver.integrator=\"{integrator}\""]
    if SCENES[scene_name] is not None:
        overrides.append(f"duration={SCENES[scene_name]}")
    scene = load_scene(scene_name, overrides)
    factors = []
    for _ in range(repeats):
        model, sim, path, steps_per_frame = prepare_simulation(scene)
        sim.step(1, tool=path)  # compile / record outside the timing
        frames = scene.frame_count
        start = time.perf_counter()
        for _ in range(frames):
            sim.step(steps_per_frame, tool=path)
            sim.kinetic_energy()
        wall = time.perf_counter() - start
        factors.append(frames * steps_per_frame * sim.dt / wall)
    return model, sim, np.array(factors)


def run(quick: bool = False):
    rows = []
    spacings = (0.002,) if quick else (0.002, 0.001)
    cases = [(s, i, "skin_press") for s in spacings
             for i in ("semi_implicit", "xpbd", "implicit_euler")]
    cases += [(s, "semi_implicit", "straight_incision") for s in spacings]
    for spacing, integrator, scene_name in cases:
        repeats = 1 if quick else 3
        model, sim, factors = measure(spacing, integrator, scene_name, repeats=repeats)
        rows.append({"scene": scene_name, "spacing_m": spacing, "integrator": integrator,
                     "nodes": model.node_count, "springs": model.spring_count,
                     "dt_s": sim.dt, "substeps": sim.substeps,
                     "realtime_factor_median": float(np.median(factors)),
                     "realtime_min": float(factors.min()), "realtime_max": float(factors.max())})
        print(f"  {scene_name} {spacing * 1e3:g} mm {integrator}: {np.median(factors):.2f} x "
              f"real time ({sim.substeps} substeps of {sim.substep:.3g} s)", flush=True)
    write_csv("realtime", rows)
    write_markdown("realtime", "Real-time factor: skin patch (Table 1)",
                   "Simulated time / wall time, median (min, max) of repeats; dt = 1 ms (the "
                   "haptic tick) with the substeps the scene's automatic choice gives (implicit "
                   "Euler and XPBD: 1, they have no stability limit).\n\n" + markdown_table(rows))
    return rows


if __name__ == "__main__":
    run()
