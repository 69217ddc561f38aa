"""warp_cut/cut/contact/material_point.py: the blade's crossing carried from the deformed skin into the
rest shape.

Compared against: distances and closest points of a point to a triangle worked out by hand
(above the inside, past a corner, past an edge) and by brute force over a fine grid of the
triangle; the inverse of an affine deformation applied here to a flat sheet (the material point
of a crossing is where the deformation came from); a crossing beyond the reach of every
triangle (over an opening), and nodes that do not span the tangent plane.
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from warp_cut.cut.contact.material_point import (
    affine_material_point,
    closest_on_triangles,
    material_point,
    nearest_triangle,
)

coordinates = st.floats(-1.0, 1.0, allow_nan=False)
points_3d = st.tuples(coordinates, coordinates, coordinates).map(np.array)


# ----------------------------------------------------------------------------- closest_on_triangles

def test_closest_points_above_the_inside_past_a_corner_and_past_an_edge():
    """Triangle (0,0,0), (1,0,0), (0,1,0): a point 1 above (0.2, 0.2) is 1 away at
    (0.6, 0.2, 0.2); (-1, -1, 0) is sqrt 2 from corner 0; (0.5, 3, 0) is closest to corner 2;
    (0.5, -2, 0.5) is closest to the edge's point (0.5, 0, 0)."""
    corners = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], float)
    cases = [([0.2, 0.2, 1.0], 1.0, [0.6, 0.2, 0.2]),
             ([-1.0, -1.0, 0.0], np.sqrt(2.0), [1.0, 0.0, 0.0]),
             ([0.5, 3.0, 0.0], np.hypot(0.5, 2.0), [0.0, 0.0, 1.0]),
             ([0.5, -2.0, 0.5], np.hypot(2.0, 0.5), [0.5, 0.5, 0.0])]
    for point, distance, lam in cases:
        d, got = closest_on_triangles(np.array(point), corners)
        assert d[0] == pytest.approx(distance) and got[0] == pytest.approx(lam)


def test_a_point_exactly_on_an_edge_is_at_distance_zero():
    corners = np.array([[[0, 0, 0], [2, 0, 0], [0, 2, 0]]], float)
    d, lam = closest_on_triangles(np.array([1.0, 1.0, 0.0]), corners)  # on the hypotenuse
    assert d[0] == pytest.approx(0.0, abs=1e-15) and lam[0] == pytest.approx([0.0, 0.5, 0.5])


@settings(max_examples=60, deadline=None)
@given(st.lists(points_3d, min_size=3, max_size=3), points_3d)
def test_the_closest_point_is_no_farther_than_any_point_of_the_triangle(triangle, point):
    """Random triangles and points: the coordinates are a point of the triangle (>= 0, sum 1) at
    the distance reported, and no point of a fine grid over the triangle is nearer; the grid's
    nearest is within its spacing of it."""
    corners = np.array(triangle)[None]
    normal = np.cross(corners[0, 1] - corners[0, 0], corners[0, 2] - corners[0, 0])
    assume(np.linalg.norm(normal) > 1e-2)
    d, lam = closest_on_triangles(point, corners)
    assert np.all(lam >= -1e-12) and lam.sum() == pytest.approx(1.0)
    assert np.linalg.norm(point - lam[0] @ corners[0]) == pytest.approx(d[0], abs=1e-9)
    steps = 60
    i, j = np.meshgrid(np.arange(steps + 1), np.arange(steps + 1))
    keep = i + j <= steps
    grid = np.stack([steps - i[keep] - j[keep], i[keep], j[keep]], axis=1) / steps
    brute = np.linalg.norm(grid @ corners[0] - point, axis=1).min()
    diameter = max(np.linalg.norm(corners[0, a] - corners[0, b]) for a, b in ((0, 1), (1, 2), (2, 0)))
    assert d[0] <= brute + 1e-12
    assert d[0] >= brute - diameter / steps


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 40), st.integers(0, 2**32 - 1), points_3d, st.booleans())
def test_the_nearest_triangle_is_the_brute_force_nearest(count, seed, point, touching):
    """Random soups of triangles (a strip of a mesh when ``touching``: triangles sharing
    corners, so ties of equal distance occur): the triangle, distance and coordinates the
    pruned search returns are those of the first minimum over all triangles."""
    rng = np.random.default_rng(seed)
    if touching:
        strip = rng.uniform(-1.0, 1.0, (count + 2, 3))
        corners = np.stack([strip[:-2], strip[1:-1], strip[2:]], axis=1)
    else:
        corners = rng.uniform(-1.0, 1.0, (count, 3, 3)) * rng.uniform(0.01, 1.0, (count, 1, 1)) \
            + rng.uniform(-2.0, 2.0, (count, 1, 3))
    d, lam = closest_on_triangles(point, corners)
    k, dist, got = nearest_triangle(point, corners)
    assert (k, dist) == (int(np.argmin(d)), float(d.min()))
    assert np.array_equal(got, lam[k])


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 20), st.integers(0, 2**32 - 1), points_3d, st.floats(0.0, 2.0))
def test_a_triangle_is_within_reach_exactly_when_the_nearest_is(count, seed, point, reach):
    """The shortcut through the corners answers as the exact nearest distance does."""
    from warp_cut.cut.contact.material_point import _within

    corners = np.random.default_rng(seed).uniform(-1.0, 1.0, (count, 3, 3))
    assert _within(point, corners, reach) == (closest_on_triangles(point, corners)[0].min() <= reach)


