"""Host entry points of the cylinder collision test (kernels in ``warp_cut.kernels.collision``)."""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels.collision import cylinder_contact_mask
from .control import Tool

__all__ = ["cylinder_contacts", "axis_distance", "pushed_out"]


def cylinder_contacts(points, p0, p1, radius: float, device: str = "cpu") -> np.ndarray:
    """Which points lie inside a cylinder, by the paper's test (section 2.2).

    A point is inside when it projects onto the axis segment (both angles at p0 and p1 at
    most 90 degrees) and its distance to the axis is strictly below the radius. A zero-length
    or zero-radius cylinder contains nothing.

    Args:
        points: Positions [m], shape (n, 3).
        p0: One end of the axis [m], shape (3,).
        p1: The other end [m], shape (3,).
        radius: Cylinder radius [m], >= 0.
        device: Warp device the test runs on.

    Returns:
        Mask, shape (n,) bool.

    Raises:
        InputError: A non-finite end point or a bad radius.
    """
    tool = Tool(p0, p1, radius)
    pts = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    if len(pts) == 0:
        return np.zeros(0, dtype=bool)
    x = wp.array(pts, dtype=wp.vec3, device=device)
    inside = wp.zeros(len(pts), dtype=wp.int32, device=device)
    wp.launch(cylinder_contact_mask, dim=len(pts), device=device,
              inputs=[x, wp.vec3(*tool.p0), wp.vec3(*tool.p1), tool.radius, inside])
    return inside.numpy().astype(bool)


def axis_distance(points, tool: Tool) -> np.ndarray:
    """Distances (n,) [m] of points (n, 3) [m] from the line of the tool's axis (p0 = p1: from p0)."""
    x = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    axis = tool.p1 - tool.p0
    rel = x - tool.p0
    along = rel @ axis / max(float(axis @ axis), 1e-300)
    return np.linalg.norm(rel - np.outer(along, axis), axis=1)


def pushed_out(points, tool: Tool) -> np.ndarray:
    """Points (n, 3) [m] moved onto the tool's cylinder surface where they lie inside it (the
    push-out the kernels apply, along (N - p) / d from the closest axis point p; a point on the
    axis goes along a fixed perpendicular); the others unchanged. A copy, float64."""
    x = np.array(points, dtype=np.float64).reshape(-1, 3)
    axis = tool.p1 - tool.p0
    length2 = float(axis @ axis)
    if not len(x) or length2 <= 0.0 or tool.radius <= 0.0:
        return x
    t = (x - tool.p0) @ axis / length2
    closest = tool.p0 + np.clip(t, 0.0, 1.0)[:, None] * axis
    perp = x - closest
    d = np.linalg.norm(perp, axis=1)
    inside = (t >= 0.0) & (t <= 1.0) & (d < tool.radius)
    if not inside.any():
        return x
    a = axis / np.sqrt(length2)
    fixed = np.cross(a, [0.0, 0.0, 1.0])
    if np.linalg.norm(fixed) < 1e-3:
        fixed = np.cross(a, [1.0, 0.0, 0.0])
    fixed /= np.linalg.norm(fixed)
    direction = np.where((d > 0.0)[:, None], perp / np.maximum(d, 1e-300)[:, None], fixed[None])
    x[inside] = closest[inside] + tool.radius * direction[inside]
    return x
