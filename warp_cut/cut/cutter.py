"""Cutter: the three-stage cut (paper section 2.3), decided in the rest (material) shape.

The blade meets the skin where it lies now; the cut changes the material. Each time the tool's
tip has travelled a set fraction of the lip spacing (``CutSettings.travel``; or every
``interval`` seconds, on a clock) while the tool's axis crosses the skin (and, optionally, the
tool pushes harder than a threshold) a cut event runs:

* where the blade is: the crossing of the tool's axis with the current skin around it, with
  the skin's normal there (``warp_cut.cut.contact.surface``), carried into the rest shape by the
  tissue round it (``BladeContact.material``, ``warp_cut.cut.contact.material_point``); a crossing
  over an opening (an earlier wound) waits for the skin beyond it;
* Stage 2 - the rest points of the crossings are fitted with a chain of cubic Bezier
  segments (``warp_cut.cut.curve.incision``);
* Stages 1 and 3 - the piece of rest curve cut since the last event sweeps a band whose nodes
  are deleted, and the region round it is re-meshed with the slit in it, every triangle at
  least 20 degrees in the rest shape (``warp_cut.cut.remesh.cut_piece``); the tissue's springs the curve
  crosses leave their residual links (``warp_cut.cut.wound.links``); a piece the slit cuts free
  is removed (``warp_cut.cut.wound.islands``).

An incision starts where the axis first crossed the skin (found among the tool's poses since
the previous event, so neither a thin tool slipping between nodes nor the event interval
delays it) and ends when the tool leaves the skin - lifted out, or moved off the tissue -
and only then: one stroke is one incision. Its slit is open up to the blade at every event:
nothing waits for the tool to leave.
"""

from __future__ import annotations

import time
from functools import partial

import numpy as np
import warp as wp

from ..errors import InputError
from ..kernels import cutting as cut_kernels
from ..kernels import scatter
from ..mesh.checks import cuttable_problems
from ..mesh.triangulate import border_loop_count
from ..sim.control import Tool
from ..sim.model import TissueModel
from ..sim.slots import member
from ..sim.strokes import inside_cylinder
from .contact.contact import BladeContact, HitLists
from .contact.material_point import MaterialPoint
from .contact.surface import Crossing
from .curve.incision import Incision
from .events import EventClock
from .host import CutHost
from .remesh.cut_piece import PieceCut, Refusal, SlitDoesNotFit, cut_piece
from .remesh.flips import flip_to_delaunay
from .settings import CutSettings
from .sweep.piece import Piece, goes_back, piece_to_cut, without_necks
from .sweep.tissue_at_rest import joined_start, rest_point_on_tissue
from .tally import CutTally
from .tolerances import EXIT_ADVANCE, FLAP_AREA, FLAP_TRIANGLES, MIN_ADVANCE, SCRAP_AREA, SCRAP_TRIANGLES
from .topology import NodePositions, TopologyEditor
from .wound.islands import Freed, FreedPieces
from .wound.links import OriginalSprings, carry_links, link_crossed_springs, settle_pending_links
from .wound.measures import gap_profile, incision_width, lip_deviation, path_coverage

__all__ = ["Cutter"]

END_TRIES = 4
"""Tries to cut an ended incision's slit to its end, each a quarter spacing shorter (a fill that
does not lay the whole slit is refused: ``SlitDoesNotFit``)."""


