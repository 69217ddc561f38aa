"""Edge flips among the triangles a cut made: a prestressed strip made Delaunay in the rest shape.

Each event's fill is Delaunay within its region (``warp_cut.cut.remesh.fill``); the edges where two
events' regions meet need not be. In a prestressed sheet the rest shape decides what each
spring carries: an edge gets
the cotangent tension (T/2)(cot a + cot b)|e| from the angles a, b opposite it, which is
negative (a compressed spring) where a + b > 180 deg, i.e. where the edge is not locally
Delaunay. The strip the fills leave beside the wound depends on where each event happened to
cut, and its springs then hold the lips unevenly (the opening measured at the lips scattered
with the event interval). So once an incision is complete the edges between two triangles the
cut made are flipped until
each is locally Delaunay in the rest shape (Lawson's algorithm), where the new pair faces the
skin's side in the rest shape and at the current positions and is no sliver where the nodes
are now.

Only triangles the cut made are flipped: the tissue's own mesh, the wound's border (one
triangle per edge) and any hole still open are left as they are.
"""

from __future__ import annotations

import numpy as np

from ...mesh.geometry import SLIVER_DEG, cross3, edge_keys, half_edges, triangle_angles, triangle_min_angles
from ..classes import SpringClass

__all__ = ["flip_to_delaunay", "FACING_COS", "DELAUNAY_TOLERANCE_DEG", "OLD_PAIR", "NEW_PAIR"]

FACING_COS = 0.5
"""A flipped triangle's normal must lie within 60 degrees of the old pair's mean normal."""

DELAUNAY_TOLERANCE_DEG = 1e-6
"""An edge is flipped to Delaunay when its two opposite angles sum above 180 deg by more than
this (a cocircular quad, such as a rectangle split on either diagonal, is left alone)."""


OLD_PAIR = ((0, 1, 2), (1, 0, 3))
"""A quad i, j, k, l (local corners 0..3) split on its diagonal i - j: (i, j, k), (j, i, l)."""
NEW_PAIR = ((0, 3, 2), (3, 1, 2))
"""The same quad split on the other diagonal k - l: (i, l, k), (l, j, k)."""


def _normal(x: np.ndarray) -> np.ndarray:
    """Unit normal of the triangle x (3, 3) by its winding (zero if degenerate)."""
    n = cross3(x[1] - x[0], x[2] - x[0])
    length = np.linalg.norm(n)
    return n / length if length > 0 else n


def _other_diagonal(editor, t: int, i: int, j: int, k: int) -> tuple | None:
    """Across t = (i, j, k)'s edge i -> j: (the partner u, its far corner l, the quad's two
    triangles on the other diagonal k - l), or None on the border or where k - l is already
    an edge."""
    partners = editor.triangles_with_edge(i, j) - {t}
    if len(partners) != 1:
        return None
    u = partners.pop()
    l = next(int(v) for v in editor.model.triangle_table.column("corners")[u] if int(v) not in (i, j))
    if editor.spring_between(k, l) is not None:
        return None
    return u, l, [(i, l, k), (l, j, k)]


def _faces_as_before(quad: np.ndarray) -> bool:
    """Whether both triangles of ``NEW_PAIR`` on ``quad`` (the (4, 3) points i, j, k, l) face
    within 60 deg of ``OLD_PAIR``'s mean normal (``FACING_COS``)."""
    facing = _normal(quad[list(OLD_PAIR[0])]) + _normal(quad[list(OLD_PAIR[1])])
    facing /= max(np.linalg.norm(facing), 1e-300)
    return all(_normal(quad[list(tri)]) @ facing >= FACING_COS for tri in NEW_PAIR)


def _smallest_angles(quad: np.ndarray) -> tuple[float, float]:
    """Smallest angle [deg] of ``OLD_PAIR`` and of ``NEW_PAIR`` on ``quad`` (4, 3)."""
    return float(triangle_min_angles(quad, OLD_PAIR).min()), float(triangle_min_angles(quad, NEW_PAIR).min())


def _apply_flip(editor, candidates: set[int], t: int, u: int, new) -> None:
    """Replace triangles t and u by ``new`` (their new slots join ``candidates``; the new
    diagonal's rest length from the rest shape)."""
    editor.delete_triangles([t, u])
    candidates.difference_update((t, u))
    for tri in new:
        candidates.add(editor.add_triangle(tri, editor.model.points, SpringClass.GREEN))


