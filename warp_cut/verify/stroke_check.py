"""Run one stroke through a cutting Simulator, as a user does, checking the tissue after every edit.

``run_stroke`` steps ``sim`` once per ``sim.dt`` with the stroke's pose (``sim.step(tool=pose)``),
runs ``cut_problems`` (``warp_cut.verify.validity``) whenever a cut event or another topology edit
happened in the step, lets the tool go (``tool=None``) for a short settle so the incision ends,
and measures the stroke (``warp_cut.verify.stroke_quality``). An exception inside the stroke is
caught and returned in the result with its traceback, so a fuzz run can go on.
"""

from __future__ import annotations

import math
import traceback
from dataclasses import dataclass, field

import numpy as np

from ..sim.strokes import inside_cylinder
from .stroke_quality import (
    border_loop_count,
    coverage,
    curve_coverage,
    lip_deviation,
    new_rest_edges,
    new_rest_slivers,
    new_slivers,
    original_border,
    skin_at_rest,
    wound_edges,
)
from .validity import cut_problems

__all__ = ["StrokeResult", "run_stroke", "coverage_tolerance"]


@dataclass
class StrokeResult:
    """What one stroke did. Lengths [m], times [ms]; nan where nothing was measured."""

    events: int = 0
    """Cut events during the stroke (``cutter.totals['events']``)."""
    edits: int = 0
    """Topology edits (cut events and incision ends), each followed by the checks."""
    incisions: int = 0
    """Incisions the stroke started (one stroke should make one)."""
    unfilled_holes: int = 0
    """Holes the stroke left open after the tool had left, measured on the mesh: border loops
    it added beyond one per incision (a slit inside the tissue adds one, one that runs off
    the border or into an earlier wound none)."""
    coverage: float = float("nan")
    curve_coverage: float = float("nan")
    lip_deviation_max: float = float("nan")
    lip_deviation_median: float = float("nan")
    lip_nodes: int = 0
    slivers: int = 0
    """Triangles the stroke made under ``SLIVER_DEG`` (10 deg) as the skin lies at its end."""
    min_new_angle_deg: float = float("nan")
    rest_slivers: int = 0
    """Triangles the stroke made under ``MIN_ANGLE_DEG`` (20 deg) in the rest shape: the cut's promise broken."""
    min_new_rest_angle_deg: float = float("nan")
    small_rest_triangles: int = 0
    """Triangles the stroke made with a rest edge under ``SMALL_EDGE`` (0.2) spacings."""
    min_new_rest_edge: float = float("nan")
    """The shortest rest edge of a triangle the stroke made [x spacing]."""
    border_loops_added: int = 0
    latency_ms: list = field(default_factory=list)
    """Host time of each cut event of the stroke [ms] (sum of the Cutter's stages)."""
    violations: dict = field(default_factory=dict)
    """Check name -> {"events": how many checks failed it, "first": message, "t": time [s]}."""
    exception: str | None = None
    """'Type: message' of an exception raised during the stroke, or None."""
    traceback: str = ""
    skipped: str = ""
    """Why the stroke was not run (e.g. its start pose touches the deformed tissue)."""


def coverage_tolerance(spacing: float, radius: float) -> float:
    """The coverage distance [m]: half a mesh spacing plus the lip offset (0.25 tool radius)."""
    return 0.5 * spacing + 0.25 * radius


def _record(result: StrokeResult, problems, t: float) -> None:
    for message in problems:
        name = message.split(":", 1)[0]
        entry = result.violations.setdefault(name, {"events": 0, "first": message[:300], "t": t})
        entry["events"] += 1


def _drive(sim, stroke, surface, result, check: bool, settle: float) -> None:
    """Step through the stroke and the settle, checking after every topology edit."""
    cutter, model = sim.cutter, sim.model
    t0 = sim.time
    pose = lambda t: stroke.pose(t - t0)  # noqa: E731 - the Simulator calls this with its time
    steps = math.ceil(stroke.duration / sim.dt - 1e-9) + 1
    settle_steps = max(1, math.ceil(settle / sim.dt))
    for k in range(steps + settle_steps):
        version, events = model.topology_version, cutter.totals["events"]
        triangles = model.triangle_table.count
        sim.step(tool=pose if k < steps else None)
        result.events += cutter.totals["events"] - events
        if model.topology_version != version:
            result.edits += 1
            if check:
                _record(result, cut_problems(sim, surface, first_new_triangle=triangles), sim.time)


def _measure(sim, stroke, surface, result, before: dict, border_keys) -> None:
    cutter, model = sim.cutter, sim.model
    result.incisions = len(cutter.incisions) - before["incisions"]
    mine = cutter.incisions[before["incisions"]:]
    tol = coverage_tolerance(surface.spacing, stroke.radius)
    result.coverage = coverage(stroke, surface, model.points, wound_edges(model, border_keys), tol,
                               skin_at_rest(model, surface), before["skin"])
    result.curve_coverage = curve_coverage(stroke, surface, [np.array(i.path) for i in mine], tol)
    result.lip_deviation_max, result.lip_deviation_median, result.lip_nodes = lip_deviation(
        stroke, model, before["nodes"])
    result.slivers, result.min_new_angle_deg = new_slivers(model, sim.positions, before["triangles"])
    result.rest_slivers, result.min_new_rest_angle_deg = new_rest_slivers(model, before["triangles"])
    result.small_rest_triangles, result.min_new_rest_edge = new_rest_edges(model, before["triangles"],
                                                                          surface.spacing)
    result.border_loops_added = border_loop_count(model) - before["loops"]
    result.unfilled_holes = max(0, result.border_loops_added - result.incisions)
    result.latency_ms = cutter.event_latency_ms()[before["latency"]:].tolist()


def run_stroke(sim, stroke, surface, *, border_keys=None, check: bool = True,
               settle: float = 0.02) -> StrokeResult:
    """Cut ``stroke`` into ``sim`` (a Simulator with cutting on ``TissueModel.from_surface(surface)``).

    border_keys: the tissue's original border edges (``original_border(model)`` before any
    cut; default: taken now). check: run the invariants after every edit. settle: time [s]
    with the tool away after the stroke (the incision ends then).
    """
    model, cutter = sim.model, sim.cutter
    border_keys = original_border(model) if border_keys is None else border_keys
    result = StrokeResult()
    live = np.flatnonzero(model.active)
    start = stroke.pose(0.0)
    if inside_cylinder(sim.positions[live], start.p0, start.p1, start.radius).any():
        result.skipped = "the start pose touches the (deformed) tissue"
        return result
    before = {"incisions": len(cutter.incisions), "nodes": model.node_count,
              "triangles": model.triangle_table.count, "loops": border_loop_count(model),
              "latency": len(next(iter(cutter.latency_ms.values()))), "skin": skin_at_rest(model, surface)}
    try:
        _drive(sim, stroke, surface, result, check, settle)
    except Exception as exc:  # recorded with its traceback: one failing case must not stop a fuzz run
        result.exception = f"{type(exc).__name__}: {exc}"
        result.traceback = "".join(traceback.format_exception(exc)[-6:])
    try:
        _measure(sim, stroke, surface, result, before, border_keys)
    except Exception as exc:  # the tissue may be broken after an exception; keep what we have
        if result.exception is None:
            result.exception = f"measure {type(exc).__name__}: {exc}"
            result.traceback = "".join(traceback.format_exception(exc)[-6:])
    return result
