"""warp_cut: soft-tissue cutting on a mass-spring model (Zhang et al. 2021) with NVIDIA Warp.

Model / State / Control / Solver, as in Warp's sim and Newton:

* ``TissueModel`` - the topology store (nodes, springs, triangles, residual links, material);
* ``State`` - positions and velocities on the device;
* ``Tool`` / ``ToolPath`` - the cylinder tool the user drives;
* ``Simulator`` - binds them to a solver and steps in time.
"""

from .collision import cylinder_contacts
from .control import Tool, ToolPath
from .cutting import CutSettings
from .errors import (InputError, SceneError, SimulationUnstable, ToolStartsInside,
                     WarpCutError)
from .material import Material
from .model import TissueModel
from .simulator import Simulator
from .stability import StepLimit, stable_time_step
from .state import State

__all__ = [
    "TissueModel", "Material", "State", "Tool", "ToolPath", "Simulator", "CutSettings",
    "cylinder_contacts", "stable_time_step", "StepLimit",
    "WarpCutError", "InputError", "SceneError", "ToolStartsInside", "SimulationUnstable",
]

__version__ = "0.1.0"
