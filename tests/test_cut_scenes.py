"""The bundled cutting scenes run with physics: the cut while the tissue moves under the tool.

tests/test_cutting.py drives cuts on a resting patch; here the scenes' tool cuts by itself
(``Cutter.after_step``). Runs are shrunk to keep the file fast: a smaller patch, or a shorter
stroke of the straight incision (same entry, blade angle and speed). What a run should do is
derived from the scene's keyframes: the blade goes into the skin along its own axis, draws
along x at 2 cm/s, and comes out along its axis.
"""

import math

import numpy as np
import pytest
from test_cutting import assert_open_slit

from warp_cut.cut.classes import NodeClass
from warp_cut.cut.curve.incision import polyline_distance
from warp_cut.cut.tolerances import FIRST_STATION, LAST_STATION, MIN_ADVANCE
from warp_cut.mesh.geometry import triangle_normals
from warp_cut.runner import run_scene
from warp_cut.scene import load_scene

SMALL = "tissue.size=[0.05,0.03]"
"""A 5 x 3 cm patch: the straight incision enters 7 mm inside its pinned border."""


class _Keep:
    """Run observer that keeps the simulator, for what metrics.json does not hold."""

    sim = None

    def on_frame(self, sim, frame):
        self.sim = sim

    def finish(self, metrics):
        pass


def run(scene):
    """(RunResult, the Simulator at the end) of a scene."""
    keep = _Keep()
    result = run_scene(scene, observers=[keep])
    return result, keep.sim


def axis_crossing(frame, z=0.0):
    """Where the tool's axis through keyframe ``frame`` crosses the plane at height z [m], (3,)."""
    s = (z - frame.p0[2]) / (frame.p1[2] - frame.p0[2])
    return frame.p0 + s * (frame.p1 - frame.p0)


def drawing(scene):
    """(start [s], end [s], length [m]) of the stretch over which a straight stroke's contact
    point moves. Going in (keyframe 0 -> 1) and out (2 -> 3) along its own axis, the axis
    crosses the skin at one point; between 1 and 2 the tool translates, so the crossing moves
    by the same vector at any skin height: a skin sagging under gravity shifts both ends of
    the cut alike, and the travel in the skin is that of the crossings with z = 0."""
    k = scene.tool.keyframes
    assert len(k) == 4
    for a, b in ((k[0], k[1]), (k[2], k[3])):
        np.testing.assert_allclose(axis_crossing(a), axis_crossing(b), atol=1e-8)
    np.testing.assert_allclose(k[2].p0 - k[1].p0, k[2].p1 - k[1].p1, atol=1e-8)  # a translation
    return k[1].t, k[2].t, float(np.linalg.norm(axis_crossing(k[2]) - axis_crossing(k[1])))


def _toml(v) -> str:
    return "[" + ",".join(repr(float(c)) for c in v) + "]"


def short_stroke(travel, overrides=()):
    """The bundled straight incision on the SMALL patch with its cut shortened to ``travel``
    [m] at the scene's own speed, blade angle and lift; the run ends 0.2 s after the blade is
    out. Returns (scene, drawing start [s], drawing end [s])."""
    base = load_scene("straight_incision")
    k = base.tool.keyframes
    t1, t2, length = drawing(base)
    speed = length / (t2 - t1)
    shift = (k[2].p0 - k[1].p0) * travel / length
    t_end = t1 + travel / speed
    frames = [(k[0].t, k[0].p0, k[0].p1), (t1, k[1].p0, k[1].p1),
              (t_end, k[1].p0 + shift, k[1].p1 + shift),
              (t_end + k[3].t - k[2].t, k[3].p0 - k[2].p0 + k[1].p0 + shift, k[3].p1 - k[2].p1 + k[1].p1 + shift)]
    keys = ",".join(f"{{t={t!r},p0={_toml(p0)},p1={_toml(p1)}}}" for t, p0, p1 in frames)
    scene = load_scene("straight_incision", [SMALL, f"duration={frames[-1][0] + 0.2!r}",
                                             f"tool.keyframes=[{keys}]", *overrides])
    return scene, t1, t_end