def test_a_degenerate_triangle_is_as_far_as_its_segment():
    """Corners (0,0,0), (1,0,0), (2,0,0) span the segment from x = 0 to 2: the point
    (0.5, 3, 0) is 3 away from it, at (0.5, 0, 0)."""
    corners = np.array([[[0, 0, 0], [1, 0, 0], [2, 0, 0]]], float)
    d, lam = closest_on_triangles(np.array([0.5, 3.0, 0.0]), corners)
    assert d[0] == pytest.approx(3.0)
    assert lam[0] @ corners[0] == pytest.approx([0.5, 0.0, 0.0])


# ----------------------------------------------------------------------------- material_point

def sheet(n: int = 5, cell: float = 1e-3):
    """A flat n x n grid of ``cell`` squares in z = 0 centred on the origin, split on one
    diagonal, counter-clockwise from +z: (points (k, 3), triangles (t, 3))."""
    g = (np.stack(np.meshgrid(np.arange(n), np.arange(n)), axis=-1).reshape(-1, 2) - (n - 1) / 2) * cell
    tri = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            tri += [[a, b, e], [a, e, d]]
    return np.column_stack([g, np.zeros(len(g))]), np.array(tri)


def deform(points, matrix, shift):
    """The affine deformation x -> matrix x + shift of rest points (k, 3)."""
    return points @ np.asarray(matrix).T + shift


def test_the_triangle_map_carries_a_crossing_back_through_its_triangle():
    """The sheet stretched 1.5 x along x and moved: a crossing at the image of rest point
    (0.3, -0.2, 0) mm goes back to it, with the rest triangle's normal +z; a crossing 1 mm
    beyond the sheet's edge is over an opening (reach 0.2 mm), and no triangles give None."""
    rest, tri = sheet()
    matrix, shift = np.diag([1.5, 1.0, 1.0]), np.array([2e-3, 1e-3, 5e-4])
    now = deform(rest, matrix, shift)
    target = np.array([0.3e-3, -0.2e-3, 0.0])
    got = material_point(deform(target[None], matrix, shift)[0], now[tri], rest[tri], reach=2e-4)
    assert got.rest == pytest.approx(target, abs=1e-15) and got.distance == pytest.approx(0.0, abs=1e-15)
    assert got.normal == pytest.approx([0, 0, 1])
    a, b, c = rest[tri[got.triangle]]
    s, t = np.linalg.solve(np.column_stack([(b - a)[:2], (c - a)[:2]]), (target - a)[:2])
    assert min(s, t, 1 - s - t) >= -1e-12  # the triangle reported holds the point
    beyond = deform(np.array([[3.0e-3, 0.0, 0.0]]), matrix, shift)[0]
    assert material_point(beyond, now[tri], rest[tri], reach=2e-4) is None
    assert material_point(beyond, np.zeros((0, 3, 3)), np.zeros((0, 3, 3)), reach=1.0) is None


# ----------------------------------------------------------------------------- affine_material_point

@settings(max_examples=40, deadline=None)
@given(st.floats(0.6, 1.6), st.floats(0.6, 1.6), st.floats(-0.4, 0.4), st.floats(-np.pi, np.pi),
       st.floats(0.0, 1.2), st.tuples(st.floats(-1.5e-3, 1.5e-3), st.floats(-1.5e-3, 1.5e-3)))
