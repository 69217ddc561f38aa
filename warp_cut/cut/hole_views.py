"""A hole's nodes seen in coordinates where the skin faces +z: along the skin's mean normal
there, or in the slit chart where one plane would fold a curved skin. Stage 3's orientation
tests and ear clipping work in them.
"""

from __future__ import annotations

import math

import numpy as np

from ..mesh.geometry import plane_frame

__all__ = ["UP", "HoleCoordinates", "hole_views"]


UP = np.array([0.0, 0.0, 1.0])
"""The skin's outward normal in a hole's coordinates (``hole_views``)."""


class HoleCoordinates:
    """A hole's nodes in 3D coordinates where the skin faces +z, indexed like
    ``NodePositions``: the fill's orientation tests and ear clipping work in them."""

    def __init__(self, nodes, xyz):
        self._xyz = dict(zip(nodes, np.asarray(xyz, dtype=np.float64)))

    def __getitem__(self, index):
        if isinstance(index, (int, np.integer)):
            return self._xyz[int(index)]
        return np.array([self._xyz[int(i)] for i in index], dtype=np.float64).reshape(-1, 3)


def hole_views(incision, positions, nodes):
    """The hole's coordinates to triangulate it in, best first: seen along the skin's mean
    outward normal there, or, where the skin turns by more than 30 degrees across the hole
    (one plane would fold it), first in the slit chart. A generator: the second view is made
    only if the first gives no fill."""
    nodes = list(dict.fromkeys(nodes))
    x = positions[nodes]
    normals = incision.normal_at(incision.project(x)[0])
    n = normals.sum(axis=0)
    n /= np.linalg.norm(n)
    if float((normals @ n).min()) >= math.cos(math.radians(30.0)):
        yield _plane_view(nodes, x, n)
        yield _chart_view(incision, nodes, x)
    else:
        yield _chart_view(incision, nodes, x)
        yield _plane_view(nodes, x, n)


def _plane_view(nodes, x, n) -> HoleCoordinates:
    """Nodes at ``x`` (k, 3) [m] seen along the unit normal ``n``."""
    e1, e2 = plane_frame(n)
    return HoleCoordinates(nodes, x @ np.stack([e1, e2, n]).T)


def _chart_view(incision, nodes, x) -> HoleCoordinates:
    """Nodes at ``x`` (k, 3) [m] in the slit chart (u, v, 0) (``Incision.chart``), which
    follows the curve on curved skin where one plane would fold."""
    uv = incision.chart(x)
    return HoleCoordinates(nodes, np.column_stack([uv, np.zeros(len(nodes))]))
