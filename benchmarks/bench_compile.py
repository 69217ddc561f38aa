"""Kernel compile time on a cold and a warm Warp kernel cache, per integrator.

Each measurement is a fresh interpreter that builds the default skin patch, a Simulator with
every physics on and takes one step; cold uses an empty temporary cache directory
(WARP_CACHE_PATH), warm runs again on the cache the cold run filled.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile

from common import markdown_table, write_csv, write_markdown

SCRIPT = r"""
import json, sys, time
t0 = time.perf_counter()
import warp as wp
wp.init()
t1 = time.perf_counter()
from warp_cut import Simulator, TissueModel, Tool
from warp_cut.sim.warp_config import quiet_warp
quiet_warp()
model = TissueModel.from_patch((0.10, 0.06), 0.002)
model.add_residual_links([[0, 1]], [0.002])
sim = Simulator(model, integrator=sys.argv[1])
t2 = time.perf_counter()
sim.step(1, tool=Tool([0, 0, 0.01], [0, 0, 0.05], 0.001))
t3 = time.perf_counter()
print(json.dumps({"warp_init_s": t1 - t0, "first_step_s": t3 - t2, "total_s": t3 - t0}))
"""


def measure(integrator: str, cache: str) -> dict:
    env = dict(os.environ, WARP_CACHE_PATH=cache)
    out = subprocess.run([sys.executable, "-c", SCRIPT, integrator], env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def run(quick: bool = False):
    rows = []
    for integrator in ("semi_implicit", "implicit_euler", "xpbd"):
        with tempfile.TemporaryDirectory() as cache:
            cold = measure(integrator, cache)
            warm = measure(integrator, cache)
        rows.append({"integrator": integrator, "cold_total_s": cold["total_s"],
                     "warm_total_s": warm["total_s"],
                     "compile_s": cold["total_s"] - warm["total_s"],
                     "cold_first_step_s": cold["first_step_s"],
                     "warm_first_step_s": warm["first_step_s"]})
        print(f"  {integrator}: cold {cold['total_s']:.2f} s, warm {warm['total_s']:.2f} s",
              flush=True)
    write_csv("compile", rows)
    write_markdown("compile", "Compile time: cold and warm kernel cache",
                   "Whole process (interpreter start-up, import, Warp init, model build, solver "
                   "set-up, first step: every kernel module the scene uses - springs, the node "
                   "pass with gravity and tool, residual links, diagnostics - compiled or "
                   "loaded), default skin patch with all physics on; compile_s = cold - warm. "
                   "The first step alone is shown too (XPBD compiles its valence kernel at "
                   "set-up, before it).\n\n" + markdown_table(rows))
    return rows


if __name__ == "__main__":
    run()
