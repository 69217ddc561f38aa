"""The run loop of a scene: build, step frame by frame, measure, write outputs atomically."""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .io import write_csv, write_json, write_ply
from .scene import Scene
from .simulator import Simulator
from .solver import INTEGRATORS

__all__ = ["RunResult", "prepare_simulation", "run_scene", "run_metrics", "frame_values",
           "timeseries_columns", "write_outputs", "TIMESERIES_COLUMNS"]

TIMESERIES_COLUMNS = ["t", "tool_fx", "tool_fy", "tool_fz", "contacts", "kinetic_energy"]
"""Columns of timeseries.csv: time [s], tool force [N], mean nodes in contact, energy [J]."""


@dataclass
class RunResult:
    """What a run measured. metrics: the metrics.json content; columns: name -> (frames,)."""

    metrics: dict
    columns: dict = field(default_factory=dict)
    final_mesh: dict | None = None
    """points (k, 3) [m], triangles (t, 3) and node_class (k,) of the live nodes at the end."""


def prepare_simulation(scene: Scene):
    """Build the model and a Simulator whose dt divides the frame time exactly.

    Returns (model, simulator, tool_path, steps_per_frame). Raises InputError (bad scene, tool inside tissue).
    """
    model = scene.build_model()
    frame_dt = 1.0 / scene.fps
    dt = scene.solver["dt"]
    if dt == "auto":
        limit = INTEGRATORS[scene.solver["integrator"]].step_limit(model).step
        target = scene.solver["safety"] * limit if math.isfinite(limit) else frame_dt
        substeps = 1 if scene.solver["substeps"] == "auto" else scene.solver["substeps"]
        target *= substeps
    else:
        target = dt
    steps_per_frame = max(1, math.ceil(frame_dt / target - 1e-9))
    options = scene.simulator_options()
    sim = Simulator(model, dt=frame_dt / steps_per_frame, **options)
    path = scene.tool_path()
    if path is not None and scene.physics["collision"]:
        sim.check_tool_outside(path.pose_at(0.0))
    return model, sim, path, steps_per_frame


def _progress(total: int, quiet: bool):
    if quiet or not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="frame", desc="simulating", leave=False)


def run_scene(scene: Scene, *, quiet: bool = True, observers=()) -> RunResult:
    """Run a scene to its end. ``observers`` get ``on_frame(sim, frame)`` after every output
    frame (frame 0 is the initial state) and ``finish(metrics)`` at the end."""
    _, sim, path, steps_per_frame = prepare_simulation(scene)
    frames = scene.frame_count
    cols = {c: np.zeros(frames + 1) for c in timeseries_columns(sim)}
    bar = _progress(frames, quiet)
    for obs in observers:
        obs.on_frame(sim, 0)
    start = time.perf_counter()
    try:
        for frame in range(frames + 1):
            if frame:
                sim.step(steps_per_frame, tool=path)
                for obs in observers:
                    obs.on_frame(sim, frame)
                if bar is not None:
                    bar.update(1)
            for name, value in frame_values(sim).items():
                cols[name][frame] = value
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - start
    metrics = run_metrics(scene, sim, frames=frames, steps=frames * steps_per_frame,
                          wall_time=wall, columns=cols)
    for obs in observers:
        obs.finish(metrics)
    return RunResult(metrics, cols, final_mesh(sim))


def timeseries_columns(sim) -> list[str]:
    """Columns of timeseries.csv for this Simulator (the incision width when it cuts)."""
    return TIMESERIES_COLUMNS + (["incision_width_m"] if sim.cutter is not None else [])


def frame_values(sim) -> dict:
    """One row of timeseries.csv: column name -> value for the Simulator's current state."""
    fx, fy, fz = sim.tool_force
    row = {"t": sim.time, "tool_fx": fx, "tool_fy": fy, "tool_fz": fz,
           "contacts": sim.contact_count, "kinetic_energy": sim.kinetic_energy()}
    if sim.cutter is not None:
        row["incision_width_m"] = sim.cutter.incision_width()
    return row


def run_metrics(scene: Scene, sim, *, frames: int, steps: int, wall_time: float,
                columns: dict) -> dict:
    """The metrics.json content of a run that ends in ``sim``'s current state.

    Args:
        scene: the Scene run.
        sim: the Simulator at the end of the run.
        frames: output frames after t = 0.
        steps: ``sim.step`` steps taken.
        wall_time: wall time of the simulation loop [s].
        columns: the time series, name -> (frames + 1,) (the width curve is measured on it).
    """
    model = sim.model
    metrics = {
        "name": scene.name,
        "scene_file": str(scene.path) if scene.path else None,
        "nodes": model.node_count,
        "springs": model.spring_count,
        "triangles": model.triangle_count,
        "frames": frames,
        "steps": steps,
        "dt": sim.dt,
        "substeps": sim.substeps,
        "substep_s": sim.substep,
        "stable_step_s": sim.step_limit.step,
        "stable_step_undamped_s": sim.step_limit.undamped_step,
        "integrator": sim.integrator,
        "sim_time_s": sim.time,
        "wall_time_s": wall_time,
        "realtime_factor": sim.time / wall_time if wall_time > 0 else None,
        "first_contact_time_s": sim.first_contact_time,
        "first_contact_point": sim.first_contact_point,
        "first_contact_time_exact_s": sim.first_contact_time_exact,
        "first_contact_point_exact": sim.first_contact_point_exact,
        "max_tool_force_n": sim.max_tool_force,
        "finite": True,
    }
    metrics["mesh"] = mesh_quality(sim)
    if sim.cutter is not None:
        metrics.update(sim.cutter.metrics())
        from .width_curve import width_curve_metrics

        metrics["width_curve"] = width_curve_metrics(columns["t"], columns["incision_width_m"])
    return metrics


def mesh_quality(sim) -> dict:
    """``mesh`` entry of metrics.json: validity, smallest angle, slivers made by the cut."""
    from .mesh_checks import check_mesh

    model = sim.model
    made = sim.cutter.live_new_triangles() if sim.cutter is not None else np.zeros(0, np.int64)
    report = check_mesh(sim.positions, model.triangles, model.springs, active=model.active,
                        masses=model.masses, sliver_triangles=made)
    return {"valid": report.valid, "problems": report.problems[:10],
            "min_angle_deg": report.min_angle_deg, "slivers": report.slivers,
            "triangles": model.triangle_count, "triangles_made_by_cut": int(len(made)),
            "nodes": model.active_node_count}


def final_mesh(sim) -> dict:
    """The live surface at the end: compact node numbering, classes kept."""
    model = sim.model
    live = np.flatnonzero(model.active)
    remap = np.full(model.node_count, -1, dtype=np.int64)
    remap[live] = np.arange(len(live))
    return {"points": sim.positions[live], "triangles": remap[model.triangles],
            "node_class": model.node_class[live].copy()}


def write_outputs(result: RunResult, out_dir) -> list[Path]:
    """Write metrics.json, timeseries.csv and final_mesh.ply into out_dir (each atomically)."""
    out = Path(out_dir)
    columns = list(result.columns)
    rows = zip(*(result.columns[c] for c in columns))
    write_csv(out / "timeseries.csv", columns, ([float(v) for v in row] for row in rows))
    written = [out / "timeseries.csv"]
    if result.final_mesh is not None:
        write_ply(out / "final_mesh.ply", **result.final_mesh)
        written.append(out / "final_mesh.ply")
    write_json(out / "metrics.json", result.metrics)
    return written + [out / "metrics.json"]
