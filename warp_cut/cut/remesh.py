"""Stage 3 of the cut: shortest-distance node matching (paper section 2.3.3, Algorithm 2).

The grey area removed by Stage 1 leaves a hole whose border is a chain of surviving nodes.
Each chain is paired with the lip nodes of the incision that face it (by the slit coordinate
theta, see ``warp_cut.cut.incision``) and the strip between the two is triangulated by walking
along both at once: every step adds one triangle, joining the current border node to the
nearest next lip node or the current lip node to the next border node - whichever new edge
is shorter. This is the paper's rule: border nodes join their nearest lip node (red springs)
and each quad of two neighbouring border nodes and their lip nodes is split by its shorter
diagonal (green). Nodes joined to the curve's end points are yellow, the others blue.
Triangles keep the winding of the surface they replace.
"""

from __future__ import annotations

import numpy as np

from ..mesh.geometry import cross3, triangle_min_angles
from .classes import NodeClass, SpringClass
from .hole_chains import hole_chains, split_at_lips, start_at_slit_start
from .hole_views import UP, hole_views
from .incision import closest_on_polyline
from .lip_slots import PLACEHOLDER, LipSlots, lips_for_chain
from .strip import ear_clip, hole_polygon, turns_with, zip_strip

__all__ = ["fill_hole"]


def _triangulate(chain, lips, editor, chart, positions, min_angle_deg, defer_slivers, slots, tool=None):
    """The matching strip between ``chain`` and ``lips``, or, where displaced nodes make it
    fold over or thin, the hole polygon cut into ears: the better-shaped valid one, or None
    when neither is valid (or, with ``defer_slivers``, both have an angle below
    ``min_angle_deg``). Orientation and ears are judged in the hole's coordinates ``chart``
    (the skin facing +z), shapes on the skin (``positions``); no triangle may bridge the slit
    (``LipSlots.bridges``). A candidate with a triangle turned over on the skin waits while
    ``tool`` (the tool now, or None) is within reach of that triangle: beyond it, the tool is
    not what turned it, and waiting would only let the hole grow behind the tool."""
    lip_set = set(lips)

    def lips_only(tri) -> bool:  # between the lips: it would cover the slit and bury one
        return all(v in lip_set for v in tri)

    candidates = []  # (smallest angle [deg], triangles)
    rest = slots.rest_positions() if editor.policy.prestressed else None
    if lips:
        strip = zip_strip(chain, lips, chart, UP, lips_only)
        if _acceptable(strip, editor, chart, UP, slots, lips_only):
            candidates.append((_min_angle(strip, positions, rest), strip))
    if not candidates or candidates[0][0] < min_angle_deg:
        ears = ear_clip(hole_polygon(chain, lips), chart, UP, lips_only)
        if _acceptable(ears, editor, chart, UP, slots, lips_only):
            candidates.append((_min_angle(ears, positions, rest), ears))
    facing = [c for c in candidates if _faces_out(c[1], positions, slots.incision, tool)]
    # a triangle turned over on the skin (nodes the tool displaced) waits while the tool cuts;
    # once it has gone, it is accepted rather than leave a hole
    candidates = facing if facing or slots.incision.open_end else candidates
    if not candidates:
        return None
    angle, best = max(candidates, key=lambda c: c[0])
    if angle < min_angle_deg and defer_slivers:
        return None  # the tool moves on: the next event may shape it better
    return best


