"""A straight slit along mesh edges: the reference crack of the fracture-mechanics check.

A slit in a triangle mesh needs the two sides not to share nodes along it. Deleting the
springs that cross a segment is not enough (the nodes on it would still join both sides), and
deleting a thin row of triangles would open a gap of finite width. Here the segment runs along
mesh edges from one node (a tip) to another, and every node strictly between the tips is
duplicated: the triangles on the side the normal x direction points to (the "upper" side) move
to the copies, the others keep the originals; the tips stay shared, so the slit is closed at
both ends. Nothing is deleted but the springs from line nodes to the upper side, which are made
again from the copies with the same rest length and stiffness. Each spring along the line,
which bordered one triangle on each side, becomes two, one per side, with the same rest length
and the stiffness split in proportion to the two triangles' areas: along a row of the patch
lattice (mirror-symmetric triangles) these are exactly the two halves of the sheet (van Gelder
springs give each half its own triangle's stiffness, and a prestressed sheet keeps, on each
side, the tension (T/2) cot(alpha) |e| of that side's triangle), so before anything moves the
mesh is the uncut sheet with the traction across the line released.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ...mesh.geometry import cross3
from ..classes import NodeClass
from ..topology import TopologyEditor

__all__ = ["Slit", "open_slit"]


@dataclass(frozen=True)
class Slit:
    """A slit made by ``open_slit``.

    lower: original nodes strictly between the tips, ordered from start to end, shape (k,).
    upper: their copies (the upper side), shape (k,).
    arc: distance of each from the start [m], shape (k,).
    tips: the two shared end nodes (start, end).
    length: distance between the tips [m].
    """

    lower: np.ndarray
    upper: np.ndarray
    arc: np.ndarray
    tips: tuple[int, int]
    length: float


def _line_nodes(model, start, end, tolerance):
    """Live nodes on the segment (sorted by arc length) and the two tips."""
    x = model.points
    direction = end - start
    length = float(np.linalg.norm(direction))
    if length <= 0:
        raise InputError("a slit needs two different end points")
    t = direction / length
    live = np.flatnonzero(model.active)
    s = (x[live] - start) @ t
    off = np.linalg.norm(x[live] - start - np.outer(s, t), axis=1)
    on = live[(off <= tolerance) & (s >= -tolerance) & (s <= length + tolerance)]
    arc = (x[on] - start) @ t
    order = np.argsort(arc)
    on, arc = on[order], arc[order]
    if len(on) < 3 or arc[0] > tolerance or arc[-1] < length - tolerance:
        raise InputError(f"the slit from {start.tolist()} to {end.tolist()} must start and end "
                         f"at mesh nodes and pass through at least one node between them")
    return on, arc, length, t


def _check_edges(editor, nodes) -> None:
    for a, b in zip(nodes[:-1], nodes[1:]):
        if editor.spring_between(int(a), int(b)) is None:
            raise InputError(f"the slit must run along mesh edges: nodes {int(a)} and {int(b)} "
                             f"on it are not joined by a spring")


def _area(points, corners) -> float:
    p = points[list(corners)]
    return 0.5 * float(np.linalg.norm(cross3(p[1] - p[0], p[2] - p[0])))


def open_slit(model, start, end, *, normal=(0.0, 0.0, 1.0), tolerance: float | None = None,
              editor: TopologyEditor | None = None) -> Slit:
    """Cut a straight slit from ``start`` to ``end`` [m] (both mesh nodes) along mesh edges.

    Args:
        model: The TissueModel, edited in place.
        start, end: End points [m], shape (3,).
        normal: The sheet's normal (the upper side is normal x (end - start)), shape (3,).
        tolerance: Distance [m] within which a node lies on the segment (default 1e-6 x length).
        editor: The model's TopologyEditor (one is made if None).

    Returns:
        The Slit (node pairs across it).
    """
    start, end = np.asarray(start, np.float64), np.asarray(end, np.float64)
    tol = 1e-6 * float(np.linalg.norm(end - start)) if tolerance is None else float(tolerance)
    editor = editor or TopologyEditor(model)
    nodes, arc, length, t = _line_nodes(model, start, end, tol)
    _check_edges(editor, nodes)
    interior, line = nodes[1:-1], {int(v) for v in nodes}
    side_dir = cross3(np.asarray(normal, np.float64), t)
    corners = model.triangle_table.column("corners")
    x = model.points
    upper_tris = sorted({tr for v in interior for tr in editor.node_triangles[int(v)]
                         if (x[corners[tr]].mean(axis=0) - start) @ side_dir > 0})
    old = {}  # sorted pair -> (rest length, stiffness) of the springs at the line nodes
    pairs = model.spring_table.column("pairs")
    for v in interior:
        for slot in editor.node_springs[int(v)]:
            old[tuple(int(u) for u in pairs[slot])] = (model.spring_table.column("rest_length")[slot],
                                                       model.spring_table.column("stiffness")[slot])
    upper_corners = [tuple(int(v) for v in corners[tr]) for tr in upper_tris]
    editor.begin()
    copies = editor.add_nodes(x[interior], NodeClass.NORMAL)
    copy_of = {int(v): int(c) for v, c in zip(interior, copies)}
    original = {c: v for v, c in copy_of.items()}
    editor.delete_triangles(upper_tris)
    editor.add_triangles([[copy_of.get(v, v) for v in tri] for tri in upper_corners], model.points)
    report = editor.finish()
    _restore_springs(model, editor, report.new_springs, original, old, line)
    return Slit(np.asarray(interior, np.int64), np.asarray(copies, np.int64), arc[1:-1],
                (int(nodes[0]), int(nodes[-1])), length)


def _restore_springs(model, editor, new_springs, original, old, line) -> None:
    """Give the remade springs the rest length and stiffness of the ones they replace; split
    a spring along the line between its two copies in proportion to their triangles' areas."""
    table = model.spring_table
    pairs = table.column("pairs")
    x = model.points
    corners = model.triangle_table.column("corners")
    for slot in new_springs:
        if not table.alive[slot]:
            continue
        a, b = (int(v) for v in pairs[slot])
        key = tuple(sorted((original.get(a, a), original.get(b, b))))
        rest, k = old[key]
        if key[0] in line and key[1] in line:
            kept = editor.spring_between(*key)
            up = sum(_area(x, corners[tr]) for tr in editor.triangles_with_edge(a, b))
            low = sum(_area(x, corners[tr]) for tr in editor.triangles_with_edge(*key))
            table.set("stiffness", [kept], k * low / (up + low))
            table.set("rest_length", [kept], rest)  # as before the edit (its prestress, if any)
            k = k * up / (up + low)
        table.set("rest_length", [slot], rest)
        table.set("stiffness", [slot], k)
