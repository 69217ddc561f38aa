"""CutHost: what a cut needs from the simulation it cuts.

``warp_cut.Simulator`` provides it, and so does a cut worker's replica
(``warp_cut.cut.cut_worker.ReplicaHost``): a cut driver is given its host at every call and
keeps nothing of it, so the cut never imports the simulator.
"""

from __future__ import annotations

from typing import Protocol

from ..sim.contacts import ToolContacts
from ..sim.control import Tool
from ..sim.device_model import DeviceModel
from ..sim.model_change import ModelChange
from ..sim.state import State

__all__ = ["CutHost"]


class CutHost(Protocol):
    """What a cut needs from the simulation it cuts; ``warp_cut.Simulator`` provides it.

    Attributes:
        time: Simulated time at the end of the last step [s].
        dt: The step [s].
        tool_pose: The tool at the end of the last step, or None.
        collision: Whether the tool touches the tissue at all.
        contacts: The tool's contacts over the last step (``ToolContacts``: force [N], ...).
        state: The device state; the cut reads ``state.positions``.
        device_model: The device mirror of the model; the cut reads node flags and springs.
    """

    time: float
    dt: float
    tool_pose: Tool | None
    collision: bool
    contacts: ToolContacts
    state: State
    device_model: DeviceModel

    def notify_model_changed(self, change: ModelChange) -> None:
        """Mirror the model's latest edit on the device, place its new nodes and follow the
        stable step."""
