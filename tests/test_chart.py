"""warp_cut/cut/chart.py: the region's flat chart, barycentric coordinates, and the map from the
chart back through the region's triangles.

Compared against: the frame's algebra (orthonormal, right-handed, along the normal), lengths
and signed areas before and after projection, the affine combination a barycentric coordinate
triple names, a point located in its triangle by solving the 2 x 2 system here, and the nearest
point of the triangles' union found by Shapely for points outside them.
"""

import numpy as np
import pytest
import shapely
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from warp_cut.cut.chart import PiecewiseLinearMap, RegionChart, barycentric

unit_floats = st.floats(-1.0, 1.0, allow_nan=False)
vectors = st.tuples(unit_floats, unit_floats, unit_floats).map(np.array).filter(lambda v: np.linalg.norm(v) > 0.1)


def rotation_to(normal: np.ndarray) -> np.ndarray:
    """A rotation taking +z to the unit ``normal`` (Rodrigues), built here independently."""
    n = normal / np.linalg.norm(normal)
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(z, n), float(z @ n)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)


def signed_area_2d(p) -> float:
    a, b, c = p
    return 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


# ----------------------------------------------------------------------------- RegionChart

@settings(max_examples=60, deadline=None)
@given(vectors, vectors)
def test_the_chart_frame_is_orthonormal_right_handed_round_the_normal(normal, centre):
    """e1, e2 unit and orthogonal, both normal to the (normalised) normal, e1 x e2 = normal;
    a normal along world X (where the frame's helper axis changes) included."""
    chart = RegionChart(centre, 3.0 * normal)
    n = normal / np.linalg.norm(normal)
    assert chart.normal == pytest.approx(n)
    assert [chart.e1 @ chart.e1, chart.e2 @ chart.e2, chart.e1 @ chart.e2] == pytest.approx([1, 1, 0], abs=1e-12)
    assert [chart.e1 @ n, chart.e2 @ n] == pytest.approx([0, 0], abs=1e-12)
    assert np.cross(chart.e1, chart.e2) == pytest.approx(n, abs=1e-12)


@pytest.mark.parametrize("normal", [[1, 0, 0], [-1, 0, 0], [0.95, 0.1, 0.0], [0, 0, -1]])
def test_a_normal_near_the_frame_helper_axis_still_gives_a_right_handed_frame(normal):
    chart = RegionChart([0, 0, 0], normal)
    assert np.cross(chart.e1, chart.e2) == pytest.approx(chart.normal, abs=1e-12)


@settings(max_examples=60, deadline=None)
@given(vectors, vectors, st.lists(vectors, min_size=3, max_size=3), st.floats(-2.0, 2.0))
def test_points_of_the_chart_plane_keep_their_distances_and_winding(normal, centre, local, lift):
    """Triangles in the plane through ``centre`` normal to ``normal``: the chart keeps every
    distance, maps the centre to 0, ignores a move along the normal, and a triangle wound
    counter-clockwise seen from the normal's side has positive area in the chart (to 1e-9: the
    coordinates are of order 1, a nearly axial normal rounds the frame at 1e-12)."""
    rot = rotation_to(normal)
    flat = np.array([[p[0], p[1], 0.0] for p in local])
    points = centre + flat @ rot.T
    chart = RegionChart(centre, normal)
    xy = chart.to2d(points)
    for i in range(3):
        for j in range(3):
            assert np.linalg.norm(xy[i] - xy[j]) == pytest.approx(np.linalg.norm(points[i] - points[j]), abs=1e-9)
    assert chart.to2d(centre) == pytest.approx([0, 0], abs=1e-9)
    n = rot[:, 2]
    assert chart.to2d(points + lift * n) == pytest.approx(xy, abs=1e-9)
    area_3d = 0.5 * np.cross(points[1] - points[0], points[2] - points[0]) @ n  # signed, seen from n
    assert signed_area_2d(xy) == pytest.approx(area_3d, abs=1e-9)
    assert chart.direction2d(points[1] - points[0]) == pytest.approx(xy[1] - xy[0], abs=1e-9)


def test_the_chart_of_tilted_triangles_is_their_plane_with_their_winding():
    """Two counter-clockwise triangles of a unit square tilted about x by 40 deg: the chart's
    normal is the square's (the winding's side), its centre the corners' mean, and the square
    comes back as a unit square of positive orientation."""
    tilt = np.radians(40.0)
    rot = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)], [0, np.sin(tilt), np.cos(tilt)]])
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float) @ rot.T + [0.3, -0.2, 0.5]
    corners = square[[[0, 1, 2], [0, 2, 3]]]
    chart = RegionChart.of_triangles(corners)
    assert chart.normal == pytest.approx(rot[:, 2])
    assert chart.centre == pytest.approx(corners.reshape(-1, 3).mean(axis=0))
    xy = chart.to2d(corners)
    assert [signed_area_2d(t) for t in xy] == pytest.approx([0.5, 0.5])
    flipped = RegionChart.of_triangles(corners[:, ::-1])  # wound the other way: seen from below
    assert flipped.normal == pytest.approx(-rot[:, 2])