def fill_hole(editor, incision, removed_corners, positions, open_chains=(), *,
              min_angle_deg: float = 15.0, defer_slivers: bool = False, tool=None) -> dict:
    """Re-mesh the hole around ``incision`` (Stage 3).

    Args:
        editor: The TopologyEditor of the current edit.
        incision: The incision whose lips face the hole.
        removed_corners: Corners of the triangles this edit removed (their winding order).
        positions: A ``NodePositions`` of the current node positions [m] (new springs take
            their rest lengths from them); the lip nodes made here are added to it.
        open_chains: Borders of holes an earlier event left open, tried again.
        min_angle_deg: Smallest acceptable triangle angle [deg].
        defer_slivers: Leave a hole open (for the next event) rather than fill it with a
            triangle whose smallest angle is below ``min_angle_deg``.
        tool: The tool now (a ``Tool``), or None: a hole whose new lip nodes would lie inside
            it stays open until it has moved on (a node made inside the tool would be pushed
            out at once: a jolt in the tool's force).

    Returns:
        ``created`` lip nodes, new ``triangles``, ``chains`` count, ``unfilled`` chains
        (borders left open), ``waiting`` chains (while the tool cuts: open onto an opening -
        the tissue's edge, an earlier wound - with no station facing them yet; they join the
        next event's hole), and the ``yellow`` / ``blue`` border nodes. Lip nodes are made
        only for chains whose fill is accepted. A closed chain that does not hold the slit's
        start (the slit's end was lost) is closed over without lips.
    """
    _drop_islands(editor, removed_corners, open_chains)
    created, triangles = [], []
    for attempt in range(1 + _REOPENED_STATIONS):
        chains, slots, pieces = _hole_pieces(editor, incision, removed_corners, positions, open_chains)
        in_slit = _in_the_slit(pieces, incision, positions, slots) if not incision.open_end and not attempt else []
        if in_slit:  # once the tool has gone: they go, their stations get new lips
            editor.delete_nodes(in_slit)
            chains, slots, pieces = _hole_pieces(editor, incision, removed_corners, positions, open_chains)
        made, unfilled, waiting, under_tool = _fill_pieces(pieces, editor, incision, positions, slots, tool,
                                                           min_angle_deg, defer_slivers)
        created += slots.created
        triangles += made
        if incision.open_end or not unfilled:
            break
        # once the tool has gone, a hole no fill closes is opened back by one station: its end
        # lips go (their stations get new lips; a closed hole's one lip, where it touches the
        # slit), and the fill is tried again
        ends = [v for chain in unfilled for v in dict.fromkeys((chain[0], chain[-1]))
                if v in slots.lip_nodes and editor.model.active[v]]
        if not ends:
            break
        editor.delete_nodes(ends)
    triangles = [tri for tri in triangles if _exists(editor, tri)]  # a reopened station's went
    classes = _classify(editor, incision, triangles, positions)
    return {"created": [v for v in created if editor.model.active[v]], "triangles": triangles,
            "chains": len(chains), "unfilled": unfilled, "waiting": waiting, "under_tool": under_tool, **classes}


_REOPENED_STATIONS = 2
"""Times a hole no fill closes once the tool has gone is opened back by one station."""


def _fill_pieces(pieces, editor, incision, positions, slots: LipSlots, tool, min_angle_deg: float,
                 defer_slivers: bool):
    """Fill each hole border of ``pieces`` (``_fill_releasing_pushed_lip``, else close it over
    once the tool has gone; a notch no fill passes waits while the tool cuts and is left open
    to its opening once it has gone): (triangles made, unfilled chains, waiting chains,
    whether a chain waits for the tool)."""
    triangles, unfilled, waiting, under_tool = [], [], [], False
    slots.projected([v for piece in pieces for v in piece])  # at once: every fill asks of them
    for chain in pieces:
        notch = _notch(editor, chain, slots)
        outcome, tris = _fill_releasing_pushed_lip(chain, editor, incision, positions, slots, notch, tool,
                                                   min_angle_deg, defer_slivers)
        if outcome == "waiting":
            waiting.append(chain)  # open to an opening, no station here yet: kept for later
            continue
        if outcome == "open":
            continue  # once the tool has gone: a notch open to an opening, no hole
        if outcome == "under_tool":
            unfilled.append(chain)  # under the tool: filled once it has moved on
            under_tool = True
            continue
        if tris is None:
            if notch and incision.open_end:
                waiting.append(chain)  # open to an opening: tried again while the tool cuts
                continue
            if notch:
                incision.reached_border = True
                continue
            if not incision.open_end:
                tris = _close_over(chain, editor, incision, positions, slots)
            if tris is None:
                unfilled.append(chain)  # leave it open (for now) rather than make an invalid mesh
                continue
        made = slots.accept()
        for tri in tris:
            tri = tuple(made.get(v, v) for v in tri)
            triangles.append(tri)
            editor.add_triangle(tri, positions, SpringClass.RED)
    return triangles, unfilled, waiting, under_tool


