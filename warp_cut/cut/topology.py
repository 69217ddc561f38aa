"""TopologyEditor: the one place where a TissueModel's topology changes.

Nodes, springs, triangles, masses, classes, residual links and hinges change together in one edit:
deleting a node deletes its springs, triangles and links; deleting a spring whose two end
nodes survive makes a residual-stress link (SPEC section 1) and deletes the triangles it
bounds; new triangles bring their missing edge springs; lumped masses of every node touched
are recomputed from its triangles; nodes left without any triangle are removed as fragments; a
sheet that bends gets the hinges of the edges whose triangles changed made again, at the
current shape (``warp_cut.sim.bending``). Every operation costs what it touches: adjacency
(node -> springs, triangles, links, hinges) is kept up to date instead of being rebuilt.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..mesh.geometry import triangle_areas
from ..sim.prestress import prestressed_rest_lengths
from ..sim.stiffness import membrane_modulus, van_gelder_stiffness
from .classes import NodeClass, SpringClass

__all__ = ["TopologyEditor", "EditReport", "NodePositions", "MAX_PRESTRAIN"]

MAX_PRESTRAIN = 0.5
"""Largest |f / (k L)| a spring a cut makes or changes in a prestressed sheet is given
(``TopologyEditor._prestress``)."""


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
            made = np.isin(index, np.fromiter(self.extra, dtype=np.int64, count=len(self.extra)))
            for k in np.flatnonzero(made):
                out[k] = self.extra[int(index[k])]
        out[~made] = self.base[index[~made]]
        return out

    def __setitem__(self, index: int, value) -> None:
        self.extra[int(index)] = np.asarray(value, dtype=np.float64)


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
    orphaned_links: list = field(default_factory=list)
    """(surviving node, deleted node, force [N], smoothing [m]) of links that lost a node."""
    severed_links: list = field(default_factory=list)
    """(node i, node j, force [N], smoothing [m]) of links that lost both nodes."""
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
        n = model.node_table.count
        self.node_springs: list[set] = [set() for _ in range(n)]
        self.node_triangles: list[set] = [set() for _ in range(n)]
        self.node_links: list[set] = [set() for _ in range(n)]
        for slot in model.spring_table.live_slots():
            i, j = model.spring_table.column("pairs")[slot]
            self.node_springs[i].add(int(slot))
            self.node_springs[j].add(int(slot))
        for slot in model.triangle_table.live_slots():
            for v in model.triangle_table.column("corners")[slot]:
                self.node_triangles[v].add(int(slot))
        for slot in model.link_table.live_slots():
            i, j = model.link_table.column("pairs")[slot]
            self.node_links[i].add(int(slot))
            self.node_links[j].add(int(slot))
        self.node_hinges: list[set] = [set() for _ in range(n)]
        self.edge_hinges: dict[tuple[int, int], int] = {}
        for slot in model.hinge_table.live_slots():
            self._register_hinge(int(slot))
        self.report = EditReport()
        self._touched: set[int] = set()
        self._settling: set[int] = set()
        """Springs to take the sheet's modulus at ``finish`` (``settle_membrane``)."""
        self.hinge_nodes_changed: set[int] = set()
        """Nodes of the hinges the current edit made or deleted."""

    # ------------------------------------------------------------------ queries
    @property
    def touched_nodes(self) -> set:
        """Nodes whose springs, triangles or links changed in the current edit."""
        return set(self._touched)

    def spring_between(self, i: int, j: int) -> int | None:
        """The live spring slot joining nodes i and j, or None."""
        pairs = self.model.spring_table.column("pairs")
        for slot in self.node_springs[i]:
            a, b = pairs[slot]
            if (a == j) or (b == j):
                return slot
        return None

    def triangles_with_edge(self, i: int, j: int) -> set:
        return self.node_triangles[i] & self.node_triangles[j]

    # ------------------------------------------------------------------ edit
    def begin(self) -> None:
        self.report = EditReport()
        self._touched = set()
        self.hinge_nodes_changed = set()
        self._settling = set()

    def delete_triangles(self, slots) -> None:
        table = self.model.triangle_table
        corners = table.column("corners")
        for slot in {int(s) for s in slots}:
            if not table.alive[slot]:
                continue
            for v in corners[slot]:
                self.node_triangles[v].discard(slot)
                self._touched.add(int(v))
            self.report.deleted_triangle_corners.append(tuple(int(v) for v in corners[slot]))
            table.kill([slot])
            self.report.deleted_triangles.append(slot)

    def delete_springs(self, slots, *, residual: bool = True, doomed_nodes=(), pending: list | None = None) -> None:
        """Delete springs and the triangles they bound. A deleted spring whose two end nodes
        survive (are active and not in ``doomed_nodes``) becomes a residual-stress link
        (not in the prestress model, where the cut releases the springs' tension instead);
        with ``pending`` given, its (slot, i, j, rest length [m]) is appended there instead,
        for the caller to make the link later (``make_links``)."""
        model = self.model
        residual = residual and model.material.residual_stress_model == "links"
        table = model.spring_table
        pairs = table.column("pairs")
        rest = table.column("rest_length")
        doomed = set(int(v) for v in doomed_nodes)
        link_pairs, link_rest = [], []
        for slot in {int(s) for s in slots}:
            if not table.alive[slot]:
                continue
            i, j = (int(v) for v in pairs[slot])
            self.delete_triangles(self.triangles_with_edge(i, j))
            if residual and model.active[i] and model.active[j] and i not in doomed and j not in doomed:
                if pending is not None:
                    pending.append((slot, i, j, float(rest[slot])))
                else:
                    link_pairs.append((i, j))
                    link_rest.append(rest[slot])
            self.node_springs[i].discard(slot)
            self.node_springs[j].discard(slot)
            self._touched.update((i, j))
            table.kill([slot])
            self.report.deleted_springs.append(slot)
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
        new = self.model.add_residual_links(pairs, rest_lengths)
        for slot, (i, j) in zip(new, pairs):
            self.node_links[int(i)].add(int(slot))
            self.node_links[int(j)].add(int(slot))
            self._touched.update((int(i), int(j)))
        self.report.residual_links.extend(int(s) for s in new)

    def delete_links(self, slots, *, lost_nodes=()) -> None:
        """Delete residual links. A link losing one of ``lost_nodes`` (nodes being deleted) while
        its other node lives on is reported in ``report.orphaned_links``, one losing both in
        ``report.severed_links``, for the caller to carry to the nodes that take their place."""
        table = self.model.link_table
        pairs = table.column("pairs")
        lost = {int(v) for v in lost_nodes}
        for slot in {int(s) for s in slots}:
            if not table.alive[slot]:
                continue
            i, j = (int(v) for v in pairs[slot])
            force, smoothing = float(table.column("force")[slot]), float(table.column("smoothing")[slot])
            for gone, keep in ((i, j), (j, i)):
                if gone in lost and keep not in lost and self.model.active[keep]:
                    self.report.orphaned_links.append((keep, gone, force, smoothing))
            if i in lost and j in lost:
                self.report.severed_links.append((i, j, force, smoothing))
            self.node_links[i].discard(slot)
            self.node_links[j].discard(slot)
            self._touched.update((i, j))  # their stable-step rows change
            table.kill([slot])
            self.report.deleted_links.append(slot)

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
        for _ in range(k):
            self.node_springs.append(set())
            self.node_triangles.append(set())
            self.node_links.append(set())
            self.node_hinges.append(set())
        self.report.new_nodes.extend(int(s) for s in slots)
        self._touched.update(int(s) for s in slots)
        return slots

    def add_link(self, i: int, j: int, force: float, smoothing: float) -> int:
        """A residual link between nodes i and j of magnitude ``force`` [N] and smoothing length
        ``smoothing`` [m] (a link carried over from a deleted node)."""
        slot = int(self.model.link_table.append(pairs=np.array([[i, j]]), force=[force],
                                                smoothing=[smoothing])[0])
        self.node_links[i].add(slot)
        self.node_links[j].add(slot)
        self._touched.update((int(i), int(j)))
        self.report.carried_links.append(slot)
        return slot

    def move_link(self, slot: int, i: int, j: int) -> None:
        """Make residual link ``slot`` join nodes i and j instead (same force and smoothing)."""
        table = self.model.link_table
        for v in table.column("pairs")[slot]:
            self.node_links[int(v)].discard(slot)
            self._touched.add(int(v))  # its stable-step row changes
        table.set("pairs", [slot], np.array([[i, j]]))
        self.node_links[i].add(slot)
        self.node_links[j].add(slot)
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
        a, b = sorted((int(i), int(j)))
        length = float(np.linalg.norm(positions[b] - positions[a]))
        slot = int(self.model.spring_table.append(
            pairs=np.array([[a, b]]), rest_length=[length],
            stiffness=[self.model.material.stiffness], spring_class=[spring_class])[0])
        self.node_springs[a].add(slot)
        self.node_springs[b].add(slot)
        self._touched.update((a, b))
        self.report.new_springs.append(slot)
        return slot

    def add_triangle(self, corners, positions: np.ndarray,
                     edge_class: int = SpringClass.NORMAL) -> int:
        """A triangle (3 node indices, wound CCW seen from outside) with its missing edge springs."""
        a, b, c = (int(v) for v in corners)
        for i, j in ((a, b), (b, c), (c, a)):
            self.add_spring(i, j, positions, edge_class)
        area = float(triangle_areas(positions[[a, b, c]], [[0, 1, 2]])[0])
        slot = int(self.model.triangle_table.append(corners=np.array([[a, b, c]]), area=[area])[0])
        for v in (a, b, c):
            self.node_triangles[v].add(slot)
            self._touched.add(v)
        self.report.new_triangles.append(slot)
        return slot

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
        stray = {slot for v in self._touched for slot in self.node_springs[v]
                 if not self.triangles_with_edge(*(int(u) for u in pairs[slot]))}
        if stray:
            self.delete_springs(sorted(stray), residual=False)
            self.report.stray_springs.extend(sorted(stray))
        fragments = [v for v in self._touched
                     if model.active[v] and not self.node_triangles[v]]
        if fragments:
            self.delete_nodes(fragments)
            self.report.removed_fragments.extend(fragments)
        self._refresh_membrane()
        if model.material.bending_rigidity > 0:
            self._refresh_hinges(model.points if positions is None else positions)
        touched = np.array(sorted(v for v in self._touched if model.active[v]), dtype=np.int64)
        if len(touched) and lumped:
            areal = model.material.density * model.material.thickness
            areas = model.triangle_table.column("area")
            masses = np.array([areal * sum(areas[t] for t in self.node_triangles[v]) / 3.0
                               for v in touched])
            model.node_table.set("masses", touched, masses)
        model.topology_version += 1
        return self.report

    def _refresh_membrane(self) -> None:
        """Stiffness and rest lengths of the springs this edit changed, and of those
        ``settle_membrane`` named: van Gelder's stiffness with material springs (for the named
        ones whatever the model), the prestress's rest lengths in a prestressed sheet."""
        model = self.model
        material, prestressed = model.stiffness_model == "material", bool(model.prestress_tension)
        settling = {s for s in self._settling if model.spring_table.alive[s]}
        if not (material or prestressed or settling):
            return
        changed = set(self._changed_springs()) if material or prestressed else set()
        stiffened = sorted((changed if material else set()) | settling)
        if stiffened:
            self._refresh_membrane_stiffness(stiffened, self._spring_lengths(stiffened))
        if prestressed:
            self._prestress(sorted(changed | settling))

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

    def _register_hinge(self, slot: int) -> None:
        a, b, k, l = (int(v) for v in self.model.hinge_table.column("nodes")[slot])
        for v in (a, b, k, l):
            self.node_hinges[v].add(slot)
        self.edge_hinges[(a, b)] = slot

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
        prestressed sheet, ``_prestress``)."""
        model = self.model
        table = model.hinge_table
        fresh = []
        for i, j in sorted(self._changed_edges()):
            old = self.edge_hinges.get((i, j))
            hinge = self._hinge_of_edge(i, j) if model.active[i] and model.active[j] else None
            if old is not None and hinge is not None and tuple(table.column("nodes")[old]) == hinge:
                continue
            if old is not None:
                self._kill_hinge(old)
            if hinge is not None:
                fresh.append(hinge)
        if fresh:
            for slot in model.add_hinges(np.array(fresh, dtype=np.int64), positions):
                self._register_hinge(int(slot))
                self.hinge_nodes_changed.update(int(v) for v in table.column("nodes")[slot])
                self.report.new_hinges.append(int(slot))

    def _kill_hinge(self, slot: int) -> None:
        nodes = [int(v) for v in self.model.hinge_table.column("nodes")[slot]]
        for v in nodes:
            self.node_hinges[v].discard(slot)
        del self.edge_hinges[(nodes[0], nodes[1])]
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
        sheet's modulus for the triangles they border then (``_refresh_membrane_stiffness``)
        and, in a prestressed sheet, the rest lengths that carry its tension with that
        stiffness: for the springs of a finished cut, whose triangles are final (with the
        paper's constant K every new spring is K until then, which is the lattice's modulus
        only on equilateral pairs). Part of an edit begun."""
        table = self.model.triangle_table
        corners = [table.column("corners")[t] for t in triangles if table.alive[t]]
        self._settling.update(self._springs_on(self._edges_of(corners)))

    def _spring_lengths(self, slots: list[int]) -> np.ndarray:
        """The lengths [m] (k,) van Gelder's stiffness takes: the rest shape's in a prestressed
        sheet, else the springs' rest lengths."""
        if self.model.prestress_tension:
            return self._rest_shape_lengths(slots)
        return self.model.spring_table.column("rest_length")[slots]

    def _refresh_membrane_stiffness(self, slots: list[int], lengths: np.ndarray) -> None:
        """Give the springs ``slots`` their van Gelder stiffness from the triangles they now
        border and their ``lengths`` [m] (k,) (``warp_cut.sim.stiffness``) for the sheet's
        modulus ``membrane_modulus`` (E t with material springs, 2 K / sqrt(3) with the
        paper's constant K: K itself on an equilateral pair); one of length 0 keeps its own."""
        model = self.model
        areas, pairs = model.triangle_table.column("area"), model.spring_table.column("pairs")
        keep = np.asarray(lengths) > 0
        slots, lengths = [slot for slot, ok in zip(slots, keep) if ok], np.asarray(lengths)[keep]
        if slots:
            area_sums = [sum(areas[t] for t in self.triangles_with_edge(*(int(v) for v in pairs[slot])))
                         for slot in slots]
            modulus = membrane_modulus(model.material, model.stiffness_model)
            k = van_gelder_stiffness(modulus, np.array(area_sums), lengths ** 2)
            model.spring_table.set("stiffness", slots, k)

    def _rest_shape_lengths(self, slots: list[int]) -> np.ndarray:
        """Lengths [m] (k,) of springs ``slots`` between their nodes' rest positions."""
        pairs = self.model.spring_table.column("pairs")[slots]
        points = self.model.points
        return np.linalg.norm(points[pairs[:, 1]] - points[pairs[:, 0]], axis=1)

    def _prestress(self, slots: list[int]) -> None:
        """Rest lengths of the springs ``slots`` (those whose triangles changed in this edit)
        that carry the model's membrane tension in the rest shape, as ``apply_prestress`` gives
        the original springs (``warp_cut.sim.prestress.prestressed_rest_lengths``, from the
        nodes' rest positions and the triangles each spring borders now). So a new spring
        carries the tension its neighbours carry, and an edge the cut left on one triangle
        carries its side's share only (the traction across the cut is released). f / (k L) is
        kept within +-``MAX_PRESTRAIN``: a triangle nearly flat in the rest shape would
        otherwise give a rest length near 0, or a long one."""
        if not slots:
            return
        model = self.model
        pairs = model.spring_table.column("pairs")[slots]
        triangles = sorted({t for i, j in pairs for t in self.triangles_with_edge(int(i), int(j))})
        corners = model.triangle_table.column("corners")[triangles].reshape(-1, 3)
        rest = prestressed_rest_lengths(model.points, corners, pairs, model.spring_table.column("stiffness")[slots],
                                        model.prestress_tension, max_ratio=MAX_PRESTRAIN)
        model.spring_table.set("rest_length", slots, rest)
