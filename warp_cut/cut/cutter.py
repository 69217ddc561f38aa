"""Cutter: the three-stage cut (paper section 2.3) driven by the tool while the simulation runs.

Every ``interval`` seconds while the tool's axis crosses the skin (and, optionally, the tool
pushes harder than a threshold) a cut event runs:

* the contact point is where the axis crosses the current, deformed skin around it, with the
  skin's normal there (``warp_cut.cut.surface``): the cut follows curved and sagging skin;
* Stage 1 - the tool's cross-section circle sweeps a capsule from the previous contact point to
  this one; the nodes inside are deleted with their springs, and so are the tissue's nodes whose
  rest position lies within half the circle's radius of that stretch carried into the rest
  shape (the material the blade passed through, wherever the tool has pushed it); the springs
  passing through the capsule are deleted (each whose two nodes survive becomes a
  residual-stress link), and the triangles touched form the grey area (Warp kernels find the
  hits; the edit is host-side; ``warp_cut.cut.swept_volume``);
* Stage 2 - the contact path is refitted with a C1 chain of cubic Bezier segments whose end is
  the tool's contact point;
* Stage 3 - the grey area is re-meshed by shortest-distance node matching (``warp_cut.cut.remesh``).

The incision starts where the axis first crossed the skin (found among the tool's poses since
the previous event, so neither a thin tool slipping between nodes nor the event interval
delays it) and ends when the tool leaves the skin - lifted out, or moved off the tissue -
and only then: one stroke is one incision. While the tool cuts, lips are made only behind its
footprint (a node made inside the tool would be pushed out at once: a jolt in the tool's
force); the slit's tip is its newest lip pair and the tissue ahead of it is re-closed after
each event until the tool has gone. Residual-stress links whose node a later event deletes are
carried to the node that takes its place on the same side.
"""

from __future__ import annotations

import time

import numpy as np
import warp as wp

from ..errors import InputError
from ..kernels import cutting as cut_kernels
from ..kernels import scatter
from ..mesh.checks import cuttable_problems
from ..sim.control import Tool
from ..sim.model import TissueModel
from .classes import NodeClass
from .contact import BladeContact
from .events import EventClock
from .flips import flip_slivers, flip_to_delaunay
from .host import CutHost
from .incision import Incision
from .lip_slots import lips_inside
from .measures import gap_profile, incision_width, lip_deviation, path_coverage
from .remesh import fill_hole
from .settings import CutSettings
from .surface import Crossing
from .swept_volume import HitLists, SweptVolume
from .topology import NodePositions, TopologyEditor
from .wound_links import align_links, carry_links, open_links

__all__ = ["Cutter", "STAGES"]

STAGES = ("stage1_swept_volume", "stage2_bezier", "stage3_matching", "device_update")
"""Names of the timed parts of a cut event (latency in metrics.json)."""


