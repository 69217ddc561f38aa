"""warp_cut/live (no browser): the scalpel's pose and motion against closed forms, real-time
pacing on a fake clock, the ViewFrame against the Simulator, a scripted cut, the saved run
against what ``warp-cut run`` writes and the USD checker, commands while running."""

import json
import math
import threading
import time

import numpy as np
import pytest
import trimesh
from test_cut_scenes import blade_travel_per_event, events_while_drawing

from warp_cut.cli import main
from warp_cut.cut.classes import NodeClass
from warp_cut.errors import InputError
from warp_cut.io.usd_check import check_usd, validate_usd
from warp_cut.live import LiveCut, ScalpelPose
from warp_cut.live.pacing import RateMeter, RealTimeClock
from warp_cut.live.scalpel import ToolMotion
from warp_cut.live.scripted import straight_cut

SMALL = ["tissue.size=[0.06,0.04]"]
"""The straight incision's scene on a 6 x 4 cm patch (the scalpel starts at x = -2 cm)."""


class FakeClock:
    """A wall clock [s] that moves only when the test moves it. It counts its reads, and a test
    can wait for the next ones: a thread pacing itself by it reads it on every pass of its
    loop while it runs (waiting on a condition, not sleeping)."""

    def __init__(self, t: float = 100.0):
        self.t = t
        self.reads = 0
        self._read = threading.Condition()

    def __call__(self) -> float:
        with self._read:
            self.reads += 1
            self._read.notify_all()
            return self.t

    def advance(self, seconds: float) -> None:
        with self._read:
            self.t += seconds

    def wait_for_reads(self, n: int, timeout: float = 120.0) -> bool:
        """Whether the clock was read ``n`` more times within ``timeout`` [s] of wall time."""
        with self._read:
            target = self.reads + n
            return self._read.wait_for(lambda: self.reads >= target, timeout)


# ---------------------------------------------------------------- scalpel
def test_pose_axis_is_the_scene_scalpel_and_round_trips():
    pose = ScalpelPose([0, 0, 0.004], 60.0, 0.0)
    assert pose.axis == pytest.approx([-0.5, 0.0, math.sqrt(3) / 2])
    rng = np.random.default_rng(3)
    for _ in range(50):
        tilt, heading = rng.uniform(5.0, 90.0), rng.uniform(-179.0, 179.0)
        again = ScalpelPose.from_axis([0, 0, 0], ScalpelPose([0, 0, 0], tilt, heading).axis)
        assert again.tilt_deg == pytest.approx(tilt)
        if tilt < 89.9:
            assert again.heading_deg == pytest.approx(heading)
    assert ScalpelPose([0, 0, 0], 30, 190).heading_deg == pytest.approx(-170)
    assert ScalpelPose.from_axis([0, 0, 0], [1, 0, -1]).tilt_deg == 5.0  # pointing down: raised
    with pytest.raises(InputError, match="tilt"):
        ScalpelPose([0, 0, 0], 95.0, 0.0)
    with pytest.raises(InputError, match="tip"):
        ScalpelPose([0, np.nan, 0], 60.0, 0.0)


def test_trajectory_moves_at_the_speed_and_turn_rate_then_stops():
    start = ScalpelPose([0.0, 0.0, 0.01], 60.0, 0.0)
    motion = ToolMotion(start, length=0.04, radius=0.001, speed=0.02, turn_rate=90.0, time=1.0)
    motion.target = start.moved(tip=[0.006, 0.008, 0.01], tilt_deg=90.0)  # 10 mm, 30 deg away
    path = motion.trajectory()
    quarter = path.pose(1.25)
    assert np.linalg.norm(quarter.tip - start.tip) == pytest.approx(0.005)  # 20 mm/s x 0.25 s
    assert np.cross(quarter.tip - start.tip, [0.6, 0.8, 0.0]) == pytest.approx(np.zeros(3), abs=1e-12)
    turned = math.degrees(math.acos(np.clip(quarter.axis @ start.axis, -1, 1)))
    assert turned == pytest.approx(22.5)  # 90 deg/s x 0.25 s
    assert path.pose(1.25).tip == pytest.approx(quarter.tip)  # a function of time alone
    end = path.pose(1.5)
    assert end.tip == pytest.approx([0.006, 0.008, 0.01]) and end.tilt_deg == pytest.approx(90.0)
    tool = path(1.25)
    assert tool.p0 == pytest.approx(quarter.tip) and tool.length == pytest.approx(0.04)
    motion.advance(path, 1.6)
    assert motion.arrived


