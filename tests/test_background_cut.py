"""warp_cut/cut/background.py, warp_cut/cut/cut_worker.py: the cut in a worker process, its edits applied between ticks.

The worker's replica and the loop's model must stay the same tissue edit by edit; the cut it
makes must be the one the in-loop Cutter makes on the same stroke (up to the few steps an edit
arrives late); its failures must reach the loop as errors, and closing must leave no process.
"""

import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import DEVICE
from hypothesis import HealthCheck, Phase, example, given, seed, settings
from hypothesis import strategies as st
from test_cut_fuzz import cut_cases, make_stroke, make_surface

from warp_cut import Simulator, TissueModel, Tool
from warp_cut.cut.background import BackgroundCutter, arrival_positions
from warp_cut.cut.cut_worker import ANCHORS, ModelEdit, TableEdit, WorkerEvent, motion_anchors
from warp_cut.cut.settings import CutSettings
from warp_cut.errors import CutWorkerError, InputError
from warp_cut.sim.model_change import ModelChange
from warp_cut.verify.validity import cut_problems

AXIS = np.array([-0.5, 0.0, 0.866])
"""The scalpel leaning back 60 degrees along -x."""
TABLES = ("node_table", "spring_table", "triangle_table", "link_table")


CLOCK = 1.0 / 60.0
"""Cut events on a clock here, one per 60 fps frame (``cutting.interval``): an event falls due
while the tool is lowered or still, as these tests need, whatever its travel."""
LAG_1 = CutSettings(worker=True, max_lag=1, interval=CLOCK)
"""A cut in a worker whose every edit lands two steps after its event (the same every run)."""


def scalpel(k: int, lift_at: int | None = None, y: float = 3e-4) -> Tool:
    """Tick k of a stroke at ``y`` [m]: 200 ticks going 6 mm in along the axis, then 2 cm/s
    along x; from ``lift_at`` on, 2 cm above the skin."""
    tip = (np.array([-0.012, y, 0.004]) - min(k, 200) / 200 * 0.006 * AXIS
           + np.array([max(0, k - 200) * 2e-5, 0.0, 0.0]))
    if lift_at is not None and k >= lift_at:
        tip = tip + np.array([0.0, 0.0, 0.02])
    return Tool(p0=tip, p1=tip + 0.04 * AXIS, radius=0.001)


def cut_stroke(background: bool, ticks: int = 1300, lift_at: int = 1200):
    """A 2 cm stroke on a 4 x 3 cm patch, then the tool lifted out; (sim, its model). In the
    background, each edit lands two steps after its event (``max_lag`` 1): the loop runs
    faster than real time here, and the run is the same every time."""
    model = TissueModel.from_patch((0.04, 0.03), 0.002)
    sim = Simulator(model, dt=1e-3, device=DEVICE, cutting=LAG_1 if background
                    else CutSettings(interval=CLOCK))
    for k in range(ticks):
        sim.step(tool=scalpel(k, lift_at))
    if background:
        sim.cutter.flush(sim)
    return sim, model


@pytest.fixture(scope="module")
def background_run():
    sim, model = cut_stroke(background=True)
    metrics = sim.cutter.metrics(sim.positions)  # cut_stroke flushed: nothing in flight
    replica = sim.cutter.call(sim, "model")
    yield sim, model, metrics, replica
    sim.close()


@pytest.fixture(scope="module")
def loop_run():
    sim, model = cut_stroke(background=False)
    return sim, model, sim.cutter.metrics(sim.positions)


def test_the_loop_model_is_the_worker_replica(background_run):
    sim, model, _, replica = background_run
    assert sim.cutter.edits_applied > 10
    assert set(sim.cutter.lag_steps) == {2}  # max_lag 1: received the step after, applied the next
    assert_same_tables(model, replica)
    assert model.topology_version == replica.topology_version


