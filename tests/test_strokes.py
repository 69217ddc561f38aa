"""warp_cut/sim/strokes.py and stroke_quality.py: tool poses drawing a path on a surface, and
the coverage measure.

The slivers among the triangles a stroke made (``new_slivers``, ``new_rest_slivers``) are
checked on a hand-built mesh whose angles are known.

Poses are checked against the definition (axis through the surface point, tilted by alpha from
the tangent plane, leaning back against the travel, tip ``depth`` below the tangent plane),
against closed-form traces (a circle around a cylinder, a geodesic over a dome), and the start
pose against the Simulator's own inside test. Coverage is checked on cuts made through the
Cutter's API at rest, where the answer is known (1 on the cut, 0 beside it, 1/2 for a stroke
twice as long).
"""

import math

import numpy as np
import pytest
import warp as wp
from conftest import DEVICE

import warp_cut as wc
from warp_cut.cut.tolerances import MIN_ANGLE_DEG
from warp_cut.mesh import surfaces as S
from warp_cut.sim import strokes as K
from warp_cut.verify.stroke_check import coverage_tolerance
from warp_cut.verify.stroke_quality import (
    _over_skin,
    coverage,
    new_rest_edges,
    new_rest_slivers,
    new_slivers,
    original_border,
    skin_at_rest,
    wound_edges,
)

H = 0.002


def check_pose_geometry(stroke, surf, times):
    for t in times:
        tool = stroke.pose(t)
        a = (tool.p1 - tool.p0) / np.linalg.norm(tool.p1 - tool.p0)
        s = stroke.speed * (t - stroke.t_in)
        p, n, tangent = (np.array([np.interp(s, stroke.arclength, v[:, c]) for c in range(3)])
                         for v in (stroke.trace, stroke.normals, stroke.tangents))
        assert math.asin(np.clip(a @ n, -1, 1)) == pytest.approx(stroke.tilt, abs=2e-3)
        assert a @ tangent == pytest.approx(-math.cos(stroke.tilt), abs=2e-3)  # leans back
        closest = tool.p0 + ((p - tool.p0) @ a) * a
        assert np.linalg.norm(closest - p) < 2e-6  # the axis passes through the surface point
        assert (p - tool.p0) @ n == pytest.approx(stroke.depth, rel=2e-3)  # tip depth below the plane
        assert tool.radius == stroke.radius


def test_line_on_a_turned_grid():
    surf = S.flat_grid(0.04, H, angle=0.3)
    stroke = K.Stroke(surf, K.line([-0.01, 0.002], 0.2, 0.02), tilt=math.radians(50), radius=0.001,
                      depth=0.003, speed=0.02)
    assert stroke.length == pytest.approx(0.02, rel=1e-9)
    np.testing.assert_allclose(stroke.trace[-1], [-0.01 + 0.02 * math.cos(0.2), 0.002 + 0.02 * math.sin(0.2), 0])
    assert stroke.t_travel == pytest.approx(1.0)
    check_pose_geometry(stroke, surf, np.linspace(stroke.t_in, stroke.t_in + stroke.t_travel, 7))


def test_circle_around_a_cylinder():
    """A path along v on the cylinder is a circle of the cylinder's radius; the tool follows
    the surface: the same tilt to the local tangent plane all the way round."""
    r = 0.03
    surf = S.cylinder(r, 0.04, math.radians(150), H)
    stroke = K.Stroke(surf, K.line([0.0, -0.0235], math.pi / 2, 0.047), tilt=math.radians(60),
                      radius=0.001, depth=0.003, speed=0.02)
    np.testing.assert_allclose(np.hypot(stroke.trace[:, 1], stroke.trace[:, 2] + r), r, atol=1e-12)
    assert stroke.length == pytest.approx(0.047, rel=1e-5)  # the chart is an isometry
    check_pose_geometry(stroke, surf, np.linspace(stroke.t_in, stroke.t_in + stroke.t_travel, 9))


def test_geodesic_over_a_dome():
    """A line through the apex of the polar chart is a great circle: arc length = chart length."""
    rc = 0.04
    surf = S.dome(rc, 0.03, H)
    stroke = K.Stroke(surf, K.line([-0.02, 0.0], 0.0, 0.04), tilt=math.radians(45), radius=0.001,
                      depth=0.002, speed=0.02)
    assert stroke.length == pytest.approx(0.04, rel=1e-5)
    np.testing.assert_allclose(stroke.trace[:, 1], 0.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(stroke.trace + [0, 0, rc], axis=1), rc, atol=1e-12)
    check_pose_geometry(stroke, surf, np.linspace(stroke.t_in, stroke.t_in + stroke.t_travel, 9))


