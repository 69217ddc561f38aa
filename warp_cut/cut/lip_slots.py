"""The lip slots of an incision during one Stage 3 fill (``warp_cut.cut.remesh``).

A slot is a place a lip node belongs: the slit's start and end nodes and, at every station
along the curve, one node on each side (``Incision.lip_nodes``), each with its slit coordinate
theta. ``lips_for_chain`` picks the slots facing a hole's border chain; ``LipSlots`` knows
which slots have nodes, proposes nodes for the empty ones (placeholders, made real only if the
fill is accepted), and answers the questions a fill asks of them: which side of the slit a
node is on, whether a triangle would join the two sides behind the slit's tip, whether a new
lip would lie inside the tool.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..sim.strokes import inside_cylinder
from .classes import NodeClass
from .lip_placement import lip_placement
from .topology import NodePositions

__all__ = ["LipSlots", "lips_for_chain", "lips_inside", "LIP_TOOL_SLACK", "PLACEHOLDER"]


def lips_for_chain(incision, chain, theta_of, lip_slots, onto_opening: bool = False):
    """The lip slots facing a border chain, ordered along it (decreasing theta); [] when a
    closed chain does not hold the slit's start (it is then closed over, see
    ``remesh.fill_hole``). A closed chain from a station's lip round to itself (the start node
    is gone) faces every other slot, round the slit from that lip. ``onto_opening``: the
    chain's ends lie on an opening the cut ran into (``remesh._notch``)."""
    total = 2.0 * incision.length
    closed = chain[0] == chain[-1]
    lip_node_ids = {node for node, *_ in lip_slots if node >= 0}
    starts = [s for s in lip_slots if s[3] == -1]
    # a loop from a station's lip round to itself (the slit's start node is gone, so the hole
    # round the start touches the slit at that lip only): every slot, starting from that lip
    looped = closed and chain[0] in lip_node_ids and bool(starts) and starts[0][0] < 0
    closed = closed and not looped
    if closed and not starts:
        return []
    if closed:
        hi, lo = total, 0.0
    else:
        hi, lo = theta_of(chain[0]), theta_of(chain[-1])
    # both ends at one slit coordinate: around the whole slit (the chain leaves an earlier
    # opening at the open tip and comes back to it there) if its nodes reach away from it
    around = looped or onto_opening and not closed and abs(hi - lo) < 1e-3 * incision.spacing and any(
        abs(theta_of(v) - hi) > incision.spacing for v in chain[1:-1])
    wraps = not closed and (hi < lo or around)
    top = hi + total if wraps else hi
    lo = hi if around else lo
    picked = []
    for node, theta, side, station in lip_slots:
        if node >= 0 and node in (chain[0], chain[-1]):
            continue  # shared end points are added below
        t = theta + total if wraps and theta <= hi else theta
        if closed and station == -1:
            continue  # the start closes the loop at both ends
        if lo < t < top:
            picked.append((t, node, side, station))
    picked.sort(key=lambda item: -item[0])
    ordered = [(node, side, station) for _, node, side, station in picked]
    if closed:
        start = starts[0]
        ordered = [(start[0], 0, -1)] + ordered + [(start[0], 0, -1)]
    else:
        if chain[0] in lip_node_ids:
            ordered.insert(0, (chain[0], None, None))
        if chain[-1] in lip_node_ids:
            ordered.append((chain[-1], None, None))
    return ordered


PLACEHOLDER = 1 << 40
"""Lip nodes a fill would make are numbered from here until the fill is accepted."""


LIP_TOOL_SLACK = 1.02
"""A lip node is taken to be inside the tool within this many tool radii of its axis."""


def lips_inside(tool, points) -> bool:
    """True if any of ``points`` (k, 3) [m], where lip nodes would be made, lies inside the
    tool's cylinder (widened by ``LIP_TOOL_SLACK``): a node made there is pushed out at once."""
    return bool(inside_cylinder(points, tool.p0, tool.p1, LIP_TOOL_SLACK * tool.radius).any())


