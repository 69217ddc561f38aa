"""Stage 1 of a cut event, the swept volume (paper section 2.3).

The tool's cross-section circle sweeps a capsule from the previous contact point to the current
one. Warp kernels find the live nodes inside it and the springs through it, one thread per
candidate near the capsule, into compact hit lists; the host deletes them through the
``TopologyEditor``. A deleted spring that crosses the cut and whose nodes survive becomes a
residual-stress link. The nodes of the original tissue whose rest position lies within half
the circle's radius of the swept stretch carried into the rest shape go too: the material the
blade passed through, wherever the tool has pushed it.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels.cutting import capsule_node_hits_among, capsule_spring_hits_among
from ..sim.control import Tool
from ..sim.model import TissueModel
from .classes import NodeClass
from .incision import Incision, closest_on_polyline
from .topology import TopologyEditor
from .wound_links import separated_by

__all__ = ["HitLists", "SweptVolume"]


class HitLists:
    """Compact hit lists from the cut's kernels (int32 slots), grown when they overflow."""

    def __init__(self, device):
        self.device = device
        self.buffer = wp.zeros(1024, dtype=wp.int32, device=device)
        self.count = wp.zeros(1, dtype=wp.int32, device=device)

    def run(self, kernel, dim, inputs) -> np.ndarray:
        """Launch ``kernel`` over ``dim`` threads with ``inputs`` and the hit buffer; the hits
        as an int64 array (k,)."""
        while True:
            self.count.zero_()
            wp.launch(kernel, dim=dim, device=self.device, inputs=inputs + [self.buffer, self.count])
            n = int(self.count.numpy()[0])
            if n <= self.buffer.shape[0]:
                return self.buffer.numpy()[:n].astype(np.int64)
            self.buffer = wp.zeros(2 * n, dtype=wp.int32, device=self.device)


