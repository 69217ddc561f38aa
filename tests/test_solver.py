"""warp_cut/solver.py: a scene pays only for the physics it enables (modules neither launched
nor compiled), checked in a fresh interpreter."""

import json
import subprocess
import sys

SCRIPT = r"""
import json, sys
import warp as wp
wp.config.log_level = getattr(wp, "LOG_ERROR", 40)
from warp_cut import Simulator, TissueModel, Tool
from warp._src.context import user_modules
gravity, collision, residual = (a == "1" for a in sys.argv[1:4])
model = TissueModel.from_patch((0.01, 0.01), 0.002)
model.add_residual_links([[0, 1]], [0.002])
sim = Simulator(model, gravity=(0, 0, -9.81) if gravity else None, collision=collision,
                residual_stress=residual)
sim.step(3, tool=Tool([0, 0, 0.01], [0, 0, 0.05], 0.001))
print(json.dumps({name.rsplit(".", 1)[-1]: bool(mod.execs) for name, mod in user_modules.items()
                  if name.startswith("warp_cut.kernels")}))
"""


def loaded(gravity, collision, residual):
    out = subprocess.run([sys.executable, "-c", SCRIPT, str(int(gravity)), str(int(collision)),
                          str(int(residual))], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_disabled_physics_is_not_compiled():
    mods = loaded(gravity=False, collision=False, residual=False)
    assert mods.get("springs") and mods.get("integrate")
    for name in ("gravity", "collision", "residual"):
        assert not mods.get(name, False), f"{name} was loaded although disabled"


def test_enabled_physics_is_compiled():
    mods = loaded(gravity=True, collision=True, residual=True)
    for name in ("springs", "integrate", "gravity", "collision", "residual"):
        assert mods.get(name), f"{name} was not loaded although enabled"