def test_what_the_loop_reads_between_edits_is_the_worker_cut(background_run):
    """Counters, lip pairs, the wound's width and the incision curve are read in the loop
    without a round trip; they equal the worker Cutter's after the last edit."""
    sim, _, _, _ = background_run
    cutter = sim.cutter
    assert cutter.totals == cutter.call(sim, "totals") and cutter.totals["events"] > 10
    assert len(cutter.incisions) == len(cutter.call(sim, "incisions")) == 1
    width = cutter.incision_width(sim.positions)
    assert np.isfinite(width) and width == cutter.call(sim, "incision_width", sim.positions)
    worker_curve = cutter.call(sim, "incisions")[-1].curve.control_points_flat()
    np.testing.assert_array_equal(sim.incision_controls, worker_curve)


def test_settings_and_end_incision_reach_the_worker():
    model = TissueModel.from_patch((0.04, 0.03), 0.002)
    with Simulator(model, dt=1e-3, device=DEVICE, cutting=LAG_1) as sim:
        for k in range(500):
            sim.step(tool=scalpel(k))
        cutter = sim.cutter
        cutter.end_incision(sim)  # the tool is still in: the incision ends anyway
        assert cutter.call(sim, "current") is None and len(cutter.incisions) == 1
        stiff = CutSettings(force_threshold=1e9, worker=True, max_lag=1, interval=CLOCK)  # no tool pushes this hard
        cutter.settings = stiff
        for k in range(500, 560):
            sim.step(tool=scalpel(k))
        cutter.flush(sim)
        assert cutter.call(sim, "settings") == stiff and len(cutter.incisions) == 1


def test_the_background_cut_leaves_a_valid_tissue(background_run):
    sim, _, metrics, _ = background_run
    assert cut_problems(sim) == []
    assert metrics["cut"]["incisions"] == 1 and metrics["cut"]["unfilled_holes"] == 0
    assert metrics["incision"]["coverage"] >= 0.95


def test_the_background_cut_is_the_in_loop_cut(background_run, loop_run):
    """The same stroke cut in the loop and in the background: the same incision (its length
    within two spacings: an edit lands a few steps after its positions were taken), the same
    kind of wound (one incision, no hole, lips as many within 20 %)."""
    _, _, bg, _ = background_run
    _, _, fg = loop_run
    assert fg["cut"]["incisions"] == 1 and fg["cut"]["unfilled_holes"] == 0
    assert abs(bg["incision"]["length_m"] - fg["incision"]["length_m"]) <= 2 * 0.002
    assert bg["cut"]["lip_nodes"] == pytest.approx(fg["cut"]["lip_nodes"], rel=0.2)


def test_a_lifted_and_returned_tool_makes_two_incisions():
    """The tool leaves the skin while an edit is in flight and comes back: the worker ends
    the first incision before the poses of the second stroke reach it."""
    model = TissueModel.from_patch((0.04, 0.03), 0.002)
    with Simulator(model, dt=1e-3, device=DEVICE, cutting=LAG_1) as sim:
        for k in range(700):
            sim.step(tool=scalpel(k, lift_at=500) if k < 600 else scalpel(k - 450, y=0.008))
        for k in range(700, 1000):
            sim.step(tool=scalpel(k - 450, y=0.008))
        sim.cutter.flush(sim)
        assert sim.cutter.call(sim, "metrics", sim.positions)["cut"]["incisions"] == 2
        assert cut_problems(sim) == []
    assert not sim.cutter._process.is_alive()  # the with block closed it


def test_a_mesh_that_cannot_be_cut_is_refused_and_no_worker_is_left():
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], float) * 0.01
    fan = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])  # edge 0-1 shared by three triangles
    model = TissueModel.from_triangles(points, fan)
    with pytest.raises(InputError, match="cannot be cut"):
        BackgroundCutter(model)