def _hole_pieces(editor, incision, removed_corners, positions, open_chains):
    """The hole's border chains, the lip slots, and the chains split at lips (``pieces``)."""
    chains = hole_chains(editor, removed_corners, open_chains)
    slots = LipSlots(editor, incision, positions)
    pieces = [piece for chain in chains
              for piece in split_at_lips(start_at_slit_start(chain, incision, slots), slots)]
    return chains, slots, pieces


def _in_the_slit(pieces, incision, positions, slots: LipSlots) -> list[int]:
    """Nodes on the hole's border that stand in the slit, where no fill can pass them: the two
    lips of a station twisted over each other (``LipSlots.twisted_pair``), a lip on the other
    side of the curve at an end of a hole both of whose ends are lips of its side
    (``LipSlots.crossed_end``, any distance), a lip pushed across the curve (more than the lip
    offset) that closes a hole on itself (``LipSlots.crossed``), and tissue nodes nearer the
    curve than the lip offset along it (pulled there after the tool passed)."""
    nodes = [v for piece in pieces
             for v in slots.twisted_pair(piece) + [slots.crossed_end(piece, beyond=0.0)] if v is not None]
    nodes += [piece[0] for piece in pieces if piece[0] == piece[-1] and slots.crossed(piece[0])]
    lips = slots.lip_nodes
    border = sorted({v for piece in pieces for v in piece if v not in lips} - set(nodes))
    if border:
        u, _, dist = incision.project(positions[border])
        inside = (dist < incision.lip_offset) & (u > incision.spacing) & (u < incision.length - incision.spacing)
        nodes += [v for v, hit in zip(border, inside) if hit]
    return nodes


def _fill_releasing_pushed_lip(chain, editor, incision, positions, slots: LipSlots, notch: bool, tool,
                               min_angle_deg: float, defer_slivers: bool):
    """``_fill_chain``, first with a lip pushed across the curve at an end of the chain taken
    as tissue (``LipSlots.crossed_end``), and as it is if that fill fails."""
    pushed = slots.crossed_end(chain)
    if pushed is not None:
        slots.release(pushed)
        outcome, tris = _fill_chain(chain, editor, incision, positions, slots, notch, tool,
                                    min_angle_deg, defer_slivers)
        if outcome != "unfilled":
            return outcome, tris
        slots.restore(pushed)
    return _fill_chain(chain, editor, incision, positions, slots, notch, tool, min_angle_deg, defer_slivers)


def _fill_chain(chain, editor, incision, positions, slots: LipSlots, notch: bool, tool,
                min_angle_deg: float, defer_slivers: bool):
    """The fill of one hole border ``chain`` with the lips facing it: ("filled", triangles with
    proposed lips, to accept), ("unfilled", None: no valid fill), ("under_tool", None: a new lip
    would lie inside the tool), ("waiting", None: open onto an opening with no station facing
    it yet, while the tool cuts) or ("open", None: the same once the tool has gone, a notch)."""
    ordered = lips_for_chain(incision, chain, slots.theta_of, slots.free_for(chain), notch)
    if not ordered and chain[0] != chain[-1]:
        return ("waiting" if incision.open_end else "open"), None
    for snap in (0.5 * incision.spacing, 0.0):  # a tissue node snapped as a lip may be out of turn
        lips = slots.propose(ordered, chain, snap=snap)
        if tool is not None and slots.proposed_inside(tool):
            slots.discard()
            return "under_tool", None
        for view in hole_views(incision, positions, chain + lips):
            tris = _triangulate(chain, lips, editor, view, positions, min_angle_deg, defer_slivers, slots, tool)
            if tris is not None:
                return "filled", tris
        slots.discard()
        known = slots.lip_nodes
        if not any(v < PLACEHOLDER and v not in known for v in lips):
            break  # nothing was snapped: the same fill again would fail the same way
    return "unfilled", None


