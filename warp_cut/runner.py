"""The run loop of a scene: build, step frame by frame, measure, write outputs atomically."""

from __future__ import annotations

import dataclasses
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from .cut.wound.width_curve import width_curve_metrics
from .errors import InputError, WarpCutError
from .io.files import write_csv, write_json, write_ply
from .io.plots import FinalFrame, write_run_plots
from .io.usd_export import DEFAULT_CHUNK_FRAMES, UsdRecorder
from .mesh.checks import check_mesh
from .mesh.geometry import compact_surface
from .scene import Scene
from .simulator import Simulator
from .ticks import Pacer, TickLog, frozen_gc

__all__ = ["RunResult", "prepare_simulation", "run_scene", "run_to_directory", "record_frame",
           "frame_values", "timeseries_columns", "run_metrics", "final_mesh", "write_outputs",
           "TIMESERIES_COLUMNS", "PROFILE_COLUMNS"]

TIMESERIES_COLUMNS = ["t", "tool_fx", "tool_fy", "tool_fz", "contacts", "kinetic_energy", "tick_max_ms"]
"""Columns of timeseries.csv: time [s], tool force [N], mean nodes in contact, energy [J], the
longest tick (one step) of the frame [ms]."""

PROFILE_COLUMNS = ["incision", "arc_length_m", "gap_m"]
"""Columns of incision_profile.csv (``Cutter.gap_profile`` at the end of a run with cutting):
incision index, arc length along it [m], gap between its lips there [m]."""


@dataclass
class RunResult:
    """What a run measured. metrics: the metrics.json content; columns: name -> (frames,)."""

    metrics: dict
    columns: dict = field(default_factory=dict)
    final_mesh: dict | None = None
    """points (k, 3) [m], triangles (t, 3) and node_class (k,) of the live nodes at the end."""
    profile: dict | None = None
    """The incisions' opening at the end (``Cutter.gap_profile``, PROFILE_COLUMNS), or None
    without cutting."""


def prepare_simulation(scene: Scene, *, cut_in_background: bool = False, max_lag: int | None = None):
    """Build the model and a Simulator whose step divides the frame time exactly (the
    Simulator's own choice of step, shortened to fit: ``Simulator.fit_to_frame``).

    ``cut_in_background``: for a scene that cuts, cut in a worker process
    (``CutSettings(worker=True)``), its events in flight at most ``max_lag`` steps (None: no
    bound).

    Returns (model, simulator, tool_path, steps_per_frame). Raises InputError (bad scene, tool inside tissue).
    """
    model = scene.build_model()
    options = scene.simulator_options()
    if options.get("cutting") is not None and cut_in_background:
        options["cutting"] = dataclasses.replace(options["cutting"], worker=True, max_lag=max_lag)
    sim = Simulator(model, dt=scene.solver.dt, **options)
    try:
        steps_per_frame = sim.fit_to_frame(1.0 / scene.fps)
        path = scene.tool_path()
        if path is not None and scene.physics.collision:
            sim.check_tool_outside(path.pose_at(0.0))
    except BaseException:
        sim.close()
        raise
    return model, sim, path, steps_per_frame


def _progress(total: int, quiet: bool):
    if quiet or not sys.stderr.isatty():
        return None

    return tqdm(total=total, unit="frame", desc="simulating", leave=False)


def run_scene(scene: Scene, *, quiet: bool = True, observers=(), cut_in_background: bool = False,
              pace: float = 1.0, max_lag: int | None = None) -> RunResult:
    """Run a scene to its end.

    Args:
        scene: the validated scene.
        quiet: no progress bar (there is none off a terminal either).
        observers: objects with ``on_frame(sim, frame)``, called after every output frame
            (frame 0 is the initial state), and ``finish(metrics)``, called at the end.
        cut_in_background: for a scene that cuts, run the cut in a worker process
            (``CutSettings(worker=True)``) and pace the loop at real time, one step
            per step dt of wall time, as a haptic device paces it: each edit lands as many
            steps after its event as the worker took, as it would in a live loop. The worker
            is stopped at the end.
        pace: with ``cut_in_background``, steps per step dt of wall time (1: real time; 3: a
            loop three times faster than real time, each tick a third of dt); (0, 1000].
        max_lag: with ``cut_in_background``, steps an event may stay in flight before the loop
            waits for its edit (None: never; 1: each edit lands two steps after its event, so
            the wound is the same run to run whatever the machine's load).

    Returns:
        The metrics, the time series and the final mesh.
    """
    check_pace(pace, cut_in_background)
    if max_lag is not None and not cut_in_background:
        raise InputError(f"max_lag: {max_lag!r} bounds the edits of a cut in the background "
                         "(--cut-in-background); without it every edit lands in its own step")
    background = bool(cut_in_background) and scene.physics.cutting
    model, sim, path, steps_per_frame = prepare_simulation(scene, cut_in_background=background, max_lag=max_lag)
    try:
        series, ticks, wall = _step_frames(scene, sim, path, steps_per_frame, quiet, observers,
                                           Pacer(sim.dt / pace) if background else None)
        if sim.cutter is not None:
            sim.cutter.flush(sim)
        metrics = run_metrics(scene, sim, series, steps=scene.frame_count * steps_per_frame,
                              wall_time=wall, ticks=ticks if path is not None else None)
        for obs in observers:
            obs.finish(metrics)
        profile = sim.cutter.gap_profile(sim.positions) if sim.cutter is not None else None
        return RunResult(metrics, series, final_mesh(sim), profile)
    finally:
        sim.close()