# ------------------------------------------------------------------ when the cut starts
def test_force_threshold_above_the_uncut_peak_makes_no_incision():
    """``cutting.force_threshold``: an incision starts only once |tool force| reaches it. A run
    whose threshold is never reached cuts nothing, so it is the run without cutting, step for
    step; a threshold 10 % above the largest force that run sees is then never reached (its
    peak is measured here, and the held run must see the same). With 0, any contact cuts."""
    shrunk = [SMALL, "duration=0.6"]
    uncut = run_scene(load_scene("straight_incision", [*shrunk, "physics.cutting=false"])).metrics
    peak = uncut["max_tool_force_n"]
    assert peak > 0
    held = run_scene(load_scene("straight_incision", [*shrunk, f"cutting.force_threshold={1.1 * peak!r}"])).metrics
    assert held["cut"]["incisions"] == 0 and held["cut"]["events"] == 0 and held["cut"]["deleted_nodes"] == 0
    assert held["max_tool_force_n"] == pytest.approx(peak, rel=1e-6)
    free = run_scene(load_scene("straight_incision", [*shrunk, "cutting.force_threshold=0"])).metrics
    assert free["cut"]["incisions"] == 1 and free["cut"]["events"] > 0


def tilt_of(frame) -> float:
    """Angle [deg] between the tool's axis at keyframe ``frame`` and the skin's plane z = 0."""
    axis = (frame.p1 - frame.p0) / np.linalg.norm(frame.p1 - frame.p0)
    return math.degrees(math.asin(abs(axis[2])))


def blade_travel_per_event(cutting, speed, spacing) -> float:
    """How far [m] a blade drawn at ``speed`` [m/s] along the skin moves between due cut
    events under ``cutting`` (CutSettings), lip spacing ``spacing`` [m]: ``speed x interval`` on
    the clock, the travel itself by travel."""
    interval, distance = cutting.event_rule(spacing)
    return speed * interval if distance is None else distance


def events_while_drawing(travel, per_event, spacing, radius, tilt_deg):
    """Cut events a straight stroke makes while its blade draws ``travel`` [m] through the skin,
    ``per_event`` [m] between due events (``blade_travel_per_event``), a tool of ``radius`` [m]
    whose axis stands ``tilt_deg`` from the skin, station spacing ``spacing`` [m].

    An event extends the incision only once the blade has advanced ``MIN_ADVANCE`` spacings
    along the rest curve since the last one: every k = ceil(MIN_ADVANCE s / per_event) due
    events. The slit's tip stays r / sin(tilt) + s / 4 behind the blade while it cuts
    (``Cutter._behind_the_blade``), and from its start the slit opens once it holds its first
    lip pair: its first station ``FIRST_STATION`` s from the start, ``LAST_STATION`` s behind
    the tip. So the first event that cuts comes once the blade has drawn behind + (FIRST_STATION
    + LAST_STATION) s, then one every k due events; when the blade leaves, one more cuts the
    slit to its end: (travel - behind - (FIRST_STATION + LAST_STATION) s) / (k per_event) + 1,
    give or take one at each end (the phase of the events against the drawing's start and end)."""
    k = math.ceil(MIN_ADVANCE * spacing / per_event - 1e-9)
    behind = radius / math.sin(math.radians(tilt_deg)) + 0.25 * spacing
    return (travel - behind - (FIRST_STATION + LAST_STATION) * spacing) / (k * per_event) + 1.0


@pytest.mark.parametrize("setting", [
    "cutting.interval=0.05",
    "cutting.interval=0.0166667",  # one event per 60 fps frame: the blade moves 1/3 mm, an extension every 2 frames
    "cutting.travel=0.3",  # 0.6 mm: an extension at every event
    "cutting.travel=1.0",  # the default: one lip spacing
])
def test_cut_events_follow_the_interval_or_the_travel(setting):
    """``cutting.interval`` / ``cutting.travel``: the events of a 2 cm stroke drawn at 2 cm/s
    (1 s) are those ``events_while_drawing`` counts: one per due event where the blade moves
    MIN_ADVANCE spacings (0.5 mm) in one (50 ms: 1 mm; by travel 0.6 and 2 mm), one per two
    where it needs two (1/60 s: 1/3 mm), less those before the slit behind the blade (r / sin
    60 deg + s / 4) holds its first lip pair, plus the one that cuts to the end when the blade
    leaves; +- 2 for the phase at both ends. Going in and out along its axis the blade does not
    move the crossing (by travel those events fall due, but cut nothing)."""
    scene, start, end = short_stroke(0.02, [setting])
    m = run_scene(scene).metrics
    speed = drawing(scene)[2] / (end - start)
    spacing = scene.tissue.spacing
    expected = events_while_drawing(0.02, blade_travel_per_event(scene.cutting, speed, spacing), spacing,
                                    scene.tool.radius, tilt_of(scene.tool.keyframes[1]))
    ran = m["cut"]["events"] + m["cut"]["skipped_events"]  # a skipped event ran: its slit did not fit yet
    assert abs(ran - expected) <= 2, (m["cut"], expected)
    assert m["cut"]["incisions"] == 1