class SweptVolume:
    """Deletes what the tool's swept capsule cuts, as the first part of a topology edit.

    Args:
        model: The tissue being cut.
        editor: Its topology editor (the edit is begun here).
        hits: The hit lists the kernels write into.
        spacing: The mesh spacing [m] (the reach of the tissue's displacement around the tool).
        device: Warp device of the kernels.
    """

    def __init__(self, model: TissueModel, editor: TopologyEditor, hits: HitLists, spacing: float, device):
        self.model = model
        self.editor = editor
        self.hits = hits
        self.spacing = float(spacing)
        self.device = device

    def cut(self, sim, inc: Incision, a: np.ndarray, b: np.ndarray, normal, near: np.ndarray,
            positions: np.ndarray) -> None:
        """Begin an edit and delete what the capsule a-b [m] (radius ``inc.sweep_radius``)
        touches: the nodes inside and the springs through it, among the live nodes ``near`` it
        (k,) and their springs. A deleted spring that crosses the cut (its nodes on either side
        of the line a-b in the skin, whose outward normal is ``normal``) becomes a residual-stress
        link, a node the capsule deletes replaced by the lip that takes its place; one with both
        nodes on one side, grazed by the capsule, joins what the cut does not separate and makes
        none, and so does one this incision made itself (tissue it re-closed ahead of its tip:
        the springs it stands for left their links already). The links act once the wound is
        open where they crossed (``wound_links.open_links``): under the tool there are
        no lips yet, and links there would pull the sides together across the hole the tool is
        in. ``sim`` is the CutHost (its device positions and mirror), ``positions`` its node
        positions [m] (node_count, 3)."""
        editor, model, r = self.editor, self.model, inc.sweep_radius
        nodes, springs = self._hits_of(sim, near, a, b, r)
        editor.begin()
        doomed = {int(v) for v in nodes} | self.material_cut(positions, sim.tool_pose, near, a, b, r)
        own_lips = {n for n in inc.left + inc.right + [inc.start_node] if n >= 0}
        pairs = model.spring_table.column("pairs")
        crossing = separated_by(positions, pairs[springs], a, b, normal)
        cut = [sl for sl, k in zip(springs, crossing)
               if k and sl < inc.first_own_spring and not ({int(v) for v in pairs[sl]} & own_lips)]
        separated = self._losing_nodes(cut, doomed)
        editor.delete_springs(cut, residual=True, doomed_nodes=doomed, pending=separated)
        known = {frozenset(link[:2]) for link in inc.pending_links}
        inc.pending_links += [(i, j, rest, inc.length) for _, i, j, rest in separated
                              if frozenset((i, j)) not in known]  # tissue re-closed and cut again
        editor.delete_springs(springs, residual=False)  # grazed on one side, or at own lips
        editor.delete_nodes(sorted(doomed))

    def _losing_nodes(self, springs, doomed: set[int]) -> list[tuple[int, int, int, float]]:
        """(slot, i, j, rest length [m]) of the separated ``springs`` that lose one node or both
        to the cut (in ``doomed``): the tissue on both sides lives on, so their residual links
        are made too, each lost node replaced by the lip that takes its place on its side
        (``wound_links.open_links``). Without them a coarse event, whose capsule swallows the
        nodes along the line, would leave that stretch of the wound with fewer links than fine
        events leave it, and the wound's width would depend on the event interval.
        None in the prestress model."""
        model = self.model
        if not self.editor.policy.makes_links:
            return []
        table = model.spring_table
        pairs, rest = table.column("pairs"), table.column("rest_length")
        out = []
        for slot in springs:
            i, j = (int(v) for v in pairs[slot])
            if table.alive[slot] and (i in doomed or j in doomed) and model.active[i] and model.active[j]:
                out.append((int(slot), i, j, float(rest[slot])))
        return out

    def _hits_of(self, sim, near: np.ndarray, a, b, r: float) -> tuple[np.ndarray, np.ndarray]:
        """(nodes (k,), springs (m,)) of the capsule a-b of radius ``r`` [m]: the live nodes of
        ``near`` inside it and their springs passing through it (Warp kernels)."""
        near_springs = sorted({s for v in near for s in self.editor.node_springs[v]})
        dm = sim.device_model
        nodes = self.hits.run(capsule_node_hits_among, len(near), [
            sim.state.positions, dm.node_flags, self._index_array(near), wp.vec3(*a), wp.vec3(*b), float(r)])
        springs = self.hits.run(capsule_spring_hits_among, len(near_springs), [
            sim.state.positions, dm.spring_indices, self._index_array(near_springs),
            wp.vec3(*a), wp.vec3(*b), float(r)])
        return nodes, springs

    def material_cut(self, positions: np.ndarray, tool: Tool | None, near: np.ndarray, a: np.ndarray,
                     b: np.ndarray, r: float) -> set[int]:
        """Nodes of the original tissue (not lips) among ``near`` whose rest positions lie
        within half the sweep radius ``r`` of the swept segment carried into the rest shape:
        material the blade passed through. The tool's front pushes such a node ahead of it (up
        a tilted shaft, off the path), so the capsule on the skin never reaches it; the blade
        would have cut it. The segment's ends a, b [m] are carried by the displacement of the
        tissue around them (nodes beyond 1.5 radii of the ``tool``'s axis, Gaussian weights of
        two spacings); ``positions`` are the current node positions [m] (node_count, 3)."""
        model = self.model
        near = np.asarray(near, dtype=np.int64)
        original = near[model.node_class[near] != NodeClass.LIP]
        if len(original) == 0:
            return set()
        x = positions[original].astype(np.float64)
        rest = model.points[original]
        free = np.ones(len(original), dtype=bool)
        if tool is not None:
            _, _, _, from_axis = closest_on_polyline(x, np.stack([tool.p0, tool.p1]))
            free = from_axis > 1.5 * tool.radius
        if free.sum() < 3:
            return set()
        ends = []
        for p in (a, b):
            w = np.exp(-(np.linalg.norm(x[free] - p, axis=1) / (2.0 * self.spacing)) ** 2)
            if not w.sum() > 1e-12:
                return set()
            ends.append(p + (w @ (rest[free] - x[free])) / w.sum())
        _, _, _, dist = closest_on_polyline(rest, np.stack(ends))
        return {int(v) for v in original[dist < 0.5 * r]}

    def _index_array(self, idx) -> wp.array:
        return wp.array(np.asarray(idx, dtype=np.int32), dtype=wp.int32, device=self.device)
