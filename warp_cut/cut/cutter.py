"""Cutter: the three-stage cut (paper section 2.3) driven by the tool while the simulation runs.

Once the tool is in contact (and, optionally, pushes harder than a threshold), every
``interval`` seconds a cut event runs:

* the contact point is where the tool axis crosses the tissue's surface plane at the cut;
* Stage 1 - the tool's cross-section circle sweeps a capsule from the previous contact point to
  this one; the nodes inside are deleted with their springs, the springs passing through it are
  deleted (each whose two nodes survive becomes a residual-stress link), and the triangles
  touched form the grey area (Warp kernels find the hits; the edit is host-side);
* Stage 2 - the contact path is refitted with a C1 chain of cubic Bezier segments whose end is
  the tool's contact point;
* Stage 3 - the grey area is re-meshed by shortest-distance node matching (``warp_cut.cut.remesh``).

The incision ends when the tool leaves the surface; the next contact starts a new one.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import warp as wp

from ..errors import InputError
from ..kernels import cutting as cut_kernels
from ..kernels import scatter
from ..kernels.cutting import capsule_node_hits_among, capsule_spring_hits_among
from ..sim.control import Tool
from ..sim.device_model import DeviceModel
from ..sim.model import TissueModel
from ..sim.stability import RowSums, StepLimit
from ..sim.state import State
from .classes import NodeClass
from .incision import Incision, polyline_distance
from .remesh import fill_hole
from .topology import NodePositions, TopologyEditor

__all__ = ["CutSettings", "Cutter", "CutHost", "STAGES"]

STAGES = ("stage1_swept_volume", "stage2_bezier", "stage3_matching", "device_update")
"""Names of the timed parts of a cut event (latency in metrics.json)."""


@dataclass(frozen=True)
class CutSettings:
    """Cutting parameters (SI). None means the documented default.

    sweep_radius: radius of the swept circle [m] (default: the tool radius).
    interval: time between cut events [s] (default 1/60, one per rendered frame).
    force_threshold: cutting starts once |tool force| >= this [N] (default 0: any contact).
    spacing: lip station spacing [m] (default: median spring rest length).
    tolerance: Bezier fit tolerance [m] (default 0.1 x spacing).
    lip_offset: half the initial slit width [m] (default 0.25 x sweep radius).
    """

    sweep_radius: float | None = None
    interval: float = 1.0 / 60.0
    force_threshold: float = 0.0
    spacing: float | None = None
    tolerance: float | None = None
    lip_offset: float | None = None

    def __post_init__(self):
        for name in ("sweep_radius", "spacing", "tolerance", "lip_offset"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"cutting.{name} must be > 0 m, got {v}")
        if not (np.isfinite(self.interval) and self.interval >= 0):
            raise InputError(f"cutting.interval must be >= 0 s, got {self.interval}")
        if not (np.isfinite(self.force_threshold) and self.force_threshold >= 0):
            raise InputError(f"cutting.force_threshold must be >= 0 N, got {self.force_threshold}")


class _Hits:
    """Compact hit lists from the Stage 1 kernels, grown when they overflow."""

    def __init__(self, device):
        self.device = device
        self.buffer = wp.zeros(1024, dtype=wp.int32, device=device)
        self.count = wp.zeros(1, dtype=wp.int32, device=device)

    def run(self, kernel, dim, inputs) -> np.ndarray:
        while True:
            self.count.zero_()
            wp.launch(kernel, dim=dim, device=self.device, inputs=inputs + [self.buffer, self.count])
            n = int(self.count.numpy()[0])
            if n <= self.buffer.shape[0]:
                return self.buffer.numpy()[:n].astype(np.int64)
            self.buffer = wp.zeros(2 * n, dtype=wp.int32, device=self.device)


class CutHost(Protocol):
    """What the Cutter needs from the simulation it cuts; ``warp_cut.Simulator`` provides it.

    Attributes:
        time: Simulated time at the end of the last step [s].
        tool_pose: The tool at the end of the last step, or None.
        collision: Whether the tool touches the tissue at all.
        tool_force: Reaction of the tissue on the tool over the last step [N], shape (3,).
        contact_count: Mean number of nodes in contact per substep over the last step.
        contact_centroid: Mean position of the nodes in contact [m], shape (3,), or None.
        state: The device state; the cut reads ``state.positions``.
        device_model: The device mirror of the model; the cut reads node flags and springs.
    """

    time: float
    tool_pose: Tool | None
    collision: bool
    tool_force: np.ndarray
    contact_count: float
    contact_centroid: np.ndarray | None
    state: State
    device_model: DeviceModel

    def apply_topology_edit(self, new_nodes: np.ndarray, new_positions: np.ndarray,
                            explicit_limit: StepLimit) -> None:
        """Mirror the model's latest edit on the device and update the stable step."""


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
        self.editor = TopologyEditor(model)
        self.row_sums = RowSums(model)
        lengths = model.rest_lengths
        self.spacing = self.settings.spacing or float(np.median(lengths))
        self.incisions: list[Incision] = []
        self.current: Incision | None = None
        self._last_event = -np.inf
        self._hits = _Hits(device)
        self.latency_ms = {name: [] for name in STAGES}
        self.totals = {"deleted_nodes": 0, "deleted_springs": 0, "residual_links": 0,
                       "lip_nodes": 0, "new_springs": 0, "removed_fragments": 0, "events": 0}
        self.new_triangles: set[int] = set()
        self.contact_path: list[np.ndarray] = []
        self.unfilled_holes = 0
        # compile the cut's kernels now, so that no cut event pays for it

        for module in (cut_kernels, scatter):
            wp.load_module(module, device=device)

    # ----------------------------------------------------------------- driving
    def after_step(self, sim: CutHost) -> None:
        """Advance the cut after a simulation step of ``sim``."""
        tool = sim.tool_pose if sim.collision else None
        if tool is None or tool.radius <= 0:
            self.end_incision(sim)
            return
        if sim.time - self._last_event < self.settings.interval - 1e-12:
            return
        self._last_event = sim.time
        if self.current is None:
            pushing = np.linalg.norm(sim.tool_force) >= self.settings.force_threshold
            if sim.contact_count > 0 and pushing and sim.contact_centroid is not None:
                normal = self._surface_normal(sim, sim.contact_centroid)
                point = self._axis_crossing(tool, sim.contact_centroid, normal)
                if point is not None:
                    self.start_incision(sim, point, normal, self.settings.sweep_radius or tool.radius)
            return
        point = self._axis_crossing(tool, self.current.path[0], self.current.normal)
        if point is None:
            self.end_incision(sim)  # the tool left the surface: this incision is complete
            return
        self.extend_incision(sim, point)

    def start_incision(self, sim: CutHost, point, normal, sweep_radius: float) -> Incision:
        """Begin a new incision at ``point`` [m] on the surface with unit ``normal``; the swept
        circle has radius ``sweep_radius`` [m]. (``after_step`` calls this at first contact;
        a haptic loop or a test may call it directly.)"""
        if not (np.isfinite(sweep_radius) and sweep_radius > 0):
            raise InputError(f"sweep radius must be > 0 m, got {sweep_radius}")
        s = self.settings
        self.current = Incision(point, normal, spacing=self.spacing,
                                lip_offset=s.lip_offset or 0.25 * sweep_radius,
                                tolerance=s.tolerance or 0.1 * self.spacing)
        self.current.sweep_radius = float(sweep_radius)
        self.incisions.append(self.current)
        return self.current

    def end_incision(self, sim: CutHost) -> None:
        """Finish the current incision (the next cut starts a new one); a hole still open
        waiting for better geometry is filled now, slivers or not."""
        inc = self.current
        self.current = None
        if inc is not None and inc.open_chains:
            self.editor.begin()
            report, result, positions = self._stage3(sim, inc, None, defer_slivers=False)
            self._apply(sim, report, positions)
            self._count(report, result)

    @staticmethod
    def _axis_crossing(tool: Tool, origin, normal) -> np.ndarray | None:
        """Where the tool axis crosses the plane (origin, normal), or None if it does not."""
        s0 = float(np.dot(tool.p0 - origin, normal))
        s1 = float(np.dot(tool.p1 - origin, normal))
        if s0 * s1 > 0 or s0 == s1:
            return None
        return tool.p0 + (s0 / (s0 - s1)) * (tool.p1 - tool.p0)

    def _surface_normal(self, sim: CutHost, point) -> np.ndarray:
        """Mean unit normal of the triangles around the live node nearest ``point``."""
        model = self.model
        x = self._positions_view(sim)
        live = np.flatnonzero(model.active)
        node = int(live[np.argmin(np.linalg.norm(x[live] - point, axis=1))])
        corners = model.triangle_table.column("corners")
        normal = np.zeros(3)
        for t in self.editor.node_triangles[node]:
            p = x[corners[t]].astype(np.float64)
            normal += np.cross(p[1] - p[0], p[2] - p[0])
        n = np.linalg.norm(normal)
        return normal / n if n > 0 else np.array([0.0, 0.0, 1.0])

    def _index_array(self, idx) -> wp.array:
        return wp.array(np.asarray(idx, dtype=np.int32), dtype=wp.int32, device=self.device)

    def _neighbourhood(self, sim: CutHost, a, b, radius) -> tuple[list[int], list[int]]:
        """Candidate nodes and springs for the swept capsule a-b: the nodes within
        radius + |b - a| + 3 spacings of a, found by walking the mesh outward from the
        incision's anchor node, and the springs at them. The walk costs what the cut touches,
        however large the tissue (the Stage 1 kernels then test only these)."""
        inc, editor, model = self.current, self.editor, self.model
        x = self._positions_view(sim)
        reach = radius + float(np.linalg.norm(np.asarray(b) - a)) + 3.0 * self.spacing
        anchor = inc.anchor
        if anchor < 0 or not model.active[anchor]:
            live = np.flatnonzero(model.active)  # once per incision, or after losing the anchor
            anchor = int(live[np.argmin(np.linalg.norm(x[live] - a, axis=1))])
        pairs = model.spring_table.column("pairs")
        seen, frontier, nodes = {anchor}, [anchor], []
        while frontier:
            v = frontier.pop()
            if np.linalg.norm(x[v] - a) > reach:
                continue
            nodes.append(v)
            for slot in editor.node_springs[v]:
                for u in pairs[slot]:
                    u = int(u)
                    if u not in seen:
                        seen.add(u)
                        frontier.append(u)
        springs = sorted({slot for v in nodes for slot in editor.node_springs[v]})
        return nodes, springs

    def _positions_view(self, sim: CutHost) -> np.ndarray:
        # zero-copy on the CPU; a copy from a GPU
        return sim.state.positions.numpy()[: self.model.node_count]

    # ----------------------------------------------------------------- one event
    def extend_incision(self, sim: CutHost, point) -> None:
        """One cut event: sweep from the incision's last contact point to ``point`` [m]
        (Stages 1-3), then mirror the edit on the device."""

        inc, editor = self.current, self.editor
        if inc is None:
            raise InputError("no incision in progress: call start_incision first")
        point = np.asarray(point, dtype=np.float64)
        r = inc.sweep_radius
        a = inc.path[-1]
        if np.linalg.norm(point - a) < 0.1 * self.spacing:
            return  # the tool has not moved enough to extend the incision
        dm = sim.device_model
        t0 = time.perf_counter()
        near_nodes, near_springs = self._neighbourhood(sim, a, point, r)
        nodes = self._hits.run(capsule_node_hits_among, len(near_nodes), [
            sim.state.positions, dm.node_flags, self._index_array(near_nodes),
            wp.vec3(*a), wp.vec3(*point), float(r)])
        springs = self._hits.run(capsule_spring_hits_among, len(near_springs), [
            sim.state.positions, dm.spring_indices, self._index_array(near_springs),
            wp.vec3(*a), wp.vec3(*point), float(r)])
        editor.begin()
        doomed = set(int(v) for v in nodes)
        if inc.end_node >= 0:
            doomed.add(inc.end_node)  # the slit's end moves on with the tool
            inc.end_node = -1
        own_lips = {n for n in inc.left + inc.right + [inc.start_node] if n >= 0}
        residual = [sl for sl in springs if not (set(self.model.spring_table.column("pairs")[sl]) & own_lips)]
        no_residual = [sl for sl in springs if sl not in set(residual)]
        editor.delete_springs(residual, residual=True, doomed_nodes=doomed)
        editor.delete_springs(no_residual, residual=False)
        editor.delete_nodes(sorted(doomed))
        t1 = time.perf_counter()
        inc.extend(point, min_step=0.0)
        inc.plan_stations()
        self.contact_path.append(point)
        t2 = time.perf_counter()
        # a sliver may wait a few events for better geometry, not forever
        report, result, positions = self._stage3(sim, inc, point, defer_slivers=inc.deferrals < 3)
        t3 = time.perf_counter()
        self._apply(sim, report, positions)
        t4 = time.perf_counter()
        for name, dt in zip(STAGES, (t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
            self.latency_ms[name].append(1e3 * dt)
        self.totals["events"] += 1
        self._count(report, result)

    def _stage3(self, sim: CutHost, inc: Incision, point, *, defer_slivers: bool):
        """Re-mesh the grey area of the current edit and the holes left open before, then
        finish the edit. Returns (edit report, fill result, positions)."""
        editor = self.editor
        positions = NodePositions(self._positions_view(sim))
        result = {"created": [], "yellow": [], "blue": [], "unfilled": []}
        if editor.report.deleted_triangle_corners or inc.open_chains:
            result = fill_hole(editor, inc, editor.report.deleted_triangle_corners, positions,
                               inc.open_chains, defer_slivers=defer_slivers)
        inc.deferrals = inc.deferrals + 1 if result["unfilled"] else 0
        inc.open_chains = result["unfilled"]  # retried at the next event
        report = editor.finish()
        candidates = [v for v in list(report.new_nodes) + sorted(editor.touched_nodes)
                      if self.model.active[v]]
        if candidates and point is not None:
            xs = positions[candidates]
            inc.anchor = int(candidates[int(np.argmin(np.linalg.norm(xs - point, axis=1)))])
        return report, result, positions

    def _count(self, report, result) -> None:
        tot = self.totals
        tot["deleted_nodes"] += len(report.deleted_nodes) - len(report.removed_fragments)
        tot["deleted_springs"] += len(report.deleted_springs)
        tot["residual_links"] += len(report.residual_links)
        tot["lip_nodes"] += len(result["created"])
        tot["new_springs"] += len(report.new_springs)
        tot["removed_fragments"] += len(report.removed_fragments)
        self.unfilled_holes = sum(len(i.open_chains) for i in self.incisions)
        self.new_triangles.update(report.new_triangles)
        self.new_triangles.difference_update(report.deleted_triangles)

    def _apply(self, sim: CutHost, report, positions: NodePositions) -> None:
        """Update the explicit step's limit node by node (rows of the nodes whose springs or
        links changed), then let the host mirror the edit and initialise the new nodes."""
        new = np.array(report.new_nodes, dtype=np.int64)
        changed = set(self.editor.touched_nodes)
        for slot in report.residual_links:
            changed.update(int(v) for v in self.model.link_table.column("pairs")[slot])
        changed |= {int(v) for v in report.deleted_nodes}
        self.row_sums.update(sorted(changed), self.editor, positions)
        sim.apply_topology_edit(new, positions[new] if len(new) else np.zeros((0, 3)),
                                self.row_sums.limit())

    # ----------------------------------------------------------------- measures
    def incision_width(self, positions: np.ndarray) -> float:
        """Median distance [m] between the paired lip nodes across the incisions (nan if none).

        Args:
            positions: Current node positions [m], shape (node_count, 3).
        """
        x = positions
        active = self.model.active
        widths = []
        for inc in self.incisions:
            pairs = inc.pairs()
            if len(pairs):
                pairs = pairs[active[pairs[:, 0]] & active[pairs[:, 1]]]
                widths.extend(np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1).tolist())
        return float(np.median(widths)) if widths else float("nan")

    def lip_deviation(self, positions: np.ndarray, in_plane: bool = True) -> float:
        """Largest distance [m] of a lip node from the tool's contact path (a polyline).

        Args:
            positions: Current node positions [m], shape (node_count, 3).
            in_plane: Measure in the surface plane of each incision (the component along its
                normal removed), i.e. the incision's shape as seen on the skin; else in 3D.
        """
        model = self.model
        lips = np.flatnonzero(model.active & (model.node_class == NodeClass.LIP))
        polylines = [inc for inc in self.incisions if len(inc.path) > 1]
        if not len(lips) or not polylines:
            return float("nan")
        x = np.asarray(positions)[lips].astype(np.float64)
        best = np.full(len(lips), np.inf)
        for inc in polylines:
            poly = np.array(inc.path)
            pts = x
            if in_plane:
                n = inc.normal
                pts = x - np.outer((x - poly[0]) @ n, n)
                poly = poly - np.outer((poly - poly[0]) @ n, n)
            best = np.minimum(best, polyline_distance(pts, poly))
        return float(best.max())

    def metrics(self, positions: np.ndarray) -> dict:
        """The cut's entries of metrics.json: ``cut``, ``incision`` and ``latency_ms``.

        Args:
            positions: Current node positions [m], shape (node_count, 3).
        """
        length = sum(inc.length for inc in self.incisions)
        cut = {k: v for k, v in self.totals.items()}
        cut["incisions"] = len(self.incisions)
        cut["unfilled_holes"] = self.unfilled_holes
        return {
            "cut": cut,
            "incision": {"length_m": length, "max_deviation_m": self.lip_deviation(positions),
                         "max_deviation_3d_m": self.lip_deviation(positions, in_plane=False),
                         "width_m": self.incision_width(positions)},
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
        two lip nodes are alive.

        Args:
            positions: Current node positions [m], shape (node_count, 3).

        Returns:
            ``incision`` (k,) int: index into ``incisions``; ``arc_length_m`` (k,): the
            station's arc length u along the incision's curve [m]; ``gap_m`` (k,): the distance
            between the station's left and right lip nodes [m] (the ``pairs`` whose median is
            ``incision_width``).
        """
        active = self.model.active
        rows = [(n, u, a, b) for n, inc in enumerate(self.incisions)
                for u, a, b in zip(inc.station_u, inc.left, inc.right)
                if a >= 0 and b >= 0 and active[a] and active[b]]
        index = np.array([r[0] for r in rows], dtype=np.int64)
        u = np.array([r[1] for r in rows], dtype=np.float64)
        pairs = np.array([r[2:] for r in rows], dtype=np.int64).reshape(-1, 2)
        x = np.asarray(positions, dtype=np.float64)
        gap = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
        return {"incision": index, "arc_length_m": u, "gap_m": gap}