# ------------------------------------------------------------------ every integrator
@pytest.mark.parametrize("integrator", ["semi_implicit", "implicit_euler", "xpbd"])
def test_every_integrator_cuts_one_open_incision(integrator):
    """A 1 cm stroke under each integrator: the run is finite, the mesh valid, one stroke is
    one incision with no hole left, and it covers >= 90 % of the tool's path in the skin. Its
    ends are where the blade crossed the skin going in and coming out, both along its axis:
    the first crossing lies on the axis of the drawing's first pose, the last on that of its
    last pose (to 1 um; the incision stopped 0.46 mm short of it under XPBD while its last
    crossings had to advance ``MIN_ADVANCE`` spacings), and its rest length is the distance
    between them within 5 %. Under XPBD the unsupported skin sags 1.3-3.2 mm under the tool,
    so the 60 degree blade meets it up to 1.9 mm further on: 11 mm for 10 mm of travel."""
    # XPBD's one iteration per substep holds a spring at k / (1 + k h^2 (n_i w_i + n_j w_j)):
    # at one 1 ms substep (its stable "auto") that is 1/275 of the stiffest spring here, a
    # jelly the blade pushes ahead of itself; at 8 substeps 1/5 (docs/model.md)
    accuracy = ["solver.substeps=8"] if integrator == "xpbd" else []
    scene, _, _ = short_stroke(0.01, [f'solver.integrator="{integrator}"', *accuracy])
    start, end, travel = drawing(scene)
    assert travel / (end - start) == pytest.approx(0.02)  # the scene's 2 cm/s
    result, sim = run(scene)
    m = result.metrics
    assert m["finite"] and m["mesh"]["valid"], m["mesh"]["problems"]
    assert m["cut"]["incisions"] == 1 and m["cut"]["unfilled_holes"] == 0, m["cut"]
    assert m["incision"]["coverage"] >= 0.9, m["incision"]
    inc = sim.cutter.incisions[0]
    first, last = np.asarray(inc.contact_path[0]), np.asarray(inc.contact_path[-1])
    keys = scene.tool.keyframes
    assert distance_from_axis(first, keys[1]) < 1e-6 and distance_from_axis(last, keys[2]) < 1e-6
    assert m["incision"]["length_m"] == pytest.approx(np.linalg.norm(last - first), rel=0.05)
    assert_open_slit(sim, inc)


def distance_from_axis(point, frame) -> float:
    """Distance [m] of ``point`` (3,) from the line of the tool's axis in keyframe ``frame``."""
    axis = (frame.p1 - frame.p0) / np.linalg.norm(frame.p1 - frame.p0)
    d = np.asarray(point) - frame.p0
    return float(np.linalg.norm(d - (d @ axis) * axis))


# ------------------------------------------------------------------ the whole straight incision
@pytest.fixture(scope="module")
def straight():
    """The bundled straight incision (4 cm cut) on a 6 x 3 cm patch, to its end (3 s): (RunResult,
    Simulator, scene)."""
    scene = load_scene("straight_incision", ["tissue.size=[0.06,0.03]"])
    result, sim = run(scene)
    return result, sim, scene


