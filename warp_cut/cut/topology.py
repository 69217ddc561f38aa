"""TopologyEditor: the one place where a TissueModel's topology changes.

Nodes, springs, triangles, masses, classes, residual links and hinges change together in one edit:
deleting a node deletes its springs, triangles and links; deleting a spring whose two end
nodes survive makes a residual-stress link (SPEC section 1) and deletes the triangles it
bounds; new triangles bring their missing edge springs; lumped masses of every node touched
are recomputed from its triangles; nodes left without any triangle are removed as fragments; a
sheet that bends gets the hinges of the edges whose triangles changed made again, at the
current shape (``warp_cut.sim.bending``); the springs the edit changed get what the material
says (its ``MaterialPolicy``, chosen once). Every operation costs what it touches: the model's
adjacency (``TissueModel.index``: node -> springs, triangles, links, hinges) is kept up to date
instead of being rebuilt.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from ..mesh.geometry import corner_areas
from ..mesh.triangulate import connected_groups
from ..sim.bending import mass_caps
from ..sim.material_policy import material_policy
from ..sim.model_change import ModelChange
from ..sim.slots import member
from .classes import NodeClass, SpringClass

__all__ = ["TopologyEditor", "EditReport", "NodePositions", "OrphanedLink", "SeveredLink"]


class NodePositions:
    """Current node positions [m] for an edit: a (slots, 3) base array (e.g. a zero-copy view of
    the device state) plus positions of nodes the edit creates. Indexing by an int gives (3,),
    by a list (k, 3), always float64."""

    def __init__(self, base: np.ndarray):
        self.base = base
        self.extra: dict[int, np.ndarray] = {}

    def __getitem__(self, index):
        if isinstance(index, (int, np.integer)):
            index = int(index)
            return self.extra[index] if index in self.extra else np.asarray(self.base[index], np.float64)
        index = np.asarray(index, dtype=np.int64).reshape(-1)
        out = np.empty((len(index), 3), dtype=np.float64)
        made = np.zeros(len(index), dtype=bool)
        if self.extra:
            made = member(index, np.fromiter(self.extra, dtype=np.int64, count=len(self.extra)))
            for k in np.flatnonzero(made):
                out[k] = self.extra[int(index[k])]
        out[~made] = self.base[index[~made]]
        return out

    def __setitem__(self, index: int, value) -> None:
        self.extra[int(index)] = np.asarray(value, dtype=np.float64)


class OrphanedLink(NamedTuple):
    """A residual link an edit cut off at one end: ``keep`` lives on, ``gone`` was deleted."""

    keep: int
    gone: int
    force: float
    """[N]"""
    smoothing: float
    """[m]"""


class SeveredLink(NamedTuple):
    """A residual link an edit cut off at both ends, the deleted nodes ``i`` and ``j``."""

    i: int
    j: int
    force: float
    """[N]"""
    smoothing: float
    """[m]"""


@dataclass
class EditReport:
    """What one edit did (slot indices)."""

    deleted_nodes: list = field(default_factory=list)
    deleted_springs: list = field(default_factory=list)
    deleted_triangles: list = field(default_factory=list)
    deleted_triangle_corners: list = field(default_factory=list)
    """Corners (3 node indices, in winding order) of each deleted triangle."""
    residual_links: list = field(default_factory=list)
    new_nodes: list = field(default_factory=list)
    new_springs: list = field(default_factory=list)
    new_triangles: list = field(default_factory=list)
    deleted_links: list = field(default_factory=list)
    carried_links: list = field(default_factory=list)
    """Residual links re-made between a surviving node and the node that took a deleted one's place."""
    moved_links: list = field(default_factory=list)
    """Residual links whose end nodes were changed (``TopologyEditor.move_link``)."""
    orphaned_links: list[OrphanedLink] = field(default_factory=list)
    """Links that lost a node."""
    severed_links: list[SeveredLink] = field(default_factory=list)
    """Links that lost both nodes."""
    removed_fragments: list = field(default_factory=list)
    """Nodes deleted because the edit left them without any triangle."""
    stray_springs: list = field(default_factory=list)
    """Springs deleted because the edit left them on no triangle (inside the grey area)."""
    deleted_hinges: list = field(default_factory=list)
    new_hinges: list = field(default_factory=list)