def test_worker_failures_reach_the_loop_and_close_stops_it():
    model = TissueModel.from_patch((0.01, 0.01), 0.002)
    sim = Simulator(model, dt=1e-3, device=DEVICE, cutting=CutSettings(worker=True))
    cutter = sim.cutter
    with pytest.raises(CutWorkerError, match="AttributeError"):
        cutter.call(sim, "no_such_method")
    cutter._busy = True  # as with an event in flight: its answer would come first
    with pytest.raises(InputError, match="flush"):
        cutter.metrics(sim.positions)
    cutter._busy = False
    assert cutter.call(sim, "totals")["events"] == 0  # the worker answers after a failure
    sim.close()
    assert not cutter._process.is_alive()
    sim.close()  # closing twice is harmless


def test_a_failed_event_stops_the_cut_for_good():
    """An event that fails in the worker leaves its replica unknown: the error reaches the
    loop, and every later step raises it again instead of cutting a tissue that may differ."""
    model = TissueModel.from_patch((0.02, 0.02), 0.002)
    with Simulator(model, dt=1e-3, device=DEVICE, cutting=CutSettings(worker=True)) as sim:
        cutter = sim.cutter
        cutter._post(("event", WorkerEvent(0.0, 1e-3, True, buffer="no-such-buffer", capacity=1, node_count=1)))
        cutter._busy = True
        with pytest.raises(CutWorkerError, match="no-such-buffer"):
            cutter.flush(sim)
        for _ in range(2):
            with pytest.raises(CutWorkerError, match="no-such-buffer"):
                sim.step(tool=scalpel(0))


def test_a_dead_worker_is_an_error_not_a_hang():
    model = TissueModel.from_patch((0.02, 0.02), 0.002)
    sim = Simulator(model, dt=1e-3, device=DEVICE, cutting=CutSettings(worker=True))
    try:
        sim.cutter._process.kill()
        sim.cutter._process.join()
        with pytest.raises(CutWorkerError, match="died"):
            for k in range(300):  # the first event finds the pipe closed
                sim.step(tool=scalpel(k))
    finally:
        sim.close()



def test_a_script_without_a_main_guard_is_told_why_its_worker_died(tmp_path):
    """The spawned worker imports the main script; one that makes a background Simulator at
    its top level kills the worker at start: the error must say so, not just "died"."""
    script = tmp_path / "no_guard.py"
    script.write_text("import warp_cut as wc\n"
                      "model = wc.TissueModel.from_patch((0.02, 0.02), 0.002)\n"
                      "wc.Simulator(model, dt=1e-3, cutting=wc.CutSettings(worker=True))\n")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert done.returncode != 0
    assert "CutWorkerError" in done.stderr and "if __name__" in done.stderr

def assert_same_tables(model, replica) -> None:
    """The loop's model and the worker's replica hold the same rows in every table."""
    for name in TABLES:
        ours, theirs = getattr(model, name), getattr(replica, name)
        assert ours.count == theirs.count, name
        np.testing.assert_array_equal(ours.alive, theirs.alive, err_msg=name)
        for column in ours._cols:
            np.testing.assert_array_equal(ours.column(column), theirs.column(column),
                                          err_msg=f"{name}.{column}")


@seed(20261130)
@settings(max_examples=6, deadline=None, database=None, phases=[Phase.generate],
          suppress_health_check=list(HealthCheck))