def test_straight_incision_width_rises_then_settles_lower(straight):
    """The width-time curve (paper Fig. 6): the incision opens (its lips, one tissue before,
    stay apart once the tool is out), and settles lower: after the tool is out nothing drives
    the width any more, so over the last 0.3 s of the run it changes less than over the last
    0.3 s the blade drew, and it ends below its peak."""
    result, sim, scene = straight
    t, w = result.columns["t"], result.columns["incision_width_m"]
    k = scene.tool.keyframes
    out = t >= k[3].t  # the blade lifted out of the skin
    assert np.all(w[out] > 0.0)
    last = w[np.searchsorted(t, t[-1] - 0.3)], w[-1]
    drawing_end = w[np.searchsorted(t, k[2].t - 0.3)], w[np.searchsorted(t, k[2].t)]
    assert abs(last[1] - last[0]) < abs(drawing_end[1] - drawing_end[0]), (last, drawing_end)
    plateau = w[t >= t[-1] - 0.3].mean()
    assert plateau < np.nanmax(w)


def test_straight_incision_leaves_one_incision(straight):
    """After the stroke: a valid mesh, one incision with no hole, covering the tool's path, as
    long as the blade's 4 cm travel (``drawing``) within one station spacing (each end is
    where the axis crossed the dented skin)."""
    result, sim, scene = straight
    m = result.metrics
    assert m["finite"] and m["mesh"]["valid"], m["mesh"]["problems"]
    assert m["cut"]["incisions"] == 1 and m["cut"]["unfilled_holes"] == 0, m["cut"]
    assert m["incision"]["coverage"] >= 0.9
    _, _, travel = drawing(scene)
    assert abs(m["incision"]["length_m"] - travel) <= sim.cutter.spacing


def test_straight_incision_leaves_an_open_slit(straight):
    """After the stroke the slit is open along its whole length (``assert_open_slit``)."""
    _, sim, _ = straight
    assert_open_slit(sim, sim.cutter.incisions[0])


def test_straight_incision_makes_no_sliver(straight):
    """SPEC section 4: no triangle the cut made has an angle below 10 deg."""
    result, _, _ = straight
    assert result.metrics["mesh"]["slivers"] == 0, result.metrics["mesh"]


# ------------------------------------------------------------------ the curved incision
@pytest.fixture(scope="module")
def curved():
    """The bundled S-shaped incision (+-8 mm in y) on a 6 x 3 cm patch, run until 0.1 s after
    the blade is out: (RunResult, Simulator, scene)."""
    scene = load_scene("curved_incision", ["tissue.size=[0.06,0.03]", "duration=2.5"])
    result, sim = run(scene)
    return result, sim, scene


def test_curved_incision_follows_the_tool(curved):
    """Valid mesh, one incision, no hole, >= 90 % coverage, and lips near the tool's contact
    path.

    Bound: a station's lip is made lip_offset off the curve, which lies within ``tolerance`` of
    the contact path; the slit's edge between two stations' lips is a chord of its lip line
    (the fill may put nodes on it, lips too), which on the inner side of a bend of radius R
    lies up to the sagitta c^2 / (8 (R - lip_offset)) farther from the curve, c the chord
    (at most a spacing). The S-curve y = 8 mm sin(pi x / 2 cm) bends most at its crests,
    R = (2 cm / pi)^2 / 8 mm = 5.1 mm: 0.09 mm. So where a lip is made (its rest position) it is
    within lip_offset + tolerance + sagitta of the path. Afterwards it moves with the tissue;
    the only in-plane loads are the tool, which pushes no node farther than its radius r out of
    its way (to the cylinder's surface, half a spacing here), and the residual links, which
    pull the lips towards the other side, i.e. towards the path. So max_deviation_m <=
    lip_offset + tolerance + sagitta + r.
    """
    result, sim, scene = curved
    m = result.metrics
    assert m["finite"] and m["mesh"]["valid"], m["mesh"]["problems"]
    assert m["cut"]["incisions"] == 1 and m["cut"]["unfilled_holes"] == 0, m["cut"]
    assert m["incision"]["coverage"] >= 0.9
    model, inc = sim.model, sim.cutter.incisions[0]
    radius = (0.02 / np.pi) ** 2 / 0.008
    sagitta = inc.spacing ** 2 / (8.0 * (radius - inc.lip_offset))
    lips = np.flatnonzero(model.active & (model.node_class == NodeClass.LIP))
    made = polyline_distance(model.points[lips], np.asarray(inc.path))
    assert made.max() <= inc.lip_offset + inc.tolerance + sagitta, (lips[np.argmax(made)], made.max())
    bound = inc.lip_offset + inc.tolerance + sagitta + scene.tool.radius
    assert m["incision"]["max_deviation_m"] <= bound
    assert m["incision"]["max_deviation_3d_m"] >= m["incision"]["max_deviation_m"] - 1e-12