class TopologyEditor:
    """Edits a model in place. Use ``begin()`` ... operations ... ``finish(positions)``."""

    def __init__(self, model):
        self.model = model
        self.index = model.index
        """The model's adjacency, kept up to date by every operation here."""
        self.policy = material_policy(model)
        """How changed springs get their stiffness and rest length (chosen once)."""
        self.report = EditReport()
        self._touched: set[int] = set()
        self._settling: set[int] = set()
        """Springs to take the sheet's modulus at ``finish`` (``settle_membrane``)."""
        self.hinge_nodes_changed: set[int] = set()
        """Nodes of the hinges the current edit made or deleted."""

    @property
    def node_springs(self) -> list[set]:
        """Live spring slots at each node (``TopologyIndex.node_springs``)."""
        return self.index.node_springs

    @property
    def node_triangles(self) -> list[set]:
        """Live triangle slots at each node (``TopologyIndex.node_triangles``)."""
        return self.index.node_triangles

    @property
    def node_links(self) -> list[set]:
        """Live residual-link slots at each node (``TopologyIndex.node_links``)."""
        return self.index.node_links

    # ------------------------------------------------------------------ queries
    @property
    def touched_nodes(self) -> set:
        """Nodes whose springs, triangles or links changed in the current edit."""
        return set(self._touched)

    def spring_between(self, i: int, j: int) -> int | None:
        """The live spring slot joining nodes i and j, or None."""
        return self.index.spring_between(i, j)

    def triangles_with_edge(self, i: int, j: int) -> set:
        """Live triangle slots holding both nodes i and j."""
        return self.index.triangles_with_edge(i, j)

    # ------------------------------------------------------------------ edit
    def begin(self) -> None:
        self.report = EditReport()
        self._touched = set()
        self.hinge_nodes_changed = set()
        self._settling = set()

    def delete_triangles(self, slots) -> None:
        table = self.model.triangle_table
        alive = table.alive
        dead = [slot for slot in {int(s) for s in slots} if alive[slot]]
        for slot, tri in zip(dead, table.column("corners")[dead].tolist()):
            self.index.remove_triangle(slot, tri)
            self._touched.update(tri)
            self.report.deleted_triangle_corners.append(tuple(tri))
        table.kill(dead)
        self.report.deleted_triangles.extend(dead)

    def delete_springs(self, slots, *, residual: bool = True, doomed_nodes=(), pending: list | None = None) -> None:
        """Delete springs and the triangles they bound. A deleted spring whose two end nodes
        survive (are active and not in ``doomed_nodes``) becomes a residual-stress link
        (not in the prestress model, where the cut releases the springs' tension instead);
        with ``pending`` given, its (slot, i, j, rest length [m]) is appended there instead,
        for the caller to make the link later (``make_links``)."""
        model = self.model
        residual = residual and self.policy.makes_links
        table = model.spring_table
        pairs = table.column("pairs")
        rest = table.column("rest_length")
        doomed = set(int(v) for v in doomed_nodes)
        link_pairs, link_rest = [], []
        dead = [slot for slot in {int(s) for s in slots} if table.alive[slot]]
        for slot, (i, j) in zip(dead, pairs[dead].tolist()):
            self.delete_triangles(self.triangles_with_edge(i, j))
            if residual and model.active[i] and model.active[j] and i not in doomed and j not in doomed:
                if pending is not None:
                    pending.append((slot, i, j, float(rest[slot])))
                else:
                    link_pairs.append((i, j))
                    link_rest.append(rest[slot])
            self.index.remove_spring(slot, i, j)
            self._touched.update((i, j))
        table.kill(dead)
        self.report.deleted_springs.extend(dead)
        self.make_links(link_pairs, link_rest)

    def make_links(self, pairs, rest_lengths, *, once_per_pair: bool = True) -> None:
        """Residual-stress links between node pairs (l, 2) for springs of rest lengths (l,) [m]
        (``TissueModel.add_residual_links``: sigma_r x thickness x rest length); with
        ``once_per_pair`` a pair already joined by a link gets no second one (a spring's own
        pair), without it each link is made (links of several springs carried to one pair)."""
        fresh, seen = [], set()
        for (i, j), rest in zip(pairs, rest_lengths):
            key = frozenset((int(i), int(j)))
            if not once_per_pair or (key not in seen and not self.node_links[int(i)] & self.node_links[int(j)]):
                seen.add(key)
                fresh.append(((int(i), int(j)), rest))
        if not fresh:
            return
        pairs, rest_lengths = [p for p, _ in fresh], [r for _, r in fresh]
        new = self.model.add_residual_links(pairs, rest_lengths)  # registers them in the index
        for i, j in pairs:
            self._touched.update((int(i), int(j)))
        self.report.residual_links.extend(int(s) for s in new)

    def delete_links(self, slots, *, lost_nodes=()) -> None:
        """Delete residual links. A link losing one of ``lost_nodes`` (nodes being deleted) while
        its other node lives on is reported in ``report.orphaned_links``, one losing both in
        ``report.severed_links``, for the caller to carry to the nodes that take their place."""
        table = self.model.link_table
        pairs = table.column("pairs")
        lost = {int(v) for v in lost_nodes}
        dead = [slot for slot in {int(s) for s in slots} if table.alive[slot]]
        rows = zip(dead, pairs[dead].tolist(), table.column("force")[dead].tolist(),
                   table.column("smoothing")[dead].tolist())
        for slot, (i, j), force, smoothing in rows:
            for gone, keep in ((i, j), (j, i)):
                if gone in lost and keep not in lost and self.model.active[keep]:
                    self.report.orphaned_links.append(OrphanedLink(keep, gone, force, smoothing))
            if i in lost and j in lost:
                self.report.severed_links.append(SeveredLink(i, j, force, smoothing))
            self.index.remove_link(slot, i, j)
            self._touched.update((i, j))  # their stable-step rows change
        table.kill(dead)
        self.report.deleted_links.extend(dead)

    def delete_nodes(self, nodes) -> None:
        """Delete nodes with their springs (no residual links: an end is gone), triangles and links."""
        nodes = [int(v) for v in nodes if self.model.active[int(v)]]
        doomed = set(nodes)
        for v in nodes:
            self.delete_springs(list(self.node_springs[v]), residual=False, doomed_nodes=doomed)
            self.delete_triangles(list(self.node_triangles[v]))
            self.delete_links(list(self.node_links[v]), lost_nodes=doomed)
        if nodes:
            self.model.node_table.kill(nodes)
            self.report.deleted_nodes.extend(nodes)
            self._touched.difference_update(nodes)
            self._sever_orphans_of(doomed)

    def _sever_orphans_of(self, doomed: set) -> None:
        """Links reported orphaned earlier in this edit whose surviving node is now deleted too
        (a scrap or an island removed after the event's own deletions) have lost both nodes:
        they move to ``report.severed_links``."""
        report = self.report
        report.severed_links += [SeveredLink(*link) for link in report.orphaned_links if link.keep in doomed]
        report.orphaned_links = [link for link in report.orphaned_links if link.keep not in doomed]

    def add_nodes(self, points, node_class: int = NodeClass.LIP) -> np.ndarray:
        """New nodes with rest positions ``points`` (k, 3) [m]; masses set at finish. Their
        current positions are the caller's (``cut.lip_placement``: they differ in a prestressed
        sheet)."""
        model = self.model
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        k = len(pts)
        slots = model.node_table.append(
            points=pts, masses=np.full(k, 1.0), damping=np.full(k, model.material.damping),
            pinned=np.zeros(k, bool), node_class=np.full(k, node_class, np.int8))
        self.index.grow(model.node_table.count)
        self.report.new_nodes.extend(int(s) for s in slots)
        self._touched.update(int(s) for s in slots)
        return slots

    def add_link(self, i: int, j: int, force: float, smoothing: float) -> int:
        """A residual link between nodes i and j of magnitude ``force`` [N] and smoothing length
        ``smoothing`` [m] (a link carried over from a deleted node)."""
        slot = int(self.model.link_table.append(pairs=np.array([[i, j]]), force=[force],
                                                smoothing=[smoothing])[0])
        self.index.add_link(slot, int(i), int(j))
        self._touched.update((int(i), int(j)))
        self.report.carried_links.append(slot)
        return slot

    def move_link(self, slot: int, i: int, j: int) -> None:
        """Make residual link ``slot`` join nodes i and j instead (same force and smoothing)."""
        table = self.model.link_table
        a, b = (int(v) for v in table.column("pairs")[slot])
        self.index.remove_link(slot, a, b)
        self._touched.update((a, b))  # their stable-step rows change
        table.set("pairs", [slot], np.array([[i, j]]))
        self.index.add_link(slot, int(i), int(j))
        self._touched.update((int(i), int(j)))
        self.report.moved_links.append(slot)

    def add_spring(self, i: int, j: int, positions: np.ndarray, spring_class: int) -> int:
        """A spring between i and j with rest length from ``positions`` (node_count, 3) [m];
        returns the existing slot if there already is one."""
        if i == j:
            raise InputError(f"a spring cannot join node {i} to itself")
        existing = self.spring_between(i, j)
        if existing is not None:
            return existing
        return int(self._append_springs([(min(int(i), int(j)), max(int(i), int(j)))], positions, spring_class)[0])

    def _append_springs(self, pairs: list, positions: np.ndarray, spring_class: int) -> np.ndarray:
        """New springs on the node pairs ``pairs`` (k pairs (a, b), a < b, none there yet), rest
        lengths from ``positions`` [m]; their slots (k,)."""
        if not pairs:
            return np.zeros(0, dtype=np.int64)
        ends = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        lengths = [np.linalg.norm(d) for d in positions[ends[:, 1]] - positions[ends[:, 0]]]  # as one spring's
        k = len(ends)
        slots = self.model.spring_table.append(
            pairs=ends, rest_length=lengths, stiffness=np.full(k, self.model.material.stiffness),
            spring_class=np.full(k, spring_class))
        for slot, (a, b) in zip(slots.tolist(), pairs):
            self.index.add_spring(slot, a, b)
        self._touched.update(ends.ravel().tolist())
        self.report.new_springs.extend(slots.tolist())
        return slots

    def add_triangle(self, corners, positions: np.ndarray,
                     edge_class: int = SpringClass.NORMAL) -> int:
        """A triangle (3 node indices, wound CCW seen from outside) with its missing edge springs."""
        return int(self.add_triangles([corners], positions, edge_class)[0])

    def add_triangles(self, corners, positions: np.ndarray,
                      edge_class: int = SpringClass.NORMAL) -> np.ndarray:
        """Triangles ``corners`` (k, 3) (node indices, each wound CCW seen from outside) with
        their missing edge springs (rest lengths from ``positions`` (node_count, 3) [m]), in one
        append per table; their slots (k,). The same slots and springs as ``add_triangle`` one
        triangle at a time."""
        tris = np.asarray(corners, dtype=np.int64).reshape(-1, 3)
        missing, seen = [], set()
        for tri in tris.tolist():
            for i, j in zip(tri, tri[1:] + tri[:1]):
                if i == j:
                    raise InputError(f"a spring cannot join node {i} to itself")
                pair = (i, j) if i < j else (j, i)
                if pair not in seen:
                    seen.add(pair)
                    if self.spring_between(i, j) is None:
                        missing.append(pair)
        self._append_springs(missing, positions, edge_class)
        areas = corner_areas(positions[tris.reshape(-1)].reshape(-1, 3, 3)) if len(tris) else np.zeros(0)
        slots = self.model.triangle_table.append(corners=tris, area=areas)
        for slot, tri in zip(slots.tolist(), tris.tolist()):
            self.index.add_triangle(slot, tri)
        self._touched.update(tris.reshape(-1).tolist())
        self.report.new_triangles.extend(slots.tolist())
        return slots

    def split_pinched_nodes(self, nodes, positions) -> list[int]:
        """Give each node of ``nodes`` whose triangles make several fans (pieces that share no
        edge at it: tissue held together by one node, where a slit ran into another) one copy
        per fan but its largest, at the same rest and current position (``positions``, a
        NodePositions the copies' positions go into); returns the copies. A fan's triangles
        are made again on its copy; the springs left on no triangle go at ``finish``."""
        model = self.model
        copies = []
        for v in sorted({int(v) for v in nodes}):
            if not model.active[v]:
                continue
            corners = model.triangle_table.column("corners")  # the table grows as fans are made again
            fans = _fans(v, self.node_triangles[v], corners)
            for fan in sorted(fans, key=len)[:-1]:
                tris = [tuple(int(x) for x in corners[t]) for t in sorted(fan)]
                copy = int(self.add_nodes(model.points[v][None], NodeClass(int(model.node_class[v])))[0])
                model.node_table.set("pinned", [copy], [bool(model.pinned[v])])
                positions[copy] = positions[v]
                self.delete_triangles(sorted(fan))
                self.add_triangles([[copy if x == v else x for x in tri] for tri in tris], model.points)
                copies.append(copy)
        return copies

    def set_spring_class(self, slot: int, spring_class: int) -> None:
        self.model.spring_table.set("spring_class", [slot], spring_class)

    def set_node_class(self, nodes, node_class: int) -> None:
        nodes = np.asarray(list(nodes), dtype=np.int64)
        if len(nodes):
            self.model.node_table.set("node_class", nodes, node_class)

    # ------------------------------------------------------------------ finish
    def finish(self, *, lumped: bool = True, positions=None) -> EditReport:
        """Remove springs left on no triangle and nodes left without any (fragments), make the
        hinges of changed edges again (at ``positions``, current node positions [m] indexable
        by node arrays; the rest positions if None), recompute the lumped masses of touched
        nodes, bump the version."""
        model = self.model
        # a spring no triangle uses any more lay inside the grey area: it goes too
        pairs = model.spring_table.column("pairs")
        near = self.index.springs_at(self._touched)
        stray = {slot for slot, (a, b) in zip(near, pairs[near].tolist()) if not self.triangles_with_edge(a, b)}
        if stray:
            self.delete_springs(sorted(stray), residual=False)
            self.report.stray_springs.extend(sorted(stray))
        fragments = [v for v in self._touched
                     if model.active[v] and not self.node_triangles[v]]
        if fragments:
            self.delete_nodes(fragments)
            self.report.removed_fragments.extend(fragments)
        self._refresh_membrane()
        touched = np.array(sorted(v for v in self._touched if model.active[v]), dtype=np.int64)
        if len(touched) and lumped:
            areal = model.material.density * model.material.thickness
            areas = model.triangle_table.column("area")
            masses = np.array([areal * sum(areas[t] for t in self.node_triangles[v]) / 3.0
                               for v in touched])
            model.node_table.set("masses", touched, masses)
        if model.material.bending_rigidity > 0:
            self._refresh_hinges(model.points if positions is None else positions)
            self._cap_hinges_at(touched)
        model.topology_version += 1
        return self.report

    def _refresh_membrane(self) -> None:
        """Stiffness and rest lengths of the springs this edit changed, and of those
        ``settle_membrane`` named, as the material policy says (``warp_cut.sim.material_policy``)."""
        alive = self.model.spring_table.alive
        settling = sorted(s for s in self._settling if alive[s])
        self.policy.refresh(self._changed_springs, settling)

    @staticmethod
    def _edges_of(corners) -> set[tuple[int, int]]:
        """Node pairs (i < j) of the edges of triangles given by their corners (3 nodes each)."""
        return {tuple(sorted((int(c[k]), int(c[(k + 1) % 3])))) for c in corners for k in range(3)}

    def _changed_edges(self) -> set[tuple[int, int]]:
        """Node pairs (i < j) of the edges of the triangles this edit deleted or made (one made
        and deleted again in the edit is among the deleted ones: its slot no longer holds it)."""
        table = self.model.triangle_table
        corners = list(self.report.deleted_triangle_corners)
        corners += [table.column("corners")[t] for t in self.report.new_triangles if table.alive[t]]
        return self._edges_of(corners)

    def _hinge_of_edge(self, i: int, j: int) -> tuple[int, int, int, int] | None:
        """[i, j, k, l] of the edge i < j if exactly two live triangles share it, wound apart."""
        tris = self.triangles_with_edge(i, j)
        if len(tris) != 2:
            return None
        corners = self.model.triangle_table.column("corners")
        k = l = -1
        for t in tris:
            c = [int(v) for v in corners[t]]
            at = c.index(i)
            if c[(at + 1) % 3] == j:
                k = c[(at + 2) % 3]
            else:
                l = c[(at + 1) % 3]
        return (i, j, k, l) if k >= 0 and l >= 0 else None

    def _refresh_hinges(self, positions) -> None:
        """Hinges of the edges whose triangles changed: kept where the edge still joins the same
        two triangles' corners, else deleted and made again at ``positions`` (where two
        triangles share the edge), as new springs take their current length (outside a
        prestressed sheet, ``PrestressedSprings``)."""
        model = self.model
        table = model.hinge_table
        fresh = []
        for i, j in sorted(self._changed_edges()):
            old = self.index.edge_hinges.get((i, j))
            hinge = self._hinge_of_edge(i, j) if model.active[i] and model.active[j] else None
            if old is not None and hinge is not None and tuple(table.column("nodes")[old]) == hinge:
                continue
            if old is not None:
                self._kill_hinge(old)
            if hinge is not None:
                fresh.append(hinge)
        if fresh:
            for slot in model.add_hinges(np.array(fresh, dtype=np.int64), positions):  # indexed there
                self.hinge_nodes_changed.update(int(v) for v in table.column("nodes")[slot])
                self.report.new_hinges.append(int(slot))

    def _cap_hinges_at(self, nodes: np.ndarray) -> None:
        """Lower the caps of the hinges kept at ``nodes`` whose masses this edit made smaller
        (``mass_caps``; the hinges it made got theirs with the new masses)."""
        model = self.model
        slots = np.array(self.index.hinges_at(nodes), dtype=np.int64) if len(nodes) else np.zeros(0, np.int64)
        if not len(slots):
            return
        table = model.hinge_table
        corners, caps = table.column("nodes")[slots], table.column("cap")[slots]
        lowered = mass_caps(caps, corners, model.masses, model.bending_budget)
        changed = lowered < caps
        if changed.any():
            table.set("cap", slots[changed], lowered[changed])
            self.hinge_nodes_changed.update(int(v) for v in corners[changed].ravel())

    def _kill_hinge(self, slot: int) -> None:
        nodes = [int(v) for v in self.model.hinge_table.column("nodes")[slot]]
        self.index.remove_hinge(slot, nodes)
        self.hinge_nodes_changed.update(nodes)
        self.model.hinge_table.kill([slot])
        self.report.deleted_hinges.append(slot)

    def _springs_on(self, edges) -> list[int]:
        """Slots of the live springs on ``edges`` (node pairs)."""
        model = self.model
        slots = (self.spring_between(i, j) for i, j in edges if model.active[i] and model.active[j])
        return sorted(slot for slot in slots if slot is not None)

    def _changed_springs(self) -> list[int]:
        """Slots of the live springs on the edges of the triangles this edit deleted or made."""
        return self._springs_on(self._changed_edges())

    def settle_membrane(self, triangles) -> None:
        """At ``finish``, give the springs on the edges of ``triangles`` (live slots) the
        sheet's modulus for the triangles they border then (``MaterialPolicy.stiffen``)
        and, in a prestressed sheet, the rest lengths that carry its tension with that
        stiffness: for the springs of a finished cut, whose triangles are final (with the
        paper's constant K every new spring is K until then, which is the lattice's modulus
        only on equilateral pairs). Part of an edit begun."""
        table = self.model.triangle_table
        corners = [table.column("corners")[t] for t in triangles if table.alive[t]]
        self._settling.update(self._springs_on(self._edges_of(corners)))

    # ------------------------------------------------------------------ the notice
    def model_change(self, new_positions) -> ModelChange:
        """The ``ModelChange`` of the edit just finished, its new nodes at ``new_positions``
        (k, 3) [m] (in the order of ``report.new_nodes``): the nodes whose springs, triangles,
        links or mass changed (with the ends of the links it made, carried or moved, and the
        nodes it deleted), what it deleted, and the nodes of the hinges it changed."""
        report = self.report
        link_pairs = self.model.link_table.column("pairs")
        touched = set(self._touched) | {int(v) for v in report.deleted_nodes}
        for slot in list(report.residual_links) + list(report.carried_links) + list(report.moved_links):
            touched.update(int(v) for v in link_pairs[slot])
        return ModelChange.of(new_nodes=report.new_nodes, new_positions=new_positions, touched_nodes=touched,
                              deleted_nodes=report.deleted_nodes, deleted_springs=report.deleted_springs,
                              deleted_triangles=report.deleted_triangles, deleted_links=report.deleted_links,
                              hinge_nodes=self.hinge_nodes_changed)


def _fans(v: int, triangles, corners: np.ndarray) -> list[set[int]]:
    """The triangles at node ``v`` (slots) grouped into fans: pieces joined through an edge at v
    (two triangles at v share an edge there when they share their other node of it)."""
    tris = [int(t) for t in triangles]
    first_at: dict[int, int] = {}
    links = []
    for t, row in zip(tris, corners[tris].tolist()):
        for x in row:
            if x != v:
                links.append((t, first_at.setdefault(x, t)))
    return [set(fan) for fan in connected_groups(tris, links)]
