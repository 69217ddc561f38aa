"""Triangulations of a parameter domain: a triangular lattice (optionally periodic and jittered)
and jittered points in a disk joined by Delaunay triangulation, with slivers trimmed off the border.

Parameter points ``uv`` are (n, 2) [m]; triangles (t, 3) int64 are wound counter-clockwise in
the parameter plane.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.tri import Triangulation

from ..errors import InputError
from .geometry import edge_keys, triangle_min_angles

__all__ = ["zip_rows", "lattice", "jitter_lattice", "disk_points", "delaunay", "trim_border_slivers",
           "boundary_edges", "connected_groups", "border_loops", "border_loop_count", "topology_problems"]


def zip_rows(lower, upper, lower_u, upper_u) -> list[tuple[int, int, int]]:
    """Triangulate the strip between two rows of nodes, always adding the shorter diagonal.

    Args:
        lower: Node indices of the lower row (at smaller v), sorted by u.
        upper: Node indices of the upper row, sorted by u (the same u range).
        lower_u: u [m] of the lower row's nodes.
        upper_u: u [m] of the upper row's nodes.

    Returns:
        Triangles as (i, j, k) tuples, counter-clockwise in the (u, v) plane.
    """
    tris = []
    i = j = 0
    while i < len(lower) - 1 or j < len(upper) - 1:
        take_lower = j == len(upper) - 1 or (
            i < len(lower) - 1 and (lower_u[i + 1] - upper_u[j]) ** 2 <= (upper_u[j + 1] - lower_u[i]) ** 2)
        if take_lower:
            tris.append((lower[i], lower[i + 1], upper[j]))
            i += 1
        else:
            tris.append((lower[i], upper[j + 1], upper[j]))
            j += 1
    return tris


def lattice(width_u: float, width_v: float, spacing: float, *, periodic_v: bool = False):
    """A triangular lattice on [-width_u/2, width_u/2] x [-width_v/2, width_v/2] [m].

    Rows run along u, ``spacing`` x sqrt(3)/2 apart (rounded to fit width_v; an even count
    when v is periodic, the last row then joining the first across v = width_v / 2); odd rows
    are staggered by half a spacing and end in an extra node on each u border, so the u
    borders stay straight. Returns (uv (n, 2), triangles (t, 3))."""
    if not (width_u > 0 and width_v > 0 and spacing > 0):
        raise InputError(f"lattice sizes and spacing must be > 0 m, got {width_u}, {width_v}, {spacing}")
    pitch = spacing * math.sqrt(3.0) / 2.0
    if periodic_v:
        rows = max(4, 2 * round(width_v / (2.0 * pitch)))
    else:
        rows = max(1, round(width_v / pitch)) + 1
    dv = width_v / (rows if periodic_v else rows - 1)
    nu = max(1, round(width_u / spacing))
    du = width_u / nu
    even = np.arange(nu + 1) * du
    odd = np.concatenate([[0.0], (np.arange(nu) + 0.5) * du, [width_u]])
    uv, index, us, start = [], [], [], 0
    for r in range(rows):
        u = even if r % 2 == 0 else odd
        uv.append(np.column_stack([u, np.full(len(u), r * dv)]))
        index.append(np.arange(start, start + len(u)))
        us.append(u)
        start += len(u)
    tris = []
    for r in range(rows - 1):
        tris += zip_rows(index[r], index[r + 1], us[r], us[r + 1])
    if periodic_v:
        tris += zip_rows(index[-1], index[0], us[-1], us[0])
    uv = np.concatenate(uv) - np.array([width_u / 2.0, width_v / 2.0])
    return uv, np.asarray(tris, dtype=np.int64)


def jitter_lattice(uv, triangles, amount: float, rng, *, border_u: float, border_v: float | None):
    """Move each node by a random vector no longer than ``amount`` x half its shortest edge
    (amount in [0, 1)): no triangle can turn over, since no node moves half the distance to
    the opposite side of a lattice triangle. Nodes on the u borders |u| = border_u move along
    v only, nodes on |v| = border_v (None: none) along u only, corners stay."""
    if not 0 <= amount < 1:
        raise InputError(f"jitter must be in [0, 1), got {amount}")
    uv = np.array(uv, dtype=np.float64)
    edges = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    length = np.linalg.norm(uv[edges[:, 0]] - uv[edges[:, 1]], axis=1)
    shortest = np.full(len(uv), np.inf)
    np.minimum.at(shortest, edges.ravel(), np.repeat(length, 2))
    radius = 0.5 * amount * shortest * np.sqrt(rng.uniform(0.0, 1.0, len(uv)))
    angle = rng.uniform(0.0, 2.0 * np.pi, len(uv))
    step = radius[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    tol = 1e-9 * max(border_u, 1e-300)
    step[np.abs(np.abs(uv[:, 0]) - border_u) < tol, 0] = 0.0
    if border_v is not None:
        step[np.abs(np.abs(uv[:, 1]) - border_v) < tol, 1] = 0.0
    return uv + step


def disk_points(radius: float, spacing: float, jitter: float, rng) -> np.ndarray:
    """Points (n, 2) [m] filling the disk of ``radius``: one ring on the border, ``spacing``
    apart, and inside a triangular lattice of ``spacing`` whose points are moved by up to
    ``jitter`` x spacing (uniform in a disk), keeping those at least half a spacing inside."""
    if not (radius > 2.0 * spacing and spacing > 0):
        raise InputError(f"disk radius must exceed 2 x spacing > 0, got radius {radius}, spacing {spacing}")
    if not 0 <= jitter <= 0.3:
        raise InputError(f"jitter must be in [0, 0.3] x spacing, got {jitter}")
    k = max(6, round(2.0 * np.pi * radius / spacing))
    phi = 2.0 * np.pi * np.arange(k) / k
    ring = radius * np.column_stack([np.cos(phi), np.sin(phi)])
    pitch = spacing * math.sqrt(3.0) / 2.0
    rows = np.arange(-math.ceil(radius / pitch), math.ceil(radius / pitch) + 1)
    cols = np.arange(-math.ceil(radius / spacing) - 1, math.ceil(radius / spacing) + 2)
    jj, ii = np.meshgrid(rows, cols, indexing="ij")
    grid = np.column_stack([(ii + 0.5 * (jj % 2)).ravel() * spacing, jj.ravel() * pitch])
    r = jitter * spacing * np.sqrt(rng.uniform(0.0, 1.0, len(grid)))
    a = rng.uniform(0.0, 2.0 * np.pi, len(grid))
    grid = grid + r[:, None] * np.column_stack([np.cos(a), np.sin(a)])
    inner = grid[np.hypot(grid[:, 0], grid[:, 1]) <= radius - 0.5 * spacing]
    return np.concatenate([ring, inner])


def delaunay(uv) -> np.ndarray:
    """Delaunay triangles (t, 3) of parameter points (n, 2), counter-clockwise."""
    uv = np.asarray(uv, dtype=np.float64)
    tri = Triangulation(uv[:, 0], uv[:, 1]).triangles.astype(np.int64)
    a, b, c = uv[tri[:, 0]], uv[tri[:, 1]], uv[tri[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    tri[cross < 0] = tri[cross < 0][:, [0, 2, 1]]
    return tri


def boundary_edges(triangles) -> np.ndarray:
    """Directed edges (e, 2) used by exactly one triangle, in that triangle's winding."""
    tri = np.asarray(triangles, dtype=np.int64)
    directed = tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    if not len(directed):
        return directed
    key = edge_keys(np.sort(directed, axis=1), int(directed.max()) + 1)  # 1-D keys: sorted, equal ones adjoin
    order = np.argsort(key, kind="stable")
    same = key[order[1:]] == key[order[:-1]]
    once = np.ones(len(key), dtype=bool)
    once[1:] &= ~same
    once[:-1] &= ~same
    keep = np.empty(len(key), dtype=bool)
    keep[order] = once
    return directed[keep]


