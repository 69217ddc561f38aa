"""LiveCut: an interactive cutting run, driven by the user as it goes, with no display of its own.

The run is a scene's simulation (``runner.prepare_simulation``) stepped in steps of the scene's
dt (1 ms, a haptic device's period) towards a tool pose the user moves (``scalpel``), in real
time on a thread of its own (``start``) or as fast as asked (``advance``, for tests and
benchmarks). A viewer reads ``view_frame()`` and ``status()`` and sends commands; commands that
change the simulation run on its thread, between steps:

* ``set_target`` / ``set_depth`` / ``nudge``: where the scalpel should go (it follows at a
  bounded speed, ``set_speed``);
* ``set_cutting``: cutting off ends the incision in progress and starts no new one (the tool
  still presses the tissue); on, the next contact starts an incision;
* ``set_paused``; ``reset``: the scene's tissue and tool anew;
* ``set_parameters``: K, D, residual strain, tool radius, gravity; the simulation is rebuilt from
  the scene with these as overrides (a rebuild starts the tissue, the tool and the recording
  anew: these are properties of the model, compiled into its kernels and its stable step);
* ``save``: the run so far (since the last rebuild) as ``warp-cut run`` writes it.

Frames are recorded every ``steps_per_frame`` steps for the saved run (``recording``); the
scene's fps is adjusted so that a frame is a whole number of steps.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import math
import queue
import sys
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, WarpCutError
from ..io.usd_export import DEFAULT_CHUNK_FRAMES
from ..runner import prepare_simulation
from ..scene import load_scene
from ..simulator import DEFAULT_GRAVITY
from .frames import SimulatorFrames, ViewFrame
from .loop_thread import LoopThread
from .pacing import RateMeter, RealTimeClock
from .recording import LiveRecording
from .scalpel import ScalpelPose, ToolMotion

__all__ = ["LiveCut", "LiveParameters", "LiveStatus", "NO_CUT_FORCE"]

NO_CUT_FORCE = sys.float_info.max
"""Cut-start force threshold [N] while cutting is off: no tool force reaches it."""

_COMMAND_TIMEOUT = 300.0
"""Longest wait [s] for a command on the simulation thread (a save of a long run included)."""


@dataclass(frozen=True)
class LiveParameters:
    """What a live run may change; each change rebuilds the simulation from the scene.

    stiffness: spring stiffness K [N/m]. damping: D [N s/m]. residual_strain: eps_r [-].
    tool_radius: [m]. gravity: the scene's gravity (standard gravity if it has none) or none.
    """

    stiffness: float
    damping: float
    residual_strain: float
    tool_radius: float
    gravity: bool

    @classmethod
    def from_scene(cls, scene) -> LiveParameters:
        m = scene.material
        return cls(m.stiffness, m.damping, m.residual_strain, scene.tool.radius,
                   scene.physics.gravity is not None)

    def overrides(self, gravity_vector) -> list[str]:
        """``--set`` strings giving a scene these parameters."""
        gravity = "false" if not self.gravity else "[{}, {}, {}]".format(*map(repr, map(float, gravity_vector)))
        return [f"material.stiffness={self.stiffness!r}", f"material.damping={self.damping!r}",
                f"material.residual_strain={self.residual_strain!r}",
                f"tool.radius={self.tool_radius!r}", f"physics.gravity={gravity}"]


@dataclass(frozen=True)
class LiveStatus:
    """What the run is doing: time [s], real-time factors (simulated over wall time, and over
    compute time: how much faster it could go; None until measured), paused, cutting, error
    (a message, or None), the last recorded frame, incisions and cut events so far, the tool
    force [N] (3,), simulated time given up when it could not keep up [s], the build count, the
    compute time of the simulation (stepping and recording) since the build [s], and the CPU
    time of the threads that stepped it since the start [s] (unlike compute time, not inflated
    when other programs share the cores)."""

    time: float
    realtime_factor: float | None
    compute_factor: float | None
    paused: bool
    cutting: bool
    error: str | None
    frame: int
    incisions: int
    cut_events: int
    force: np.ndarray
    behind_s: float
    generation: int
    compute_s: float
    cpu_s: float


@dataclass
class _Run:
    """One build of the simulation: everything a rebuild replaces."""

    scene: object
    sim: object
    steps_per_frame: int
    motion: ToolMotion
    recording: LiveRecording
    frames: SimulatorFrames
    start_pose: ScalpelPose
    rest_points: np.ndarray
    cut_settings: object
    steps_in_frame: int = 0


class LiveCut:
    """An interactive cutting run of a scene (see the module docstring).

    Args:
        scene: scene file or bundled scene name (None: the default scene); it needs a [tool]:
            the scalpel's radius, length and starting pose (its first keyframe).
        overrides: ``section.key=value`` strings, as ``warp-cut run --set``.
        speed: largest tip speed of the scalpel [m/s]; turn_rate: of its axis [deg/s].
        view_rate: ViewFrames published per second of wall time while running [1/s].
        chunk_frames: frames per USD chunk file of the recording.
        cut_in_background: run the cut in a worker process (``CutSettings(worker=True)``): a
            cut event no longer stalls the real-time loop.
        max_lag: with ``cut_in_background``, the steps an event may stay in flight before the
            loop waits for its edit (None: never wait; 1: each edit two steps after its event).
        clock: the wall clock [s] the real-time thread paces the simulation by and measures its
            real-time factor with (``time.perf_counter``; tests pass a clock they move by hand).

    Raises InputError (SceneError, ToolStartsInside) for a bad scene or overrides.
    """

    def __init__(self, scene=None, overrides=(), *, speed: float = 0.02, turn_rate: float = 90.0,
                 view_rate: float = 30.0, chunk_frames: int = DEFAULT_CHUNK_FRAMES,
                 cut_in_background: bool = False, max_lag: int | None = None,
                 clock: Callable[[], float] = time.perf_counter):
        base = load_scene(scene, list(overrides))
        if base.tool is None:
            raise InputError(f"{base.path}: a live run needs a [tool] in the scene (its radius, "
                             "length and first keyframe give the scalpel and where it starts)")
        if not (math.isfinite(view_rate) and view_rate > 0):
            raise InputError(f"view rate must be > 0 per second, got {view_rate}")
        self._source, self._overrides = scene, list(overrides)
        self._gravity = base.physics.gravity if base.physics.gravity is not None else DEFAULT_GRAVITY
        self._dt = base.solver.dt if base.solver.dt != "auto" else 1e-3
        self._frame_steps = max(1, math.ceil(1.0 / (base.fps * self._dt) - 1e-9))
        self._chunk_frames = chunk_frames
        self._cut_in_background, self._max_lag = bool(cut_in_background), max_lag
        self._speed, self._turn_rate = speed, turn_rate
        self.view_rate = float(view_rate)
        self.params = LiveParameters.from_scene(base)
        self.cutting = bool(base.physics.cutting)
        self.paused = False
        self.error: str | None = None
        self.generation = 0
        self._lock = threading.RLock()
        self._commands: queue.Queue = queue.Queue()
        self._looper = LoopThread(self._loop, "warp-cut-live-simulation")
        self._clock = RealTimeClock(now=clock)
        self._meter = RateMeter(now=clock)
        self._view: ViewFrame | None = None
        self._view_seq = 0
        self._last_publish = -math.inf
        self._cpu_time = 0.0
        self._run = self._build(self.params)
        self._publish()

    # ------------------------------------------------------------------ building
    def _load(self, params: LiveParameters):
        fps = 1.0 / (self._frame_steps * self._dt)
        live = [f"fps={fps!r}", f"solver.dt={self._dt!r}", "physics.cutting=true"]
        return load_scene(self._source, self._overrides + params.overrides(self._gravity) + live)

    def _build(self, params: LiveParameters) -> _Run:
        """A new simulation of the scene with ``params``, recording from frame 0."""
        scene = self._load(params)
        model, sim, path, steps_per_frame = prepare_simulation(
            scene, cut_in_background=self._cut_in_background, max_lag=self._max_lag)
        start = ScalpelPose.from_tool(path.pose_at(0.0))
        motion = ToolMotion(start, length=scene.tool.length, radius=scene.tool.radius,
                            speed=self._speed, turn_rate=self._turn_rate, time=sim.time)
        sim.check_tool_outside(motion.tool)  # the scalpel as posed here (its tilt kept >= 5 deg)
        run = _Run(scene=scene, sim=sim, steps_per_frame=steps_per_frame, motion=motion,
                   recording=LiveRecording(scene, sim, steps_per_frame, chunk_frames=self._chunk_frames),
                   frames=SimulatorFrames(self.generation + 1), start_pose=start,
                   rest_points=model.points[model.active].copy(), cut_settings=sim.cutter.settings)
        self.generation += 1
        self._apply_cutting(run, self.cutting)
        return run

    def _replace_run(self, run: _Run) -> None:
        old, self._run = self._run, run
        old.recording.close()
        old.sim.close()  # a background cut's worker
        self.error = None
        self._after_pause()
        self._publish(force=True)

    @staticmethod
    def _apply_cutting(run: _Run, on: bool) -> None:
        cutter = run.sim.cutter
        if on:
            cutter.settings = run.cut_settings
        else:
            cutter.end_incision(run.sim)
            cutter.settings = dataclasses.replace(run.cut_settings, force_threshold=NO_CUT_FORCE)

    # ------------------------------------------------------------------ properties
    @property
    def sim(self):
        """The Simulator of the current build (read it only from the simulation thread, or
        while no thread runs)."""
        return self._run.sim

    @property
    def scene(self):
        """The Scene of the current build (the user's overrides, the parameters, fps adjusted)."""
        return self._run.scene

    @property
    def dt(self) -> float:
        """Simulation step [s]."""
        return self._run.sim.dt

    @property
    def steps_per_frame(self) -> int:
        """Steps between recorded frames."""
        return self._run.steps_per_frame

    @property
    def pose(self) -> ScalpelPose:
        """The scalpel's pose now."""
        with self._lock:
            return self._run.motion.pose

    @property
    def target(self) -> ScalpelPose:
        """The pose the scalpel is moving to."""
        with self._lock:
            return self._run.motion.target

    @property
    def tool_length(self) -> float:
        """Length of the scalpel [m]."""
        return self._run.motion.length

    @property
    def arrived(self) -> bool:
        """Whether the scalpel is at its target pose."""
        with self._lock:
            return self._run.motion.arrived

    @property
    def running(self) -> bool:
        """Whether the run steps in real time on its own thread."""
        return self._looper.running

    @property
    def speed(self) -> float:
        """Largest tip speed [m/s]."""
        return self._speed

    # ------------------------------------------------------------------ scalpel
    def surface_height(self, x: float, y: float) -> float:
        """Rest height [m] of the tissue below (x, y): that of the node nearest in XY."""
        rest = self._run.rest_points
        k = int(np.argmin((rest[:, 0] - x) ** 2 + (rest[:, 1] - y) ** 2))
        return float(rest[k, 2])

    def depth(self, pose: ScalpelPose | None = None) -> float:
        """Depth [m] of the tip of ``pose`` (default: the target) below the rest surface."""
        pose = pose or self.target
        return self.surface_height(pose.tip[0], pose.tip[1]) - float(pose.tip[2])

    def set_target(self, tip=None, *, tilt_deg=None, heading_deg=None) -> ScalpelPose:
        """Move the scalpel towards a pose: tip (3,) [m], tilt [deg], heading [deg] (each kept
        when not given). Raises InputError for a value out of range."""
        with self._lock:
            motion = self._run.motion
            motion.target = motion.target.moved(tip=tip, tilt_deg=tilt_deg, heading_deg=heading_deg)
            return motion.target

    def set_target_axis(self, tip, axis) -> ScalpelPose:
        """Move the scalpel towards the pose with tip (3,) [m] and axis direction (3,)."""
        with self._lock:
            self._run.motion.target = ScalpelPose.from_axis(tip, axis)
            return self._run.motion.target

    def set_depth(self, depth: float) -> ScalpelPose:
        """Move the target tip to ``depth`` [m] below the rest surface (negative: above)."""
        depth = _number(depth, "depth")
        tip = self.target.tip.copy()
        tip[2] = self.surface_height(tip[0], tip[1]) - depth
        return self.set_target(tip)

    def nudge(self, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> ScalpelPose:
        """Move the target tip by (dx, dy, dz) [m]."""
        step = np.array([_number(dx, "dx"), _number(dy, "dy"), _number(dz, "dz")])
        return self.set_target(self.target.tip + step)

    def return_to_start(self) -> ScalpelPose:
        """Send the scalpel back to where the scene starts it (out of the tissue)."""
        with self._lock:
            self._run.motion.target = self._run.start_pose
            return self._run.start_pose

    def set_speed(self, speed: float) -> None:
        """Largest tip speed [m/s] (> 0)."""
        speed = _number(speed, "tool speed")
        with self._lock:
            self._run.motion.set_limits(speed, self._turn_rate)
            self._speed = speed

    # ------------------------------------------------------------------ commands
    def set_cutting(self, on: bool) -> None:
        """Cutting on (the next contact starts an incision) or off (the incision in progress
        ends; the tool only presses the tissue)."""
        def command():
            self._apply_cutting(self._run, bool(on))
            self.cutting = bool(on)
            self._publish(force=True)
        self._submit(command)

    def set_paused(self, on: bool) -> None:
        """Pause or resume the simulation."""
        def command():
            self.paused = bool(on)
            self._after_pause()
            self._publish(force=True)
        self._submit(command)

    def reset(self) -> None:
        """Start the scene anew: tissue, tool and recording (the parameters are kept)."""
        self._submit(lambda: self._replace_run(self._build(self.params)))

    def set_parameters(self, **changes) -> LiveParameters:
        """Change stiffness, damping, residual_strain, tool_radius and/or gravity and rebuild.
        Raises InputError (naming the key and its allowed range) and keeps the run as it was
        if a value is not allowed."""
        unknown = set(changes) - {f.name for f in dataclasses.fields(LiveParameters)}
        if unknown:
            raise InputError(f"unknown parameters {sorted(unknown)}; allowed: "
                             f"{[f.name for f in dataclasses.fields(LiveParameters)]}")
        for name, value in changes.items():
            changes[name] = bool(value) if name == "gravity" else _number(value, name)
        params = dataclasses.replace(self.params, **changes)

        def command():
            run = self._build(params)  # raises before anything changes
            self.params = params
            self._replace_run(run)
        self._submit(command)
        return params

    def save(self, out_dir) -> list:
        """Write the run so far into ``out_dir`` as ``warp-cut run`` does (the current frame is
        finished first). Returns the paths written."""
        def command():
            run = self._run
            if self.error:  # as warp-cut run writes nothing for an unstable run
                raise InputError(f"nothing saved: {self.error}; reset or apply new parameters first")
            if run.steps_in_frame:
                self._step(run.steps_per_frame - run.steps_in_frame)
            run.sim.cutter.flush(run.sim)  # an edit in flight (cut in a worker), in the files
            extra = {"parameters": dataclasses.asdict(self.params), "overrides": self._overrides,
                     "cutting": self.cutting, "behind_s": self._clock.behind,
                     "scalpel_speed_m_s": self._speed}
            paths = run.recording.save(run.sim, out_dir, extra)
            self._after_pause()
            return paths
        return self._submit(command)

    def _submit(self, command):
        """Run ``command`` on the simulation thread (now, if none runs) and return its result."""
        if not self._looper.running or self._looper.is_current():
            return command()
        future: concurrent.futures.Future = concurrent.futures.Future()
        self._commands.put((command, future))
        return future.result(timeout=_COMMAND_TIMEOUT)

    def _run_commands(self) -> None:
        while True:
            try:
                command, future = self._commands.get_nowait()
            except queue.Empty:
                return
            try:
                future.set_result(command())
            except BaseException as exc:  # handed to the caller
                future.set_exception(exc)

    def _after_pause(self) -> None:
        """Forget the pacing history: a pause, rebuild or save is not falling behind."""
        self._clock.anchor(self._run.sim.time)
        self._meter.clear()

    # ------------------------------------------------------------------ stepping
    def _step(self, n: int) -> None:
        """n steps along the scalpel's motion, recording the frames they complete."""
        run = self._run
        while n > 0:
            k = min(n, run.steps_per_frame - run.steps_in_frame)
            start, cpu = time.perf_counter(), time.thread_time()
            with self._lock:
                trajectory = run.motion.trajectory()
            for _ in range(k):  # one step a tick, timed, as warp-cut run steps
                run.recording.ticks.step(run.sim, trajectory)
            with self._lock:
                run.motion.advance(trajectory, run.sim.time)
            run.steps_in_frame += k
            if run.steps_in_frame == run.steps_per_frame:
                run.recording.record(run.sim)
                run.steps_in_frame = 0
            run.recording.compute_time += time.perf_counter() - start
            self._cpu_time += time.thread_time() - cpu
            self._meter.add(run.sim.time, run.recording.compute_time)
            n -= k

    def advance(self, steps: int) -> None:
        """Run ``steps`` steps now, as fast as possible (no thread may be running); pending
        commands run first. For tests, benchmarks and scripted runs."""
        if self.running:
            raise RuntimeError("advance() drives a run without its thread; this one is running")
        self._run_commands()
        self._step(int(steps))
        self._publish(force=True)

    def advance_time(self, seconds: float) -> None:
        """Run ``seconds`` [s] of simulated time now (rounded to whole steps)."""
        self.advance(round(seconds / self.dt))

    def _loop(self) -> None:
        self._after_pause()
        while not self._looper.stopping.is_set():
            self._run_commands()
            if self.paused or self.error:  # nothing moves: nothing to publish
                self._looper.stopping.wait(0.01)
                continue
            run = self._run
            due = self._clock.steps_due(run.sim.time, run.sim.dt)
            if due == 0:
                self._looper.stopping.wait(min(0.005, self._clock.wait_time(run.sim.time, run.sim.dt)))
                continue
            try:
                self._step(min(due, run.steps_per_frame))
            except WarpCutError as exc:  # unstable: keep the state, say why, wait for the user
                self.error = str(exc)
            except Exception as exc:  # a bug: report it and stop stepping, keep serving
                traceback.print_exc()
                self.error = f"internal error: {exc!r}"
            self._publish(force=self.error is not None)

    def start(self) -> None:
        """Run in real time on a thread of its own until ``stop``."""
        self._looper.start()

    def stop(self, timeout: float = 30.0) -> None:
        """Stop the thread (after the step in progress) and wait for it."""
        if not self._looper.stop(timeout):
            raise RuntimeError(f"the simulation thread did not stop within {timeout} s")
        self._run_commands()  # a command queued while stopping still gets its answer

    def close(self) -> None:
        """Stop, remove the recording's staging files (saved copies stay) and stop a
        background cut's worker."""
        self.stop()
        self._run.recording.close()
        self._run.sim.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ------------------------------------------------------------------ reading
    def _publish(self, force: bool = False) -> None:
        now = time.perf_counter()
        if not force and now - self._last_publish < 1.0 / self.view_rate:
            return
        view = self._run.frames(self._run.sim)
        with self._lock:
            self._view = view
            self._view_seq += 1
            self._last_publish = now

    def view_frame(self) -> tuple[int, ViewFrame]:
        """(sequence number, the latest ViewFrame); the number grows with every new frame."""
        with self._lock:
            return self._view_seq, self._view

    def status(self) -> LiveStatus:
        """What the run is doing now."""
        with self._lock:
            run = self._run
            rtf, compute = self._meter.factors()
            sim = run.sim
            cutter = sim.cutter
            return LiveStatus(time=sim.time, realtime_factor=rtf, compute_factor=compute,
                              paused=self.paused, cutting=self.cutting, error=self.error,
                              frame=run.recording.frame, incisions=len(cutter.incisions),
                              cut_events=cutter.totals["events"] + cutter.totals.get("skipped_events", 0),
                              force=np.array(sim.tool_force),
                              behind_s=self._clock.behind, generation=self.generation,
                              compute_s=run.recording.compute_time, cpu_s=self._cpu_time)


def _number(value, name: str) -> float:
    """``value`` as a finite float, or InputError naming ``name``."""
    if isinstance(value, bool):
        raise InputError(f"{name} must be a number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise InputError(f"{name} must be finite, got {value!r}")
    return number
