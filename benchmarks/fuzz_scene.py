"""Named fuzz case (f): a bundled scene run as ``warp-cut run <scene> --set ...`` does, checked
and measured like a fuzz stroke.

The scene's Simulator comes from the scene loader (``warp_cut.scene.load_scene``,
``warp_cut.runner.prepare_simulation``); its tool keyframes are wrapped as a stroke whose ideal
trace is where the tool axis crosses the flat patch (z = 0) while the tip is below it.
"""

from __future__ import annotations

import math

import numpy as np

from warp_cut.mesh.surfaces import on_plane
from warp_cut.runner import prepare_simulation
from warp_cut.scene import load_scene
from warp_cut.verify.stroke_check import run_stroke
from warp_cut.verify.stroke_quality import original_border


class _Path:
    def __init__(self, uv):
        self.uv = uv


class KeyframeStroke:
    """A scene's keyframed tool (``ToolPath``) with the attributes ``run_stroke`` and the
    stroke measures use: pose(t), duration, radius, trace / arclength / path.uv / length."""

    def __init__(self, tool_path, step: float = 1e-3):
        self.tool_path = tool_path
        self.radius = tool_path.radius
        self.duration = float(tool_path.times[-1])
        crossings = []
        for t in np.arange(0.0, self.duration + step, step):
            p0, p1 = tool_path.endpoints_at(t)
            if p0[2] < 0.0 < p1[2]:
                crossings.append(p0 + (-p0[2] / (p1[2] - p0[2])) * (p1 - p0))
        trace = np.array(crossings).reshape(-1, 3)
        keep = np.concatenate([[True], np.linalg.norm(np.diff(trace, axis=0), axis=1) > 1e-9]) \
            if len(trace) else np.zeros(0, bool)
        self.trace = trace[keep]
        self.arclength = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self.trace, axis=0), axis=1))])
        self.path = _Path(self.trace[:, :2])

    @property
    def length(self) -> float:
        return float(self.arclength[-1]) if len(self.arclength) else 0.0

    def pose(self, t: float):
        return self.tool_path.pose_at(t)


def run_scene_case(name: str, overrides: list[str], reproducer: str, scene_name="straight_incision"):
    """One row: the bundled scene with ``overrides``, checked after every edit."""
    scene = load_scene(scene_name, overrides)
    model, sim, path, _ = prepare_simulation(scene)
    surface = on_plane(model.points, model.triangles, scene.tissue.spacing)
    stroke = KeyframeStroke(path)
    result = run_stroke(sim, stroke, surface, border_keys=original_border(model),
                        settle=scene.duration - stroke.duration)
    interval, _ = scene.cutting.event_rule(scene.tissue.spacing)  # None: events by the blade's travel
    axis = path.p1[0] - path.p0[0]
    tilt = math.degrees(math.asin(axis[2] / np.linalg.norm(axis)))  # from the patch's plane
    return [{
        "case": name, "stroke": 0, "kind": "scene", "path": "line", "spacing_mm": 1e3 * surface.spacing,
        "nodes": len(surface.points), "integrator": sim.integrator,
        "interval_ms": "" if interval is None else 1e3 * interval,
        "gravity": True, "length_mm": 1e3 * stroke.length, "tilt_deg": abs(tilt), "radius_mm": 1e3 * stroke.radius,
        "events": result.events, "edits": result.edits, "incisions": result.incisions,
        "unfilled_holes": result.unfilled_holes, "coverage": result.coverage,
        "curve_coverage": result.curve_coverage, "lip_dev_max_mm": 1e3 * result.lip_deviation_max,
        "slivers": result.slivers, "violations": ";".join(f"{k}x{v['events']}" for k, v in result.violations.items()),
        "first_violation": next(iter(result.violations.values()))["first"] if result.violations else "",
        "exception": result.exception or "", "traceback": result.traceback, "skipped": result.skipped,
        "reproducer": f"{reproducer}  (= warp-cut run {scene_name} " + " ".join(f"--set {o}" for o in overrides)
                      + " --no-usd --out /tmp/x)",
        "about": f"bundled scene {scene_name} with " + ", ".join(overrides), "wall_s": float("nan"),
        "_latency": result.latency_ms,
        "_violations": {k: v["first"] for k, v in result.violations.items()},
    }]
