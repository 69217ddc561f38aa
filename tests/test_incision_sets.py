"""warp_cut/verify/incision_sets.py and lowered_entry.py: the multi-stroke incisions have the
geometry their names promise (checked on the strokes' 3D traces against closed forms), and a
tool lowered onto a stroke's start comes straight down along the normal from outside the tissue,
tilted as the stroke says, into the stroke's own travel."""

import math

import numpy as np
import pytest

from warp_cut.mesh import surfaces
from warp_cut.sim.strokes import inside_cylinder
from warp_cut.verify import incision_sets as I
from warp_cut.verify.lowered_entry import LoweredStroke

FLAT = surfaces.flat_grid(0.05, 0.002)
CYLINDER = surfaces.cylinder(0.03, 0.06, math.radians(150.0), 0.002)


def at_length(stroke, s: float):
    """(point, travel tangent) of a stroke's trace at arc length s [m]."""
    p = np.array([np.interp(s, stroke.arclength, stroke.trace[:, c]) for c in range(3)])
    t = np.array([np.interp(s, stroke.arclength, stroke.tangents[:, c]) for c in range(3)])
    return p, t / np.linalg.norm(t)


@pytest.mark.parametrize("surface", [FLAT, CYLINDER], ids=["flat", "cylinder"])
def test_t_starts_at_the_first_strokes_midpoint_and_runs_perpendicular(surface):
    first, second = I.t_set(surface, heading=0.4).strokes
    middle, along = at_length(first, first.length / 2)
    assert np.linalg.norm(second.trace[0] - middle) < 1e-6
    assert abs(along @ second.tangents[0]) < 2e-3
    assert second.length == pytest.approx(0.012, rel=2e-3)


@pytest.mark.parametrize("surface", [FLAT, CYLINDER], ids=["flat", "cylinder"])
def test_x_strokes_cross_at_their_midpoints_at_right_angles(surface):
    a, b = I.x_set(surface, heading=0.4).strokes
    pa, ta = at_length(a, a.length / 2)
    pb, tb = at_length(b, b.length / 2)
    assert np.linalg.norm(pa - pb) < 1e-6
    assert abs(ta @ tb) < 2e-3


def test_excision_arcs_meet_at_both_ends_and_enclose_the_lens():
    length, width = 0.03, 0.01
    cut = I.excision_set(FLAT, length=length, width=width)
    upper, lower = cut.strokes
    assert np.linalg.norm(upper.trace[0] - lower.trace[0]) < 1e-12
    assert np.linalg.norm(upper.trace[-1] - lower.trace[-1]) < 1e-6
    assert np.linalg.norm(upper.trace[-1] - upper.trace[0]) == pytest.approx(length, rel=1e-6)
    assert upper.trace[:, 1].max() == pytest.approx(width / 2, rel=1e-4)  # the upper arc bulges left
    assert lower.trace[:, 1].min() == pytest.approx(-width / 2, rel=1e-4)
    c, s = length / 2, width / 2
    radius = (c * c + s * s) / (2 * s)
    theta = 2 * math.asin(c / radius)
    lens = radius ** 2 * (theta - math.sin(theta))  # two circular segments
    x, y = cut.island_outline[:, 0], cut.island_outline[:, 1]
    area = 0.5 * abs(x @ np.roll(y, -1) - y @ np.roll(x, -1))
    assert area == pytest.approx(lens, rel=1e-4)
    assert cut.islands == 1 and cut.wounds == [1, 1]


def test_recut_is_the_same_path_twice():
    a, b = I.recut_set(FLAT, heading=0.4).strokes
    assert np.array_equal(a.trace, b.trace) and a.duration == b.duration


def test_tight_arc_has_a_radius_of_five_spacings():
    (arc,) = I.tight_arc_set(FLAT, heading=0.4).strokes
    p = arc.trace[:, :2]
    i, j, k = 0, len(p) // 2, len(p) - 1
    a, b, c = np.linalg.norm(p[j] - p[k]), np.linalg.norm(p[i] - p[k]), np.linalg.norm(p[i] - p[j])
    cross = (p[j] - p[i])[0] * (p[k] - p[i])[1] - (p[j] - p[i])[1] * (p[k] - p[i])[0]
    assert a * b * c / (2 * abs(cross)) == pytest.approx(5 * FLAT.spacing, rel=1e-4)  # circumradius
    assert arc.length == pytest.approx(math.pi * 5 * FLAT.spacing, rel=1e-3)


def test_every_set_builds_on_the_flat_grid_and_names_its_wounds():
    for name in I.SET_BUILDERS:
        cut = I.build_set(name, FLAT, heading=0.3)
        assert cut.name == name and len(cut.wounds) == len(cut.strokes) == len(cut.paths)
        for stroke in cut.strokes:
            start = stroke.pose(0.0)
            assert not inside_cylinder(FLAT.points, start.p0, start.p1, start.radius).any()


def test_lowered_tool_comes_straight_down_tilted_into_the_strokes_travel():
    tool = I.ToolSpec(entry="lowered")
    (stroke,) = I.build_set("tight_arc", FLAT, tool, heading=0.3).strokes
    assert isinstance(stroke, LoweredStroke)
    inner = stroke.stroke
    start = stroke.pose(0.0)
    assert not inside_cylinder(FLAT.points, start.p0, start.p1, start.radius + tool.margin).any()
    assert start.p0[2] > 0  # above the skin
    normal = np.array([0.0, 0.0, 1.0])
    for t in np.linspace(0.0, stroke.t_in, 7):
        pose = stroke.pose(t)
        off = pose.p0 - stroke.landing
        assert np.linalg.norm(off - (off @ normal) * normal) < 1e-12  # vertical descent
        a = (pose.p1 - pose.p0) / np.linalg.norm(pose.p1 - pose.p0)
        assert math.degrees(math.asin(a @ normal)) == pytest.approx(60.0, abs=1e-9)
    end = stroke.pose(stroke.t_in)
    assert np.allclose(end.p0, inner.pose(inner.t_in).p0, atol=1e-12)
    for dt in (0.1, 0.5, inner.t_travel + 0.05):
        assert np.allclose(stroke.pose(stroke.t_in + dt).p0, inner.pose(inner.t_in + dt).p0, atol=1e-12)
    assert stroke.duration == pytest.approx(stroke.t_in + inner.t_travel + inner.t_out)
    assert stroke.length == inner.length and stroke.radius == inner.radius  # stands in for the Stroke
