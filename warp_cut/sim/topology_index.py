"""TopologyIndex: which springs, triangles, residual links and hinges meet at each node.

The index belongs to the model (``TissueModel.index``, built on first use) and is kept up to
date by whatever edits the model: the cut's ``TopologyEditor`` registers every element it makes
or deletes, a replica that receives another process's edit as table rows re-reads those rows
(``forget_rows`` before they are overwritten, ``register_rows`` after). Everything that asks
"what is at this node" (the editor, the stable step's element rates) reads it here, so an edit
costs what it touches instead of a pass over the tables.
"""

from __future__ import annotations

import numpy as np

__all__ = ["TopologyIndex", "INDEXED_TABLES"]

INDEXED_TABLES = ("spring_table", "triangle_table", "link_table", "hinge_table")
"""The model's slot tables whose rows the index registers by their node columns."""


class TopologyIndex:
    """Node -> element adjacency of a TissueModel (slot indices into its tables).

    Attributes:
        node_springs, node_triangles, node_links, node_hinges: one set of slots per node slot.
        edge_hinges: (i, j) with i < j the hinge's edge -> hinge slot.
    """

    def __init__(self, model):
        self.model = model
        n = model.node_table.count
        self.node_springs: list[set] = [set() for _ in range(n)]
        self.node_triangles: list[set] = [set() for _ in range(n)]
        self.node_links: list[set] = [set() for _ in range(n)]
        self.node_hinges: list[set] = [set() for _ in range(n)]
        self.edge_hinges: dict[tuple[int, int], int] = {}
        for name in INDEXED_TABLES:
            self.register_rows(name, getattr(model, name).live_slots())

    # ------------------------------------------------------------------ queries
    def spring_between(self, i: int, j: int) -> int | None:
        """The live spring slot joining nodes i and j, or None."""
        at_j = self.node_springs[j]
        for slot in self.node_springs[i]:  # the first of i's springs that j has too (i's own order)
            if slot in at_j:
                return slot
        return None

    def triangles_with_edge(self, i: int, j: int) -> set:
        """Live triangle slots holding both nodes i and j."""
        return self.node_triangles[i] & self.node_triangles[j]

    def triangles_at(self, nodes) -> list[int]:
        """Sorted live triangle slots with a corner among ``nodes``."""
        return _union_at(self.node_triangles, nodes)

    def springs_at(self, nodes) -> list[int]:
        """Sorted live spring slots with an end among ``nodes``."""
        return _union_at(self.node_springs, nodes)

    def links_at(self, nodes) -> list[int]:
        """Sorted live residual-link slots with an end among ``nodes``."""
        return _union_at(self.node_links, nodes)

    def hinges_at(self, nodes) -> list[int]:
        """Sorted live hinge slots with a node among ``nodes``."""
        return _union_at(self.node_hinges, nodes)

    # ------------------------------------------------------------------ nodes
    def grow(self, node_count: int) -> None:
        """Make room for node slots up to ``node_count`` (new nodes start with nothing)."""
        for sets in (self.node_springs, self.node_triangles, self.node_links, self.node_hinges):
            sets.extend(set() for _ in range(node_count - len(sets)))

    # ------------------------------------------------------------------ elements
    def add_spring(self, slot: int, i: int, j: int) -> None:
        self.node_springs[i].add(slot)
        self.node_springs[j].add(slot)

    def remove_spring(self, slot: int, i: int, j: int) -> None:
        self.node_springs[i].discard(slot)
        self.node_springs[j].discard(slot)

    def add_triangle(self, slot: int, corners) -> None:
        for v in corners:
            self.node_triangles[int(v)].add(slot)

    def remove_triangle(self, slot: int, corners) -> None:
        for v in corners:
            self.node_triangles[int(v)].discard(slot)

    def add_link(self, slot: int, i: int, j: int) -> None:
        self.node_links[i].add(slot)
        self.node_links[j].add(slot)

    def remove_link(self, slot: int, i: int, j: int) -> None:
        self.node_links[i].discard(slot)
        self.node_links[j].discard(slot)

    def add_hinge(self, slot: int, nodes) -> None:
        """A hinge [a, b, k, l] on the edge (a, b), a < b."""
        a, b, k, l = (int(v) for v in nodes)
        for v in (a, b, k, l):
            self.node_hinges[v].add(slot)
        self.edge_hinges[(a, b)] = slot

    def remove_hinge(self, slot: int, nodes) -> None:
        a, b, k, l = (int(v) for v in nodes)
        for v in (a, b, k, l):
            self.node_hinges[v].discard(slot)
        if self.edge_hinges.get((a, b)) == slot:
            del self.edge_hinges[(a, b)]

    # ------------------------------------------------------------------ rows
    def register_rows(self, table_name: str, slots) -> None:
        """Register the live rows ``slots`` of table ``table_name`` (one of ``INDEXED_TABLES``)."""
        table = getattr(self.model, table_name)
        key = table.column(table.key)
        self.grow(self.model.node_table.count)
        add = self._adders()[table_name]
        alive = table.alive
        for slot in np.asarray(slots, dtype=np.int64):
            if slot < len(alive) and alive[slot]:
                add(int(slot), key[slot])

    def forget_rows(self, table_name: str, slots) -> None:
        """Unregister rows ``slots`` of table ``table_name`` as they are now (before they are
        overwritten: a replica's ``put_rows``)."""
        table = getattr(self.model, table_name)
        key, alive = table.column(table.key), table.alive
        remove = self._removers()[table_name]
        for slot in np.asarray(slots, dtype=np.int64):
            if slot < len(alive) and alive[slot]:
                remove(int(slot), key[slot])

    def _adders(self) -> dict:
        return {"spring_table": lambda s, k: self.add_spring(s, int(k[0]), int(k[1])),
                "triangle_table": self.add_triangle,
                "link_table": lambda s, k: self.add_link(s, int(k[0]), int(k[1])),
                "hinge_table": self.add_hinge}

    def _removers(self) -> dict:
        return {"spring_table": lambda s, k: self.remove_spring(s, int(k[0]), int(k[1])),
                "triangle_table": self.remove_triangle,
                "link_table": lambda s, k: self.remove_link(s, int(k[0]), int(k[1])),
                "hinge_table": self.remove_hinge}


def _union_at(sets: list[set], nodes) -> list[int]:
    """Sorted union of ``sets[v]`` over the node slots ``nodes`` (an iterable or an array)."""
    if isinstance(nodes, np.ndarray):
        nodes = nodes.tolist()
    return sorted(set().union(*[sets[int(v)] for v in nodes]))
