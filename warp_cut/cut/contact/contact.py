"""Where the blade meets the skin: the contact questions a cut event asks about the tool.

The ``Cutter`` asks them at every cut event:

* where the tool's axis crosses the current, deformed skin around it (``contact``;
  ``warp_cut.cut.contact.surface.locate_crossing``), among the live nodes near the tool (a Warp kernel
  finds them, one thread per node slot), and which material point that crossing cuts
  (``material``: ``warp_cut.cut.contact.material_point``);
* whether an incision may start there (``can_start``), and where the blade entered or last
  crossed the skin among the poses since the previous event (``first_crossing``,
  ``last_crossing``);
* with no skin at the axis, whether the tool is still in the tissue: in the opening its own
  incision made (``in_own_opening``), or through an earlier one (``through_an_opening``);
* whether the tool is being drawn out of the wound the last incision cut (``drawn_out``).

Lengths are in metres; positions are (k, 3) arrays of the nodes asked about.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ...kernels.cutting import segment_node_hits
from ...sim.control import Tool
from ...sim.model import TissueModel
from ..curve.incision import Incision
from ..curve.samples import closest_on_polyline
from ..tolerances import MAP_WIDTH, VOID_REACH
from .material_point import MaterialPoint, affine_material_point, held_by
from .surface import Crossing, locate_crossing

__all__ = ["BladeContact", "HitLists"]


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


class BladeContact:
    """The contact tests of a cut on ``model``.

    Args:
        model: The tissue being cut (its topology index gives the triangles at a node).
        hits: The hit lists the node kernel writes into.
        spacing: The mesh spacing [m].
    """

    def __init__(self, model: TissueModel, hits: HitLists, spacing: float):
        self.model = model
        self.hits = hits
        self.spacing = float(spacing)
        self.exit_margin = 0.5 * self.spacing
        """How far above the skin the tip must be before the incision ends [m]: a skin that
        moves about a hovering tip does not split one stroke into several incisions."""

    def contact(self, sim, tool: Tool, x: np.ndarray) -> tuple[Crossing | None, np.ndarray]:
        """(the crossing of ``tool``'s axis with the skin, or None; positions [m] (k, 3) of the
        skin near the tool it was looked for in). ``x``: the node positions [m] of ``sim`` (the
        CutHost)."""
        nodes, _, corners = self.skin_near(sim, tool, x)
        skin = x[nodes]
        return self.locate(tool, skin, self.model.points[nodes], corners), skin

    def locate(self, tool: Tool, x: np.ndarray, rest: np.ndarray, corners: np.ndarray) -> Crossing | None:
        """The crossing of ``tool``'s axis with the skin whose nodes near it are at ``x`` (rest
        positions ``rest``), both (k, 3) [m]; the nodes within 1.5 tool radii of the axis are
        left out of the fit (the tool pushes them)."""
        return locate_crossing(tool.p0, tool.p1, x, corners, reach=tool.radius + 1.5 * self.spacing,
                               fit_radius=tool.radius + 1.5 * self.spacing, exclude=1.5 * tool.radius,
                               rest_positions=rest)

    def material(self, sim, x: np.ndarray, crossing: Crossing, tool: Tool | None,
                 reach: float | None = None) -> MaterialPoint | None:
        """The material point the blade cuts at ``crossing``, the skin's nodes at ``x`` (n, 3)
        [m]: the affine map of the tissue round it (the nodes within ``TOOL_HOLD`` radii of the
        axis, which the tool pushes, left out) carried onto the rest surface
        (``affine_material_point``); None over an opening (no live triangle within ``reach``
        [m], by default the tool's radius + ``VOID_REACH`` spacings) or with no tissue node
        within 2.5 spacings (plus the radius)."""
        radius = 0.0 if tool is None else tool.radius
        scale = radius + MAP_WIDTH * self.spacing
        nodes = self.nodes_near(sim, crossing.point, crossing.point, scale + self.spacing)
        tris = np.array(self.model.index.triangles_at(nodes), dtype=np.int64)
        if len(nodes) < 3 or not len(tris):
            return None
        current = x[nodes].astype(np.float64)
        if tool is not None:
            away = ~held_by(current, tool)
            if away.sum() >= 6:
                nodes, current = nodes[away], current[away]
        weights = np.exp(-((np.linalg.norm(current - crossing.point, axis=1) / scale) ** 2)) + 1e-12
        corners = self.model.triangle_table.column("corners")[tris]
        return affine_material_point(crossing.point, crossing.normal, current, self.model.points[nodes], weights,
                                     x[corners].astype(np.float64), self.model.points[corners],
                                     reach=radius + VOID_REACH * self.spacing if reach is None else reach)

    def skin_near(self, sim, tool: Tool, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(live nodes within 1.5 tool radii + 3 spacings of its axis (k,), the live triangles
        at them (m,), their corner positions [m] (m, 3, 3))."""
        nodes = self.nodes_near(sim, tool.p0, tool.p1, 1.5 * tool.radius + 3.0 * self.spacing)
        tris = np.array(self.model.index.triangles_at(nodes), dtype=np.int64)
        corner_table = self.model.triangle_table.column("corners")
        corners = x[corner_table[tris]].astype(np.float64) if len(tris) else np.zeros((0, 3, 3))
        return nodes, tris, corners

    def nodes_near(self, sim, a, b, radius: float) -> np.ndarray:
        """Live nodes within ``radius`` [m] of segment a-b where they are now (one thread per
        node slot)."""
        return self.hits.run(segment_node_hits, self.model.node_count, [
            sim.state.positions, sim.device_model.node_flags, wp.vec3(*a), wp.vec3(*b), float(radius)])

    def nodes_near_at_rest(self, sim, a, b, radius: float) -> np.ndarray:
        """Live nodes whose rest position lies within ``radius`` [m] of segment a-b."""
        return self.hits.run(segment_node_hits, self.model.node_count, [
            sim.device_model.rest_positions, sim.device_model.node_flags, wp.vec3(*a), wp.vec3(*b),
            float(radius)])

    def can_start(self, sim, tool: Tool, crossing: Crossing | None) -> bool:
        """True if an incision may start at ``crossing``: the blade is in the skin, its axis
        through a live triangle or tissue touching it (a blade pressed against the edge of an
        opening - an earlier wound - cuts into it)."""
        if crossing is None or not crossing.inside:
            return False
        if crossing.pierced:
            return True
        return len(self.nodes_near(sim, tool.p0, tool.p1, tool.radius + 0.5 * self.spacing)) > 0

    def first_crossing(self, sim, poses: list[Tool], x: np.ndarray, rest: np.ndarray,
                       corners: np.ndarray) -> tuple[Crossing, Tool] | None:
        """(the crossing, the pose) of the earliest of ``poses`` whose axis crosses the skin
        where an incision may start (binary search: the tool goes in once between two events)."""
        lo, hi, found = 0, len(poses) - 1, None
        while lo <= hi:
            mid = (lo + hi) // 2
            hit = self.locate(poses[mid], x, rest, corners)
            if not self.can_start(sim, poses[mid], hit):
                lo = mid + 1
            else:
                found, hi = (hit, poses[mid]), mid - 1
        return found

    def last_crossing(self, poses: list[Tool], x: np.ndarray, rest: np.ndarray,
                      corners: np.ndarray) -> tuple[Crossing, Tool] | None:
        """(the crossing, the pose) of the latest of ``poses`` whose blade is in the skin, the
        skin's nodes at ``x`` (rest positions ``rest``) (k, 3) [m] with the triangles' corners
        ``corners`` (m, 3, 3) [m] (binary search: the tool leaves once between two events)."""
        lo, hi, found = 0, len(poses) - 1, None
        while lo <= hi:
            mid = (lo + hi) // 2
            hit = self.locate(poses[mid], x, rest, corners)
            if hit is not None and hit.inside:
                found, lo = (hit, poses[mid]), mid + 1
            else:
                hi = mid - 1
        return found

    def in_own_opening(self, inc: Incision, tool: Tool) -> bool:
        """True if the tool is still in the opening the incision ``inc`` made: its axis at the
        incision's end (``at_the_end_of``), its tip no higher above the skin there than
        ``exit_margin``. A thick tool crossing an earlier wound leaves no skin on one side of
        its axis until this event's lips are made, so no crossing is found there; the tool has
        not left the skin for that."""
        end, normal = inc.contact_path[-1], inc.contact_normals[-1]
        return self.at_the_end_of(inc, tool) and float((tool.p0 - end) @ normal) <= self.exit_margin

    def drawn_out(self, incisions: list[Incision], poses: list[Tool], tip_before: np.ndarray | None) -> bool:
        """True while the tool is drawn out of the wound the last of ``incisions`` cut: its
        axis at that incision's end (``at_the_end_of``) and its tip moving out along the skin's
        normal there since the last event (from ``tip_before``, else the first of ``poses``).
        A tool drawn out lifts the skin around it; that skin closing over its tip again is
        not a new cut."""
        if not incisions:
            return False
        inc = incisions[-1]
        before = poses[0].p0 if tip_before is None else tip_before
        return float((poses[-1].p0 - before) @ inc.contact_normals[-1]) > 0.0 and self.at_the_end_of(inc, poses[-1])

    def at_the_end_of(self, inc: Incision, tool: Tool) -> bool:
        """True if the tool's axis passes within 2 sweep radii + a spacing of the last point
        ``inc`` cut."""
        _, _, _, from_axis = closest_on_polyline(inc.contact_path[-1][None], np.stack([tool.p0, tool.p1]))
        return bool(from_axis[0] <= 2.0 * inc.sweep_radius + self.spacing)

    def through_an_opening(self, inc: Incision, tool: Tool, skin: np.ndarray) -> bool:
        """True if the tool passes through an opening in the skin (an earlier wound) with its
        tip down in the tissue: skin around its axis (``skin``: positions [m] (k, 3) of the live
        nodes ``skin_near`` found, within 1.5 radii + 3 spacings), and the tip not above it by
        more than ``exit_margin`` along the skin's normal where ``inc`` last cut (median over
        those nodes). A thin tool crossing a wide earlier wound has no skin at its axis there,
        but has not left the skin: the incision goes on where the blade meets skin again. A
        blade the skin fell away from, or lifted out, has."""
        if len(skin) < 3:
            return False
        heights = (tool.p0 - skin.astype(np.float64)) @ inc.contact_normals[-1]
        return bool(np.median(heights) <= self.exit_margin)
