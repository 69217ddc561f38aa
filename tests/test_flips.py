"""Sliver flips after an incision, and flips to Delaunay in a prestressed sheet's rest shape
(warp_cut.cut.flips).

Compared against: the quad's geometry (the other diagonal's angles, computed here), the
in-circle determinant (Delaunay's own test, written here independently of the angles the module
sums), the mesh checks (winding, springs = edges, masses), the pair's area, and the cases a flip
must refuse (a partner the cut did not make, a non-convex quad that would fold, a border edge,
a cocircular quad).
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from warp_cut import TissueModel
from warp_cut.cut.flips import flip_slivers, flip_to_delaunay
from warp_cut.cut.topology import TopologyEditor
from warp_cut.mesh.checks import check_mesh
from warp_cut.mesh.geometry import SLIVER_DEG, triangle_areas, triangle_min_angles


def quad_model(apex_y: float, far_x: float = 1.0):
    """Two triangles on the diagonal 0-1 of the quad 0 (0,0), 1 (2,0), 2 (far_x, apex_y),
    3 (1,-1) [mm]: a sliver when apex_y is small."""
    points = np.array([[0, 0, 0], [2, 0, 0], [far_x, apex_y, 0], [1, -1, 0]], dtype=float) * 1e-3
    tri = np.array([[0, 1, 2], [1, 0, 3]])
    return TissueModel.from_triangles(points, tri, pinned="none")


def flipped(model, candidates):
    editor = TopologyEditor(model)
    editor.begin()
    flips = flip_slivers(editor, set(candidates), model.points)
    report = editor.finish(positions=model.points)
    return flips, report


def test_a_sliver_across_the_diagonal_is_flipped_and_the_mesh_stays_valid():
    model = quad_model(0.1)  # apex 0.1 mm above a 2 mm diagonal: angles of about 5.7 deg
    before = triangle_min_angles(model.points, model.triangles).min()
    area = triangle_areas(model.points, model.triangles).sum()
    assert before < SLIVER_DEG
    flips, report = flipped(model, [0, 1])
    assert flips == 1 and len(report.new_triangles) == 2
    after = triangle_min_angles(model.points, model.triangles)
    expected = triangle_min_angles(model.points, [[0, 3, 2], [3, 1, 2]]).min()  # the other diagonal
    assert after.min() == pytest.approx(expected)
    assert after.min() > before
    assert triangle_areas(model.points, model.triangles).sum() == pytest.approx(area)
    assert {tuple(sorted(s)) for s in model.springs.tolist()} == {(0, 2), (0, 3), (1, 2), (1, 3), (2, 3)}
    assert check_mesh(model.points, model.triangles, model.springs, active=model.active).valid


def test_no_flip_of_a_triangle_the_cut_did_not_make():
    model = quad_model(0.1)
    flips, _ = flipped(model, [0])  # the partner is the tissue's own triangle
    assert flips == 0 and len(model.triangles) == 2


def test_no_flip_that_would_fold_a_non_convex_quad():
    model = quad_model(0.1, far_x=2.6)  # the apex beyond the diagonal's end: the quad is not convex
    flips, _ = flipped(model, [0, 1])
    assert flips == 0


def jittered_sheet(seed: int, n: int, jitter: float, z_noise: float):
    """An n x n grid of 1 mm cells, interior nodes moved by up to ``jitter`` cells, heights up to
    ``z_noise`` [m], each cell split on a random diagonal: (points, triangles), or a hypothesis
    ``assume`` failure when a triangle is turned over."""
    rng = np.random.default_rng(seed)
    grid = np.stack(np.meshgrid(np.arange(n), np.arange(n)), axis=-1).reshape(-1, 2).astype(float)
    inner = np.all((grid > 0) & (grid < n - 1), axis=1)
    grid[inner] += rng.uniform(-jitter, jitter, (inner.sum(), 2))
    points = np.column_stack([grid * 1e-3, rng.uniform(-z_noise, z_noise, len(grid))])
    tri = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            tri += [[a, b, e], [a, e, d]] if rng.random() < 0.5 else [[a, b, d], [b, e, d]]
    tri = np.array(tri)
    d1, d2 = points[tri[:, 1], :2] - points[tri[:, 0], :2], points[tri[:, 2], :2] - points[tri[:, 0], :2]
    assume(np.all(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] > 0))  # a valid sheet: no triangle turned over
    return points, tri


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_flips_on_a_jittered_sheet_never_lower_the_smallest_angle_nor_break_the_mesh(seed):
    points, tri = jittered_sheet(seed, 6, 0.35, 2e-5)
    model = TissueModel.from_triangles(points, tri, pinned="none")
    flat = points * [1, 1, 0]  # the area seen from above is kept by flips of convex quads
    area = triangle_areas(flat, model.triangles).sum()
    before = np.sort(triangle_min_angles(points, model.triangles))
    flipped(model, range(len(tri)))
    after = np.sort(triangle_min_angles(points, model.triangles))
    report = check_mesh(model.points, model.triangles, model.springs, active=model.active)
    assert not [p for p in report.problems if not p.startswith("sliver")], report.problems
    assert triangle_areas(flat, model.triangles).sum() == pytest.approx(area, rel=1e-9)
    assert after[0] >= before[0] - 1e-9  # each flip raises its pair's smallest angle


def in_circle(a, b, c, d) -> float:
    """> 0 when d lies inside the circle through a, b, c (counter-clockwise, xy plane)."""
    m = np.array([[p[0] - d[0], p[1] - d[1], (p[0] - d[0]) ** 2 + (p[1] - d[1]) ** 2] for p in (a, b, c)])
    return float(np.linalg.det(m))


def locally_delaunay(points, triangles, tolerance=1e-12) -> bool:
    """Whether no triangle's circumcircle holds the far corner of its neighbour across an edge."""
    far = {}
    for tri in triangles:
        for q in range(3):
            far[(int(tri[q]), int(tri[(q + 1) % 3]))] = int(tri[(q + 2) % 3])
    scale = np.ptp(points[:, :2]) ** 4
    for (i, j), k in far.items():
        l = far.get((j, i))
        if l is not None and in_circle(points[i], points[j], points[k], points[l]) > tolerance * scale:
            return False
    return True


