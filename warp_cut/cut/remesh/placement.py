"""Where a node the re-mesh makes starts: its current position in the deformed tissue.

A new node is a point of the region's flat chart. Its rest position comes through the rest
triangle it lies in; its current position first does too (``PiecewiseLinearMap``: the
barycentric coordinates carried to where that triangle's corners are now), so nothing jumps
where the tissue lies as it rests, whatever it is stretched or bent to. Right at the blade it is
not so: the tool pushes the nodes inside its cylinder onto its surface, so the triangles there
are its dent, crushed or turned over, and a node placed through them can make a new triangle
that is born folded over, and that a membrane keeps folded long after the tool has gone.

So the new triangles are checked against the tissue round them (``tissue_map``: the affine map
from the chart to where the region's nodes are now, fitted to the nodes the tool does not hold,
Gaussian weights, the map the blade's crossing is carried into the rest shape with,
``contact.material_point``). A new triangle whose current normal points against that map's is
folded; its new corners are placed through the map instead, and pushed out of the tool's
cylinder as the kernels would push them, again while a corner so moved turns a neighbour
over (each new point at most once). A triangle whose corners are all old nodes keeps the
shape the motion gave it.

Shapes: chart points (n, 2) [m]; current positions (n, 3) [m]; triangles (t, 3) rows of those.
"""

from __future__ import annotations

import numpy as np

from ...sim.collision import pushed_out
from ...sim.control import Tool
from ..contact.material_point import held_by
from ..tolerances import MAP_WIDTH

__all__ = ["tissue_map", "folded_against", "start_positions"]


def tissue_map(chart: np.ndarray, x: np.ndarray, at: np.ndarray, scale: float) -> np.ndarray | None:
    """The affine maps from the chart to the current shape round the points ``at`` (m, 2) [m],
    each fitted to the nodes at chart points ``chart`` (k, 2) [m] now at ``x`` (k, 3) [m] with
    weights exp(-(distance / scale)^2): (m, 3, 3) rows [origin, d/dchart_x, d/dchart_y], a point
    q of the chart going to origin + (q - at) @ rows[1:]. None if the nodes do not span the
    chart (fewer than three, or all on a line)."""
    if len(chart) < 3:
        return None
    rel = (chart[None, :, :] - at[:, None, :]) / scale                         # (m, k, 2)
    w = np.exp(-(rel * rel).sum(axis=2)) + 1e-12                               # (m, k)
    basis = np.concatenate([np.ones(rel.shape[:2] + (1,)), rel], axis=2)      # (m, k, 3)
    normal = np.einsum("mk,mki,mkj->mij", w, basis, basis)                     # (m, 3, 3)
    if (np.linalg.cond(normal) > 1e10).any():
        return None
    maps = np.linalg.solve(normal, np.einsum("mk,mki,kj->mij", w, basis, x))
    maps[:, 1:] /= scale
    return maps


def folded_against(x: np.ndarray, triangles: np.ndarray, maps: np.ndarray) -> np.ndarray:
    """(t,) bool: triangles (t, 3) of the points at ``x`` (n, 3) [m] whose normal points against
    the tissue's there (``maps`` (t, 3, 3), ``tissue_map`` at each triangle; its normal
    d/dchart_x x d/dchart_y, outward as the chart is wound)."""
    a, b, c = x[triangles[:, 0]], x[triangles[:, 1]], x[triangles[:, 2]]
    normal = np.cross(b - a, c - a)
    return (normal * np.cross(maps[:, 1], maps[:, 2])).sum(axis=1) < 0.0


def start_positions(chart: np.ndarray, triangles: np.ndarray, x: np.ndarray, new: np.ndarray,
                    tool: Tool | None, spacing: float) -> np.ndarray:
    """The current positions (n, 3) [m] the fill's points start at: ``x`` (n, 3) [m] holds the
    old nodes' and the new points' through their rest triangles (pushed out of ``tool``);
    ``new`` (n,) bool marks the new points. A new point of a triangle (t, 3) that is folded
    against the tissue round it goes where the tissue's map carries it (module docstring),
    fitted to the old nodes the tool does not hold (to all old nodes if fewer than three are
    free of it). ``spacing``: the cut's station spacing [m]. A copy."""
    x = np.array(x, dtype=np.float64)
    old = ~new
    sources = old & ~held_by(x, tool)
    if sources.sum() < 3:
        sources = old
    radius = 0.0 if tool is None else tool.radius
    scale = radius + MAP_WIDTH * spacing
    touching = triangles[new[triangles].any(axis=1)]
    centres = chart[touching].mean(axis=1)
    maps = tissue_map(chart[sources], x[sources], centres, scale)
    if maps is None:
        return x
    placed_by_map = np.zeros(len(x), dtype=bool)
    while True:  # a moved corner can turn a neighbour over: again, at most once per new point
        folded = folded_against(x, touching, maps)
        moved = np.unique(touching[folded].ravel())
        moved = moved[new[moved] & ~placed_by_map[moved]]
        if not len(moved):
            return x
        placed = tissue_map(chart[sources], x[sources], chart[moved], scale)
        if placed is None:
            return x
        x[moved] = placed[:, 0] if tool is None else pushed_out(placed[:, 0], tool)
        placed_by_map[moved] = True
