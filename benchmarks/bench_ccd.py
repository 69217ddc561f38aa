"""Cost of continuous collision detection per step, against the cost of a step.

The Simulator runs continuous detection once per step until the first contact. This measures
one detection (tool far from the tissue: the bounding-sphere test rejects every node; tool
touching it: the exact solver runs for the nodes near the tool) and one 1 ms step with the
tool, on skin patches of about 1k and 10k nodes. Results: benchmarks/results/ccd_cost.json, .md.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from pathlib import Path

import warp as wp

from warp_cut import Material, Simulator, TissueModel, Tool
from warp_cut.io.files import atomic_path
from warp_cut.sim.ccd import ContinuousDetector
from warp_cut.sim.warp_config import quiet_warp

RESULTS = Path(__file__).parent / "results"


def _per_call(fn, repeat: int) -> float:
    fn()  # warm-up (compiles or loads the kernels)
    start = time.perf_counter()
    for _ in range(repeat):
        fn()
    return (time.perf_counter() - start) / repeat


def measure(side: float, repeat: int = 200) -> dict:
    model = TissueModel.from_patch((side, side), 0.002, material=Material())
    sim = Simulator(model, dt=1e-3, gravity=None)
    det = ContinuousDetector(sim.device)
    x, v, f = sim.state.positions, sim.state.velocities, sim.device_model.node_flags
    far = (Tool([0, 0, 0.02], [0.02, 0, 0.04], 0.001), Tool([0, 0, 0.0199], [0.02, 0, 0.0399], 0.001))
    near = (Tool([0, 0, 0.0008], [0.02, 0, 0.02], 0.001), Tool([0, 0, 0.0007], [0.02, 0, 0.0199], 0.001))
    ccd_far = _per_call(lambda: det.first_contact(x, v, f, *far, interval=1e-3), repeat)
    ccd_near = _per_call(lambda: det.first_contact(x, v, f, *near, interval=1e-3), repeat)
    step = _per_call(lambda: sim.step(1, tool=far[0]), repeat)
    return {"nodes": model.node_count, "substeps": sim.substeps, "ccd_far_us": 1e6 * ccd_far,
            "ccd_near_us": 1e6 * ccd_near, "step_us": 1e6 * step,
            "ccd_far_fraction_of_step": ccd_far / step}


def main() -> int:
    quiet_warp()
    rows = [measure(0.059), measure(0.186)]
    result = {"rows": rows, "machine": {"platform": platform.platform(), "python": sys.version.split()[0],
                                        "warp": wp.__version__, "device": "cpu"}}
    with atomic_path(RESULTS / "ccd_cost.json") as tmp:
        tmp.write_text(json.dumps(result, indent=2) + "\n")
    md = ["# Continuous detection: cost per step (CPU)", "",
          "| nodes | detection, tool far [us] | detection, tool touching [us] | one step [us] | far / step |",
          "|---|---|---|---|---|"]
    md += [f"| {r['nodes']} | {r['ccd_far_us']:.0f} | {r['ccd_near_us']:.0f} | {r['step_us']:.0f} "
           f"({r['substeps']} substeps) | {r['ccd_far_fraction_of_step']:.0%} |" for r in rows]
    md += ["", f"Command: `python benchmarks/bench_ccd.py`; {result['machine']['platform']}, "
               f"warp {wp.__version__}, device cpu.", ""]
    with atomic_path(RESULTS / "ccd_cost.md") as tmp:
        tmp.write_text("\n".join(md))
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