def test_vertical_tool_and_phases():
    surf = S.saddle(0.04, 25.0, H)
    stroke = K.Stroke(surf, K.arc([-0.005, 0.0], 0.0, 0.012, 0.01), tilt=math.pi / 2, radius=0.0005,
                      depth=0.002, speed=0.01)
    p0, a = stroke.tip(stroke.t_in + 0.3)
    assert a @ stroke.normals[0] <= 1.0 and np.isclose(np.linalg.norm(a), 1.0)
    # continuous at the phase changes, outside the tissue at both ends
    for t in (stroke.t_in, stroke.t_in + stroke.t_travel):
        np.testing.assert_allclose(stroke.tip(t - 1e-9)[0], stroke.tip(t + 1e-9)[0], atol=1e-9)
    for t in (0.0, stroke.duration):
        tool = stroke.pose(t)
        assert not K.inside_cylinder(surf.points, tool.p0, tool.p1, tool.radius).any()
    assert surf.offset(stroke.pose(0.0).p0[None])[0] > 0 and surf.offset(stroke.pose(stroke.duration).p0[None])[0] > 0


def test_start_pose_passes_the_simulators_check():
    surf = S.dome(0.03, 0.025, H)
    stroke = K.Stroke(surf, K.line([-0.01, 0.0], 0.0, 0.02), tilt=math.radians(30), radius=0.004,
                      depth=0.004, speed=0.02)
    sim = wc.Simulator(wc.TissueModel.from_surface(surf), dt=1e-3, gravity=None, device=DEVICE)
    sim.check_tool_outside(stroke.pose(0.0))  # raises ToolStartsInside if not
    inside = sim.check_tool_outside
    with pytest.raises(wc.ToolStartsInside):
        inside(stroke.pose(stroke.t_in))  # the tip is in the tissue at the end of the plunge


def test_inside_cylinder_matches_the_collision_kernel(rng):
    pts = rng.uniform(-0.01, 0.01, (500, 3))
    for _ in range(5):
        p0, p1 = rng.uniform(-0.01, 0.01, 3), rng.uniform(-0.01, 0.01, 3)
        r = rng.uniform(0.001, 0.005)
        want = wc.cylinder_contacts(pts, p0, p1, r, DEVICE)
        got = K.inside_cylinder(pts.astype(np.float32).astype(np.float64), p0, p1, r)
        assert (got == want).mean() > 0.99  # float32 kernel vs float64: only boundary cases differ


def test_tool_path_keyframes_match_the_poses():
    surf = S.flat_grid(0.04, H)
    stroke = K.Stroke(surf, K.zigzag([-0.008, 0.0], 0.0, 0.016, 0.002, 0.008), tilt=math.radians(60),
                      radius=0.001, depth=0.002, speed=0.02)
    path = stroke.tool_path(1e-3)
    for t in np.linspace(0, stroke.duration, 37):
        np.testing.assert_allclose(path.pose_at(t).p0, stroke.pose(t).p0, atol=2e-6)


def test_path_shapes():
    arc = K.arc([0.0, 0.0], 0.0, math.pi * 0.01, 0.01)  # half a circle of radius 1 cm, turning left
    np.testing.assert_allclose(np.linalg.norm(arc.uv - [0.0, 0.01], axis=1), 0.01, atol=1e-12)
    np.testing.assert_allclose(arc.uv[-1], [0.0, 0.02], atol=1e-12)
    assert arc.length == pytest.approx(math.pi * 0.01, rel=1e-5)  # chords of 0.1 mm
    zz = K.zigzag([0.0, 0.0], 0.0, 0.03, 0.002, 0.01)
    assert zz.uv[0] == pytest.approx([0.0, 0.0])
    assert np.abs(zz.uv[:, 1]).max() <= 0.002 and np.abs(zz.uv[:, 1]).max() > 0.0015
    crossings = np.sum(np.diff(np.sign(zz.uv[1:, 1])) != 0)  # three wavelengths: ~6 zero crossings
    assert 5 <= crossings <= 7


def test_paths_leaving_the_mesh_are_refused():
    surf = S.flat_grid(0.02, H)
    with pytest.raises(wc.InputError):
        K.Stroke(surf, K.line([0.0, 0.0], 0.0, 0.02), tilt=1.0, radius=0.001, depth=0.002, speed=0.01)
    with pytest.raises(wc.InputError):
        K.Stroke(surf, K.line([0.0, 0.0], 0.0, 0.005), tilt=0.0, radius=0.001, depth=0.002, speed=0.01)


# ---------------------------------------------------------------- coverage on known cuts
@pytest.fixture(scope="module")
def straight_cut():
    """A 12 mm cut along y = 0.7 mm on a resting turned grid, made through the Cutter's API."""
    wp.init()
    surf = S.flat_grid(0.03, H, angle=0.2)
    model = wc.TissueModel.from_surface(surf)
    sim = wc.Simulator(model, dt=1e-3, gravity=None, device=DEVICE, cutting=wc.CutSettings())
    border = original_border(model)
    a, b = np.array([-0.006, 0.0007, 0.0]), np.array([0.006, 0.0007, 0.0])
    sim.cutter.start_incision(sim, a, [0, 0, 1], 0.001)
    for k in range(1, 41):
        sim.cutter.extend_incision(sim, a + (b - a) * k / 40)
    sim.cutter.end_incision(sim)
    return surf, model, border