class Cutter:
    """Cuts a TissueModel while a simulation of it runs.

    The simulation calls ``after_step(host)`` after every step (``Simulator(cutting=...)``
    registers it as a post-step hook); ``start_incision``, ``extend_incision`` and
    ``end_incision`` drive a cut directly. Every call gets the ``CutHost`` it acts on; the
    Cutter keeps the model's topology editor and the incisions, nothing of the host.

    Args:
        model: The tissue to cut (edited in place through a ``TopologyEditor``).
        settings: Cutting parameters (default ``CutSettings()``).
        device: Warp device of the cut's kernels.
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
        self.spacing = self.settings.lip_spacing(model.rest_lengths)
        self.contact = BladeContact(model, HitLists(device), self.spacing)
        self.originals = OriginalSprings(model) if self.editor.policy.makes_links else None
        """The tissue's springs as built (the paper's links model: each one a curve crosses
        leaves a link)."""
        self.incisions: list[Incision] = []
        self.current: Incision | None = None
        self._clock = EventClock()
        self._poses: list[Tool] = []
        """Tool poses of the steps since the last cut event (where the blade entered)."""
        self._tip_before: np.ndarray | None = None
        """The tool's tip at the last cut event [m] (None: no tool then)."""
        self._linked: set[int] = set()
        """The tissue's springs a cut has linked (once, however many incisions cross one)."""
        self.tally = CutTally()
        """What the events counted and how long they took."""
        self.totals, self.skipped, self.latency_ms = self.tally.totals, self.tally.skipped, self.tally.latency_ms
        """The tally's counts (metrics.json's ``cut``), refusals by reason, and stage times [ms]."""
        self.new_triangles: set[int] = set()
        """Live triangles the cut made (slots)."""
        self.freed = FreedPieces(self.editor, SCRAP_AREA * self.spacing**2, SCRAP_TRIANGLES, self.settings.keep_islands,
                                 FLAP_AREA * self.spacing**2, FLAP_TRIANGLES)
        """Removes the scraps, flaps and islands an edit leaves (a scrap holding the newest lip
        pair of the incision being cut waits: its next event closes onto it; a flap holding a
        node of its slit waits for its end)."""
        self._loops_before = border_loop_count(model.triangles)
        for module in (cut_kernels, scatter):  # compiled now, so no cut event pays for it
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
        tip = tool.p0 if cutting else None
        if not self._clock.due(sim.time, sim.dt, tip, *self.settings.event_rule(self.spacing)) or not cutting:
            return
        poses, self._poses = self._poses, []
        tip_before, self._tip_before = self._tip_before, tool.p0
        if self.current is None:
            if not self.contact.drawn_out(self.incisions, poses, tip_before):
                self._start_where_the_blade_entered(sim, poses)
            return
        self._follow(sim, tool, poses)

    def _follow(self, sim: CutHost, tool: Tool, poses: list[Tool]) -> None:
        """One event of the incision in progress: extend it to where the blade is now, wait
        (over an opening, just above the skin), or end it (the tool has left the skin). Once
        the blade is out of the skin, the incision reaches where it last crossed it among
        ``poses``, the steps' tool poses since the last event."""
        contact = self.contact
        crossing, skin = contact.contact(sim, tool, self._positions_view(sim))
        if crossing is None and (contact.in_own_opening(self.current, tool)
                                 or contact.through_an_opening(self.current, tool, skin)):
            return  # no skin around the axis, but the blade is still down in the tissue: wait
        if crossing is not None and crossing.inside:
            self._extend(sim, crossing, tool)
            return
        self._follow_to_exit(sim, poses[:-1])  # the blade has come out of the skin since the last event
        if crossing is None or crossing.tip_height > contact.exit_margin:
            self.end_incision(sim)  # the tool has left the skin: this incision is complete

    def _follow_to_exit(self, sim: CutHost, poses: list[Tool]) -> None:
        """Carry the incision's path on to the last of ``poses`` whose blade was in the skin:
        events come a travel apart, so the blade may have cut up to that much further before it
        left (``end_incision`` then cuts it)."""
        if not poses:
            return
        x = self._positions_view(sim)
        nodes, _, corners = self.contact.skin_near(sim, poses[-1], x)
        found = self.contact.last_crossing(poses, x[nodes], self.model.points[nodes], corners)
        point = None if found is None else self._point_ahead(sim, *found, least=EXIT_ADVANCE)
        if point is not None:
            self._extend_path(point, found[0])

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
        nodes, _, corners = self.contact.skin_near(sim, tool, x)
        rest = self.model.points[nodes]
        now = self.contact.locate(tool, x[nodes], rest, corners)
        if not self.contact.can_start(sim, tool, now):
            return
        entry, entry_tool = now, tool
        if self.settings.force_threshold == 0.0:
            found = self.contact.first_crossing(sim, poses, x[nodes], rest, corners)
            if found is not None:
                entry, entry_tool = found
        start = self.contact.material(sim, x, entry, entry_tool)
        if start is None:
            return
        self._begin(start, entry, self.settings.sweep_radius or tool.radius)
        self._extend(sim, now, tool)

    def start_incision(self, sim: CutHost, point, normal, sweep_radius: float) -> Incision:
        """Begin a new incision at ``point`` [m] on the skin as it lies now, with unit outward
        ``normal`` there; the swept circle has radius ``sweep_radius`` [m]. (``after_step``
        calls this where the blade entered; a haptic loop or a test may call it directly.) A
        point beside the skin (over an opening, or beyond the tissue's edge) starts the
        incision there, carried into the rest shape by the tissue nearest it: the slit then
        opens from that opening's border once the blade is in the tissue.

        Raises:
            InputError: A bad radius, or no tissue node within 2.5 spacings of ``point``.
        """
        if not (np.isfinite(sweep_radius) and sweep_radius > 0):
            raise InputError(f"sweep radius must be > 0 m, got {sweep_radius}")
        crossing = _crossing_at(point, normal)
        start = self.contact.material(sim, self._positions_view(sim), crossing, None, reach=np.inf)
        if start is None:
            raise InputError(f"the incision's start {np.asarray(point).tolist()} is not near the skin "
                             f"(no tissue node within {2.5 * self.spacing:.3g} m of it)")
        self.end_incision(sim)
        return self._begin(start, crossing, sweep_radius)

    def _begin(self, start: MaterialPoint, crossing: Crossing, sweep_radius: float) -> Incision:
        """A new incision from the material point ``start`` (the blade's ``crossing`` there)."""
        s = self.settings
        rest, entry = self._joined_start(start.rest, sweep_radius)
        inc = Incision(rest, start.normal, spacing=self.spacing,
                       lip_offset=s.lip_offset or 0.25 * sweep_radius, tolerance=s.tolerance or 0.1 * self.spacing,
                       contact_point=crossing.point, contact_normal=crossing.normal)
        inc.sweep_radius = float(sweep_radius)
        inc.entry = entry
        inc.starts_on_tissue = rest_point_on_tissue(self.model, rest, self.spacing)
        self.incisions.append(inc)
        self.current = inc
        return inc

    def end_incision(self, sim: CutHost) -> None:
        """Finish the current incision (the next cut starts a new one): its waiting links go to
        the nearest lip pairs, and in a prestressed sheet the cut's edges are made Delaunay in
        the rest shape and its springs take the sheet's modulus."""
        inc, self.current = self.current, None
        if inc is None or len(inc.path) < 2:
            return
        now = time.perf_counter()
        for back in range(END_TRIES):  # the tool has gone: up to the end, or as near it as fits
            if self._cut(sim, inc, None, inc.length - back * MIN_ADVANCE * self.spacing, (now, now, now),
                         final=True):
                break
        self.editor.begin()
        settle_pending_links(self.editor, inc, reach=np.inf)
        freed = self.freed.at_incision_end()  # no event closes onto them now
        self._count_freed(freed)
        flips = self._settle_prestressed(sim)
        if not (self.editor.report.residual_links or flips or freed.scraps or freed.flaps
                or self.editor.policy.prestressed):
            return
        self.totals["delaunay_flips"] += flips
        positions = NodePositions(self._positions_view(sim))
        report = self.editor.finish(positions=positions)
        self.totals["residual_links"] += len(report.residual_links)
        self._apply(sim, report, positions)

    def _settle_prestressed(self, sim: CutHost) -> int:
        """In a prestressed sheet, flip the cut's edges to Delaunay in the rest shape and give its
        springs the sheet's modulus (part of an edit begun); the flips made."""
        if not self.editor.policy.prestressed or not self.new_triangles:
            return 0
        candidates = {t for t in self.new_triangles if self.model.triangle_table.alive[t]}
        flips = flip_to_delaunay(self.editor, candidates, self.model.points, NodePositions(self._positions_view(sim)))
        self.editor.settle_membrane(candidates)
        return flips

    def _positions_view(self, sim: CutHost) -> np.ndarray:
        # zero-copy on the CPU; a copy from a GPU
        return sim.state.positions.numpy()[: self.model.node_count]

    # ----------------------------------------------------------------- one event
    def extend_incision(self, sim: CutHost, point, normal=None) -> None:
        """One cut event: cut from the incision's last crossing to ``point`` [m] on the skin as
        it lies now, whose unit outward normal there is ``normal`` (default: the last one), then
        mirror the edit on the device."""
        if self.current is None:
            raise InputError("no incision in progress: call start_incision first")
        normal = self.current.contact_normals[-1] if normal is None else normal
        self._extend(sim, _crossing_at(point, normal), None)

    def _extend(self, sim: CutHost, crossing: Crossing, tool: Tool | None) -> None:
        """Extend the current incision to the blade's ``crossing`` and cut the new piece."""
        t0 = time.perf_counter()
        point = self._point_ahead(sim, crossing, tool)
        if point is None:
            return
        t1 = time.perf_counter()
        inc = self.current
        self._extend_path(point, crossing)
        t2 = time.perf_counter()
        self._cut(sim, inc, tool, inc.length - self._behind_the_blade(inc, tool), (t0, t1, t2))

    def _point_ahead(self, sim: CutHost, crossing: Crossing, tool: Tool | None,
                     least: float = MIN_ADVANCE) -> MaterialPoint | None:
        """The material point of the blade's ``crossing`` if the current incision goes on to it;
        None (wait) over an opening, when the blade has not moved on enough, or when it is back
        over what is cut. A lowered tool's incision turns back here first (``turn_back``)."""
        inc = self.current
        point = self.contact.material(sim, self._positions_view(sim), crossing, tool)
        if point is None or np.linalg.norm(point.rest - inc.path[-1]) < least * self.spacing:
            return None  # over an opening, or the blade has not moved on enough: wait
        if inc.turns_back(point.rest):  # a tool lowered with its axis tilted, now travelling
            inc.turn_back()
            rest, inc.entry = self._joined_start(inc.path[0], inc.sweep_radius)
            inc.start_at(rest)
            inc.starts_on_tissue = rest_point_on_tissue(self.model, inc.path[0], self.spacing)
        if inc.retraces(point.rest, inc.sweep_radius):
            return None  # back over what is cut (a bouncing skin under a tilted blade)
        if inc.entry is not None:
            self._keep_or_undo_join(inc, point.rest)
        return point

    def _joined_start(self, entry: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray | None]:
        """Where an incision the blade entered at the rest point ``entry`` [m] starts
        (``joined_start``: in an earlier wound its swept disc of ``radius`` [m] reaches), and the
        entry to remember while the blade's travel may still undo that move (None: not moved)."""
        rest = joined_start(self.model, self.incisions, entry, radius)
        return rest, None if np.array_equal(rest, entry) else np.asarray(entry, dtype=np.float64).copy()

    def _keep_or_undo_join(self, inc: Incision, rest: np.ndarray) -> None:
        """Once the blade has travelled ``MIN_ADVANCE`` spacings from where it entered, keep a
        start moved into an earlier wound (``joined_start``) only if the blade travels away from
        that wound (a T's stem). A wound ahead is one the stroke will cross: starting in it ran
        the path from the wound back to the entry and on again, a hairpin nothing could be cut
        along, so the incision starts where the blade entered. Nothing is cut until then
        (``_cut``)."""
        travel = rest - inc.entry
        if np.linalg.norm(travel) < MIN_ADVANCE * self.spacing:
            return
        if np.dot(inc.path[0] - inc.entry, travel) > 0:
            inc.restart_at(inc.entry, MIN_ADVANCE * self.spacing)
            inc.starts_on_tissue = rest_point_on_tissue(self.model, inc.path[0], self.spacing)
        inc.entry = None

    def _extend_path(self, point: MaterialPoint, crossing: Crossing) -> None:
        """Extend the current incision's path (and refit its curve) to the material ``point`` of
        the blade's ``crossing``, keeping where the skin was there."""
        self.current.extend(point.rest, 0.0, point.normal, contact_point=crossing.point,
                            contact_normal=crossing.normal)

    def _behind_the_blade(self, inc: Incision, tool: Tool | None) -> float:
        """How far behind the blade's crossing [m] the slit's tip stays while the tool cuts: its
        footprint on the skin (r / sin of the axis' angle to it) and a quarter spacing, further
        while the tip would lie in the tool (a node made inside the tool would be pushed out at
        once: a jolt in the force it feeds back). 0 without a tool."""
        if tool is None or not tool.length > 0:
            return 0.0
        normal = inc.contact_normals[-1]
        sin_a = abs(float(np.dot(tool.p1 - tool.p0, normal))) / tool.length
        behind = inc.sweep_radius / max(sin_a, 0.25) + 0.25 * self.spacing
        crossing, rest_end = inc.contact_path[-1], inc.path[-1]
        while behind < inc.length:  # the tip where the tissue now lies, carried with the crossing
            tip = crossing + inc.point_at(inc.length - behind)[0] - rest_end
            if not inside_cylinder(tip[None], tool.p0, tool.p1, tool.radius)[0]:
                break
            behind += 0.25 * self.spacing
        return behind

    def _cut(self, sim: CutHost, inc: Incision, tool: Tool | None, upto: float, times: tuple,
             final: bool = False) -> bool:
        """Cut the piece of ``inc``'s curve from its last cut to arc length ``upto`` [m] (Stages 1
        and 3), its links and any island, then mirror the edit; ``times`` (perf_counter at the
        event's start, after locating, after the curve) for the latency; ``final``: the
        incision's last cut (nothing waits for a later event). False if nothing was cut (too
        short a piece, a slit that does not fit, a joined start the blade's travel has not yet
        kept or undone: the next event tries again)."""
        nodes_near = partial(self.contact.nodes_near_at_rest, sim)
        piece = piece_to_cut(self.model, nodes_near, inc, tool, upto, final)
        if piece is None:
            return False
        positions = NodePositions(self._positions_view(sim))
        self.editor.begin()
        t3 = time.perf_counter()
        cut = self._cut_piece(inc, piece, positions, tool)
        if isinstance(cut, Refusal) and goes_back(self.model, inc):  # once more from the cut point
            again = piece_to_cut(self.model, nodes_near, inc, tool, upto, final, from_cut_point=True)
            if again is not None:
                piece, cut = again, self._cut_piece(inc, again, positions, tool)
        if isinstance(cut, Refusal):
            self.tally.refused(cut)
            return False
        t4 = time.perf_counter()
        report = self._finish_edit(inc, piece, cut, positions, final)
        t5 = time.perf_counter()
        self._apply(sim, report, positions)
        t6 = time.perf_counter()
        self.tally.edit(report, cut)
        if cut.met_border and self.current is not None:  # not at an ended incision's last cut
            self.current.reached_border = True
        self.tally.times((*times, t3, t4, t5, t6))
        return True

    def _cut_piece(self, inc: Incision, piece: Piece, positions: NodePositions,
                   tool: Tool | None) -> PieceCut | Refusal:
        """Stages 1 and 3 on ``piece`` (``cut_piece.cut_piece``, in the edit begun); why not, if
        its slit does not fit (nothing was edited then)."""
        try:
            return self._remesh(inc, piece, positions, tool)
        except SlitDoesNotFit as why:
            if not (piece.on_tissue & ~piece.necks).any():
                inc.cut_point = piece.points[-1].copy()  # only a strip beside an opening or a neck: it does not fit
            return why.reason

    def _remesh(self, inc: Incision, piece: Piece, positions: NodePositions, tool: Tool | None) -> PieceCut:
        """``cut_piece.cut_piece`` on ``piece``; where its slit does not fit and the piece crosses a
        neck of tissue, once more with the neck left as it was (``piece.without_necks``)."""
        first = not inc.station_u and inc.tip_node < 0

        def cut(p: Piece) -> PieceCut:
            return cut_piece(self.editor, inc, p.u, p.on_tissue, p.near, positions, tool=tool, first=first,
                             beside=p.beside)

        try:
            return cut(piece)
        except SlitDoesNotFit:
            if not piece.necks.any():
                raise
        return cut(without_necks(self.model, inc, piece))

    def _finish_edit(self, inc: Incision, piece: Piece, cut: PieceCut, positions: NodePositions, final: bool):
        """After the re-mesh: the cut point moves to the piece's end, the springs the piece
        crossed get their links, nodes pinched apart are split, scraps and the islands cut free
        go, the edit is finished and the residual links carried to the nodes that take them.
        Returns the editor's report of the edit."""
        editor = self.editor
        inc.cut_point = piece.points[-1].copy()
        self._wound_links(inc, piece.points, cut)
        split = editor.split_pinched_nodes(editor.touched_nodes, positions)
        cut.inserted += split
        cut.met_border |= bool(split)  # a node split apart may be all that held a piece
        self._free_islands(set() if final else self._newest_lips(inc), set() if final else inc.slit_nodes)
        report = editor.finish(positions=positions)
        takers = cut.lips + cut.inserted + list(editor.touched_nodes)
        self.totals["lost_links"] += carry_links(editor, inc, report, takers, reach=2.0 * self.spacing)
        return editor.report

    def _wound_links(self, inc: Incision, piece: np.ndarray, cut: PieceCut) -> None:
        """The links of the tissue's springs ``piece`` crosses (the paper's links model)."""
        if self.originals is not None:
            link_crossed_springs(self.editor, inc, self.originals, piece, self._linked)

    def _free_islands(self, keep: set[int], slit: set[int]) -> None:
        """Remove the scraps this event trimmed off (but those holding a node of ``keep``), the
        flaps it left (but those holding a node of ``slit``, the incision's, till its end) and
        the pieces of skin it cut free (unless the settings keep them)."""
        self._count_freed(self.freed.after_edit(keep, slit))

    def _count_freed(self, freed: Freed) -> None:
        """Add what ``FreedPieces`` removed to the totals."""
        self.totals["removed_scraps"] += freed.scraps
        self.totals["removed_flaps"] += freed.flaps
        self.totals["removed_islands"] += freed.islands

    def _newest_lips(self, inc: Incision) -> set[int]:
        """The two lip nodes of ``inc``'s newest lip pair (none if it has none)."""
        k = inc.last_pair(self.model.active)
        return {inc.left[k], inc.right[k]} if k >= 0 else set()

    def _apply(self, sim: CutHost, report, positions: NodePositions) -> None:
        """Keep ``new_triangles`` up to date and tell the host what the edit changed
        (``ModelChange``), the new nodes where ``positions`` placed them."""
        self.new_triangles.update(report.new_triangles)
        self.new_triangles.difference_update(report.deleted_triangles)
        placed = np.array(report.new_nodes, dtype=np.int64)
        sim.notify_model_changed(self.editor.model_change(positions[placed] if len(placed) else np.zeros((0, 3))))

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
        """Control points [m] of the latest incision's Bezier chain in the rest shape,
        (3 s + 1, 3) for s segments (end points shared), or None while there is no incision."""
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
        ``warp_cut.cut.wound.measures.lip_deviation``)."""
        return lip_deviation(self.incisions, self.model, positions, in_plane=in_plane)

    @property
    def unfilled_holes(self) -> int:
        """Holes in the tissue, measured on the mesh: its border loops beyond those it had
        before the first cut and one per incision (a slit inside the tissue adds one; one that
        runs off the border or into an earlier wound adds none)."""
        return max(0, border_loop_count(self.model.triangles) - self._loops_before - len(self.incisions))

    def coverage(self, positions: np.ndarray) -> float:
        """Fraction of the blade's path in the rest shape (its crossings, from where it entered)
        that the opened incisions cover, within 0.5 spacing."""
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
        live = self.model.triangle_table.live_slots()
        return np.flatnonzero(member(live, np.fromiter(self.new_triangles, dtype=np.int64)))

    def event_latency_ms(self) -> np.ndarray:
        """Each cut event's whole time [ms] (events,): the sum of its stages (``tally.STAGES``)."""
        return self.tally.event_latency_ms()

    def latency_summary(self) -> dict:
        """p50 / p99 / max latency per stage [ms] over the cut events."""
        return self.tally.latency_summary()

    def gap_profile(self, positions: np.ndarray) -> dict:
        """The opening of every incision along its length: one row per station whose two lip
        nodes are alive (``warp_cut.cut.wound.measures.gap_profile``).

        Args:
            positions: Current node positions [m], shape (node_count, 3).
        """
        return gap_profile(self.incisions, self.model, positions)


def _crossing_at(point, normal) -> Crossing:
    """A crossing at ``point`` [m] with unit outward ``normal`` (the direct API's)."""
    n = np.asarray(normal, dtype=np.float64)
    return Crossing(np.asarray(point, dtype=np.float64), n / np.linalg.norm(n), float("nan"), True)