def test_an_affinely_deformed_sheet_gives_back_exactly_where_the_crossing_came_from(sx, sy, shear, turn, tilt, at):
    """The flat sheet stretched, sheared, turned in its plane, then tilted out of it and moved:
    the crossing at the image of a rest point comes back to that point (the affine fit is exact
    for an affine deformation, whatever the weights), on the rest surface, normal +z."""
    rest, tri = sheet()
    c, s = np.cos(turn), np.sin(turn)
    in_plane = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.array([[sx, shear, 0], [0, sy, 0], [0, 0, 1]])
    lift = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)], [0, np.sin(tilt), np.cos(tilt)]])
    matrix, shift = lift @ in_plane, np.array([1e-3, -2e-3, 3e-3])
    now = deform(rest, matrix, shift)
    target = np.array([at[0], at[1], 0.0])
    point = deform(target[None], matrix, shift)[0]
    weights = np.random.default_rng(7).uniform(0.1, 1.0, len(rest))
    got = affine_material_point(point, lift[:, 2], now, rest, weights, now[tri], rest[tri], reach=1e-4)
    assert got.rest == pytest.approx(target, abs=1e-12)
    assert got.distance == pytest.approx(0.0, abs=1e-12)
    assert got.normal == pytest.approx([0, 0, 1])


def test_a_crossing_beyond_reach_of_every_triangle_has_no_material_point():
    """A crossing 1 mm past the sheet's edge (reach 0.3 mm) lies over an opening: None; with no
    live triangle at all, None too."""
    rest, tri = sheet()
    weights = np.ones(len(rest))
    point = np.array([3.0e-3, 0.0, 0.0])
    assert affine_material_point(point, [0, 0, 1], rest, rest, weights, rest[tri], rest[tri], reach=3e-4) is None
    assert affine_material_point(point, [0, 0, 1], rest, rest, weights, np.zeros((0, 3, 3)), np.zeros((0, 3, 3)),
                                 reach=1.0) is None


def test_a_fit_landing_off_the_rest_sheet_stays_where_it_lands():
    """The sheet unmoved, a crossing 0.2 mm beyond its right edge (within reach): the affine
    image is the crossing itself, off the sheet, and so is the material point (on the plane of
    the nearest rest triangle, 0.2 mm from it). A crossing in a gaping wound is carried into
    the slit it gapes from, not onto a lip: snapped onto the lips, a stroke across the wound
    ran along them, where nothing is cut."""
    rest, tri = sheet()
    point = np.array([2.2e-3, 0.4e-3, 0.0])
    got = affine_material_point(point, [0, 0, 1], rest, rest, np.ones(len(rest)), rest[tri], rest[tri], reach=3e-4)
    assert got.rest == pytest.approx([2.2e-3, 0.4e-3, 0.0], abs=1e-15)
    assert got.distance == pytest.approx(0.2e-3)


def test_a_gaping_slit_carries_a_crossing_in_it_back_into_the_slit():
    """A sheet cut along y = 0 (no triangle joins the two halves, whose nearest rows rest 0.2 mm
    apart: a slit) gapes: each half moved 0.5 mm away from it. A crossing halfway across the gap
    comes back into the slit, near its middle, not onto either lip."""
    rest, tri = sheet(6)
    upper, lower = rest[:, 1] > 0.0, rest[:, 1] < 0.0
    rest = rest.copy()
    rest[upper, 1] -= 0.4e-3  # the rows at +-0.5 mm now rest at +-0.1 mm
    rest[lower, 1] += 0.4e-3
    halves = tri[np.all(upper[tri], axis=1) | np.all(lower[tri], axis=1)]
    now = rest.copy()
    now[upper, 1] += 0.5e-3
    now[lower, 1] -= 0.5e-3
    keep = upper | lower
    point = np.array([0.3e-3, 0.0, 0.0])
    got = affine_material_point(point, [0, 0, 1], now[keep], rest[keep], np.ones(keep.sum()), now[halves],
                                rest[halves], reach=1e-3)
    assert got is not None
    assert got.rest[0] == pytest.approx(0.3e-3, abs=1e-9)
    assert abs(got.rest[1]) < 0.05e-3  # in the slit (|y| < 0.1 mm), near its middle


def test_nodes_on_a_line_fall_back_to_the_triangle_map():
    """Nodes that all lie on one line do not span the tangent plane (rank < 3): the material
    point is then the triangle map's (the sheet stretched 2 x along y, so the two differ from
    the identity)."""
    rest, tri = sheet()
    matrix = np.diag([1.0, 2.0, 1.0])
    now = deform(rest, matrix, 0.0)
    on_line = np.flatnonzero(np.abs(rest[:, 1]) < 1e-12)  # the middle row
    target = np.array([0.25e-3, 0.6e-3, 0.0])
    point = deform(target[None], matrix, 0.0)[0]
    got = affine_material_point(point, [0, 0, 1], now[on_line], rest[on_line], np.ones(len(on_line)),
                                now[tri], rest[tri], reach=1e-4)
    expected = material_point(point, now[tri], rest[tri], reach=1e-4)
    assert got.rest == pytest.approx(expected.rest, abs=1e-15) and got.rest == pytest.approx(target, abs=1e-15)