# ---------------------------------------------------------------- pacing
def test_clock_runs_the_steps_due_and_counts_what_it_gives_up():
    now = FakeClock()
    clock = RealTimeClock(max_lag=0.1, now=now)
    clock.anchor(0.0)
    now.t += 0.0105
    assert clock.steps_due(0.0, 0.001) == 10
    assert clock.steps_due(0.010, 0.001) == 0
    assert clock.wait_time(0.010, 0.001) == pytest.approx(0.0005)
    now.t += 0.5  # a stall: 0.5 s behind; one step is run, the rest given up
    assert clock.steps_due(0.010, 0.001) == 1
    assert clock.behind == pytest.approx(0.5005 - 0.001, abs=1e-9)
    assert clock.steps_due(0.011, 0.001) == 0  # that step ends now: nothing more is due
    now.t += 0.0105
    assert clock.steps_due(0.011, 0.001) == 10  # then one step per millisecond again
    meter = RateMeter(window=1.0, now=now)
    for k in range(5):
        meter.add(sim_time=0.5 * k * 0.1, compute_time=0.25 * k * 0.1)
        now.t += 0.1
    assert meter.factors() == pytest.approx((0.5, 2.0))


# ---------------------------------------------------------------- a scripted cut
@pytest.fixture(scope="module", params=[False, 1], ids=["cut in the loop", "cut in the background"])
def cut_run(request):
    """A scripted 15 mm cut; in the background with each edit two steps late (max_lag 1)."""
    live = LiveCut("straight_incision", SMALL, cut_in_background=bool(request.param), max_lag=request.param or None)
    _, before = live.view_frame()
    straight_cut(live, 0.015)
    yield live, before
    live.close()


def _same_mesh_as_simulator(frame, sim):
    model = sim.model
    live_nodes = np.flatnonzero(model.active)
    assert np.array_equal(frame.points, sim.state.positions.numpy()[live_nodes])
    assert np.array_equal(frame.points[frame.faces], sim.positions[model.triangles].astype(np.float32))
    assert np.array_equal(frame.node_class, model.node_class[live_nodes])


def test_view_frame_is_the_simulator_state():
    live = LiveCut("straight_incision", SMALL)
    try:
        seq, frame = live.view_frame()
        _same_mesh_as_simulator(frame, live.sim)
        assert frame.tool is None and frame.incision is None  # no step yet
        live.advance(5)
        seq2, frame = live.view_frame()
        assert seq2 > seq and frame.time == pytest.approx(5 * live.dt)
        assert frame.tool[0] == pytest.approx(live.pose.tip) and frame.tool[2] == 0.001
        assert live.dt == 0.001 and live.steps_per_frame == 17  # 1 ms steps, frames of 17 steps
    finally:
        live.close()


def test_scripted_cut_changes_the_topology_and_marks_the_wound(cut_run):
    live, before = cut_run
    _, after = live.view_frame()
    _same_mesh_as_simulator(after, live.sim)
    assert after.topology != before.topology
    assert len(after.faces) != len(before.faces) or not np.array_equal(after.faces, before.faces)
    counts = np.bincount(after.node_class, minlength=len(NodeClass))
    assert counts[NodeClass.LIP] >= 10 and counts[NodeClass.BLUE] >= 10 and counts[NodeClass.YELLOW] >= 2
    controls = after.incision
    assert controls.shape[1] == 3 and (len(controls) - 1) % 3 == 0
    # the incision runs where the blade crossed the skin: 15 mm along +x, on y = 0
    assert controls[-1, 0] - controls[0, 0] == pytest.approx(0.015, abs=0.002)
    assert np.abs(controls[:, 1]).max() < 1e-3
    # a 15 mm stroke at the scalpel's speed, 60 degrees from the skin, events by the scene's
    # rule: those the same straight stroke makes in a scene run (``events_while_drawing``), +- 2
    scene = live.scene
    spacing = scene.tissue.spacing
    expected = events_while_drawing(0.015, blade_travel_per_event(scene.cutting, live.speed, spacing), spacing,
                                    scene.tool.radius, live.pose.tilt_deg)
    status = live.status()
    assert status.incisions == 1 and abs(status.cut_events - expected) <= 2 and status.error is None


