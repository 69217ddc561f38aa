"""Live cutting in a browser, and a player for finished runs (``warp-cut live``, ``warp-cut view``).

The run logic (``LiveCut``: simulation thread, scalpel pose, parameters, save) and the reading
of finished runs (``RunPlayback``) need no display and no optional dependency; the browser layer
(``viewer``, ``player``; viser) is imported only by the commands that serve a page
(``pip install 'warp-cut[live]'``).
"""

from .engine import LiveCut, LiveParameters, LiveStatus
from .frames import SimulatorFrames, ViewFrame
from .scalpel import ScalpelPose, ToolMotion

__all__ = ["LiveCut", "LiveParameters", "LiveStatus", "ViewFrame", "SimulatorFrames",
           "ScalpelPose", "ToolMotion"]