MAX_PACE = 1000.0
"""The fastest pace a run may ask for [steps per step dt of wall time]."""


def check_pace(pace, cut_in_background) -> None:
    """Raise InputError unless ``pace`` is a number in (0, MAX_PACE], and 1 without
    ``cut_in_background`` (only a background cut's run is paced)."""
    if isinstance(pace, bool) or not isinstance(pace, (int, float)) or not 0.0 < pace <= MAX_PACE:
        raise InputError(f"pace: {pace!r} is not a number in (0, {MAX_PACE:g}] (steps per step of wall time)")
    if pace != 1.0 and not cut_in_background:
        raise InputError(f"pace: {pace!r} paces a run that cuts in the background (--cut-in-background); "
                         "without it the run goes as fast as it can")


def _step_frames(scene: Scene, sim: Simulator, path, steps_per_frame: int, quiet: bool, observers,
                 pacer: Pacer | None) -> tuple[dict, TickLog, float]:
    """Step the scene's frames one tick at a time (held to ``pacer`` if given), recording each
    frame; returns (time series, ticks, wall time [s])."""
    frames = scene.frame_count
    series = {c: np.zeros(frames + 1) for c in timeseries_columns(sim)}
    ticks = TickLog(frames * steps_per_frame, budget=sim.dt)
    bar = _progress(frames, quiet)
    try:
        with frozen_gc():
            start = time.perf_counter()  # the loop's wall time: after the one collection before it
            if pacer is not None:
                pacer.start = start  # the pacer's clock starts with the loop's
            for frame in range(frames + 1):
                for _ in range(steps_per_frame if frame else 0):
                    ticks.step(sim, path)  # one step per tick, as a haptic loop calls it
                    if pacer is not None:
                        pacer.wait(ticks.count - 1)
                for obs in observers:
                    obs.on_frame(sim, frame)
                record_frame(series, frame, sim, ticks)
                if bar is not None and frame:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return series, ticks, time.perf_counter() - start


def timeseries_columns(sim: Simulator) -> list[str]:
    """Columns of timeseries.csv for this simulator (the incision width when it cuts)."""
    return TIMESERIES_COLUMNS + (["incision_width_m"] if sim.cutter is not None else [])


def frame_values(sim: Simulator, ticks: TickLog | None = None) -> dict:
    """One row of timeseries.csv from the simulator's state now: column name -> value
    (``tick_max_ms`` from ``ticks``, the frame's ticks; 0 without)."""
    fx, fy, fz = sim.tool_force
    row = {"t": sim.time, "tool_fx": fx, "tool_fy": fy, "tool_fz": fz, "contacts": sim.contacts.count,
           "kinetic_energy": sim.kinetic_energy(),
           "tick_max_ms": ticks.frame_max_ms() if ticks is not None else 0.0}
    if sim.cutter is not None:
        row["incision_width_m"] = sim.cutter.incision_width(sim.positions)
    return row


def record_frame(series: dict, frame: int, sim: Simulator, ticks: TickLog | None = None) -> None:
    """Fill row ``frame`` of the time series (``timeseries_columns``) from the simulator's
    state after that frame (see ``frame_values``)."""
    for name, value in frame_values(sim, ticks).items():
        series[name][frame] = value


