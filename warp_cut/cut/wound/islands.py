"""Pieces of skin a cut frees: an excision's island, found after the edit that closes it, and
the scraps an edit trims off; ``FreedPieces`` removes them within the edit.

When a slit runs into an opening (an earlier wound, the tissue's edge), the piece of tissue it
bounds may come free. The triangles joined through shared edges to those the edit made are
grown into their connected pieces one layer at a time, the smallest piece first; once only one
piece is still growing, every other one is finished and smaller, so the search costs about
what the small pieces hold, not the whole tissue. A finished piece that holds no pinned node (or is smaller
than the one still growing) is an island.

Triangles are slots of the model's triangle table.
"""

from __future__ import annotations

import numpy as np

from ...mesh.geometry import corner_areas

__all__ = ["FreedPieces", "islands_from", "scraps_from", "piece_nodes"]


def _neighbours(model, t: int) -> set[int]:
    """Live triangles sharing a node with triangle ``t`` (a piece held by one node is held)."""
    index, c = model.index, model.triangle_table.column("corners")[t]
    out = index.node_triangles[int(c[0])] | index.node_triangles[int(c[1])] | index.node_triangles[int(c[2])]
    return out - {t}


def islands_from(model, seeds, limit: int | None = None) -> list[set[int]]:
    """The pieces of the mesh reachable from the triangles ``seeds`` that came apart from the
    rest: every connected piece but the one that is still growing when all the others are done
    (the tissue), each as its set of triangle slots. ``limit``: stop (no island) once the
    pieces searched hold this many triangles (default: half the live triangles)."""
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
    if searched >= limit:
        return []
    growing = [k for k, f in enumerate(fronts) if f]
    finished = [k for k, p in enumerate(pieces) if p and k not in growing]
    if not pieces:  # no live seed: nothing was cut free
        return []
    if not growing:  # every piece finished: the largest is the tissue
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


def _rest_area(model, triangles: set[int]) -> float:
    """Rest area [m^2] of the triangle slots ``triangles``."""
    return float(corner_areas(model.points[_corners(model, triangles)]).sum())


class FreedPieces:
    """Removes, within an edit of ``editor`` (a ``TopologyEditor``), what the edit left apart
    from the tissue: its scraps (``scraps_from``: rest area below ``scrap_area`` [m^2], at most
    ``scrap_triangles`` triangles), whatever the settings say, and the islands a slit meeting
    an opening cut free (``islands_from``), unless ``keep_islands``. A scrap holding a node of
    ``keep`` (the incision's newest lip pair, which its next event closes onto) waits for a
    later edit."""

    def __init__(self, editor, scrap_area: float, scrap_triangles: int, keep_islands: bool):
        self.editor = editor
        self.scrap_area, self.scrap_triangles = float(scrap_area), int(scrap_triangles)
        self.keep_islands = bool(keep_islands)
        self.waiting: set[int] = set()
        """Triangles (slots) of the scraps that wait."""

    def after_edit(self, keep: set[int]) -> tuple[int, int]:
        """Remove the scraps near what the edit made or touched (and the waiting ones), and the
        islands it cut free. Every edit is searched, not only one whose slit met an opening by a
        new point: a slit whose lips were matched to nodes of an earlier wound's border frees its
        island just the same (an arc across a zigzag wound left a free piece of 24 triangles).
        Returns (scraps, islands) removed."""
        editor = self.editor
        near = set(editor.report.new_triangles).union(*(editor.node_triangles[v] for v in editor.touched_nodes))
        scraps = self.remove_scraps(near, keep)
        if self.keep_islands:
            return scraps, 0
        islands = islands_from(editor.model, editor.report.new_triangles)
        for island in islands:
            self._remove(island)
        return scraps, len(islands)

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

    def _remove(self, triangles: set[int]) -> None:
        """Delete the nodes (and so the springs and triangles) of the triangle slots ``triangles``."""
        self.editor.delete_nodes(piece_nodes(self.editor.model, triangles).tolist())