@pytest.fixture(scope="module")
def reference_run(tmp_path_factory):
    """What ``warp-cut run`` writes for the same scene (a short run: the files, not their values)."""
    ref = tmp_path_factory.mktemp("reference") / "ref"
    assert main(["run", "--quiet", "--out", str(ref), "--set", "duration=0.05"] +
                [f"--set={s}" for s in SMALL]) == 0
    usd = ref / "straight_incision.usdc"
    assert check_usd(usd) == [] and validate_usd(usd) == []
    return ref


def test_save_writes_what_warp_cut_run_writes(cut_run, reference_run, tmp_path):
    live, _ = cut_run
    out = tmp_path / "live"
    paths = live.save(out)
    assert all(p.is_file() for p in paths)
    ref = reference_run
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in ref.iterdir())
    usd = out / "straight_incision.usdc"
    assert check_usd(usd) == [] and validate_usd(usd) == []
    assert main(["usd-check", str(usd)]) == 0
    m = json.loads((out / "metrics.json").read_text())
    assert set(json.loads((ref / "metrics.json").read_text())) <= set(m)
    frames = live.status().frame
    assert m["frames"] == frames and m["usd_frames"] == frames + 1
    assert m["sim_time_s"] == pytest.approx(m["steps"] * m["dt"]) and m["steps"] == 17 * frames
    assert m["cut"]["incisions"] == 1 and m["mesh"]["valid"] and m["live"]["cutting"] is True
    rows = (out / "timeseries.csv").read_text().splitlines()
    assert len(rows) == frames + 2
    # the USD's last frame is the final mesh, read back by an independent reader
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(usd))
    assert stage.GetEndTimeCode() == frames
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Tissue"))
    ply = trimesh.load(out / "final_mesh.ply", process=False)
    assert np.array(mesh.GetPointsAttr().Get(frames)) == pytest.approx(ply.vertices, abs=1e-9)
    assert np.array_equal(np.array(mesh.GetFaceVertexIndicesAttr().Get(frames)).reshape(-1, 3), ply.faces)


def test_a_second_save_holds_the_run_since_the_start(cut_run, tmp_path):
    live, _ = cut_run
    out = tmp_path / "again"
    live.save(out)
    first = json.loads((out / "metrics.json").read_text())["frames"]
    live.advance_time(0.2)
    live.save(out)
    m = json.loads((out / "metrics.json").read_text())
    assert m["frames"] == live.status().frame >= first + 11
    assert check_usd(out / "straight_incision.usdc") == []
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary left


# ---------------------------------------------------------------- commands
@pytest.mark.parametrize("background", [False, 1], ids=["cut in the loop", "cut in the background"])
def test_cutting_off_presses_without_cutting_then_on_cuts(background):
    # in the background each edit lands two steps after its event (max_lag 1): whether the
    # cut's edits have landed by the end of the stroke does not hang on the worker's speed
    with LiveCut("straight_incision", SMALL, cut_in_background=background, max_lag=1 if background else None) as live:
        live.set_cutting(False)
        version = live.sim.model.topology_version
        straight_cut(live, 0.004, settle=0.0)
        assert live.sim.model.topology_version == version and live.status().incisions == 0
        assert live.sim.contacts.max_force > 0.005  # the blade pressed the skin
        live.set_cutting(True)
        straight_cut(live, 0.004, settle=0.0)
        assert live.sim.model.topology_version > version and live.status().incisions == 1


def test_parameters_rebuild_and_bad_values_are_refused():
    with LiveCut("straight_incision", SMALL) as live:
        generation = live.generation
        with pytest.raises(InputError, match=r"material\.residual_strain.*0\.99"):
            live.set_parameters(residual_strain=1.5)
        with pytest.raises(InputError, match="stiffness must be a number"):
            live.set_parameters(stiffness="stiff")
        with pytest.raises(InputError, match="unknown parameters"):
            live.set_parameters(mass=1.0)
        assert live.generation == generation  # the run goes on as it was
        live.advance(20)
        live.set_parameters(stiffness=320.0, gravity=False, tool_radius=0.0015)
        assert live.generation == generation + 1 and live.sim.time == 0.0
        assert np.all(live.sim.model.stiffness == 320.0) and live.sim.gravity is None
        live.advance(1)
        assert live.view_frame()[1].tool[2] == 0.0015
        with pytest.raises(InputError, match="tilt"):
            live.set_target(tilt_deg=120)
        with pytest.raises(InputError, match="depth must be finite"):
            live.set_depth(float("nan"))


def test_a_scene_without_a_tool_is_refused(tmp_path):
    scene = tmp_path / "no_tool.toml"
    scene.write_text('name = "no_tool"\n[tissue]\nsize = [0.02, 0.02]\n')
    with pytest.raises(InputError, match=r"needs a \[tool\]"):
        LiveCut(str(scene))