def run_metrics(scene: Scene, sim: Simulator, series: dict, *, steps: int,
                wall_time: float, ticks: TickLog | None = None) -> dict:
    """The content of metrics.json for a run of ``scene`` that has reached ``sim.time``.

    Args:
        scene: the scene that was run.
        sim: the simulator at the end of the run.
        series: the time series so far (``record_frame``), name -> (frames + 1,).
        steps: steps taken.
        wall_time: wall-clock time of the stepping [s].
        ticks: the run's ticks (``tick_ms`` and ``tool_force_jump_n`` are added), or None.
    """
    model = sim.model
    metrics = {
        "name": scene.name,
        "scene_file": str(scene.path) if scene.path else None,
        "nodes": model.node_count,
        "springs": model.spring_count,
        "triangles": model.triangle_count,
        "frames": len(series["t"]) - 1,
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
        "first_contact_time_s": sim.contacts.first_time,
        "first_contact_point": sim.contacts.first_point,
        "first_contact_time_exact_s": sim.contacts.first_time_exact,
        "first_contact_point_exact": sim.contacts.first_point_exact,
        "max_tool_force_n": sim.contacts.max_force,
        "finite": True,
        "mesh": mesh_quality(sim),
    }
    if ticks is not None:
        metrics.update(ticks.metrics())
    if sim.cutter is not None:
        x = sim.positions
        metrics.update(sim.cutter.metrics(x))
        gaps = sim.cutter.gap_profile(x)["gap_m"]
        metrics["incision"]["max_gap_m"] = float(gaps.max()) if len(gaps) else None
        metrics["width_curve"] = width_curve_metrics(series["t"], series["incision_width_m"])
    return metrics


def mesh_quality(sim) -> dict:
    """``mesh`` entry of metrics.json: validity, smallest angle, slivers made by the cut."""

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
    live, triangles = compact_surface(model.active, model.triangles)
    return {"points": sim.positions[live], "triangles": triangles,
            "node_class": model.node_class[live].copy()}


def write_outputs(result: RunResult, out_dir) -> list[Path]:
    """Write metrics.json, timeseries.csv, final_mesh.ply and, with cutting,
    incision_profile.csv into out_dir (each atomically)."""
    out = Path(out_dir)
    columns = list(result.columns)
    rows = zip(*(result.columns[c] for c in columns))
    write_csv(out / "timeseries.csv", columns, ([float(v) for v in row] for row in rows))
    written = [out / "timeseries.csv"]
    if result.profile is not None:
        p = result.profile
        write_csv(out / "incision_profile.csv", PROFILE_COLUMNS,
                  ([int(n), float(u), float(g)] for n, u, g in zip(*(p[c] for c in PROFILE_COLUMNS))))
        written.append(out / "incision_profile.csv")
    if result.final_mesh is not None:
        write_ply(out / "final_mesh.ply", **result.final_mesh)
        written.append(out / "final_mesh.ply")
    write_json(out / "metrics.json", result.metrics)
    return written + [out / "metrics.json"]


def run_to_directory(scene: Scene, out_dir, *, usd: bool = True, usd_path=None,
                     usd_chunk: int = DEFAULT_CHUNK_FRAMES, quiet: bool = True,
                     cut_in_background: bool = False, pace: float = 1.0,
                     max_lag: int | None = None) -> tuple[RunResult, list[Path]]:
    """Run ``scene`` and write everything a run writes into ``out_dir``: metrics.json,
    timeseries.csv, final_mesh.ply, incision_profile.csv (with cutting), the pictures and
    (``usd``) the USD playback file.

    What ``warp-cut run`` does, and what each batch worker does. On bad input or an unstable
    simulation nothing is left behind (the USD chunks included) and the error is raised.

    Args:
        scene: the validated scene.
        out_dir: output directory (created if missing).
        usd: write USD; ``usd_path`` chooses the file (default ``OUT/<name>.usdc``) and
            ``usd_chunk`` the frames per chunk file.
        quiet: no progress bar.
        cut_in_background: cut in a worker, the loop paced at real time (``run_scene``).
        pace: with ``cut_in_background``, the pace as a multiple of real time (``run_scene``).
        max_lag: with ``cut_in_background``, steps an event may stay in flight (``run_scene``).

    Returns:
        The run's result and the paths written.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a directory")
    final = FinalFrame()
    recorder = None
    if usd:
        recorder = UsdRecorder(usd_path or out / f"{scene.name}.usdc", scene, chunk_frames=usd_chunk)
    try:
        result = run_scene(scene, quiet=quiet, observers=[final] + ([recorder] if recorder else []),
                           cut_in_background=cut_in_background, pace=pace,
                           max_lag=max_lag)
    except WarpCutError:
        if recorder is not None:  # bad input or unstable: leave nothing behind
            recorder.abort()
        raise
    written = write_outputs(result, out)
    written += write_run_plots(out, result.columns, final.picture, scene.name)
    if recorder is not None:
        written.append(Path(recorder.path))
    return result, written