def delaunay_flipped(model, candidates, positions=None):
    editor = TopologyEditor(model)
    editor.begin()
    flips = flip_to_delaunay(editor, set(candidates), model.points,
                             model.points if positions is None else positions)
    editor.finish(positions=model.points)
    return flips


def test_a_long_diagonal_is_flipped_to_delaunay():
    # 0 (0,0), 1 (2,0), 2 (1,0.5), 3 (1,-0.5) [mm]: the angles opposite 0-1 are 127 deg each
    model = quad_model(0.5)
    model.points[3] = [1e-3, -0.5e-3, 0.0]
    assert not locally_delaunay(model.points, model.triangles)
    assert delaunay_flipped(model, [0, 1]) == 1
    assert {tuple(sorted(s)) for s in model.springs.tolist()} == {(0, 2), (0, 3), (1, 2), (1, 3), (2, 3)}
    assert locally_delaunay(model.points, model.triangles)
    assert check_mesh(model.points, model.triangles, model.springs, active=model.active).valid


def test_delaunay_is_judged_in_the_rest_shape_but_no_flip_folds_the_current_shape():
    model = quad_model(0.5)
    model.points[3] = [1e-3, -0.5e-3, 0.0]
    assert delaunay_flipped(model, [1], positions=model.points) == 0  # the partner is the tissue's own
    now = model.points.copy()
    now[2] = [3.0e-3, 0.3e-3, 0.0]  # the quad is not convex where the nodes are now
    assert delaunay_flipped(model, [0, 1], positions=now) == 0
    assert delaunay_flipped(model, [0, 1], positions=model.points + [0.0, 0.0, 1e-3]) == 1  # moved, not folded


def test_a_cocircular_quad_is_left_alone():
    model = quad_model(1.0)  # 0 (0,0), 1 (2,0), 2 (1,1), 3 (1,-1): a square split on a diagonal
    assert delaunay_flipped(model, [0, 1]) == 0


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_flips_to_delaunay_make_a_jittered_sheet_delaunay_and_keep_it_whole(seed):
    points, tri = jittered_sheet(seed, 7, 0.4, 0.0)
    model = TissueModel.from_triangles(points, tri, pinned="none")
    area = triangle_areas(points, model.triangles).sum()
    before = triangle_min_angles(points, model.triangles).min()
    delaunay_flipped(model, range(len(tri)))
    assert locally_delaunay(points, model.triangles, tolerance=1e-9)
    assert len(model.triangles) == len(tri)
    assert triangle_areas(points, model.triangles).sum() == pytest.approx(area, rel=1e-9)
    assert triangle_min_angles(points, model.triangles).min() >= before - 1e-9  # Delaunay maximises it
    report = check_mesh(model.points, model.triangles, model.springs, active=model.active)
    assert not [p for p in report.problems if not p.startswith("sliver")], report.problems
