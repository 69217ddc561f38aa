"""Skin patch generator: a flat rectangular sheet in the XY plane (z = 0), triangulated.

Rows of nodes are staggered by half a spacing (a triangular lattice), so interior triangles
are nearly equilateral; the two side borders stay straight by adding a node at each end of
the staggered rows, which makes the border triangles about 30-60-90 (the row pitch is rounded to fit
the size, so their smallest angle can fall a few degrees below 30). Triangles are wound
counter-clockwise seen from +Z (normal +Z).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from .triangulate import zip_rows

__all__ = ["skin_patch_mesh"]


def skin_patch_mesh(size=(0.10, 0.06), spacing: float = 2.0e-3, origin=None):
    """A size[0] x size[1] skin patch in the XY plane, centred on the origin.

    The spacing is adjusted so that whole numbers of rows and columns fit the size exactly:
    the row pitch is size[1] / round(size[1] / (spacing sqrt(3)/2)) and the column pitch is
    fitted to it (about 2/sqrt(3) x the row pitch). Patches only a few spacings wide have
    flatter triangles.

    Args:
        size: Width (x) and height (y) [m].
        spacing: Target node spacing [m].
        origin: Optional offset [m], shape (3,), added to every point.

    Returns:
        Points [m], shape (n, 3) float64, and triangles, shape (t, 3) int64, counter-clockwise
        seen from +Z.

    Raises:
        InputError: A non-positive size or spacing, or more than 2e7 nodes.
    """
    width, height = (float(v) for v in size)
    spacing = float(spacing)
    if not (np.isfinite(width) and np.isfinite(height) and width > 0 and height > 0):
        raise InputError(f"tissue.size must be two positive lengths [m], got {size}")
    if not (np.isfinite(spacing) and spacing > 0):
        raise InputError(f"tissue.spacing must be > 0 m, got {spacing}")
    ny = max(1, round(height / (spacing * math.sqrt(3.0) / 2.0)))
    # fit the columns to the rounded row pitch, so triangles stay near-equilateral
    nx = max(1, round(width * math.sqrt(3.0) / (2.0 * height / ny)))
    if (nx + 1) * (ny + 1) > 20_000_000:
        raise InputError(
            f"tissue.spacing {spacing} m gives {(nx + 1) * (ny + 1)} nodes; allowed up to 2e7"
        )
    dx = width / nx
    dy = height / ny
    even_x = np.arange(nx + 1) * dx
    odd_x = np.concatenate([[0.0], (np.arange(nx) + 0.5) * dx, [width]])
    points, rows, rows_x = [], [], []
    start = 0
    for r in range(ny + 1):
        xs = even_x if r % 2 == 0 else odd_x
        idx = np.arange(start, start + len(xs))
        points.append(np.column_stack([xs, np.full(len(xs), r * dy), np.zeros(len(xs))]))
        rows.append(idx)
        rows_x.append(xs)
        start += len(xs)
    tris = []
    for r in range(ny):
        tris.extend(zip_rows(rows[r], rows[r + 1], rows_x[r], rows_x[r + 1]))
    pts = np.concatenate(points)
    pts[:, 0] -= width / 2.0
    pts[:, 1] -= height / 2.0
    if origin is not None:
        pts += np.asarray(origin, dtype=np.float64)
    return pts, np.asarray(tris, dtype=np.int64)