class Cutter:
    """Cuts a TissueModel while a simulation of it runs.

    The simulation calls ``after_step(host)`` after every step (``Simulator(cutting=...)``
    registers it as a post-step hook); ``start_incision``, ``extend_incision`` and
    ``end_incision`` drive a cut directly. Every call gets the ``CutHost`` it acts on; the
    Cutter keeps the model's topology editor and the incisions, nothing of the host.

    Args:
        model: The tissue to cut (edited in place through a ``TopologyEditor``).
        settings: Cutting parameters (default ``CutSettings()``).
        device: Warp device of the Stage 1 kernels.
    """

    def __init__(self, model: TissueModel, settings: CutSettings | None = None, device: str = "cpu"):
        self.model = model
        self.device = device
        self.settings = settings or CutSettings()
        if model.triangle_count == 0:
            raise InputError("cutting needs a tissue with triangles (a surface mesh)")
        problems = cuttable_problems(model.points, model.triangles)
        if problems:
            raise InputError("this mesh cannot be cut (a cut needs a manifold, consistently wound "
                             "mesh without duplicate or degenerate triangles): " + "; ".join(problems))
        self.editor = TopologyEditor(model)
        lengths = model.rest_lengths
        self.spacing = self.settings.spacing or float(np.median(lengths))
        self.edge_reach = 1.5 * float(lengths.max()) if len(lengths) else self.spacing
        """How far from the swept capsule a spring may start and still cross it [m]."""
        self.incisions: list[Incision] = []
        self.current: Incision | None = None
        self._clock = EventClock()
        self._poses: list[Tool] = []
        """Tool poses of the steps since the last cut event (where the blade entered)."""
        self._tip_before: np.ndarray | None = None
        """The tool's tip at the last cut event [m] (None: no tool then)."""
        self._hits = HitLists(device)
        self.swept_volume = SweptVolume(model, self.editor, self._hits, self.spacing, device)
        self.contact = BladeContact(model, self.editor, self._hits, self.spacing)
        self.latency_ms = {name: [] for name in STAGES}
        self.totals = {"deleted_nodes": 0, "deleted_springs": 0, "residual_links": 0,
                       "carried_links": 0, "aligned_links": 0, "lost_links": 0, "lip_nodes": 0, "lip_nodes_removed": 0,
                       "new_springs": 0, "removed_fragments": 0, "sliver_flips": 0, "delaunay_flips": 0, "events": 0}
        self.new_triangles: set[int] = set()
        self._membrane_unsettled = False
        """The cut made triangles since its springs last took the sheet's modulus."""
        self.contact_path: list[np.ndarray] = []
        self.unfilled_holes = 0
        # compile the cut's kernels now, so that no cut event pays for it
        for module in (cut_kernels, scatter):
            wp.load_module(module, device=device)

    # ----------------------------------------------------------------- driving
    def after_step(self, sim: CutHost) -> None:
        """Advance the cut after a simulation step of ``sim``."""
        tool = sim.tool_pose if sim.collision else None
        cutting = tool is not None and tool.radius > 0
        if cutting:
            self._poses.append(tool)
        else:
            self._poses.clear()
            self._tip_before = None
            self.end_incision(sim)
        if not self._clock.due(sim.time, sim.dt, self.settings.interval):
            return
        self._retry_holes(sim)
        if not cutting:
            if not any(inc.open_chains for inc in self.incisions):
                self._flip_made_triangles(sim)  # the tissue settling after a stroke can thin its triangles
            return
        poses, self._poses = self._poses, []
        tip_before, self._tip_before = self._tip_before, tool.p0
        if self.current is None:
            if not self.contact.drawn_out(self.incisions, poses, tip_before):
                self._start_where_the_blade_entered(sim, poses)
            return
        contact = self.contact
        crossing, skin = contact.contact(sim, tool, self._positions_view(sim))
        if crossing is None and (contact.in_own_opening(self.current, tool)
                                 or contact.through_an_opening(self.current, tool, skin)):
            return  # no skin around the axis, but the blade is still down in the tissue: wait
        if crossing is None or crossing.tip_height > contact.exit_margin:
            self.end_incision(sim)  # the tool has left the skin: this incision is complete
        elif crossing.inside and not self.current.retraces(crossing.point, self.current.sweep_radius):
            self.extend_incision(sim, crossing.point, crossing.normal)
        # else: the tip is just above the skin (the skin moves, the tool hovers) or back over
        # the cut: wait

    def catch_up(self, poses: list[Tool]) -> None:
        """Take the tool poses of steps whose ``after_step`` this cutter did not see (a cutter
        told only of events, ``warp_cut.cut.background``), oldest first."""
        self._poses = list(poses)

    def crossing(self, sim: CutHost, tool: Tool) -> Crossing | None:
        """Where the tool's axis crosses the skin now (None: the tool is out of the skin)."""
        return self.contact.contact(sim, tool, self._positions_view(sim))[0]

    def _start_where_the_blade_entered(self, sim: CutHost, poses: list[Tool]) -> None:
        """Start an incision if the axis crosses the skin (and the tool pushes hard enough),
        at the first of ``poses`` whose axis crossed it, then cut on to where it is now."""
        tool = poses[-1]
        if np.linalg.norm(sim.contacts.force) < self.settings.force_threshold:
            return
        x = self._positions_view(sim)
        nodes, corners = self.contact.skin_near(sim, tool, x)
        rest = self.model.points[nodes]
        now = self.contact.locate(tool, x[nodes], rest, corners)
        if not self.contact.can_start(sim, tool, now):
            return
        entry = now
        if self.settings.force_threshold == 0.0:
            entry = self.contact.first_crossing(sim, poses, x[nodes], rest, corners) or now
        self.start_incision(sim, entry.point, entry.normal, self.settings.sweep_radius or tool.radius)
        self.extend_incision(sim, now.point, now.normal)

    def start_incision(self, sim: CutHost, point, normal, sweep_radius: float) -> Incision:
        """Begin a new incision at ``point`` [m] on the skin with unit outward ``normal``; the
        swept circle has radius ``sweep_radius`` [m]. (``after_step`` calls this where the
        blade entered; a haptic loop or a test may call it directly.)"""
        if not (np.isfinite(sweep_radius) and sweep_radius > 0):
            raise InputError(f"sweep radius must be > 0 m, got {sweep_radius}")
        self.end_incision(sim)
        s = self.settings
        self.current = Incision(point, normal, spacing=self.spacing,
                                lip_offset=s.lip_offset or 0.25 * sweep_radius,
                                tolerance=s.tolerance or 0.1 * self.spacing)
        self.current.sweep_radius = float(sweep_radius)
        self.current.first_own_spring = self.model.spring_table.count
        self.incisions.append(self.current)
        return self.current

    def end_incision(self, sim: CutHost) -> None:
        """Finish the current incision (the next cut starts a new one). The tool has gone, so
        the stretch it covered gets its lips now: the tissue re-closed ahead of the slit's tip
        is removed again, stations reach to half a spacing from the curve's end and the end
        node is made there; a hole still open waiting for better geometry is filled now,
        slivers or not."""
        inc = self.current
        self.current = None
        if inc is None or len(inc.path) < 2:
            return
        self.editor.begin()
        self._reopen_tip(sim, inc, self._positions_view(sim))
        inc.open_end = False
        inc.plan_stations(clearance=0.5 * self.spacing)
        if self.editor.report.deleted_triangle_corners or inc.open_chains:
            report, result, positions = self._stage3(sim, inc, None, defer_slivers=False)
            self._apply(sim, report, positions)
            self._count(report, result)
        else:
            self.editor.finish()
        if not inc.open_chains:
            self._flip_made_triangles(sim)

    def _flip_made_triangles(self, sim: CutHost) -> None:
        """Flip among the triangles the cut made (``warp_cut.cut.flips``), once the tool has left
        the skin and no hole is open, as an edit of its own: in a prestressed sheet to Delaunay
        in the rest shape (so every spring between them carries tension), then the slivers; a
        prestressed sheet's cut then takes the sheet's modulus (``TopologyEditor.settle_membrane``)
        if anything was cut or flipped since it last did. When an incision ends, and at every
        event while there is no tool (the tissue settling after a stroke can pull its triangles
        thin)."""
        if not self.new_triangles:
            return  # nothing cut yet: no positions to read, no edit to begin
        editor = self.editor
        editor.begin()
        positions = NodePositions(self._positions_view(sim))
        candidates = set(self.new_triangles)
        prestressed = self.editor.policy.prestressed
        delaunay = flip_to_delaunay(editor, candidates, self.model.points, positions) if prestressed else 0
        slivers = flip_slivers(editor, candidates, positions)
        settle = prestressed and (self._membrane_unsettled or delaunay + slivers > 0)
        if not settle and not delaunay + slivers:
            return  # nothing edited: no version bump, nothing for a background loop to mirror
        if settle:
            editor.settle_membrane(candidates)
            self._membrane_unsettled = False
        report = editor.finish(positions=positions)
        self.totals["sliver_flips"] += slivers
        self.totals["delaunay_flips"] += delaunay
        self._apply(sim, report, positions)
        self._track_made_triangles(report)

    def _retry_holes(self, sim: CutHost) -> None:
        """Fill again the holes a finished incision left open (its fill could find no valid
        triangles where the tissue was, e.g., still moving fast): tried at every cut event."""
        for inc in self.incisions:
            if inc is self.current or not inc.open_chains:
                continue
            self.editor.begin()
            report, result, positions = self._stage3(sim, inc, None, defer_slivers=False)
            self._apply(sim, report, positions)
            self._count(report, result)

    def _reopen_tip(self, sim: CutHost, inc: Incision, x: np.ndarray) -> None:
        """Delete the triangles across the curve beyond the slit's tip (its newest live lip pair,
        or its start): the tissue re-closed there at the previous event, up to the tool. New
        stations (and, once the tool has gone, the end) get their lips there. ``x``: the node
        positions [m] (node_count, 3) the event's Stage 1 read."""
        tip_u = inc.tip_u(self.model.active)
        if inc.length <= tip_u:
            return
        tip, end = inc.point_at([tip_u, inc.length])
        near = self.contact.nodes_near(sim, tip, end, inc.sweep_radius + 2.0 * self.spacing)
        tris = np.array(sorted({t for v in near for t in self.editor.node_triangles[v]}), dtype=np.int64)
        if not len(tris):
            return
        corners = self.model.triangle_table.column("corners")[tris]
        u, side, _ = inc.project(x[corners.reshape(-1)].astype(np.float64))
        u, side = u.reshape(-1, 3), side.reshape(-1, 3)
        _, _, centre_dist = inc.project(x[corners].mean(axis=1).astype(np.float64))
        # across the curve (not only its extension beyond the end), beyond the tip; a triangle
        # joining a left lip to a right lip is across wherever the lips lie (one pushed onto
        # or over the curve still bounds its own side)
        across = (((side.min(axis=1) != side.max(axis=1)) | self._joins_both_lips(inc, corners))
                  & (u.max(axis=1) > tip_u + 1e-9)
                  & (u.min(axis=1) < inc.length - 1e-9) & (centre_dist <= inc.sweep_radius + self.spacing))
        self.editor.delete_triangles(tris[across])

    @staticmethod
    def _joins_both_lips(inc: Incision, corners: np.ndarray) -> np.ndarray:
        """(m,) bool: True for the triangles (corners (m, 3)) holding a left and a right lip
        node of ``inc``."""
        left = np.isin(corners, [v for v in inc.left if v >= 0]).any(axis=1)
        right = np.isin(corners, [v for v in inc.right if v >= 0]).any(axis=1)
        return left & right

    def _positions_view(self, sim: CutHost) -> np.ndarray:
        # zero-copy on the CPU; a copy from a GPU
        return sim.state.positions.numpy()[: self.model.node_count]

    # ----------------------------------------------------------------- one event
    def extend_incision(self, sim: CutHost, point, normal=None) -> None:
        """One cut event: sweep from the incision's last contact point to ``point`` [m] on the
        skin, whose unit outward normal there is ``normal`` (default: the last one) (Stages
        1-3), then mirror the edit on the device."""
        inc = self.current
        if inc is None:
            raise InputError("no incision in progress: call start_incision first")
        point = np.asarray(point, dtype=np.float64)
        if np.linalg.norm(point - inc.path[-1]) < 0.1 * self.spacing:
            return  # the tool has not moved enough to extend the incision
        t0 = time.perf_counter()
        a, normal_then = inc.path[-1], inc.normals[-1] if normal is None else normal
        near = self.contact.nodes_near(sim, a, point, inc.sweep_radius + self.edge_reach)
        x = self._positions_view(sim)
        self.swept_volume.cut(sim, inc, a, point, normal_then, near, x)
        self._reopen_tip(sim, inc, x)  # new stations may fall there
        t1 = time.perf_counter()
        inc.extend(point, min_step=0.0, normal=normal)
        inc.plan_stations(clearance=self._clearance(sim.tool_pose, inc))
        self.contact_path.append(point)
        t2 = time.perf_counter()
        # a sliver may wait a few events for better geometry, not forever
        report, result, positions = self._stage3(sim, inc, point, defer_slivers=inc.deferrals < 3,
                                                 tool=sim.tool_pose)
        t3 = time.perf_counter()
        self._apply(sim, report, positions)
        t4 = time.perf_counter()
        for name, dt in zip(STAGES, (t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
            self.latency_ms[name].append(1e3 * dt)
        self.totals["events"] += 1
        self._count(report, result)

    def _clearance(self, tool: Tool | None, inc: Incision) -> float:
        """How far behind the curve's end [m] a station may be while the tool cuts: past the
        tool's footprint (``_footprint``) by a quarter spacing, and further while the lips of a
        station there would be made inside the tool (a tilted tool pressing the skin down
        reaches beyond its footprint on the flat skin). A station due inside the tool would
        hold back the fill of the whole hole it borders until the tool has gone."""
        clearance = max(0.5 * self.spacing, self._footprint(tool, inc) + 0.25 * self.spacing)
        if tool is None:
            return clearance
        while clearance < inc.length and lips_inside(
                tool, np.array([inc.lip_position(inc.length - clearance, side) for side in (1, -1)])):
            clearance += 0.25 * self.spacing
        return clearance

    @staticmethod
    def _footprint(tool: Tool | None, inc: Incision) -> float:
        """How far behind the axis's crossing the tool reaches along the skin [m]: r / sin(a),
        a the axis's angle to the skin (r without a tool)."""
        if tool is None or not tool.length > 0:
            return inc.sweep_radius
        sin_a = abs(float(np.dot(tool.p1 - tool.p0, inc.normals[-1]))) / tool.length
        return inc.sweep_radius / max(sin_a, 0.25)

    def _stage3(self, sim: CutHost, inc: Incision, point, *, defer_slivers: bool, tool: Tool | None = None):
        """Re-mesh the grey area of the current edit and the holes left open before, finish the
        edit and carry the residual links of deleted nodes. Returns (edit report, fill result,
        positions)."""
        editor = self.editor
        positions = NodePositions(self._positions_view(sim))
        result = {"created": [], "yellow": [], "blue": [], "unfilled": [], "waiting": [], "under_tool": False}
        if editor.report.deleted_triangle_corners or inc.open_chains:
            result = fill_hole(editor, inc, editor.report.deleted_triangle_corners, positions,
                               inc.open_chains, defer_slivers=defer_slivers, tool=tool)
        # a hole waiting for the tool to move on does not count against the sliver deferrals
        inc.deferrals = inc.deferrals + 1 if result["unfilled"] and not result["under_tool"] else 0
        inc.open_chains = result["unfilled"] + result["waiting"]  # retried at the next event
        report = editor.finish(positions=positions)
        reach = inc.sweep_radius + 1.5 * self.spacing
        self.totals["lost_links"] += carry_links(editor, inc, report, positions, reach)
        self.totals["lost_links"] += open_links(editor, inc, positions, reach)
        self.totals["aligned_links"] += align_links(editor, inc, report.residual_links + report.carried_links)
        return report, result, positions

    def _count(self, report, result) -> None:
        tot = self.totals
        tot["deleted_nodes"] += len(report.deleted_nodes) - len(report.removed_fragments)
        tot["deleted_springs"] += len(report.deleted_springs)
        tot["residual_links"] += len(report.residual_links)
        tot["carried_links"] += len(report.carried_links)
        tot["lip_nodes"] += len(result["created"])
        tot["lip_nodes_removed"] += int(np.sum(self.model.node_class[report.deleted_nodes] == NodeClass.LIP))
        tot["new_springs"] += len(report.new_springs)
        tot["removed_fragments"] += len(report.removed_fragments)
        self.unfilled_holes = sum(len(i.open_chains) for i in self.incisions)
        self._track_made_triangles(report)
        self._membrane_unsettled |= bool(report.new_triangles)

    def _track_made_triangles(self, report) -> None:
        """Keep ``new_triangles`` (the live triangles the cut made) up to date with an edit."""
        self.new_triangles.update(report.new_triangles)
        self.new_triangles.difference_update(report.deleted_triangles)

    def _apply(self, sim: CutHost, report, positions: NodePositions) -> None:
        """Tell the host what the edit changed (``ModelChange``), with the new nodes where
        ``positions`` placed them."""
        placed = np.array(report.new_nodes, dtype=np.int64)
        sim.notify_model_changed(self.editor.model_change(
            positions[placed] if len(placed) else np.zeros((0, 3))))

    # ----------------------------------------------------------------- a driver in the step
    def flush(self, sim: CutHost) -> None:
        """Nothing is in flight: every event's edit is applied in its step."""

    def close(self) -> None:
        """Nothing outlives the simulation."""

    def call(self, sim: CutHost, name: str, *args):
        """``name(*args)``, or the attribute ``name`` (as ``BackgroundCutter.call`` asks its worker)."""
        value = getattr(self, name)
        return value(*args) if callable(value) else value

    @property
    def incision_controls(self) -> np.ndarray | None:
        """Control points [m] of the latest incision's Bezier chain, (3 s + 1, 3) for s segments
        (end points shared), or None while there is no incision."""
        curves = [inc.curve for inc in self.incisions if inc.curve is not None]
        return curves[-1].control_points_flat() if curves else None

    # ----------------------------------------------------------------- measures
    def incision_width(self, positions: np.ndarray) -> float:
        """Median distance [m] between the paired lip nodes across the incisions (nan if none).

        Args:
            positions: Current node positions [m], shape (node_count, 3).
        """
        return incision_width(self.incisions, self.model, positions)

    def lip_deviation(self, positions: np.ndarray, in_plane: bool = True) -> float:
        """Largest distance [m] of a lip node from the tool's contact path (see
        ``warp_cut.cut.measures.lip_deviation``)."""
        return lip_deviation(self.incisions, self.model, positions, in_plane=in_plane)

    def coverage(self, positions: np.ndarray) -> float:
        """Fraction of the tool's path in the skin (the contact points of every event, from
        where the blade entered) that the opened incisions cover, within 0.5 spacing."""
        return path_coverage(self.incisions, self.model, positions, 0.5 * self.spacing)

    def metrics(self, positions: np.ndarray) -> dict:
        """The cut's entries of metrics.json: ``cut``, ``incision`` and ``latency_ms``.

        Args:
            positions: Current node positions [m], shape (node_count, 3).
        """
        length = sum(inc.length for inc in self.incisions)
        cut = dict(self.totals)
        cut["incisions"] = len(self.incisions)
        cut["unfilled_holes"] = self.unfilled_holes
        cut["live_residual_links"] = self.model.link_count
        return {
            "cut": cut,
            "incision": {"length_m": length, "max_deviation_m": self.lip_deviation(positions),
                         "max_deviation_3d_m": self.lip_deviation(positions, in_plane=False),
                         "width_m": self.incision_width(positions),
                         "coverage": self.coverage(positions)},
            "latency_ms": self.latency_summary(),
        }

    def live_new_triangles(self) -> np.ndarray:
        """Rows (into ``model.triangles``) of the live triangles this cutter made."""
        table = self.model.triangle_table
        live = table.live_slots()
        return np.flatnonzero(np.isin(live, np.fromiter(self.new_triangles, dtype=np.int64)))

    def latency_summary(self) -> dict:
        """p50 / p99 / max latency per stage [ms] over the cut events."""
        out = {}
        for name, values in self.latency_ms.items():
            v = np.asarray(values)
            out[name] = ({"p50_ms": float(np.percentile(v, 50)), "p99_ms": float(np.percentile(v, 99)),
                          "max_ms": float(v.max()), "events": int(len(v))} if len(v) else None)
        return out

    # ----------------------------------------------------------------- opening profile
    def gap_profile(self, positions: np.ndarray) -> dict:
        """The opening of every incision along its length: one row per interior station whose
        two lip nodes are alive (``warp_cut.cut.measures.gap_profile``).

        Args:
            positions: Current node positions [m], shape (node_count, 3).
        """
        return gap_profile(self.incisions, self.model, positions)