def _close_over(chain, editor, incision, positions, slots: LipSlots):
    """The last resort once the tool has gone, for a hole that no fill closes without joining
    the slit's two sides (e.g. a lip pushed across the curve by a thick tool, so the hole
    touches the slit at one lip): its border alone cut into ears, which may join the sides -
    the slit stays closed there instead of a hole staying open. Only a hole that spans at most
    ``_CLOSE_OVER_SPAN`` spacings of the curve, or whose border is at most twice that long (it
    cannot close a longer stretch; on a zigzag its nodes may project onto different legs of
    the curve): a longer one stays open rather than close a long stretch of the wound. None if
    not closed."""
    limit = _CLOSE_OVER_SPAN * incision.spacing
    u, _, _ = incision.project(positions[chain])
    x = np.asarray(positions[list(chain) + [chain[0]]], dtype=np.float64)
    perimeter = float(np.linalg.norm(np.diff(x, axis=0), axis=1).sum())
    if float(u.max() - u.min()) > limit and perimeter > 2.0 * limit:
        return None
    polygon = hole_polygon(chain, [])
    for view in hole_views(incision, positions, polygon):
        ears = ear_clip(polygon, view, UP)
        if _acceptable(ears, editor, view, UP, slots, may_join=True):
            return ears
    return None


_CLOSE_OVER_SPAN = 4.0
"""Spacings of curve a hole may span and still be closed over (``_close_over``)."""


def _drop_islands(editor, removed_corners, open_chains) -> None:
    """Delete the triangles at the hole that share no edge with another triangle (left
    standing alone inside it by earlier edits): their corners join the hole's border, and a
    lip among them is free to be placed again."""
    near = {v for c in removed_corners for v in c} | {v for chain in open_chains for v in chain}
    corners = editor.model.triangle_table.column("corners")
    islands = []
    for t in {t for v in near for t in editor.node_triangles[v]}:
        a, b, c = (int(v) for v in corners[t])
        if all(len(editor.triangles_with_edge(i, j)) == 1 for i, j in ((a, b), (b, c), (c, a))):
            islands.append(t)
    editor.delete_triangles(islands)


def _notch(editor, chain, slots: LipSlots) -> bool:
    """True if an open chain ends on an opening away from the lips (the tissue's outer border
    or an earlier wound): the cut has run into it there and the region is open to it, not a
    hole."""
    if chain[0] == chain[-1]:
        return False
    lips = slots.lip_nodes
    return any(v not in lips and _on_outer_border(editor, v, lips) for v in (chain[0], chain[-1]))


def _on_outer_border(editor, v: int, lips: set) -> bool:
    """True if node v has an edge used by one live triangle whose other end is not a lip node
    either (an edge of the tissue's own border, not of a slit)."""
    corners = editor.model.triangle_table.column("corners")
    for t in editor.node_triangles[v]:
        for w in corners[t]:
            w = int(w)
            if w != v and w not in lips and len(editor.triangles_with_edge(v, w)) == 1:
                return True
    return False