@given(cut_cases())
def test_random_strokes_in_the_background_keep_the_invariants_and_the_replica(case):
    """A random stroke on a random mesh (tests/test_cut_fuzz.py's cases: flat, turned,
    Delaunay, dome, cylinder, saddle; every integrator), cut in the background with each edit
    landing two steps late: after every edit the tissue passes the mesh invariants, and at the
    end the loop's model is the worker's replica and the stroke is one incision."""
    surf = make_surface(case["mesh"])
    stroke = make_stroke(surf, case["stroke"])
    s = case["sim"]
    gravity = {} if s["gravity"] and s["integrator"] != "xpbd" else {"gravity": None}
    with Simulator(TissueModel.from_surface(surf), dt=1e-3, device=DEVICE, integrator=s["integrator"],
                   cutting=CutSettings(interval=s["interval"], worker=True, max_lag=1), **gravity) as sim:
        model = sim.model
        steps = math.ceil(stroke.duration / sim.dt - 1e-9) + 1
        for k in range(steps + 40):  # the stroke, then 40 ms with the tool away
            version = model.topology_version
            sim.step(tool=stroke.pose(k * sim.dt) if k < steps else None)
            if model.topology_version != version:
                problems = cut_problems(sim)  # the invariants (folds, which need the surface, aside)
                assert not problems, problems
        sim.cutter.flush(sim)
        assert_same_tables(model, sim.cutter.call(sim, "model"))
        assert len(sim.cutter.call(sim, "incisions")) == 1


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1))
@example(285737497)  # a neighbour 0.1 mm from the node the target is on took 1.1e-5 of the weight
def test_motion_anchors_are_the_nearest_alive_nodes(value):
    """Against a brute-force search over the alive nodes: the first anchor is the nearest one,
    every anchor is alive, the weights are positive and sum to 1; a target on a node leans
    on that node alone."""
    rng = np.random.default_rng(value)
    points = rng.uniform(-0.02, 0.02, (60, 3)) * [1.0, 1.0, 0.1]
    alive = np.flatnonzero(rng.random(60) < 0.7)
    targets = np.concatenate([rng.uniform(-0.02, 0.02, (5, 3)), points[alive[:1]]])
    anchors, weights = motion_anchors(points, alive, targets)
    assert anchors.shape == weights.shape == (6, ANCHORS)
    assert np.isin(anchors, alive).all()
    nearest = alive[np.argmin(np.linalg.norm(targets[:, None] - points[alive][None], axis=2), axis=1)]
    assert np.array_equal(anchors[:, 0], nearest)
    assert np.all(weights > 0) and np.allclose(weights.sum(axis=1), 1.0)
    assert weights[-1, 0] == pytest.approx(1.0, abs=1e-5)


def test_an_edit_moves_its_new_nodes_with_the_tissue():
    """Tissue that moved rigidly by d between the event and the step the edit applies at
    carries the edit's new nodes by d too (the loop applies them where they were made)."""
    rng = np.random.default_rng(3)
    at_event = rng.uniform(-0.01, 0.01, (40, 3))
    new_positions = rng.uniform(-0.005, 0.005, (4, 3))
    anchors, weights = motion_anchors(at_event, np.arange(40), new_positions)
    change = ModelChange.of(new_nodes=np.arange(40, 44), new_positions=new_positions)
    edit = ModelEdit({}, change, 1, anchors, weights)
    shift = np.array([3e-4, -2e-4, 1e-4])
    assert np.allclose(edit.positions_now(at_event, at_event + shift), new_positions + shift)
    assert np.allclose(edit.positions_now(at_event, at_event), new_positions)



def _send_an_event(sim, start: int = 0, limit: int = 200) -> int:
    """Step the stroke from tick ``start`` until the loop has sent an event (it is in flight);
    returns the next tick."""
    for k in range(start, start + limit):
        sim.step(tool=scalpel(k))
        if sim.cutter._busy:
            return k + 1
    raise AssertionError("no cut event was sent")


def test_a_hung_worker_is_an_error_after_the_answer_timeout():
    """A worker that stops answering (frozen with SIGSTOP) while the loop must wait for its
    edit (max_lag 1): the step raises 'did not answer' after the timeout instead of hanging,
    the worker is stopped, and every later step raises the same."""
    model = TissueModel.from_patch((0.03, 0.02), 0.002)
    sim = Simulator(model, dt=1e-3, device=DEVICE, cutting=LAG_1)
    cutter = sim.cutter
    cutter.answer_timeout = 0.5
    try:
        sim.step(40, tool=scalpel(0))
        assert cutter.worker_ms, "the worker answered the first events"
        os.kill(cutter._process.pid, signal.SIGSTOP)
        started = time.perf_counter()
        with pytest.raises(CutWorkerError, match=r"did not answer within 0\.5 s"):
            sim.step(40, tool=scalpel(0))
        assert time.perf_counter() - started >= 0.5
        assert not cutter._process.is_alive()  # given up: stopped
        with pytest.raises(CutWorkerError, match="did not answer"):
            sim.step(tool=scalpel(0))
    finally:
        sim.close()