def _steps(live) -> int:
    return round(live.status().time / live.dt)


def _wait_until(condition, clock: FakeClock, timeout: float = 120.0) -> None:
    """Wait until ``condition()`` holds, waking at each read of the clock (each pass of the
    run's thread) and at least every 50 ms; a failure after ``timeout`` [s] of wall time."""
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        clock.wait_for_reads(1, timeout=0.05)


def _settled_steps(live, clock: FakeClock, quiet_reads: int = 10, timeout: float = 120.0) -> int:
    """The run's step count once the thread has read the clock ``quiet_reads`` times without
    stepping in between (it reads it before and after each stretch of steps): every step due
    has been run."""
    deadline = time.monotonic() + timeout
    steps, quiet = _steps(live), 0
    while quiet < quiet_reads:
        assert time.monotonic() < deadline and live.status().error is None, "the thread did not settle"
        read = clock.wait_for_reads(1, timeout=0.05)
        now = _steps(live)
        quiet = quiet + 1 if read and now == steps else 0
        steps = now
    return steps


def test_real_time_thread_steps_what_the_clock_allows_pauses_saves_and_stops(tmp_path):
    """The real-time thread paced by a clock the test moves: exactly the steps due, never one
    ahead; after a stall past max_lag one step and the rest given up (simulated time plus time
    given up is the wall time); nothing while paused and no burst after it; commands and a
    save while it runs."""
    clock = FakeClock(100.0)
    live = LiveCut("straight_incision", SMALL, clock=clock)
    dt = live.dt
    try:
        live.start()
        assert clock.wait_for_reads(1)  # anchored: simulated time 0 is now
        clock.advance(50.5 * dt)
        assert _settled_steps(live, clock) == 50  # the 51st is due at 51 dt only
        clock.advance(0.5)  # a stall past max_lag (0.1 s): one step, the rest given up
        assert _settled_steps(live, clock) == 51
        status = live.status()
        assert status.time + status.behind_s == pytest.approx(clock.t - 100.0, abs=dt)
        clock.advance(10.5 * dt)
        assert _settled_steps(live, clock) == 61
        _pause_holds(live, clock)
        _command_while_running(live, clock)
        paths = live.save(tmp_path / "threaded")
        assert check_usd(paths[-1]) == []
    finally:
        live.close()
    assert not live.running
    assert not [t for t in threading.enumerate() if t.name.startswith("warp-cut-live")]


def _pause_holds(live, clock: FakeClock) -> None:
    """Paused, the run makes no step however far the clock moves; resumed, it owes none."""
    live.set_paused(True)  # a command: it runs on the thread, between two passes
    paused_at = _steps(live)
    clock.advance(0.05)
    live.set_paused(True)  # the thread has made another pass since
    assert _steps(live) == paused_at and live.status().paused
    live.set_paused(False)
    assert _settled_steps(live, clock) == paused_at


def _command_while_running(live, clock: FakeClock) -> None:
    """A target set while the thread runs is reached as the clock moves on; the simulation
    keeps within a step of the clock, never ahead of it."""
    start_steps, start_clock = _steps(live), clock.t
    live.set_target(live.target.tip + [0, 0, 0.002])  # 2 mm at 20 mm/s: 0.1 s
    for _ in range(100):
        if live.arrived:
            break
        clock.advance(10.5 * live.dt)
        due = (clock.t - start_clock) / live.dt
        assert due - 1 < _settled_steps(live, clock) - start_steps <= due + 1e-6
    assert live.arrived


def test_instability_is_reported_and_the_thread_keeps_serving(tmp_path):
    clock = FakeClock()
    live = LiveCut("straight_incision", SMALL + ["solver.substeps=1", "material.damping=0",
                                                 "material.stiffness=100000"], clock=clock)
    try:
        live.start()
        assert clock.wait_for_reads(1)  # anchored
        clock.advance(10.5 * live.dt)  # ten steps due: the stiff undamped sheet fails within them
        _wait_until(lambda: live.status().error is not None or _steps(live) >= 10, clock)
        assert "unstable" in live.status().error
        with pytest.raises(InputError, match="nothing saved"):
            live.save(tmp_path / "unstable")
        assert not (tmp_path / "unstable").exists()
        live.set_parameters(stiffness=160.0, damping=3.0)  # the thread still takes commands
        assert live.status().error is None
    finally:
        live.close()
