"""Where a new lip node goes: on the curve, or, in a prestressed sheet, with its side's tissue.

Stage 3 makes a station's lip nodes once the tool has passed it, at ``lip_offset`` either side
of the incision curve (``Incision.lip_position``). In a sheet without prestress the tissue
beside the curve is still there, and that is where the lip belongs. In a prestressed sheet
(``TissueModel.prestress_tension`` > 0) the cut releases the tension and the wound has begun to
gape by then: each side has drawn back from the curve. A lip made on the curve would fill the
gap with new material, joined to its side at the current lengths, and the opening that had
already happened would be lost to the wound (measured on ``wound_gape``: 0.65 of the closed
form against 0.75 with the lips placed here).

So in a prestressed sheet a lip goes where its material point has moved. The displacement of
its side is the Gaussian-weighted mean displacement (current minus rest position) of the live
nodes on that side near the station; the motion both sides share (their mean, e.g. a sag) was
already in the curve when the tool traced it, so only the side's part of the gape is added:

    current   = lip position + d_side - (d_left + d_right) / 2
    reference = lip position - (d_left + d_right) / 2

The slit's start and end nodes stay on the curve (where the two sides meet), with the same
reference. The reference point is the node's rest position, from which the springs made to it
get their rest lengths (``TopologyEditor.finish``): a rest position taken where the tissue had
moved to would give them the wrong lengths.
"""

from __future__ import annotations

import numpy as np

from .incision import Incision

__all__ = ["lip_placement", "REACH"]

REACH = 2.0
"""Nodes within this many station spacings of the curve point count for a side's displacement
(Gaussian weights of one spacing)."""


def lip_placement(editor, positions: np.ndarray, incision: Incision, u: float, side: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(current, rest) position [m] (3,) of a new lip node of the station at ``u`` [m] on
    ``side`` (+1 left, -1 right, 0 the slit's start or end). ``positions``: the current node
    positions [m], anything a node index array turns into (k, 3) (a ``NodePositions`` during
    an edit: the nodes it has made so far count too). Both are ``incision.lip_position`` but
    in a prestressed sheet (module docstring)."""
    point = incision.lip_position(u, side)
    if not editor.policy.prestressed:
        return point, point
    shift = _side_displacements(editor.model, positions, incision, u)
    if shift is None:
        return point, point
    common = 0.5 * (shift[0] + shift[1])
    if side == 0:
        return point, point - common  # the slit's start or end: on the curve, where both sides meet
    mine = shift[0] if side > 0 else shift[1]
    return point + mine - common, point - common


def _side_displacements(model, positions: np.ndarray, incision: Incision, u: float):
    """Weighted mean displacement [m] (3,) of the left and of the right tissue beside the curve
    at ``u`` (live nodes within ``REACH`` spacings whose closest curve point is within as much
    of ``u``), or None if a side has no such node."""
    h = incision.spacing
    centre = incision.point_at(u)[0]
    live = np.flatnonzero(model.active)
    x = np.asarray(positions[live], dtype=np.float64).reshape(-1, 3)
    dist = np.linalg.norm(x - centre, axis=1)
    near = dist < REACH * h
    if not near.any():
        return None
    nodes, x, dist = live[near], x[near], dist[near]
    along, sides, _ = incision.project(x)
    beside = np.abs(along - u) < REACH * h
    weights = np.exp(-(dist / h) ** 2) * beside
    moved = x - model.points[nodes]
    out = []
    for side in (1, -1):
        w = weights * (sides == side)
        if not w.sum() > 0.0:
            return None
        out.append((w @ moved) / w.sum())
    return out