def test_curved_incision_leaves_an_open_slit(curved):
    """After the stroke the slit is open along its whole length (``assert_open_slit``)."""
    _, sim, _ = curved
    assert_open_slit(sim, sim.cutter.incisions[0])


def test_the_blade_cuts_the_material_it_passes_through_where_the_tool_pushes_it_ahead():
    """The curved incision without residual stress: the scalpel pushes the skin in front of it
    up its tilted shaft and off the path (2 mm aside, 1.2 mm up, where a cut decided on the
    deformed skin once missed it). The cut is decided in the rest shape, where the blade's
    crossings are carried: every node of the tissue as built (the slots below the built
    model's node count: the node table only appends; the cut's own nodes, lips and the fill's,
    lie on the slit's lips or beside them) whose rest position lies within 0.4 tool radii of
    the path the axis takes through the rest surface (z = 0) is gone, no hole is left, and the
    opened incision covers the path."""
    scene = load_scene("curved_incision", ["physics.residual_stress=false"])
    built = scene.build_model().node_count
    result, sim = run(scene)
    m = result.metrics
    assert m["mesh"]["valid"], m["mesh"]["problems"]
    assert m["cut"]["incisions"] == 1 and m["cut"]["unfilled_holes"] == 0, m["cut"]
    assert m["incision"]["coverage"] >= 0.95
    path, model = scene.tool_path(), sim.model
    keys = scene.tool.keyframes
    trace = np.array([axis_crossing(path.pose_at(t)) for t in np.linspace(keys[1].t, keys[-2].t, 400)])
    original = np.arange(built)
    near = original[polyline_distance(model.points[original], trace) < 0.4 * scene.tool.radius]
    assert len(near) > 5
    assert not model.active[near].any(), near[model.active[near]]


# ------------------------------------------------------------------ cut in the background
def test_a_run_cutting_in_the_background_makes_the_in_loop_incision():
    """``run_scene(cut_in_background=True)`` (``warp-cut run --cut-in-background``): the 1 cm
    stroke cut by a worker while the loop is paced at real time. The edits land two steps
    after their events (``max_lag`` 1, so the wound does not hang on the machine's load), yet
    it is the same wound: one incision, no hole left, coverage >= 0.9, the length of the
    in-loop run's within two spacings; the run is paced (no faster than real time) and its
    worker is gone at the end."""
    scene, _, _ = short_stroke(0.01)
    loop = run_scene(scene).metrics
    keep = _Keep()
    bg = run_scene(scene, cut_in_background=True, max_lag=1, observers=[keep]).metrics
    assert bg["cut"]["incisions"] == 1 and bg["cut"]["unfilled_holes"] == 0
    assert bg["incision"]["coverage"] >= 0.9
    assert abs(bg["incision"]["length_m"] - loop["incision"]["length_m"]) <= 2 * scene.tissue.spacing
    assert bg["mesh"]["valid"] and bg["width_curve"]["peak_m"] > 0
    assert bg["realtime_factor"] <= 1.0 + 1e-3
    assert not keep.sim.cutter._process.is_alive()


# ------------------------------------------------------------------ the skin settled after a multi-stroke cut
def test_the_forearm_t_leaves_no_triangle_folded_over_once_the_skin_has_settled():
    """The bundled T round the forearm ends 0.5 s after the tool has gone: no triangle then
    faces against its rest shape (current normal against rest normal; as a membrane, without
    ``physics.bending``, two of the cut's did), the run is finite, the mesh valid, and the T
    is two incisions with no hole."""
    scene = load_scene("forearm_t_incision")
    assert scene.physics.bending
    result, sim = run(scene)
    m = result.metrics
    assert m["finite"] and m["mesh"]["valid"], m["mesh"]["problems"]
    assert m["cut"]["incisions"] == 2 and m["cut"]["unfilled_holes"] == 0, m["cut"]
    model = sim.model
    now, rest = triangle_normals(sim.positions, model.triangles), triangle_normals(model.points, model.triangles)
    facing = np.einsum("ij,ij->i", now, rest)
    assert (facing > 0.0).all(), np.flatnonzero(facing <= 0.0)