def test_on_a_curved_cap_chart_lengths_shrink_by_no_more_than_the_cosine_of_the_turn():
    """A cap of a 4 cm sphere 8 mm across, triangulated: each edge projects with a length of at
    least cos(theta) of its own, theta the largest angle between a triangle's normal and the
    chart's normal (computed here), and never longer; the docstring's < 1 % holds."""
    radius = 0.04
    ring_angles = np.linspace(0, 2 * np.pi, 9)[:-1]
    rim = [(r * np.cos(a), r * np.sin(a)) for r in (0.002, 0.004) for a in ring_angles]
    xy = np.array([(0.0, 0.0), *rim])
    points = np.column_stack([xy, np.sqrt(radius**2 - (xy**2).sum(axis=1)) - radius])
    tri = []
    for k in range(8):
        a, b = 1 + k, 1 + (k + 1) % 8
        tri += [[0, a, b], [a, 8 + a, 8 + b], [a, 8 + b, b]]
    corners = points[np.array(tri)]
    chart = RegionChart.of_triangles(corners)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    cos_turn = float((normals @ chart.normal).min())
    assert 0.99 < cos_turn < 1.0
    for t in corners:
        for i, j in ((0, 1), (1, 2), (2, 0)):
            true = np.linalg.norm(t[i] - t[j])
            flat = np.linalg.norm(chart.to2d(t[i]) - chart.to2d(t[j]))
            assert cos_turn * true - 1e-15 <= flat <= true + 1e-15


# ----------------------------------------------------------------------------- barycentric

points_2d = st.tuples(st.floats(-2, 2), st.floats(-2, 2)).map(np.array)


@settings(max_examples=80, deadline=None)
@given(st.lists(points_2d, min_size=3, max_size=3), st.lists(points_2d, min_size=1, max_size=5))
def test_barycentric_coordinates_sum_to_one_and_rebuild_the_point(triangle, queries):
    corners = np.array(triangle)[None]
    assume(abs(signed_area_2d(corners[0])) > 1e-3)
    p = np.array(queries)
    lam = barycentric(p, corners)
    assert lam.shape == (len(p), 1, 3)
    assert lam.sum(axis=2) == pytest.approx(np.ones((len(p), 1)))
    assert np.einsum("mtk,tkd->mtd", lam, corners)[:, 0] == pytest.approx(p, abs=1e-9)


@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning")  # the degenerate triangle's nan
def test_barycentric_coordinates_of_corners_edges_centroid_and_a_degenerate_triangle():
    corners = np.array([[[0, 0], [2, 0], [0, 2]], [[0, 0], [1, 1], [2, 2]]], float)
    p = np.array([[0, 0], [2, 0], [0, 2], [1, 0], [2 / 3, 2 / 3], [3, 3]], float)
    lam = barycentric(p, corners)
    assert lam[:3, 0] == pytest.approx(np.eye(3))
    assert lam[3, 0] == pytest.approx([0.5, 0.5, 0.0])  # exactly on edge 0-1: no weight on corner 2
    assert lam[4, 0] == pytest.approx([1 / 3, 1 / 3, 1 / 3])
    assert lam[5, 0] == pytest.approx([-2.0, 1.5, 1.5])  # outside: a negative coordinate
    assert np.isnan(lam[:, 1]).any(axis=1).all()  # collinear corners: nan, not a number that looks valid


# ----------------------------------------------------------------------------- PiecewiseLinearMap

def jittered_square(seed: int, n: int = 4):
    """A triangulated unit square: an n x n grid, inner nodes jittered by up to 0.3 cells, each
    cell split on its lower-left / upper-right diagonal; (nodes (k, 2), triangles (t, 3))."""
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n)), axis=-1).reshape(-1, 2)
    inner = np.all((g > 0) & (g < 1), axis=1)
    g[inner] += rng.uniform(-0.3, 0.3, (inner.sum(), 2)) / (n - 1)
    tri = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            tri += [[a, b, e], [a, e, d]]
    return g, np.array(tri)