def _removable(corners, border_set, on_border) -> bool:
    """A border triangle may go without pinching the border: two border edges (its tip node
    goes with it), or one border edge and an inner third corner."""
    edges = [(corners[k], corners[(k + 1) % 3]) for k in range(3)]
    on = [e in border_set for e in edges]
    if sum(on) == 2:
        return True
    if sum(on) == 1:
        third = corners[(on.index(True) + 2) % 3]
        return not on_border[third]
    return False


def trim_border_slivers(points, triangles, min_angle_deg: float = 15.0):
    """Drop triangles on the border whose smallest angle (in 3D, ``points`` (n, 3) [m]) is below
    ``min_angle_deg``, worst first and repeatedly, as long as the border is not pinched (see
    ``_removable``). Returns (kept node indices (k,), triangles (t', 3) renumbered)."""
    tri = np.asarray(triangles, dtype=np.int64)
    while True:
        border = boundary_edges(tri)
        on_border = np.zeros(len(points), dtype=bool)
        on_border[border.ravel()] = True
        border_set = {(int(a), int(b)) for a, b in border}
        angles = triangle_min_angles(points, tri)
        drop = next((t for t in np.argsort(angles) if angles[t] < min_angle_deg
                     and _removable([int(v) for v in tri[t]], border_set, on_border)), None)
        if drop is None:
            break
        tri = np.delete(tri, drop, axis=0)
    kept = np.unique(tri)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[kept] = np.arange(len(kept))
    return kept, remap[tri]


