"""Pieces of skin a cut frees: an excision's island, found after the edit that closes it, the
scraps an edit trims off and the flaps it leaves hanging by one edge; ``FreedPieces`` removes
them within the edit.

When a slit runs into an opening (an earlier wound, the tissue's edge), the piece of tissue it
bounds may come free. The triangles joined through shared edges to those the edit made are
grown into their connected pieces one layer at a time, the smallest piece first; once only one
piece is still growing, every other one is finished and smaller, so the search costs about
what the small pieces hold, not the whole tissue. A finished piece that holds no pinned node (or is smaller
than the one still growing) is an island.

Triangles are slots of the model's triangle table.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...mesh.geometry import corner_areas, half_edges
from ...sim.slots import member
from ..classes import NodeClass
from ..sweep.region import border_nodes

__all__ = ["Freed", "FreedPieces", "islands_from", "scraps_from", "flaps_from", "piece_nodes"]


def _neighbours(model, t: int) -> set[int]:
    """Live triangles sharing a node with triangle ``t`` (a piece held by one node is held)."""
    index, c = model.index, model.triangle_table.column("corners")[t]
    out = index.node_triangles[int(c[0])] | index.node_triangles[int(c[1])] | index.node_triangles[int(c[2])]
    return out - {t}


def islands_from(model, seeds, limit: int | None = None) -> list[set[int]]:
    """The pieces of the mesh reachable from the triangles ``seeds`` that came apart from the
    rest: every connected piece but the one that is still growing when all the others are done
    (the tissue), each as its set of triangle slots. ``limit``: stop once the pieces searched
    hold this many triangles (default: half the live triangles); the pieces found whole by then,
    each under ``limit`` (so not the tissue, which holds more), are islands all the same. Seeds
    on both sides of a long wound grow round it before they meet, and that search once hit the
    limit and forgot a piece of 9 triangles it had found, left floating in the wound."""
    alive = model.triangle_table.alive
    seeds = [int(t) for t in seeds if alive[int(t)]]
    limit = limit or max(1, model.triangle_count // 2)
    owner: dict[int, int] = {}
    pieces: list[set[int]] = []
    fronts: list[list[int]] = []
    for t in seeds:
        if t not in owner:
            owner[t] = len(pieces)
            pieces.append({t})
            fronts.append([t])
    searched = len(owner)
    while sum(1 for f in fronts if f) > 1 and searched < limit:
        k = min((k for k, f in enumerate(fronts) if f), key=lambda k: len(pieces[k]))  # the smallest grows
        front, nxt = fronts[k], []
        for t in front:
            for n in _neighbours(model, t):
                other = owner.get(n)
                if other is None:
                    owner[n] = k
                    pieces[k].add(n)
                    nxt.append(n)
                    searched += 1
                elif other != k:  # two seeds' pieces touch: one piece
                    nxt += fronts[other]
                    _merge(owner, pieces, fronts, other, k)
        fronts[k] = nxt
    finished = [k for k, p in enumerate(pieces) if p and not fronts[k]]
    if searched >= limit:  # the tissue not found: the pieces found whole under the limit are apart from it
        finished = [k for k in finished if len(pieces[k]) < limit]
    elif pieces and not any(fronts):  # every piece finished: the largest is the tissue
        largest = max(range(len(pieces)), key=lambda k: len(pieces[k]))
        finished = [k for k in finished if k != largest]
    return [pieces[k] for k in finished if _free(model, pieces[k])]


def _merge(owner: dict, pieces: list, fronts: list, src: int, dst: int) -> None:
    """Join piece ``src`` into ``dst`` (they touch); ``src``'s front is the caller's to keep."""
    for t in pieces[src]:
        owner[t] = dst
    pieces[dst] |= pieces[src]
    pieces[src], fronts[src] = set(), []


def _free(model, triangles: set[int]) -> bool:
    """True if a piece holds no pinned node (a pinned one holds it in place: not freed)."""
    return not model.pinned[piece_nodes(model, triangles)].any()


def piece_nodes(model, triangles) -> np.ndarray:
    """The nodes (sorted, unique) of the triangle slots ``triangles``."""
    return np.unique(_corners(model, triangles))


def _corners(model, triangles) -> np.ndarray:
    """Corner nodes (t, 3) of the triangle slots ``triangles``."""
    return model.triangle_table.column("corners")[np.fromiter(triangles, dtype=np.int64)]


def scraps_from(model, seeds, max_area: float, max_triangles: int) -> list[set[int]]:
    """The pieces of at most ``max_triangles`` triangles, of rest area under ``max_area`` [m^2],
    that the live triangles ``seeds`` belong to and that touch no other triangle: flecks an edit
    cut off, each as its set of triangle slots. Costs at most ``max_triangles`` + 1 triangles
    per seed."""
    alive = model.triangle_table.alive
    seen: set[int] = set()
    scraps = []
    for seed in (int(t) for t in seeds):
        if seed in seen or not alive[seed]:
            continue
        piece, front = {seed}, [seed]
        while front and len(piece) <= max_triangles:
            front = [n for t in front for n in _neighbours(model, t) if n not in piece]
            piece.update(front)
        seen |= piece
        if not front and _rest_area(model, piece) < max_area:
            scraps.append(piece)
    return scraps


def flaps_from(model, seeds, max_area: float, max_triangles: int, keep=frozenset()) -> list[tuple[set[int], tuple]]:
    """The pieces of tissue held to the rest by one edge only, near the live triangles ``seeds``:
    for each edge of theirs between two border nodes with a live triangle on either side (a
    chord between openings), the triangles joined to one side through nodes other than its two
    ends, if they close within ``max_triangles`` triangles and ``max_area`` [m^2] of rest area
    without reaching the other side and hold no pinned node and no node of ``keep``. A membrane's
    springs resist no turn about that edge, so such a flap folds over and stays folded. Only a
    flap the cut left counts (``_cut_touched``). Each as (its triangle slots, the edge's two
    nodes)."""
    index, corners, alive = model.index, model.triangle_table.column("corners"), model.triangle_table.alive
    seeds = [int(t) for t in seeds if alive[int(t)]]
    if not seeds:
        return []
    nodes = np.unique(corners[seeds])
    edges = np.sort(half_edges(corners[seeds]), axis=1)
    chords = {(a, b) for a, b in edges[member(edges, nodes[border_nodes(model, nodes)]).all(axis=1)].tolist()}
    flaps, taken = [], set()
    for a, b in sorted(chords):
        sides = index.triangles_with_edge(a, b)
        if len(sides) != 2 or sides & taken:
            continue
        for side in sorted(sides):
            piece = _held_by(model, side, (a, b), max_triangles, sides - {side})
            if piece is not None and _rest_area(model, piece) < max_area and _cut_touched(model, piece) \
                    and not _holds(model, piece, (a, b), keep):
                flaps.append((piece, (a, b)))
                taken |= piece
                break
    return flaps


def _held_by(model, start: int, hinge: tuple, max_triangles: int, other: set[int]) -> set[int] | None:
    """The triangles joined to triangle ``start`` through nodes other than the ``hinge``'s two,
    or None if they reach a triangle of ``other`` or number more than ``max_triangles``."""
    index, corners = model.index, model.triangle_table.column("corners")
    piece, front = {start}, [start]
    while front:
        front = [n for t in front for v in corners[t].tolist() if v not in hinge
                 for n in index.node_triangles[v] if n not in piece]
        piece.update(front)
        if len(piece) > max_triangles or piece & other:
            return None
    return piece


def _cut_touched(model, piece: set[int]) -> bool:
    """True if a corner of the triangle slots ``piece`` is a node the cut made or re-meshed round
    (its class not ``NORMAL``): the cut left the flap, not the mesh as it was given (the corner
    triangle of a patch may hang by one edge too)."""
    return bool((model.node_class[_corners(model, piece)] != NodeClass.NORMAL).any())


def _holds(model, piece: set[int], hinge: tuple, keep) -> bool:
    """True if the triangle slots ``piece`` hold a pinned node or a node of ``keep`` (but the
    ``hinge``'s two, which stay)."""
    nodes = [v for v in piece_nodes(model, piece).tolist() if v not in hinge]
    return bool(model.pinned[nodes].any()) or bool(set(nodes) & set(keep))


def _rest_area(model, triangles: set[int]) -> float:
    """Rest area [m^2] of the triangle slots ``triangles``."""
    return float(corner_areas(model.points[_corners(model, triangles)]).sum())


@dataclass(frozen=True)
class Freed:
    """What one edit's ``FreedPieces.after_edit`` removed."""

    scraps: int
    """Scraps (pieces apart from the tissue)."""
    flaps: int
    """Triangles of the flaps (pieces held by one edge)."""
    islands: int
    """Islands (pieces a slit cut free)."""


class FreedPieces:
    """Removes, within an edit of ``editor`` (a ``TopologyEditor``), what the edit left apart
    from the tissue: its scraps (``scraps_from``: rest area below ``scrap_area`` [m^2], at most
    ``scrap_triangles`` triangles), whatever the settings say, the flaps it left hanging by one
    edge (``flaps_from``: a chain of them under ``flap_area`` [m^2] and ``flap_triangles``), and
    the islands a slit meeting an opening cut free (``islands_from``), unless ``keep_islands``.
    A scrap holding a node of ``keep`` (the incision's newest lip pair, which its next event
    closes onto) waits for a later edit; a flap holding a node of the incision's slit, for its
    end."""

    def __init__(self, editor, scrap_area: float, scrap_triangles: int, keep_islands: bool,
                 flap_area: float = 0.0, flap_triangles: int = 0):
        self.editor = editor
        self.scrap_area, self.scrap_triangles = float(scrap_area), int(scrap_triangles)
        self.flap_area, self.flap_triangles = float(flap_area), int(flap_triangles)
        self.keep_islands = bool(keep_islands)
        self.waiting: set[int] = set()
        """Triangles (slots) of the scraps that wait."""
        self.flaps_near: set[int] = set()
        """Triangles (slots) round the edits of the incision being cut, searched for flaps again
        at its end (a flap holding a node of its slit waits till then)."""

    def after_edit(self, keep: set[int], slit: set[int] = frozenset()) -> Freed:
        """Remove the scraps near what the edit made or touched (and the waiting ones), the flaps
        it left (``remove_flaps``) and the islands it cut free. Every edit is searched, not only
        one whose slit met an opening by a new point: a slit whose lips were matched to nodes of
        an earlier wound's border frees its island just the same (an arc across a zigzag wound
        left a free piece of 24 triangles). A flap holding a node of ``slit`` (the incision being
        cut, whose next events re-mesh round it) waits for the incision's end: an edit with no
        ``slit`` searches round every edit since (``flaps_near``)."""
        editor = self.editor
        near = set(editor.report.new_triangles).union(*(editor.node_triangles[v] for v in editor.touched_nodes))
        scraps = self.remove_scraps(near, keep)
        self.flaps_near |= near
        flaps = self.remove_flaps(near, keep | slit) if slit else self._remove_flaps_near(keep)
        if self.keep_islands:
            return Freed(scraps, flaps, 0)
        islands = islands_from(editor.model, editor.report.new_triangles)
        for island in islands:
            self._remove(island)
        return Freed(scraps, flaps, len(islands))

    def at_incision_end(self) -> Freed:
        """Remove what waited for the incision's end: the waiting scraps and the flaps round
        its edits (nothing closes onto them now)."""
        scraps = self.remove_scraps(set(), keep=set())
        return Freed(scraps, self._remove_flaps_near(keep=set()), 0)

    def _remove_flaps_near(self, keep: set[int]) -> int:
        """Remove the flaps round every edit of the incision since its last search
        (``flaps_near``), which starts over. Returns the flap triangles removed."""
        flaps = self.remove_flaps(self.flaps_near, keep)
        self.flaps_near = set()
        return flaps

    def remove_scraps(self, seeds: set[int], keep: set[int]) -> int:
        """Remove the scraps the triangle slots ``seeds`` or the waiting ones belong to; one
        holding a node of ``keep`` waits. Returns the scraps removed."""
        seeds, self.waiting = seeds | self.waiting, set()
        removed = 0
        for scrap in scraps_from(self.editor.model, seeds, self.scrap_area, self.scrap_triangles):
            if keep & set(piece_nodes(self.editor.model, scrap).tolist()):
                self.waiting |= scrap
                continue
            self._remove(scrap)
            removed += 1
        return removed

    def remove_flaps(self, seeds: set[int], keep: set[int]) -> int:
        """Remove the flaps near the triangle slots ``seeds`` (``flaps_from``; the nodes of a
        flap go but its edge's two), each with the flaps its removal leaves (the triangle on the
        other side of that edge may now hang by one edge: the two were one flap hung by the
        next edge), as long as such a chain stays within the flap area and triangle count.
        Returns the flap triangles removed."""
        model, removed = self.editor.model, 0
        for piece, hinge in flaps_from(model, seeds, self.flap_area, self.flap_triangles, keep):
            if model.triangle_table.alive[sorted(piece)].all():  # not taken by a chain before it
                removed += self._remove_chain(piece, hinge, keep)
        return removed

    def _remove_chain(self, piece: set[int], hinge: tuple, keep: set[int]) -> int:
        """Remove the flap ``piece`` hung on ``hinge`` and then the flap its removal leaves, in
        turn, while their rest area and triangles in all stay within the limits. Returns the
        triangles removed."""
        editor, area, count = self.editor, 0.0, 0
        while True:
            area += _rest_area(editor.model, piece)
            count += len(piece)
            editor.delete_nodes([v for v in piece_nodes(editor.model, piece).tolist() if v not in hinge])
            seeds = set().union(*(editor.node_triangles[v] for v in hinge if editor.model.active[v]))
            more = flaps_from(editor.model, seeds, self.flap_area - area, self.flap_triangles - count, keep)
            if not more:
                return count
            piece, hinge = more[0]

    def _remove(self, triangles: set[int]) -> None:
        """Delete the nodes (and so the springs and triangles) of the triangle slots ``triangles``."""
        self.editor.delete_nodes(piece_nodes(self.editor.model, triangles).tolist())
