"""The two ways Stage 3 cuts a hole into triangles: the matching strip between its border chain
and the lips facing it (``zip_strip``, the paper's shortest-distance rule), and ears of the hole's
polygon (``ear_clip``) where the strip would fold. Pure geometry on node indices and positions
[m] (anything an index array turns into (k, 3)); ``turns_with`` is the orientation test both use.
"""

from __future__ import annotations

import math

import numpy as np

from ..mesh.geometry import plane_frame

__all__ = ["turns_with", "zip_strip", "hole_polygon", "ear_clip"]


def turns_with(tri, positions, normal) -> bool:
    """True if the triangle has three distinct corners and turns the way of ``normal``."""
    a, b, c = tri
    if a == b or b == c or a == c:
        return False
    # plain floats: this runs for every candidate triangle of every fill
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = positions[[a, b, c]].tolist()
    ux, uy, uz, wx, wy, wz = bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az
    nx, ny, nz = float(normal[0]), float(normal[1]), float(normal[2])
    turn = (uy * wz - uz * wy) * nx + (uz * wx - ux * wz) * ny + (ux * wy - uy * wx) * nz
    return turn > 1e-12 * (ux * ux + uy * uy + uz * uz + 1e-300)


def zip_strip(border, lips, positions, normal, forbidden=None) -> list[tuple[int, int, int]]:
    """Triangulate the strip between a border chain and a lip chain (both ordered the same
    way along the strip, the border chain oriented like the surface's edges on it); where one
    of the two next triangles is ``forbidden`` (a predicate on node triples), the other."""
    tris = []
    i = j = 0
    while i < len(border) - 1 or j < len(lips) - 1:
        along_border = (border[i], border[i + 1], lips[j]) if i < len(border) - 1 else None
        along_lips = (border[i], lips[j + 1], lips[j]) if j < len(lips) - 1 else None
        if along_border is None:
            choice = "lips"
        elif along_lips is None:
            choice = "border"
        else:
            d_border = np.linalg.norm(positions[border[i + 1]] - positions[lips[j]])
            d_lips = np.linalg.norm(positions[lips[j + 1]] - positions[border[i]])
            choice = "border" if d_border <= d_lips else "lips"
            first = along_border if choice == "border" else along_lips
            other = along_lips if choice == "border" else along_border
            if _blocked(first, positions, normal, forbidden) and not _blocked(other, positions, normal, forbidden):
                choice = "lips" if choice == "border" else "border"
        tri = along_border if choice == "border" else along_lips
        if len(set(tri)) == 3:
            tris.append(tri)
        if choice == "border":
            i += 1
        else:
            j += 1
    return tris


def _blocked(tri, positions, normal, forbidden) -> bool:
    """True if a (non-degenerate) strip triangle would turn over or is ``forbidden``."""
    return len(set(tri)) == 3 and (not turns_with(tri, positions, normal) or (forbidden is not None and forbidden(tri)))


def hole_polygon(border, lips) -> list[int]:
    """The hole's boundary cycle: along the border chain, then back along the lips (shared end
    nodes once)."""
    cycle = list(border) + list(reversed(lips))
    out = []
    for v in cycle:
        if not out or out[-1] != v:
            out.append(v)
    while len(out) > 1 and out[0] == out[-1]:
        out.pop()
    return out


def ear_clip(polygon, positions, normal, forbidden=None) -> list[tuple[int, int, int]]:
    """Triangulate a simple polygon (node cycle, counter-clockwise about ``normal``) by cutting
    ears, best (largest smallest angle) first, never one whose nodes are ``forbidden`` (a
    predicate on node triples); [] if the polygon is not simple or no ear is left."""
    e1, e2 = plane_frame(normal)
    pts = positions[polygon]
    # ring entries are positions in the cycle: a node may appear twice (a closed border and a
    # closed slit joined by a bridge edge walked both ways)
    xy = [(float(p @ e1), float(p @ e2)) for p in pts]
    ring = list(range(len(polygon)))
    tris = []

    def cross(a, b, c):
        return (xy[b][0] - xy[a][0]) * (xy[c][1] - xy[a][1]) - (xy[b][1] - xy[a][1]) * (xy[c][0] - xy[a][0])

    def min_angle(a, b, c):
        p = [xy[v] for v in (a, b, c)]
        angles = []
        for k in range(3):
            (x0, y0), (x1, y1), (x2, y2) = p[k], p[(k + 1) % 3], p[(k + 2) % 3]
            u, w = (x1 - x0, y1 - y0), (x2 - x0, y2 - y0)
            angles.append(math.atan2(abs(u[0] * w[1] - u[1] * w[0]), u[0] * w[0] + u[1] * w[1]))
        return min(angles)

    while len(ring) > 3:
        best, best_q = None, -1.0
        turns = [cross(ring[k - 1], ring[k], ring[(k + 1) % len(ring)]) for k in range(len(ring))]
        # only a reflex (or flat) corner can lie inside an ear of a simple polygon
        reflex = [v for v, turn in zip(ring, turns) if turn <= 0]
        for k in range(len(ring)):
            a, b, c = ring[k - 1], ring[k], ring[(k + 1) % len(ring)]
            if turns[k] <= 0:
                continue  # reflex or flat corner
            corners = {polygon[a], polygon[b], polygon[c]}
            if len(corners) < 3 or forbidden is not None and forbidden((polygon[a], polygon[b], polygon[c])):
                continue
            inside = any(cross(a, b, v) >= 0 and cross(b, c, v) >= 0 and cross(c, a, v) >= 0
                         for v in reflex if polygon[v] not in corners)
            if inside:
                continue
            q = min_angle(a, b, c)
            if q > best_q:
                best, best_q = k, q
        if best is None:
            return []
        a, b, c = ring[best - 1], ring[best], ring[(best + 1) % len(ring)]
        tris.append((a, b, c))
        ring.pop(best)
    if len(ring) == 3 and cross(*ring) > 0 and len({polygon[v] for v in ring}) == 3:
        tris.append(tuple(ring))
    else:
        return []
    return [tuple(polygon[v] for v in tri) for tri in tris]
