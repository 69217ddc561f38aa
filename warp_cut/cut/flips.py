"""Edge flips that take slivers out of the triangles a finished incision made.

Stage 3 fills each hole as the tool passes, so a fill made next to the moving tool can leave
a sliver (a triangle with an angle under SLIVER_DEG, SPEC section 4). Once the tool has left
the skin nothing moves the cut any more, and a sliver that shares its longest edge with
another triangle the cut made is flipped (Lawson's flip: the quad's other diagonal) where that
raises the pair's smallest angle and both new triangles face the skin's side the old pair did.
Only triangles the cut made are flipped: the tissue's own mesh, the wound's border (one
triangle per edge) and any hole still open are left as they are.
"""

from __future__ import annotations

import numpy as np

from ..mesh.geometry import SLIVER_DEG, cross3, triangle_min_angles
from .classes import SpringClass

__all__ = ["flip_slivers", "FACING_COS"]

FACING_COS = 0.5
"""A flipped triangle's normal must lie within 60 degrees of the old pair's mean normal."""


def _normal(x: np.ndarray) -> np.ndarray:
    """Unit normal of the triangle x (3, 3) by its winding (zero if degenerate)."""
    n = cross3(x[1] - x[0], x[2] - x[0])
    length = np.linalg.norm(n)
    return n / length if length > 0 else n


def _flip_of(editor, t: int, positions) -> tuple | None:
    """The flip that would take sliver ``t`` out: (its partner u, the two new triangles), across
    its longest edge where that helps, else the next; None when no edge will do (on the
    border, a partner the cut did not make is the caller's to refuse, the other diagonal
    already an edge, no gain in the smallest angle, or a triangle turned away from the skin)."""
    tri = [int(v) for v in editor.model.triangle_table.column("corners")[t]]
    x = positions[tri]
    lengths = [np.linalg.norm(x[(c + 1) % 3] - x[c]) for c in range(3)]
    for c in np.argsort(lengths)[::-1]:
        flip = _flip_across(editor, t, tri[c], tri[(c + 1) % 3], tri[(c + 2) % 3], positions)
        if flip is not None:
            return flip
    return None


def _flip_across(editor, t: int, i: int, j: int, k: int, positions) -> tuple | None:
    """The flip of t = (i, j, k) across its edge i -> j, or None (see ``_flip_of``)."""
    partners = editor.triangles_with_edge(i, j) - {t}
    if len(partners) != 1:
        return None
    u = partners.pop()
    l = next(int(v) for v in editor.model.triangle_table.column("corners")[u] if int(v) not in (i, j))
    if editor.spring_between(k, l) is not None:
        return None
    new = [(i, l, k), (l, j, k)]
    quad = positions[[i, j, k, l]]
    local = {i: 0, j: 1, k: 2, l: 3}
    old_angle = triangle_min_angles(quad, [[0, 1, 2], [1, 0, 3]]).min()
    new_angle = triangle_min_angles(quad, [[local[v] for v in tri_] for tri_ in new]).min()
    if new_angle <= old_angle:
        return None
    facing = _normal(quad[[0, 1, 2]]) + _normal(quad[[1, 0, 3]])
    facing /= max(np.linalg.norm(facing), 1e-300)
    if any(_normal(quad[[local[v] for v in tri_]]) @ facing < FACING_COS for tri_ in new):
        return None
    return u, new


def flip_slivers(editor, candidates: set[int], positions, *, rounds: int = 3) -> int:
    """Flip the slivers among ``candidates`` (live triangle slots the cut made) where a flip
    helps (``_flip_of``), in an edit already begun on ``editor``; ``positions`` are the current
    node positions [m] (indexable by node arrays). Repeats up to ``rounds`` passes; returns the
    flips made. The caller finishes the edit (the stray old diagonal's spring goes then)."""
    table = editor.model.triangle_table
    flips = 0
    for _ in range(rounds):
        live = np.array(sorted(t for t in candidates if table.alive[t]), dtype=np.int64)
        if not len(live):
            break
        corners = positions[table.column("corners")[live].ravel()]                 # (3 t, 3)
        angles = triangle_min_angles(corners, np.arange(3 * len(live)).reshape(-1, 3))
        made = 0
        for t in live[angles < SLIVER_DEG]:
            if not table.alive[t]:
                continue
            flip = _flip_of(editor, int(t), positions)
            if flip is None or flip[0] not in candidates:
                continue
            u, new = flip
            editor.delete_triangles([int(t), u])
            candidates.difference_update((int(t), u))
            for tri in new:
                candidates.add(editor.add_triangle(tri, positions, SpringClass.GREEN))
            made += 1
        flips += made
        if not made:
            break
    return flips