def connected_groups(items, links) -> list[list[int]]:
    """The groups of ``items`` (ints) that the pairs ``links`` (of items) join, by a union-find:
    each a list in the order of ``items``, the groups in the order of their first item."""
    parent = {int(v): int(v) for v in items}

    def root(v):
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    for a, b in links:
        parent[root(int(a))] = root(int(b))
    groups: dict[int, list[int]] = {}
    for v in parent:
        groups.setdefault(root(v), []).append(v)
    return list(groups.values())


def border_loops(border: np.ndarray) -> int:
    """Connected pieces of the border edges (each a loop when no node is pinched)."""
    return len(connected_groups(border.ravel().tolist(), border.tolist()))


def border_loop_count(triangles) -> int:
    """Border loops of the triangles (t, 3): connected pieces of their border edges."""
    edges = boundary_edges(triangles)
    return border_loops(edges) if len(edges) else 0


def topology_problems(triangles, node_count: int, expected_loops: int = 1) -> list[str]:
    """Why triangles do not form a connected manifold genus-0 surface with ``expected_loops``
    border loops (1: a disk, 2: an open tube); [] if they do. Checked: every edge in at most
    two triangles, every border node on exactly two border edges (no pinch), the number of
    border loops, Euler characteristic V - E + F = 2 - expected_loops, every node used."""
    tri = np.asarray(triangles, dtype=np.int64)
    problems = []
    key = np.sort(tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, counts = np.unique(key, axis=0, return_counts=True)
    if (counts > 2).any():
        problems.append(f"{int((counts > 2).sum())} edges in more than two triangles")
    border = edges[counts == 1]
    per_node = np.bincount(border.ravel(), minlength=node_count)
    if ((per_node != 0) & (per_node != 2)).any():
        problems.append(f"{int(((per_node != 0) & (per_node != 2)).sum())} border nodes pinched")
    loops = border_loops(border) if len(border) else 0
    if loops != expected_loops:
        problems.append(f"{loops} border loops, expected {expected_loops}")
    if len(np.unique(tri)) != node_count:
        problems.append(f"{node_count - len(np.unique(tri))} nodes in no triangle")
    euler = node_count - len(edges) + len(tri)
    if euler != 2 - expected_loops:
        problems.append(f"Euler characteristic {euler}, expected {2 - expected_loops}")
    return problems
