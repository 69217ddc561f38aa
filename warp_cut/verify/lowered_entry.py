"""A stroke whose tool is lowered straight down onto its start instead of coming in along its axis.

``warp_cut.sim.strokes.Stroke`` brings the tip in along the tool's own axis. A scalpel is also
often held at its working tilt and lowered onto the skin: ``LoweredStroke`` wraps a Stroke and
replaces its entry phase by a descent along the surface normal n0 at the path's start
(vertical on a flat mesh), the axis held at the stroke's start axis a0 (tilted by the stroke's
tilt from the tangent plane) throughout:

    p0(t) = q + (h0 - v t) n0,   0 <= t <= h0 / v,    q = P(0) - reach a0

where q is the tip at the start of travel (``Stroke.tip(Stroke.t_in)``), v the stroke's plunge
speed and h0 the smallest height [m] at which the tool (radius + margin, and margin longer below
its tip) touches no mesh node.
From then on the poses are the wrapped stroke's travel and exit. With a tilted axis the tip
meets the skin ahead of P(0) (by about depth / tan(tilt) along the travel direction) and the
axis' crossing with the skin moves back to P(0) as the tool goes down.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..sim.control import Tool, ToolPath
from ..sim.strokes import Stroke, inside_cylinder

__all__ = ["LoweredStroke", "lowered"]


class LoweredStroke:
    """``stroke`` with its entry replaced by a descent along the start normal (module docstring).

    Every attribute not set here (trace, arclength, path, length, radius, tilt, ...) is the
    wrapped stroke's, so it can stand for a Stroke in ``run_stroke`` and the quality measures.

    Args:
        stroke: the Stroke whose travel and exit are kept.
        margin: extra radius [m] the tool keeps from every mesh node at its start pose.
    """

    def __init__(self, stroke: Stroke, margin: float = 5e-4):
        self.stroke = stroke
        self.entry_normal = np.asarray(stroke.normals[0], dtype=np.float64)
        self.entry_axis = np.asarray(stroke.axes[0], dtype=np.float64)
        self.landing = np.asarray(stroke.tip(stroke.t_in)[0], dtype=np.float64)
        """Tip [m] at the end of the descent (the start of travel)."""
        self.height = self._clearance(margin)
        """Height h0 [m] of the start pose above the landing point, along the normal."""
        self.t_in = self.height / stroke.plunge_speed
        self.duration = self.t_in + stroke.t_travel + stroke.t_out
        """Time [s] from the start pose (outside) to the end pose (outside)."""

    def __getattr__(self, name):
        if name == "stroke":  # not set yet (copying, unpickling): no recursion
            raise AttributeError(name)
        return getattr(self.stroke, name)

    def _clearance(self, margin: float) -> float:
        """Smallest height [m] (growing by 25 % steps from the depth) at which the tool,
        widened by ``margin`` [m] and lengthened by it beyond the tip, touches no mesh node."""
        s = self.stroke
        h = max(s.depth, 1e-3)
        while h < 1.0:
            tip = self.landing + h * self.entry_normal
            if not inside_cylinder(s.surface.points, tip - margin * self.entry_axis,
                                   tip + s.tool_length * self.entry_axis, s.radius + margin).any():
                return h
            h *= 1.25
        raise InputError("no start height keeps the lowered tool outside the tissue (within 1 m)")

    def tip(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(tip p0 [m], unit axis) at time t [s] since the stroke began."""
        if t <= self.t_in:
            height = self.height * (1.0 - max(t, 0.0) / self.t_in)
            return self.landing + height * self.entry_normal, self.entry_axis
        return self.stroke.tip(t - self.t_in + self.stroke.t_in)

    def pose(self, t: float) -> Tool:
        """The tool at time t [s] since the stroke began."""
        p0, a = self.tip(t)
        return Tool(p0, p0 + self.stroke.tool_length * a, self.stroke.radius)

    __call__ = pose

    def tool_path(self, step: float = 1e-3) -> ToolPath:
        """The stroke as keyframes every ``step`` [s] (and at the phase changes)."""
        s = self.stroke
        times = np.union1d(np.arange(0.0, self.duration, step),
                           [self.t_in, self.t_in + s.t_travel, self.duration])
        tips = [self.tip(t) for t in times]
        p0 = np.array([p for p, _ in tips])
        return ToolPath(times, p0, p0 + s.tool_length * np.array([a for _, a in tips]), s.radius)


def lowered(stroke: Stroke, margin: float = 5e-4) -> LoweredStroke:
    """``stroke`` entered by lowering the tool along the start normal (see ``LoweredStroke``)."""
    if not math.isfinite(margin) or margin < 0:
        raise InputError(f"margin must be >= 0 m, got {margin}")
    return LoweredStroke(stroke, margin)