def stroke_on(surf, start, length):
    return K.Stroke(surf, K.line(start, 0.0, length), tilt=1.0, radius=0.001, depth=0.002, speed=0.01)


@pytest.mark.parametrize("start, length, want, tol", [
    ([-0.006, 0.0007], 0.012, 1.0, 0.0),      # the cut itself
    ([-0.006, 0.0017], 0.012, 1.0, 0.0),      # 1 mm beside it (tol 1.25 mm): the slit is within reach
    ([-0.006, 0.0047], 0.012, 0.0, 0.0),      # 4 mm beside it: intact skin
    ([-0.012, 0.0007], 0.024, 0.5, 0.05),     # twice as long: half open
])
def test_coverage_on_a_known_cut(straight_cut, start, length, want, tol):
    surf, model, border = straight_cut
    wound = wound_edges(model, border)
    assert len(wound) > 0
    got = coverage(stroke_on(surf, start, length), surf, model.points, wound, coverage_tolerance(H, 0.001),
                   skin_at_rest(model, surf))
    assert got == pytest.approx(want, abs=tol)


def test_coverage_leaves_out_the_trace_over_an_opening(straight_cut):
    """With the skin at the stroke's start given, a trace along the finished cut (over its slit:
    no triangle lies between the lips at rest) has no skin under it (nan); one beside the cut
    is all over skin and counts as before; one along the cut running 4 mm past each of its
    ends counts only its samples beyond the ends (the 12 mm in the slit, 0.6 of it, are
    covered without the skin), and none of them is open: past a slit's end the segment across
    the trace runs over intact skin.

    One crossing the cut (samples every s / 20 = 0.1 mm, placed 0.05 mm off the lip lines at
    y = 0.7 +- lip_offset = 0.45, 0.95 mm) has the slit's opening within reach only at the 5
    samples between the lips: the segment across each other sample runs parallel to the slit,
    over skin. With the skin at its start it leaves those 5 out (0 of 95); without, they are
    the covered ones (5 of 100)."""
    surf, model, border = straight_cut
    wound, tol = wound_edges(model, border), coverage_tolerance(H, 0.001)
    now = skin_at_rest(model, surf)
    assert np.isnan(coverage(stroke_on(surf, [-0.005, 0.0007], 0.010), surf, model.points, wound, tol, now, now))
    beside = stroke_on(surf, [-0.006, 0.0047], 0.012)
    assert coverage(beside, surf, model.points, wound, tol, now, now) == coverage(beside, surf, model.points,
                                                                                wound, tol, now)
    overhang = stroke_on(surf, [-0.010, 0.0007], 0.020)
    assert coverage(overhang, surf, model.points, wound, tol, now) == pytest.approx(0.6, abs=0.01)
    assert coverage(overhang, surf, model.points, wound, tol, now, now) == 0.0
    across = K.Stroke(surf, K.line([0.0, -0.00405], np.pi / 2, 0.010), tilt=1.0, radius=0.001, depth=0.002, speed=0.01)
    assert tol == pytest.approx(0.00125)
    assert coverage(across, surf, model.points, wound, tol, now, now) == 0.0
    assert coverage(across, surf, model.points, wound, tol, now) == pytest.approx(5 / 100)


def test_coverage_counts_only_openings_the_stroke_made(straight_cut):
    """The finished cut is an earlier wound when the stroke begins (its skin then is the skin
    now): a trace 1 mm beside it, within reach of its opening, is not open; a trace on intact
    skin that once was skin and is now an opening (here: the skin before the cut, given as the
    skin at the start) is."""
    surf, model, border = straight_cut
    wound, tol = wound_edges(model, border), coverage_tolerance(H, 0.001)
    now = skin_at_rest(model, surf)
    beside = stroke_on(surf, [-0.006, 0.0017], 0.012)
    assert coverage(beside, surf, model.points, wound, tol, now, now) == 0.0
    whole = skin_at_rest(wc.TissueModel.from_surface(surf), surf)
    assert coverage(beside, surf, model.points, wound, tol, now, whole) == 1.0


def test_points_over_skin():
    """Inside, on an edge and on a corner of a triangle count; beyond it, and inside a second
    triangle wound the other way, as expected."""
    skin = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], [[2.0, 0.0], [2.0, 1.0], [3.0, 0.0]]])
    points = np.array([[0.2, 0.2], [0.5, 0.5], [0.0, 0.0], [0.6, 0.6], [2.2, 0.2], [1.5, 0.2], [-0.1, 0.5]])
    np.testing.assert_array_equal(_over_skin(points, skin), [True, True, True, False, True, False, False])