def _faces_out(tris, positions, incision, tool=None) -> bool:
    """True if every triangle (node triples) turns on the skin (``positions`` [m]) the way of
    the skin's outward normal at its centre (the incision's normal at its projection); with
    ``tool``, only the triangles within its reach count (``_TOOL_REACH``)."""
    p = positions[[v for t in tris for v in t]].reshape(-1, 3, 3)
    centres = p.mean(axis=1)
    normals = cross3(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    u, _, _ = incision.project(centres)
    out = np.einsum("ij,ij->i", normals, incision.normal_at(u)) > 0.0
    if tool is not None:
        _, _, _, from_axis = closest_on_polyline(centres, np.stack([tool.p0, tool.p1]))
        out |= from_axis > tool.radius + _TOOL_REACH * incision.spacing
    return bool(out.all())


_TOOL_REACH = 2.0
"""Spacings beyond the tool's radius within which the tool is taken to displace nodes."""


def _min_angle(tris, positions, rest=None) -> float:
    """Smallest angle [deg] of triangles (node triples) at ``positions``, and at the rest
    positions ``rest`` too if given (a prestressed sheet's springs take their lengths from its
    rest shape: a triangle thin there would be a sliver once the sheet settles)."""
    if not tris:
        return 0.0
    nodes = [v for t in tris for v in t]
    local = np.arange(len(nodes)).reshape(-1, 3)
    angle = float(triangle_min_angles(positions[nodes], local).min())
    return angle if rest is None else min(angle, float(triangle_min_angles(rest[nodes], local).min()))


def _acceptable(strip, editor, positions, normal, slots: LipSlots, forbidden=None, may_join: bool = False) -> bool:
    """A strip may join the mesh only if every triangle keeps the surface's orientation, none
    bridges the slit (unless ``may_join``), is ``forbidden`` (a predicate on node triples, if
    given) or repeats a live triangle's corners, and no edge ends up with more than two
    triangles or the same direction twice."""
    if not strip:
        return False
    directed = set()
    for tri in strip:
        if (not turns_with(tri, positions, normal) or (not may_join and slots.bridges(tri))
                or (forbidden is not None and forbidden(tri)) or _exists(editor, tri)):
            return False
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            if (a, b) in directed:
                return False
            directed.add((a, b))
    corners = editor.model.triangle_table.column("corners")
    for a, b in directed:
        known = a < len(editor.node_triangles) and b < len(editor.node_triangles)
        existing = editor.triangles_with_edge(a, b) if known else set()
        if len(existing) >= 2 or (b, a) in directed and existing:
            return False
        for t in existing:  # the surviving triangle must run the edge the other way
            c = list(corners[t])
            if any(c[k] == a and c[(k + 1) % 3] == b for k in range(3)):
                return False
    return True


def _exists(editor, tri) -> bool:
    """True if a live triangle has the corners of ``tri`` (in either winding)."""
    count = len(editor.node_triangles)
    if any(v >= count for v in tri):
        return False
    a, b, c = tri
    return bool(editor.node_triangles[a] & editor.node_triangles[b] & editor.node_triangles[c])


def _classify(editor, incision, triangles, positions) -> dict:
    """Classes after a fill: lip springs along the lips; for every tissue node the edit
    touched that is joined to lip nodes, the spring to its nearest lip is red and the others
    green, and the node is yellow if one of its lips is an end point of the curve, else blue.
    A touched node no longer joined to any lip (the slit's end moved on) is grey: it borders
    the grey area."""
    model = editor.model
    lip_set = {n for n in incision.left + incision.right + [incision.start_node, incision.end_node] if n >= 0}
    ends = {incision.start_node, incision.end_node} - {-1}
    for tri in triangles:
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            if a in lip_set and b in lip_set:
                slot = editor.spring_between(a, b)
                if slot is not None:
                    editor.set_spring_class(slot, SpringClass.LIP)
    affected = ({v for tri in triangles for v in tri} | editor.touched_nodes) - lip_set
    pairs = model.spring_table.column("pairs")
    yellow, blue, grey = [], [], []
    for v in sorted(affected):
        if not model.active[v]:
            continue
        lips = sorted({int(w) for s in editor.node_springs[v] for w in pairs[s] if int(w) in lip_set})
        if not lips:
            if model.node_class[v] in (NodeClass.YELLOW, NodeClass.BLUE):
                grey.append(v)
            continue
        dist = [np.linalg.norm(positions[lip] - positions[v]) for lip in lips]
        nearest = lips[int(np.argmin(dist))]
        for lip in lips:
            editor.set_spring_class(editor.spring_between(v, lip),
                                    SpringClass.RED if lip == nearest else SpringClass.GREEN)
        (yellow if ends & set(lips) else blue).append(v)
    editor.set_node_class(yellow, NodeClass.YELLOW)
    editor.set_node_class(blue, NodeClass.BLUE)
    editor.set_node_class(grey, NodeClass.GREY)
    editor.set_node_class(lip_set, NodeClass.LIP)
    return {"yellow": yellow, "blue": blue}