def test_a_worker_that_dies_with_an_edit_in_flight_is_an_error_for_good():
    """The worker is frozen, an event is sent to it, then it is killed before it can answer:
    flushing raises 'died', and so does every later step (the replica is gone)."""
    model = TissueModel.from_patch((0.03, 0.02), 0.002)
    sim = Simulator(model, dt=1e-3, device=DEVICE, cutting=CutSettings(worker=True))
    cutter = sim.cutter
    try:
        sim.step(40, tool=scalpel(0))
        cutter.flush(sim)
        os.kill(cutter._process.pid, signal.SIGSTOP)
        k = _send_an_event(sim, 40)
        cutter._process.kill()
        cutter._process.join(timeout=10)
        with pytest.raises(CutWorkerError, match="died"):
            cutter.flush(sim)
        with pytest.raises(CutWorkerError, match="died"):
            sim.step(tool=scalpel(k))
    finally:
        sim.close()


def test_an_edit_that_fails_to_apply_stops_the_cut_for_good():
    """An edit the loop cannot apply (here one whose rows lack a column) leaves its model
    neither the replica's nor what it was: the step raises CutWorkerError naming the failure,
    and so does every later step, instead of cutting on a tissue that differs from the
    worker's."""
    model = TissueModel.from_patch((0.03, 0.02), 0.002)
    sim = Simulator(model, dt=1e-3, device=DEVICE, cutting=LAG_1)
    cutter = sim.cutter
    try:
        k = _send_an_event(sim)
        sim.step(tool=scalpel(k))  # max_lag 1: received now, applied at the next step
        assert cutter._received is not None
        _, summary = cutter._received
        broken = TableEdit(np.array([0]), {"points": np.zeros((1, 3))}, model.node_table.count)
        cutter._received = ([ModelEdit({"node_table": broken}, ModelChange.of(), 1)], summary)
        with pytest.raises(CutWorkerError, match="applying the cut worker's edit failed: ValueError"):
            sim.step(tool=scalpel(k + 1))
        with pytest.raises(CutWorkerError, match="applying"):
            sim.step(tool=scalpel(k + 2))
    finally:
        sim.close()


class _MovedEdit:
    """An edit whose new nodes have already been moved with their anchors (``positions_now``)."""

    def __init__(self, positions):
        self.positions = np.asarray(positions, dtype=np.float64)

    def positions_now(self, at_event, now):
        return self.positions.copy()


def test_new_nodes_land_outside_the_tool_as_it_is_when_the_edit_applies():
    """``arrival_positions``: a new node that would land inside the tool's cylinder (the tool
    has moved on since the event) is put on its surface, along the perpendicular from the axis;
    one outside stays where its anchors took it; without a tool nothing moves."""
    tool = Tool(p0=[0.0, 0.0, -0.005], p1=[0.0, 0.0, 0.005], radius=0.001)  # a vertical cylinder
    inside, outside = [0.0004, 0.0003, 0.0], [0.003, 0.0, 0.001]
    edits = [_MovedEdit([inside, outside]), _MovedEdit(np.zeros((0, 3)))]
    arrived = arrival_positions(edits, np.zeros((1, 3)), np.zeros((1, 3)), tool)
    np.testing.assert_allclose(arrived[0][0], [0.0008, 0.0006, 0.0], atol=1e-12)  # radius 1 mm along (4, 3)
    np.testing.assert_allclose(arrived[0][1], outside)
    assert arrived[1].shape == (0, 3)
    untouched = arrival_positions(edits, np.zeros((1, 3)), np.zeros((1, 3)), None)
    np.testing.assert_allclose(untouched[0], [inside, outside])