def interpolate_here(nodes, triangles, values, p):
    """The piecewise-linear interpolant of node ``values`` at a point ``p`` inside the mesh:
    the triangle containing it found by solving p = a + s (b - a) + t (c - a) here."""
    for tri in triangles:
        a, b, c = nodes[tri]
        s, t = np.linalg.solve(np.column_stack([b - a, c - a]), p - a)
        if min(s, t, 1 - s - t) >= -1e-12:
            return (1 - s - t) * values[tri[0]] + s * values[tri[1]] + t * values[tri[2]]
    raise AssertionError("point outside the mesh")


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1), st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=8))
def test_the_map_reproduces_the_nodes_and_is_the_linear_interpolant_inside(seed, queries):
    """Fields given at the triangles' corners from node values (a 3D position and a scalar):
    at each node the map returns the node's value, and at any point of the square the
    piecewise-linear interpolant found here."""
    nodes, tri = jittered_square(seed)
    rng = np.random.default_rng(seed + 1)
    position, scalar = rng.normal(size=(len(nodes), 3)), rng.normal(size=(len(nodes), 1))
    lift = PiecewiseLinearMap(nodes[tri], position[tri], scalar[tri])
    at_nodes = lift(nodes)
    assert at_nodes[0] == pytest.approx(position, abs=1e-12) and at_nodes[1] == pytest.approx(scalar, abs=1e-12)
    p = np.array(queries)
    got_position, got_scalar = lift(p)
    for k, q in enumerate(p):
        assert got_position[k] == pytest.approx(interpolate_here(nodes, tri, position, q), abs=1e-9)
        assert got_scalar[k] == pytest.approx(interpolate_here(nodes, tri, scalar, q), abs=1e-9)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(0, 17), st.floats(0.05, 0.9), st.floats(0.05, 0.9))
def test_the_map_is_affine_inside_each_triangle(seed, row, s, w):
    """Two points of one triangle and a point between them: the map at the point between is
    the same combination of the map at the two (an affine map, triangle by triangle)."""
    nodes, tri = jittered_square(seed)
    field = np.random.default_rng(seed).normal(size=(len(nodes), 3))
    lift = PiecewiseLinearMap(nodes[tri], field[tri])
    a, b, c = nodes[tri[row]]
    p = a + 0.8 * s * (b - a) + 0.8 * (1 - s) * 0.5 * (c - a)  # both strictly inside
    q = a + 0.1 * (b - a) + 0.7 * (c - a)
    mid = (1 - w) * p + w * q
    fp, fq, fm = lift(np.array([p, q, mid]))[0]
    assert fm == pytest.approx((1 - w) * fp + w * fq, abs=1e-9)
    tri_index, lam = lift.locate(np.array([p, q, mid]))
    assert np.all(tri_index == row) and np.all(lam >= 0)


def test_a_point_on_a_shared_edge_gets_one_value_from_either_triangle():
    """A point exactly on the diagonal two triangles share: located in one of them, with no
    weight on the far corner, so the value is the same whichever it is."""
    nodes = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    values = np.array([[0.0], [1.0], [5.0], [-2.0]])
    lift = PiecewiseLinearMap(nodes[tri], values[tri])
    k, lam = lift.locate(np.array([[0.25, 0.25]]))
    far = 1 if k[0] == 0 else 2  # the corner off the diagonal in the triangle chosen
    assert lam[0, far] == pytest.approx(0.0, abs=1e-12)
    assert lift(np.array([[0.25, 0.25]]))[0][0, 0] == pytest.approx(0.75 * 0.0 + 0.25 * 5.0)


@settings(max_examples=40, deadline=None)
@given(st.floats(-0.6, 1.6), st.floats(-0.6, 1.6))
def test_a_point_outside_goes_to_the_nearest_point_of_the_triangles(x, y):
    """An L-shaped pair of triangles with a notch (a slit's mouth): a point outside them takes
    the value at the nearest point of their union (Shapely's), on the triangle holding it."""
    nodes = np.array([[0, 0], [1, 0], [1, 0.4], [0, 1], [0.4, 1], [0.3, 0.3]], float)
    tri = np.array([[0, 1, 2], [0, 2, 5], [0, 5, 4], [0, 4, 3]])
    union = shapely.union_all([shapely.Polygon(nodes[t]) for t in tri])
    p = shapely.Point(x, y)
    gap = union.distance(p)
    assume(gap > 1e-6)
    field = np.column_stack([nodes, nodes[:, 0] * 2 - nodes[:, 1]])  # linear: any triangle agrees
    lift = PiecewiseLinearMap(nodes[tri], field[tri])
    k, lam = lift.locate(np.array([[x, y]]))
    assert np.all(lam >= -1e-12) and lam.sum() == pytest.approx(1.0)
    got = lam[0] @ nodes[tri[k[0]]]
    assert np.linalg.norm(got - [x, y]) == pytest.approx(gap, abs=1e-9)  # a nearest point (ties allowed)
    assert union.distance(shapely.Point(got)) < 1e-9
    assert lift(np.array([[x, y]]))[0][0] == pytest.approx([*got, 2 * got[0] - got[1]], abs=1e-9)


def test_no_points_give_empty_results():
    nodes = np.array([[0, 0], [1, 0], [0, 1]], float)
    lift = PiecewiseLinearMap(nodes[None], np.ones((1, 3, 3)))
    k, lam = lift.locate(np.zeros((0, 2)))
    assert k.shape == (0,) and lam.shape == (0, 3)
    assert lift(np.zeros((0, 2)))[0].shape == (0, 3)