def _makes_a_sliver(quad: np.ndarray) -> bool:
    """Whether ``NEW_PAIR`` on ``quad`` (the (4, 3) points i, j, k, l where the nodes are now)
    has an angle under SLIVER_DEG and a smaller one than ``OLD_PAIR``: a flip that is right for
    the rest shape must not thin what the wound's opening has shaped (nor undo a sliver flip,
    which would then be made again at every event)."""
    old_angle, new_angle = _smallest_angles(quad)
    return new_angle < SLIVER_DEG and new_angle < old_angle


def _delaunay_flip_across(editor, t: int, i: int, j: int, k: int, rest: np.ndarray, positions) -> tuple | None:
    """The flip of t = (i, j, k) across its edge i -> j where that edge is not locally Delaunay
    in the rest shape ``rest``: (the partner u, the two new triangles), or None (the partner
    is the caller's to check; see ``flip_to_delaunay``)."""
    other = _other_diagonal(editor, t, i, j, k)
    if other is None:
        return None
    u, l, new = other
    quad_rest, quad_now = rest[[i, j, k, l]], positions[[i, j, k, l]]
    angles = triangle_angles(quad_rest, OLD_PAIR)  # the partner may be new since the edges were listed
    if angles[0, 2] + angles[1, 2] <= 180.0 + DELAUNAY_TOLERANCE_DEG:
        return None
    if not (_faces_as_before(quad_rest) and _faces_as_before(quad_now)) or _makes_a_sliver(quad_now):
        return None
    return u, new


def _non_delaunay_edges(table, candidates: set[int], rest: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Edges between two live ``candidates`` whose opposite angles in the rest shape ``rest``
    (node_count, 3) [m] sum above 180 deg (+ ``DELAUNAY_TOLERANCE_DEG``), worst first, each as
    (t, i, j, k): one of its triangles t = (i, j, k) and the edge i -> j."""
    live = np.array(sorted(t for t in candidates if table.alive[t]), dtype=np.int64)
    if len(live) < 2:
        return []
    corners = table.column("corners")[live]                                        # (m, 3)
    opposite = triangle_angles(rest, corners)[:, [2, 0, 1]].ravel()               # (3 m,) at edge q's far corner
    edges = half_edges(corners)                                                   # (3 m, 2): (c_q, c_q+1)
    keys = edge_keys(np.sort(edges, axis=1), len(rest))
    order = np.argsort(keys, kind="stable")
    shared = np.flatnonzero(keys[order][1:] == keys[order][:-1])
    a, b = order[shared], order[shared + 1]
    total = opposite[a] + opposite[b]
    bad = np.flatnonzero(total > 180.0 + DELAUNAY_TOLERANCE_DEG)
    out = []
    for h in a[bad[np.argsort(-total[bad])]]:
        tri, q = corners[h // 3], h % 3
        out.append((int(live[h // 3]), int(tri[q]), int(tri[(q + 1) % 3]), int(tri[(q + 2) % 3])))
    return out


def flip_to_delaunay(editor, candidates: set[int], rest: np.ndarray, positions, *, rounds: int = 50) -> int:
    """Flip the edges between two of ``candidates`` (live triangle slots the cut made) until
    each is locally Delaunay in the rest shape ``rest`` (node_count, 3) [m] (Lawson's
    algorithm; see the module doc), in an edit already begun on ``editor``. A flip is made only
    where both new triangles face the old pair's side in the rest shape and at the current
    ``positions`` [m] (indexable by node arrays), makes no sliver there (``_makes_a_sliver``)
    and the other diagonal is not an edge yet.
    Repeats up to ``rounds`` passes; returns the flips made. The caller finishes the edit."""
    table = editor.model.triangle_table
    flips = 0
    for _ in range(rounds):
        made = 0
        for t, i, j, k in _non_delaunay_edges(table, candidates, rest):
            if t not in candidates or not table.alive[t] or {i, j, k} != set(table.column("corners")[t].tolist()):
                continue  # an earlier flip this pass took it
            flip = _delaunay_flip_across(editor, t, i, j, k, rest, positions)
            if flip is None or flip[0] not in candidates:
                continue
            _apply_flip(editor, candidates, t, *flip)
            made += 1
        flips += made
        if not made:
            break
    return flips
