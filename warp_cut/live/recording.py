"""Recording a live run, and saving it as ``warp-cut run`` writes a scene's run.

A frame is recorded every ``steps_per_frame`` steps (frame 0 is the initial state), exactly as
the run loop records output frames: the USD playback (``UsdRecorder``, into a private staging
directory, so memory holds one chunk however long the run) and one time-series row
(``runner.frame_values``). ``save`` writes into an output directory the files of ``warp-cut run``
- metrics.json (``runner.run_metrics``), timeseries.csv, final_mesh.ply, the pictures and
``<name>.usdc`` with ``<name>_clips/`` - each atomically; a later save replaces them.
"""

from __future__ import annotations

import itertools
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.files import atomic_path
from ..io.plots import FinalFrame, write_run_plots
from ..io.usd_export import DEFAULT_CHUNK_FRAMES, UsdRecorder
from ..runner import RunResult, final_mesh, frame_values, run_metrics, timeseries_columns, write_outputs
from ..ticks import TickLog

__all__ = ["LiveRecording"]

_unique = itertools.count()


def _link_or_copy(source: Path, target: Path) -> None:
    """Hard-link ``source`` (a chunk file never rewritten) to ``target``, or copy it."""
    try:
        os.link(source, target)
    except OSError:  # another file system, or links not allowed
        shutil.copyfile(source, target)


def copy_usd_export(source: Path, out: Path) -> Path:
    """Copy the export ``source`` (top-level file and its ``<stem>_clips`` directory) into the
    directory ``out``; the new chunks are in place before the new top-level file names them.
    Returns the copied top-level file."""
    clips, target = source.with_name(f"{source.stem}_clips"), out / source.name
    out.mkdir(parents=True, exist_ok=True)
    tag = f"{os.getpid()}-{next(_unique)}"
    fresh, old = out / f".{clips.name}.new-{tag}", out / f".{clips.name}.old-{tag}"
    placed = out / clips.name
    fresh.mkdir()
    try:
        for f in sorted(clips.iterdir()):
            _link_or_copy(f, fresh / f.name)
        if placed.exists():
            placed.rename(old)
        fresh.rename(placed)
        with atomic_path(target, suffix=target.suffix) as tmp:
            shutil.copyfile(source, tmp)
    finally:
        for leftover in (fresh, old):
            shutil.rmtree(leftover, ignore_errors=True)
    return target


class LiveRecording:
    """Records the frames of a live run of ``scene`` and saves them on request.

    Args:
        scene: the Scene the run was built from (name, fps, the tool's radius).
        sim: the Simulator, recorded now as frame 0.
        steps_per_frame: steps between frames (the frame time over dt).
        chunk_frames: frames per USD chunk file.
    """

    def __init__(self, scene, sim, steps_per_frame: int, *, chunk_frames: int = DEFAULT_CHUNK_FRAMES):
        self.scene = scene
        self.steps_per_frame = int(steps_per_frame)
        self._staging = Path(tempfile.mkdtemp(prefix="warp-cut-live-"))
        self.recorder = UsdRecorder(self._staging / f"{scene.name}.usdc", fps=scene.fps,
                                    tool_radius=scene.tool.radius, chunk_frames=chunk_frames)
        self.columns = {c: [] for c in timeseries_columns(sim)}
        self.ticks = TickLog(1024, budget=sim.dt)
        """The run's ticks (one step each): tick latency and tool-force jumps in metrics.json."""
        self.frame = -1
        """Last frame recorded."""
        self.compute_time = 0.0
        """Wall time spent stepping and recording [s] (what ``warp-cut run`` calls wall_time_s)."""
        self.record(sim)

    def record(self, sim) -> None:
        """Record the Simulator's state as the next frame."""
        self.frame += 1
        self.recorder.on_frame(sim, self.frame)
        for name, value in frame_values(sim, self.ticks).items():
            self.columns[name].append(float(value))

    def save(self, sim, out_dir, extra: dict | None = None) -> list[Path]:
        """Write the run so far into ``out_dir`` (sim must be at the last recorded frame);
        ``extra`` is added to metrics.json as ``live``. Returns the paths written."""
        out = Path(out_dir)
        if out.exists() and not out.is_dir():
            raise InputError(f"save directory {out}: exists and is not a directory")
        self.recorder.flush()
        columns = {c: np.asarray(v, dtype=np.float64) for c, v in self.columns.items()}
        metrics = run_metrics(self.scene, sim, columns, steps=self.frame * self.steps_per_frame,
                              wall_time=self.compute_time, ticks=self.ticks)
        usd = copy_usd_export(self.recorder.path, out)
        metrics.update(usd_file=str(usd), usd_frames=self.recorder.frames_written,
                       usd_write_time_s=self.recorder.write_time)
        if extra is not None:
            metrics["live"] = extra
        final = FinalFrame()
        final.on_frame(sim, self.frame)
        final.finish(metrics)
        profile = sim.cutter.gap_profile(sim.positions) if sim.cutter is not None else None
        written = write_outputs(RunResult(metrics, columns, final_mesh(sim), profile), out)
        written += write_run_plots(out, columns, final.picture, self.scene.name)
        return written + [usd]

    def close(self) -> None:
        """Remove the staging directory (the saved copies stay)."""
        shutil.rmtree(self._staging, ignore_errors=True)
