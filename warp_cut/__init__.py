"""warp_cut: soft-tissue cutting on a mass-spring model (Zhang et al. 2021) with NVIDIA Warp.

Model / State / Control / Solver, as in Warp's sim and Newton:

* ``TissueModel`` - the topology store (nodes, springs, triangles, residual links, material);
* ``State`` - positions and velocities on the device;
* ``Tool`` / ``ToolPath`` - the cylinder tool the user drives;
* ``Simulator`` - binds them to a solver and steps in time.
"""

from .cut.settings import CutSettings
from .errors import CutWorkerError, InputError, SceneError, SimulationUnstable, ToolStartsInside, WarpCutError
from .sim.collision import cylinder_contacts
from .sim.control import Tool, ToolPath
from .sim.material import Material
from .sim.model import TissueModel
from .sim.stability import StepLimit, stable_time_step
from .sim.state import State
from .simulator import Simulator

__all__ = [
    "TissueModel", "Material", "State", "Tool", "ToolPath", "Simulator", "CutSettings",
    "cylinder_contacts", "stable_time_step", "StepLimit",
    "WarpCutError", "InputError", "SceneError", "ToolStartsInside", "SimulationUnstable", "CutWorkerError",
]

__version__ = "0.1.0"