def test_uncut_tissue_has_no_wound():
    surf = S.flat_grid(0.03, H)
    model = wc.TissueModel.from_surface(surf)
    assert len(wound_edges(model, original_border(model))) == 0


def test_a_closed_tube_lies_flat_in_the_parameter_plane():
    """A closed cylinder's triangles in the parameter plane (``in_plane``): once unwrapped, their
    areas add up to the tube's (length x circumference; a triangle across the seam stretched over
    the whole plane would add a circumference's worth), and every point of the plane's period,
    the seam's two sides included, lies over one of them (a triangle reaching past the seam is
    repeated one period over). Jittered: nodes lie on both sides of the seam."""
    radius, length = 0.01, 0.03
    surf = S.cylinder(radius, length, 2 * np.pi, H, jitter=0.4, seed=3)
    model = wc.TissueModel.from_surface(surf)
    skin = skin_at_rest(model, surf)
    t = len(model.triangles)
    assert len(skin) > t  # a triangle across the seam once more
    e1, e2 = skin[:t, 1] - skin[:t, 0], skin[:t, 2] - skin[:t, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    period = 2 * np.pi * radius
    assert area == pytest.approx(length * period, rel=1e-9)
    u, v = np.meshgrid(np.linspace(-0.49 * length, 0.49 * length, 25), np.linspace(-0.5, 0.5, 81) * period)
    assert _over_skin(np.column_stack([u.ravel(), v.ravel()]), skin).all()


# ---------------------------------------------------------------- slivers among the triangles a stroke made
def test_new_slivers_at_rest_and_as_the_skin_lies():
    """Three triangles (A-B 1 cm): slot 0 the tissue's (an 11.3 deg sliver at rest, left out: made
    before the stroke), slot 1 the stroke's (15 deg at A at rest, 5 deg once C has moved towards
    A-B), slot 2 the stroke's (3 deg at E at rest, deleted: left out). At rest the stroke's live
    triangle is under the cut's 20 deg, not under 10 deg; as the skin lies it is under 10 deg."""
    L = 0.01
    h = L * math.tan(math.radians(15.0))
    a, b, c, d = [0.0, 0.0, 0.0], [L, 0.0, 0.0], [L, h, 0.0], [0.5 * L, -0.1 * L, 0.0]
    e = [L + 0.5 * h / math.tan(math.radians(1.5)), 0.5 * h, 0.0]  # B-E-C: 3 deg at E
    model = wc.TissueModel.from_triangles([a, b, c, d, e], [[0, 3, 1], [0, 1, 2], [1, 4, 2]])
    model.triangle_table.kill([2])
    now = model.points.copy()
    now[2, 1] = L * math.tan(math.radians(5.0))
    assert MIN_ANGLE_DEG == 20.0
    assert new_rest_slivers(model, 1) == (1, pytest.approx(15.0, abs=1e-9))
    assert new_slivers(model, now, 1) == (1, pytest.approx(5.0, abs=1e-9))
    assert new_slivers(model, model.points, 1) == (0, pytest.approx(15.0, abs=1e-9))  # 10 deg by default
    assert new_rest_slivers(model, 0) == (2, pytest.approx(math.degrees(math.atan(0.2)), abs=1e-9))
    count, angle = new_rest_slivers(model, 3)
    assert count == 0 and math.isnan(angle)


def test_small_triangles_among_those_a_stroke_made():
    """Slot 0 the tissue's (left out), slot 1 the stroke's with edges 2, 1 and sqrt(5) mm,
    slot 2 the stroke's with a 0.3 mm edge, slot 3 the stroke's with a 0.1 mm edge but deleted:
    on a 2 mm spacing the shortest rest edge is 0.15 spacing, one triangle under 0.2."""
    s = 0.002
    pts = [[0, 0, 0], [0.002, 0, 0], [0, 0.001, 0], [0.0023, 0, 0], [0.0021, -0.002, 0],
           [0.004, 0.004, 0], [0.0041, 0.004, 0], [0.004, 0.006, 0], [-0.002, -0.002, 0]]
    model = wc.TissueModel.from_triangles(pts, [[0, 8, 1], [0, 1, 2], [1, 4, 3], [5, 6, 7]])
    model.triangle_table.kill([3])
    count, shortest = new_rest_edges(model, 1, s)
    assert count == 1 and shortest == pytest.approx(0.0003 / s, rel=1e-9)
    assert new_rest_edges(model, 2, s) == (1, pytest.approx(0.15, rel=1e-9))
    count, shortest = new_rest_edges(model, 4, s)
    assert count == 0 and math.isnan(shortest)
