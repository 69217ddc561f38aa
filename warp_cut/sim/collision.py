"""Host entry points of the cylinder collision test (kernels in ``warp_cut.kernels.collision``)."""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels.collision import cylinder_contact_mask
from .control import Tool

__all__ = ["cylinder_contacts"]


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