class LipSlots:
    """The incision's lip slots during one fill: which exist, their slit coordinates, and lip
    nodes proposed for a chain (placeholders, made real only if its fill is accepted)."""

    def __init__(self, editor, incision, positions):
        self.editor, self.incision, self.positions = editor, incision, positions
        active = editor.model.active
        self.slots = [(node if node >= 0 and active[node] else -1, theta, side, station)
                      for node, theta, side, station in incision.lip_nodes()]
        self.theta = {node: theta for node, theta, *_ in self.slots if node >= 0}
        self.created: list[int] = []
        self._proposed: dict[int, tuple] = {}
        self._rest: dict[int, np.ndarray] = {}
        """placeholder -> rest position [m] (3,) of the lip node it stands for
        (``lip_placement``)."""
        self._version = 0
        """Counts changes of the proposed and accepted lips."""
        self._open_to: tuple | None = None
        """(version, the slit's open end u [m]) last computed."""
        self._projected: dict[int, tuple[float, int]] = {}
        """node -> (u [m], side) of nodes projected onto the curve in this fill."""
        self._released: dict[int, tuple] = {}
        """node -> (slots, theta) before ``release(node)``."""

    def release(self, node: int) -> None:
        """Free the slot of lip ``node``: its station takes a new lip, and the node counts as
        tissue where it lies (its slit coordinate from its position); ``restore`` undoes it."""
        self._released[node] = (list(self.slots), self.theta.get(node))
        self.slots = [(-1 if n == node else n, theta, side, station) for n, theta, side, station in self.slots]
        self.theta.pop(node, None)
        self._version += 1

    def restore(self, node: int) -> None:
        """Undo ``release(node)``."""
        self.slots, theta = self._released.pop(node)
        if theta is not None:
            self.theta[node] = theta
        self._version += 1

    def _end_slots(self, chain) -> list[tuple[int, int]] | None:
        """(side, station) of the lips at the two ends of an open ``chain``, or None unless
        both are interior-station lips."""
        if chain[0] == chain[-1]:
            return None
        slot_of = {n: (side, station) for n, _, side, station in self.slots if n >= 0 and station >= 0}
        ends = (chain[0], chain[-1])
        return [slot_of[v] for v in ends] if all(v in slot_of for v in ends) else None

    def crossed(self, node, beyond: float | None = None) -> bool:
        """True if ``node`` is an interior station's lip lying on the other side of the curve,
        more than ``beyond`` [m] (the lip offset by default) from it."""
        slot = next(((side, station) for n, _, side, station in self.slots if n == node), None)
        if slot is None or slot[1] < 0:
            return False
        _, now, dist = self.incision.project(self.positions[[node]])
        return bool(now[0] != slot[0] and dist[0] > (self.incision.lip_offset if beyond is None else beyond))

    def crossed_end(self, chain, beyond: float | None = None) -> int | None:
        """A lip at an end of an open ``chain`` whose two ends are interior-station lips of one
        side, lying on the other side of the curve more than ``beyond`` [m] (the lip offset by
        default; pushed there by a thick tool), or None. The hole reaches past the slit's tip,
        but the crossed lip, taken as on its own side, bounds its slit coordinates to the
        stretch between the two: no station due beyond the tip is offered to it."""
        ends = self._end_slots(chain)
        if ends is None or ends[0][0] != ends[1][0]:
            return None
        return next((v for v in (chain[0], chain[-1]) if self.crossed(v, beyond)), None)

    def twisted_pair(self, chain) -> list[int]:
        """The two lips of one station at the ends of an open ``chain``, each lying on the
        other's side of the curve (a thick tool twisted the pair over each other), or []."""
        ends = self._end_slots(chain)
        if ends is None or ends[0][1] != ends[1][1]:
            return []
        _, now, _ = self.incision.project(self.positions[[chain[0], chain[-1]]])
        return [chain[0], chain[-1]] if all(s != slot[0] for slot, s in zip(ends, now)) else []

    @property
    def lip_nodes(self) -> set:
        """The live lip nodes of the slots, and those released (still on the slit's border)."""
        return {s[0] for s in self.slots if s[0] >= 0} | set(self._released)

    def projected(self, nodes) -> list[tuple[float, int]]:
        """(u [m], side) of each node's closest curve point (projected once per fill: the
        positions do not change during it)."""
        todo = [v for v in dict.fromkeys(nodes) if v not in self._projected]
        if todo:
            u, side, _ = self.incision.project(self.positions[todo])
            self._projected.update(zip(todo, zip(u.tolist(), side.tolist())))
        return [self._projected[v] for v in nodes]

    def theta_of(self, node) -> float:
        if node in self.theta:
            return self.theta[node]
        (u, side), = self.projected([node])
        return float(self.incision.theta(u, side))

    def free_for(self, chain) -> list:
        """Slots not meshed elsewhere (no node yet, a node without triangles, or an end of
        ``chain``)."""
        tris = self.editor.node_triangles
        return [s for s in self.slots if s[0] < 0 or not tris[s[0]] or s[0] in (chain[0], chain[-1])]

    def propose(self, ordered, chain, snap: float) -> list[int]:
        """Node ids for the ordered slots: existing nodes, or placeholders placed where the lip
        node would be made (a closed loop meets the start twice: one placeholder). Where a node
        of ``chain`` on the slot's side already lies within ``snap`` [m] of that place (the
        tissue has closed in on the curve there), that node serves as the lip instead."""
        self._version += 1
        lips, here = [], {}
        inc = self.incision
        spare = self._snap_candidates(chain)
        for node, side, station in ordered:
            if node < 0:
                key = (station, side)
                if key not in here:
                    u = inc.station_u[station] if station >= 0 else (0.0 if station == -1 else inc.length)
                    point, rest = lip_placement(self.editor, self.positions, inc, u, side)
                    here[key] = self._snap(spare, point, side, snap) if station >= 0 else -1
                    if here[key] < 0:
                        here[key] = PLACEHOLDER + len(self._proposed)
                        self.positions[here[key]] = point
                        self._rest[here[key]] = rest
                    self._proposed[here[key]] = key
                node = here[key]
            lips.append(node)
        return lips

    def _snap_candidates(self, chain) -> dict:
        """Interior chain nodes that are no lip: node -> (position, side, distance from the
        curve [m])."""
        lip_nodes = {s[0] for s in self.slots if s[0] >= 0}
        inner = [v for v in chain[1:-1] if v not in lip_nodes]
        if not inner:
            return {}
        _, sides, dist = self.incision.project(self.positions[inner])
        return {v: (self.positions[v], int(side), float(d)) for v, side, d in zip(inner, sides, dist)}

    def _snap(self, spare: dict, point, side: int, snap: float) -> int:
        """The chain node that should serve as the lip at ``point`` on ``side``: one within
        half of ``snap`` of it, or within ``snap`` and nearer the curve than the lip offset
        (the tissue has closed in on the curve there); -1 if none."""
        best, best_d = -1, np.inf
        for v, (x, s, from_curve) in spare.items():
            d = float(np.linalg.norm(x - point))
            close = d < 0.5 * snap or (d < snap and from_curve < self.incision.lip_offset)
            if s == side and close and d < best_d:
                best, best_d = v, d
        if best >= 0:
            del spare[best]
        return best

    def lip_side(self, node) -> tuple[int, float] | None:
        """(side, arc length u [m]) of an interior-station lip node or placeholder (side +1
        left, -1 right); None for any other node (the start and end nodes included)."""
        key = self._proposed.get(node)
        if key is None:
            for n, _, side, station in self.slots:
                if n == node and station >= 0:
                    key = (station, side)
                    break
        if key is None or key[0] < 0:
            return None
        return key[1], self.incision.station_u[key[0]]

    def _slit_end_u(self) -> float:
        """Arc length [m] up to which the slit is open during this fill: its newest station
        with a lip that exists or is proposed now while the tool cuts (the other side's lip
        there follows), the curve's end after."""
        inc = self.incision
        if not inc.open_end:
            return inc.length
        key = self._version
        if self._open_to is not None and self._open_to[0] == key:
            return self._open_to[1]
        self._open_to = key, self._newest_lip()
        return self._open_to[1]

    def _newest_lip(self) -> float:
        inc = self.incision
        have = {st for st, _ in self._proposed.values()} | {st for n, _, _, st in self.slots if n >= 0}
        stations = [k for k in have if k >= 0]
        return inc.station_u[max(stations)] if stations else 0.0

    def bridges(self, tri) -> bool:
        """True if a triangle would join the slit's two sides: it has corners beside the open
        slit (0 < u < its open end) on both sides of the curve, or lip nodes of both sides
        other than the tip's pair with a tissue node (an open slit's newest lip pair closes it
        with the tissue ahead). The start and end nodes are on neither side."""
        lips = [(v, self.lip_side(v)) for v in tri]
        lip_sides = {side for _, side_u in lips if side_u is not None for side in (side_u[0],)}
        ends = {self.incision.start_node, self.incision.end_node}
        if len(lip_sides) == 2:
            third = [v for v, side_u in lips if side_u is None]
            tissue = len(third) == 1 and third[0] not in ends and third[0] not in self.theta
            return not (tissue and self._tip_pair([side_u for _, side_u in lips if side_u is not None]))
        side_of, upper = {v: side_u[0] for v, side_u in lips if side_u is not None}, None
        for v, side_u in lips:
            if side_u is not None or v in ends or v in self.theta:
                continue
            upper = self._slit_end_u() if upper is None else upper
            (u, side), = self.projected([v])
            if 1e-9 < u < upper:
                side_of[v] = side
        # a pair across the slit that is an edge of the mesh already (the tissue moved after
        # it was made) is no new bridge
        return any(side_of[a] != side_of[b] and not self._is_edge(a, b)
                   for a, b in itertools.combinations(side_of, 2))

    def _is_edge(self, a: int, b: int) -> bool:
        """True if nodes a and b (placeholders included) share a live triangle."""
        count = len(self.editor.node_triangles)
        return a < count and b < count and bool(self.editor.triangles_with_edge(a, b))

    def _tip_pair(self, lips) -> bool:
        """True if ``lips`` ((side, u) each) are the two lips of the open slit's newest pair."""
        return (self.incision.open_end and len(lips) == 2 and lips[0][1] == lips[1][1]
                and lips[0][1] == self._slit_end_u())

    def rest_positions(self) -> NodePositions:
        """Rest positions [m] of the nodes and of the proposed lip nodes (``lip_placement``)."""
        rest = NodePositions(self.editor.model.points)
        rest.extra.update(self._rest)
        return rest

    def proposed_inside(self, tool) -> bool:
        """True if a proposed new lip node lies inside the tool's cylinder (``lips_inside``)."""
        points = [self.positions[ph] for ph in self._proposed if ph >= PLACEHOLDER]
        return bool(points) and lips_inside(tool, np.array(points))

    def discard(self) -> None:
        self._version += 1
        for ph in self._proposed:
            if ph >= PLACEHOLDER:
                self.positions.extra.pop(ph, None)
        self._proposed.clear()
        self._rest.clear()

    def accept(self) -> dict[int, int]:
        """Make the proposed lip nodes (a snapped tissue node becomes the lip as it is);
        returns placeholder -> node."""
        self._version += 1
        mapping = {}
        for ph, (station, side) in self._proposed.items():
            if ph < PLACEHOLDER:
                node = ph
            else:
                point = self.positions.extra.pop(ph)
                node = int(self.editor.add_nodes(self._rest[ph][None], NodeClass.LIP)[0])
                self.positions[node] = point
                self.created.append(node)
            self.incision.set_lip_node(station, side, node)
            self.slots = [(node if (st == station and sd == side) else n, th, sd, st)
                          for n, th, sd, st in self.slots]
            self.theta[node] = next(th for n, th, sd, st in self.slots if n == node)
            mapping[ph] = node
        self._proposed.clear()
        self._rest.clear()
        return mapping
