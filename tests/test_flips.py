"""Flips to Delaunay in a prestressed sheet's rest shape (warp_cut.cut.remesh.flips).

Compared against: the quad's geometry (the other diagonal's angles, computed here), the
in-circle determinant (Delaunay's own test, written here independently of the angles the module
sums), the mesh checks (winding, springs = edges, masses), the pair's area, and the cases a flip
must refuse (a partner the cut did not make, a quad that is not convex where the nodes are now,
a new pair that would be a sliver where the nodes are now, a cocircular quad).
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from warp_cut import TissueModel
from warp_cut.cut.remesh.flips import flip_to_delaunay
from warp_cut.cut.topology import TopologyEditor
from warp_cut.mesh.checks import check_mesh
from warp_cut.mesh.geometry import SLIVER_DEG, triangle_areas, triangle_min_angles


def quad_model(apex_y: float, far_x: float = 1.0):
    """Two triangles on the diagonal 0-1 of the quad 0 (0,0), 1 (2,0), 2 (far_x, apex_y),
    3 (1,-1) [mm]: a sliver when apex_y is small."""
    points = np.array([[0, 0, 0], [2, 0, 0], [far_x, apex_y, 0], [1, -1, 0]], dtype=float) * 1e-3
    tri = np.array([[0, 1, 2], [1, 0, 3]])
    return TissueModel.from_triangles(points, tri, pinned="none")


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


def test_no_flip_to_delaunay_that_makes_a_sliver_where_the_nodes_are_now():
    """The rest quad's diagonal 0-1 is not Delaunay (the flip is right at rest), but where the
    nodes are now, 0 (0,0), 1 (1,0), 2 (0.5,3), 3 (0.5,-3) mm, the other diagonal would make
    triangles of 9.5 deg (under SLIVER_DEG, and under the old pair's 19 deg, both computed
    here): the flip is refused, and the tissue's own pair stays."""
    model = quad_model(0.5)
    model.points[3] = [1e-3, -0.5e-3, 0.0]
    now = np.array([[0, 0, 0], [1, 0, 0], [0.5, 3, 0], [0.5, -3, 0]], float) * 1e-3
    old = triangle_min_angles(now, [[0, 1, 2], [1, 0, 3]]).min()
    new = triangle_min_angles(now, [[0, 3, 2], [3, 1, 2]]).min()
    assert new < SLIVER_DEG and new < old
    assert not locally_delaunay(model.points, model.triangles)
    assert delaunay_flipped(model, [0, 1], positions=now) == 0
    assert sorted(map(sorted, model.triangles.tolist())) == [[0, 1, 2], [0, 1, 3]]


def test_no_flip_to_delaunay_that_turns_the_pair_away_from_the_skins_side_where_the_nodes_are_now():
    """The rest quad's diagonal 0-1 is not Delaunay, but now nodes 2 and 3 are pushed 2 mm up:
    the new pair's normals, (-2, 0, 1) and (2, 0, 1) over their lengths, lie 63 deg from the
    old pair's mean normal +z (over 60 deg, FACING_COS), though neither new triangle is a sliver
    (25 deg and more): the flip is refused; with the nodes 0.5 mm up (27 deg) it is made."""
    model = quad_model(0.5)
    model.points[3] = [1e-3, -0.5e-3, 0.0]
    for height, flips in ((2.0, 0), (0.5, 1)):
        now = np.array([[0, 0, 0], [2, 0, 0], [1, 0.5, height], [1, -0.5, height]], float) * 1e-3
        normal = np.cross(now[3] - now[0], now[2] - now[0])
        assert np.degrees(np.arccos(normal[2] / np.linalg.norm(normal))) == pytest.approx(np.degrees(np.arctan(height)))
        assert triangle_min_angles(now, [[0, 3, 2], [3, 1, 2]]).min() > 20.0
        assert delaunay_flipped(model, [0, 1], positions=now) == flips


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
