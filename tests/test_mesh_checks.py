"""Tests for warp_cut.mesh.checks (invariants and quality metrics).

Expected answers are computed independently of the module under test: by
hand (known triangles), with plain Python sets/loops over small meshes, the
law of cosines, or trimesh. The cost against mesh size is measured by
benchmarks/bench_mesh_checks.py, not here.
"""

import math

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from warp_cut.mesh.checks import (
    CHECKS,
    MeshInvalid,
    MeshReport,
    check_mesh,
    edges_of,
    triangle_angles,
    triangle_areas,
    triangle_min_angles,
    triangle_normals,
)

FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
Z = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------
# independent builders
# --------------------------------------------------------------------------
def grid(nx=5, ny=4, h=0.01):
    """nx*ny node grid in the XY plane, each cell split into two CCW (+Z) triangles."""
    pts = np.array([(i * h, j * h, 0.0) for j in range(ny) for i in range(nx)])
    vid = lambda i, j: j * nx + i  # noqa: E731
    tris = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            v00, v10, v01, v11 = vid(i, j), vid(i + 1, j), vid(i, j + 1), vid(i + 1, j + 1)
            tris.append((v00, v10, v11))
            tris.append((v00, v11, v01))
    return pts, np.array(tris, dtype=np.int32)


def springs_from(tris):
    """Triangle edges as springs, computed with plain Python sets."""
    s = set()
    for a, b, c in np.asarray(tris).tolist():
        for u, v in ((a, b), (b, c), (c, a)):
            s.add((min(u, v), max(u, v)))
    return np.array(sorted(s), dtype=np.int32).reshape(-1, 2)


def grid_mesh(nx=5, ny=4, h=0.01):
    pts, tris = grid(nx, ny, h)
    return dict(points=pts, triangles=tris, springs=springs_from(tris),
                masses=np.full(len(pts), 0.002), active=np.ones(len(pts), dtype=bool))


def run(m, **kw):
    return check_mesh(m["points"], m["triangles"], m["springs"], active=m["active"],
                      masses=m["masses"], reference_normal=Z, **kw)


def interior_triangle(tris, nx=5, ny=4):
    """Index of a triangle none of whose vertices is on the grid boundary."""
    for k, tri in enumerate(np.asarray(tris).tolist()):
        if all(0 < v % nx < nx - 1 and 0 < v // nx < ny - 1 for v in tri):
            return k
    # fall back: triangle with all three edges interior (one interior vertex is enough for 5x4)
    raise AssertionError("no interior triangle")


# --------------------------------------------------------------------------
# angles, areas, normals, edges
# --------------------------------------------------------------------------
def test_equilateral_angles():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0.5, math.sqrt(3) / 2, 0]], dtype=float)
    ang = triangle_angles(pts, [[0, 1, 2]])
    assert ang.shape == (1, 3)
    np.testing.assert_allclose(ang, [[60, 60, 60]], atol=1e-12)
    np.testing.assert_allclose(triangle_min_angles(pts, [[0, 1, 2]]), [60], atol=1e-12)


def test_right_isoceles_angles_scale_invariant():
    for h in (1e-6, 1.0, 1e3):
        pts = np.array([[0, 0, 0], [h, 0, 0], [0, h, 0]], dtype=float)
        np.testing.assert_allclose(triangle_angles(pts, [[0, 1, 2]]), [[90, 45, 45]], atol=1e-12)
        np.testing.assert_allclose(triangle_angles(pts, [[1, 2, 0]]), [[45, 45, 90]], atol=1e-12)


@pytest.mark.parametrize("corners, expected", [
    # collinear, distinct: 0/0/180 (obtuse vertex in the middle)
    ([[0, 0, 0], [2, 0, 0], [1, 0, 0]], [0, 0, 180]),
    # two coincident vertices: third vertex 0, the pair shares 180
    ([[0, 0, 0], [0, 0, 0], [1, 1, 0]], [90, 90, 0]),
    # all coincident
    ([[1, 2, 3], [1, 2, 3], [1, 2, 3]], [0, 0, 180]),
])
def test_degenerate_angles_are_defined(corners, expected):
    pts = np.array(corners, dtype=float)
    ang = triangle_angles(pts, [[0, 1, 2]])
    assert np.isfinite(ang).all()
    np.testing.assert_allclose(ang, [expected], atol=1e-9)
    assert triangle_min_angles(pts, [[0, 1, 2]])[0] == pytest.approx(0, abs=1e-9)
    assert triangle_areas(pts, [[0, 1, 2]])[0] == pytest.approx(0, abs=1e-15)
    np.testing.assert_array_equal(triangle_normals(pts, [[0, 1, 2]]), [[0, 0, 0]])


def test_geometry_helpers_reject_negative_and_out_of_range_indices():
    pts = np.zeros((3, 3))
    for bad in ([[0, 1, -1]], [[0, 1, 3]]):
        for fn in (triangle_angles, triangle_areas, triangle_normals, triangle_min_angles):
            with pytest.raises(ValueError):
                fn(pts, bad)


def test_empty_inputs():
    pts = np.zeros((0, 3))
    assert triangle_angles(pts, np.zeros((0, 3), int)).shape == (0, 3)
    assert triangle_areas(pts, []).shape == (0,)
    assert edges_of(np.zeros((0, 3), np.int32)).shape == (0, 2)
    r = check_mesh(pts, np.zeros((0, 3), int), np.zeros((0, 2), int))
    assert r.valid and r.triangle_count == 0 and math.isnan(r.min_angle_deg)


coord = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
triangle_st = st.lists(st.tuples(coord, coord, coord), min_size=3, max_size=3)


def _well_shaped(pts):
    a, b, c = pts
    area2 = np.linalg.norm(np.cross(b - a, c - a))
    longest = max(np.linalg.norm(b - a), np.linalg.norm(c - b), np.linalg.norm(a - c))
    return longest > 1e-3 and area2 > 1e-3 * longest**2


@FAST
@given(triangle_st)
def test_angles_sum_to_180_and_match_law_of_cosines(corners):
    pts = np.array(corners, dtype=float)
    assume(_well_shaped(pts))
    ang = triangle_angles(pts, [[0, 1, 2]])[0]
    assert ang.sum() == pytest.approx(180.0, abs=1e-9)
    # law of cosines on the opposite side lengths
    a = np.linalg.norm(pts[1] - pts[2])
    b = np.linalg.norm(pts[2] - pts[0])
    c = np.linalg.norm(pts[0] - pts[1])
    ref = [
        math.degrees(math.acos(np.clip((b * b + c * c - a * a) / (2 * b * c), -1, 1))),
        math.degrees(math.acos(np.clip((a * a + c * c - b * b) / (2 * a * c), -1, 1))),
        math.degrees(math.acos(np.clip((a * a + b * b - c * c) / (2 * a * b), -1, 1))),
    ]
    np.testing.assert_allclose(ang, ref, atol=1e-5)


@FAST
@given(triangle_st)
def test_angles_never_nan_even_when_degenerate(corners):
    pts = np.array(corners, dtype=float)
    pts[2] = pts[0] + 0.5 * (pts[1] - pts[0])  # force collinear (possibly coincident)
    ang = triangle_angles(pts, [[0, 1, 2]])
    assert np.isfinite(ang).all()
    assert ang.sum() == pytest.approx(180.0, abs=1e-6)


def test_areas_normals_edges_match_trimesh():
    rng = np.random.default_rng(0)
    pts, tris = grid(6, 5, 0.02)
    pts = pts + rng.normal(scale=0.002, size=pts.shape)  # non-planar, non-uniform
    mesh = trimesh.Trimesh(pts, tris, process=False)
    np.testing.assert_allclose(triangle_areas(pts, tris), mesh.area_faces, rtol=1e-12)
    n = triangle_normals(pts, tris)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(n, mesh.face_normals, atol=1e-9)
    e = edges_of(tris)
    ref = np.unique(np.sort(mesh.edges_unique, axis=1), axis=0)
    np.testing.assert_array_equal(e, ref)
    np.testing.assert_array_equal(e, springs_from(tris))
    assert e.dtype == tris.dtype


def test_grid_normals_point_up():
    pts, tris = grid()
    np.testing.assert_allclose(triangle_normals(pts, tris), np.tile(Z, (len(tris), 1)))


def test_edges_of_drops_self_pairs_and_ignores_order():
    e = edges_of(np.array([[2, 1, 0], [0, 2, 3], [4, 4, 5]]))
    np.testing.assert_array_equal(e, [[0, 1], [0, 2], [0, 3], [1, 2], [2, 3], [4, 5]])


# --------------------------------------------------------------------------
# valid grid
# --------------------------------------------------------------------------
def test_valid_grid_passes():
    nx, ny = 5, 4
    m = grid_mesh(nx, ny)
    r = run(m, expected_total_mass=0.002 * nx * ny)
    assert isinstance(r, MeshReport)
    assert r.valid, r.problems
    assert r.problems == [] and r.problem_counts == {}
    assert r.min_angle_deg == pytest.approx(45.0, abs=1e-9)
    assert r.max_angle_deg == pytest.approx(90.0, abs=1e-9)
    assert r.slivers == 0
    assert r.triangle_count == 2 * (nx - 1) * (ny - 1)
    assert r.node_count == nx * ny
    assert r.spring_count == (nx - 1) * ny + nx * (ny - 1) + (nx - 1) * (ny - 1)
    assert r.edge_count == r.spring_count
    assert r.boundary_edge_count == 2 * (nx - 1) + 2 * (ny - 1)
    assert r.nonmanifold_edge_count == 0 and r.inconsistent_edge_count == 0
    assert r.total_mass == pytest.approx(0.002 * nx * ny)
    assert r.min_spring_length == pytest.approx(0.01)
    assert r.min_area == pytest.approx(0.5 * 0.01**2)
    assert r.raise_if_invalid() is r
    assert "valid" in r.summary()
    assert trimesh.Trimesh(m["points"], m["triangles"], process=False).is_winding_consistent


def test_valid_without_optional_arguments():
    m = grid_mesh()
    r = check_mesh(m["points"], m["triangles"], m["springs"])
    assert r.valid, r.problems
    assert r.total_mass is None


def test_inactive_unreferenced_slots_are_allowed():
    m = grid_mesh()
    m["points"] = np.vstack([m["points"], [[np.nan, np.nan, np.nan], [5.0, 5.0, 5.0]]])
    m["masses"] = np.concatenate([m["masses"], [0.0, -1.0]])
    m["active"] = np.concatenate([m["active"], [False, False]])
    r = run(m, expected_total_mass=0.002 * 20)
    assert r.valid, r.problems
    assert r.node_count == 20


# --------------------------------------------------------------------------
# each invariant violated in turn
# --------------------------------------------------------------------------
def _far_pair(m):
    edges = {tuple(e) for e in m["springs"].tolist()}
    n = len(m["points"])
    return next((i, j) for i in range(n) for j in range(i + 1, n)
                if (i, j) not in edges and np.linalg.norm(m["points"][i] - m["points"][j]) > 0.025)


def mut_tri_out_of_range(m):
    m["triangles"] = m["triangles"].copy()
    m["triangles"][3, 1] = len(m["points"]) + 5
    return {"tri_index_range"}, "[3]"


def mut_tri_negative(m):
    m["triangles"] = m["triangles"].copy()
    m["triangles"][2, 0] = -1
    return {"tri_index_negative"}, "[2]"


def mut_spring_out_of_range(m):
    m["springs"] = m["springs"].copy()
    m["springs"][4, 1] = len(m["points"])
    return {"spring_index_range"}, "[4]"


def mut_spring_negative(m):
    m["springs"] = m["springs"].copy()
    m["springs"][6, 0] = -1
    return {"spring_index_negative"}, "[6]"


def mut_inactive_referenced(m):
    m["active"] = m["active"].copy()
    m["active"][7] = False
    return {"tri_inactive_node", "spring_inactive_node"}, None


def mut_duplicate_spring_reversed(m):
    m["springs"] = np.vstack([m["springs"], m["springs"][5, ::-1]])
    return {"spring_duplicate"}, "[5, " + str(len(m["springs"]) - 1) + "]"


def mut_duplicate_spring_same_order(m):
    m["springs"] = np.vstack([m["springs"], m["springs"][:1]])
    return {"spring_duplicate"}, None


def mut_self_spring(m):
    m["springs"] = np.vstack([m["springs"], [[3, 3]]])
    return {"spring_self"}, "[[3, 3]]"


def mut_zero_length_spring(m):
    a, b = m["springs"][0]
    m["points"] = m["points"].copy()
    m["points"][b] = m["points"][a]
    return {"spring_zero_length"}, None  # degenerate triangles are expected too


def mut_degenerate_triangle(m):
    # bottom-right corner (nx-1, 0) belongs to one triangle only: put it on the
    # opposite edge's midpoint -> that triangle has zero area, nothing else changes
    nx = 5
    corner = nx - 1
    k = next(k for k, t in enumerate(m["triangles"].tolist()) if corner in t)
    others = [v for v in m["triangles"][k] if v != corner]
    m["points"] = m["points"].copy()
    m["points"][corner] = 0.5 * (m["points"][others[0]] + m["points"][others[1]])
    return {"tri_degenerate"}, f"[{k}]"


def mut_flipped_triangle(m):
    k = interior_triangle(m["triangles"])
    m["triangles"] = m["triangles"].copy()
    m["triangles"][k, [1, 2]] = m["triangles"][k, [2, 1]]
    return {"tri_flipped", "winding_inconsistent"}, f"[{k}]"


def mut_repeated_vertex(m):
    m["triangles"] = m["triangles"].copy()
    m["triangles"][0, 2] = m["triangles"][0, 0]
    return {"tri_repeated_vertex"}, None


def mut_duplicate_triangle(m):
    m["triangles"] = np.vstack([m["triangles"], np.roll(m["triangles"][0], 1)])
    return {"tri_duplicate"}, None


def mut_missing_spring(m):
    m["springs"] = np.delete(m["springs"], 8, axis=0)
    return {"spring_missing"}, None


def mut_stray_spring(m):
    m["springs"] = np.vstack([m["springs"], [_far_pair(m)]])
    return {"spring_stray"}, None


def mut_nonmanifold_edge(m):
    a, b = map(int, m["triangles"][interior_triangle(m["triangles"])][:2])  # an interior edge
    new = len(m["points"])
    d = m["points"][b] - m["points"][a]
    left = np.array([-d[1], d[0], 0.0])  # new node left of a->b: (a, b, new) faces +Z
    m["points"] = np.vstack([m["points"], (m["points"][a] + m["points"][b]) / 2 + 0.3 * left + [0, 0, 0.01]])
    m["masses"] = np.append(m["masses"], 0.002)
    m["active"] = np.append(m["active"], True)
    m["triangles"] = np.vstack([m["triangles"], [a, b, new]])
    m["springs"] = np.vstack([m["springs"], [a, new], [b, new]])
    return {"edge_nonmanifold"}, None


def mut_zero_mass(m):
    m["masses"] = m["masses"].copy()
    m["masses"][5] = 0.0
    return {"mass_invalid"}, "[5]"


def mut_negative_mass(m):
    m["masses"] = m["masses"].copy()
    m["masses"][6] = -0.001
    return {"mass_invalid"}, "[6]"


def mut_nan_mass(m):
    m["masses"] = m["masses"].copy()
    m["masses"][6] = np.nan
    return {"mass_invalid"}, "[6]"


def mut_nan_point(m):
    m["points"] = m["points"].copy()
    m["points"][4, 0] = np.nan
    return {"points_finite"}, "[4]"


MUTATIONS = [
    mut_tri_out_of_range, mut_tri_negative, mut_spring_out_of_range, mut_spring_negative,
    mut_inactive_referenced, mut_duplicate_spring_reversed, mut_duplicate_spring_same_order,
    mut_self_spring, mut_zero_length_spring, mut_degenerate_triangle, mut_flipped_triangle,
    mut_repeated_vertex, mut_duplicate_triangle, mut_missing_spring, mut_stray_spring,
    mut_nonmanifold_edge, mut_zero_mass, mut_negative_mass, mut_nan_mass, mut_nan_point,
]

# mutations after which the expected checks are the *only* ones failing
# (a bad index in a triangle/spring also orphans its edges/springs, so those
# mutations legitimately report spring_stray / spring_missing as well)
EXACT = {mut_inactive_referenced, mut_duplicate_spring_reversed, mut_duplicate_spring_same_order,
         mut_self_spring, mut_degenerate_triangle, mut_flipped_triangle, mut_missing_spring,
         mut_stray_spring, mut_nonmanifold_edge, mut_zero_mass, mut_negative_mass, mut_nan_point}


@pytest.mark.parametrize("mutate", MUTATIONS, ids=lambda f: f.__name__[4:])
def test_each_violation_is_reported(mutate):
    m = grid_mesh()
    expected, fragment = mutate(m)
    assert expected <= set(CHECKS)
    r = run(m)
    assert not r.valid
    assert expected <= set(r.problem_counts), r.problems
    if mutate in EXACT:
        assert set(r.problem_counts) == expected, r.problems
    for name in expected:
        assert r.failed(name)
        msgs = [p for p in r.problems if p.startswith(name + ":")]
        assert msgs, r.problems
        if fragment is not None and len(expected) == 1:
            assert fragment in msgs[0], msgs[0]
    with pytest.raises(MeshInvalid) as exc:
        r.raise_if_invalid("after cut 1")
    assert isinstance(exc.value, ValueError)
    assert exc.value.problems == r.problems
    assert "after cut 1" in str(exc.value)
    for p in r.problems:
        assert p in str(exc.value)


def test_flipped_triangle_details():
    m = grid_mesh()
    k = interior_triangle(m["triangles"])
    m["triangles"][k, [0, 1]] = m["triangles"][k, [1, 0]]
    r = run(m)
    assert r.flipped_count == 1
    assert r.inconsistent_edge_count == 3  # all three edges of an interior triangle
    assert r.problem_counts == {"tri_flipped": 1, "winding_inconsistent": 3}
    flip_msg = next(p for p in r.problems if p.startswith("tri_flipped"))
    assert f"[{k}]" in flip_msg
    assert not trimesh.Trimesh(m["points"], m["triangles"], process=False).is_winding_consistent
    # without a reference normal only the winding inconsistency is visible
    r2 = check_mesh(m["points"], m["triangles"], m["springs"])
    assert set(r2.problem_counts) == {"winding_inconsistent"}


def test_whole_mesh_reversed_is_consistent_but_flipped():
    m = grid_mesh()
    m["triangles"] = m["triangles"][:, ::-1].copy()
    r = run(m)
    assert set(r.problem_counts) == {"tri_flipped"}
    assert r.flipped_count == len(m["triangles"])
    assert check_mesh(m["points"], m["triangles"], m["springs"], reference_normal=-Z).valid


def test_allowed_extra_springs_accepted():
    m = grid_mesh()
    i, j = _far_pair(m)
    m["springs"] = np.vstack([m["springs"], [[j, i]]])  # reversed order on purpose
    assert set(run(m).problem_counts) == {"spring_stray"}
    assert run(m, extra_springs={(i, j)}).valid
    assert run(m, extra_springs=np.array([[j, i]])).valid
    assert run(m, extra_springs=[(i, j), (0, 1)]).valid  # extras need not be present
    assert not run(m, extra_springs={(0, 1)}).valid


def test_total_mass():
    m = grid_mesh()
    total = 0.002 * len(m["points"])
    assert run(m, expected_total_mass=total * (1 + 1e-12)).valid
    r = run(m, expected_total_mass=total * (1 + 1e-6))
    assert set(r.problem_counts) == {"mass_total"}
    # inactive nodes do not count
    m["active"][[0]] = False
    m["triangles"] = m["triangles"][~(m["triangles"] == 0).any(axis=1)]
    m["springs"] = springs_from(m["triangles"])
    assert run(m, expected_total_mass=total - 0.002).valid
    with pytest.raises(ValueError):
        check_mesh(m["points"], m["triangles"], m["springs"], expected_total_mass=1.0)


def test_negative_index_is_not_wrapped():
    # with -1 numpy/Warp would silently address the last node; it must be an error
    m = grid_mesh()
    n = len(m["points"])
    k = next(k for k, t in enumerate(m["triangles"].tolist()) if n - 1 in t)
    m["triangles"][k][m["triangles"][k].tolist().index(n - 1)] = -1
    r = run(m)
    assert r.failed("tri_index_negative")


def test_zero_length_spring_threshold():
    m = grid_mesh()
    a, b = m["springs"][0]
    m["points"][b] = m["points"][a] + [1e-13, 0, 0]
    r = run(m)
    assert set(r.problem_counts) == {"spring_zero_length"}  # area ~5e-16 m^2 > min_area
    assert r.min_spring_length == pytest.approx(1e-13)
    r2 = run(m, min_length=1e-14, min_area=1e-30)
    assert r2.valid, r2.problems


def test_messages_list_first_few_offenders():
    m = grid_mesh()
    m["masses"][:] = 0.0
    r = run(m)
    msg = r.problems[0]
    assert msg.startswith("mass_invalid: 20 ")
    assert "nodes [0, 1, 2, 3, 4, ...] -> kg [0, 0, 0, 0, 0]" in msg
    assert "\n" not in msg


def test_malformed_inputs_raise():
    m = grid_mesh()
    with pytest.raises(ValueError):
        check_mesh(m["points"][:, :2], m["triangles"], m["springs"])
    with pytest.raises(ValueError):
        check_mesh(m["points"], m["triangles"].astype(float), m["springs"])
    with pytest.raises(ValueError):
        check_mesh(m["points"], m["triangles"], m["springs"], active=np.ones(3, bool))
    with pytest.raises(ValueError):
        check_mesh(m["points"], m["triangles"], m["springs"], masses=np.ones(3))
    with pytest.raises(ValueError):
        check_mesh(m["points"], m["triangles"], m["springs"], reference_normal=[0, 0, 0])
    with pytest.raises(ValueError):
        check_mesh(m["points"], m["triangles"], m["springs"], sliver_triangles=[len(m["triangles"])])


# --------------------------------------------------------------------------
# quality metrics
# --------------------------------------------------------------------------
def test_sliver_count_and_subset():
    m = grid_mesh()
    tris = m["triangles"]
    # squash the top row of nodes towards the row below: thin triangles in the top cell row
    nx, ny = 5, 4
    top = np.arange((ny - 1) * nx, ny * nx)
    m["points"][top, 1] = m["points"][top - nx, 1] + 0.001  # cell height 1 mm, width 10 mm
    sliver_ref = triangle_min_angles(m["points"], tris) < 10.0  # independent of check_mesh
    top_cells = np.flatnonzero(np.isin(tris, top).any(axis=1))
    assert set(np.flatnonzero(sliver_ref)) == set(top_cells)
    expected_min = math.degrees(math.atan2(1, 10))  # angle of the thin right triangles
    r = run(m)
    assert r.valid, r.problems
    assert r.slivers == len(top_cells)
    np.testing.assert_array_equal(r.sliver_indices, top_cells)
    assert r.min_angle_deg == pytest.approx(expected_min, abs=1e-9)
    sub = [0, 1, int(top_cells[0])]
    assert run(m, sliver_triangles=sub).slivers == 1
    mask = np.zeros(len(tris), bool)
    mask[top_cells[:3]] = True
    assert run(m, sliver_triangles=mask).slivers == 3
    assert run(m, sliver_triangles=[]).slivers == 0
    assert run(m, sliver_triangles=[], sliver_angle_deg=1.0).min_angle_deg == pytest.approx(expected_min)
    assert run(m, sliver_angle_deg=1.0).slivers == 0


def test_degenerate_triangle_is_a_sliver():
    m = grid_mesh()
    mut_degenerate_triangle(m)
    r = run(m)
    assert r.min_angle_deg == pytest.approx(0.0, abs=1e-9)
    assert r.slivers == 1 and r.degenerate_count == 1


# --------------------------------------------------------------------------
# properties
# --------------------------------------------------------------------------
@FAST
@given(nx=st.integers(2, 7), ny=st.integers(2, 6), data=st.data())
def test_random_triangle_subsets_stay_valid(nx, ny, data):
    pts, tris = grid(nx, ny)
    keep = np.array(data.draw(st.lists(st.booleans(), min_size=len(tris), max_size=len(tris))))
    sub = tris[keep]
    deactivate = data.draw(st.booleans())
    active = np.ones(len(pts), bool)
    if deactivate:  # deleted nodes stay as inactive slots
        active[:] = False
        active[np.unique(sub)] = True
    masses = np.full(len(pts), 0.5)
    r = check_mesh(pts, sub, springs_from(sub), active=active, masses=masses, reference_normal=Z,
                   expected_total_mass=0.5 * active.sum())
    assert r.valid, r.problems
    assert r.triangle_count == int(keep.sum())
    if keep.any():
        assert r.min_angle_deg == pytest.approx(45.0, abs=1e-9)
    # boundary edges by brute force
    cnt = {}
    for a, b, c in sub.tolist():
        for u, v in ((a, b), (b, c), (c, a)):
            cnt[(min(u, v), max(u, v))] = cnt.get((min(u, v), max(u, v)), 0) + 1
    assert r.boundary_edge_count == sum(1 for v in cnt.values() if v == 1)
    assert r.edge_count == len(cnt)


@FAST
@given(nx=st.integers(2, 6), ny=st.integers(2, 5), data=st.data())
def test_relabelling_keeps_validity_and_min_angle(nx, ny, data):
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    pts, tris = grid(nx, ny)
    pts = pts + rng.uniform(-0.002, 0.002, size=pts.shape) * [1, 1, 0]  # still CCW, irregular
    springs = springs_from(tris)
    masses = rng.uniform(0.001, 0.002, len(pts))
    base = check_mesh(pts, tris, springs, masses=masses, reference_normal=Z)
    assert base.valid, base.problems

    perm = np.array(data.draw(st.permutations(range(len(pts)))))  # old index i -> new perm[i]
    new_pts = np.empty_like(pts)
    new_pts[perm] = pts
    new_masses = np.empty_like(masses)
    new_masses[perm] = masses
    new_tris = perm[tris]
    new_springs = perm[springs]
    # also shuffle row order and rotate each triangle's vertex order (same winding)
    new_tris = np.roll(new_tris, data.draw(st.integers(0, 2)), axis=1)[rng.permutation(len(tris))]
    new_springs = new_springs[rng.permutation(len(springs))]
    swap = rng.random(len(springs)) < 0.5
    new_springs[swap] = new_springs[swap][:, ::-1]
    r = check_mesh(new_pts, new_tris, new_springs, masses=new_masses, reference_normal=Z,
                   expected_total_mass=masses.sum())
    assert r.valid, r.problems
    assert r.min_angle_deg == pytest.approx(base.min_angle_deg, rel=1e-12, abs=1e-12)
    assert r.slivers == base.slivers
    assert r.boundary_edge_count == base.boundary_edge_count


@FAST
@given(data=st.data())
def test_rigid_rotation_with_rotated_reference_keeps_validity(data):
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    m = grid_mesh(4, 4)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    pts = m["points"] @ q.T + rng.normal(size=3)
    r = check_mesh(pts, m["triangles"], m["springs"], reference_normal=q @ Z)
    assert r.valid, r.problems
    assert r.min_angle_deg == pytest.approx(45.0, abs=1e-6)
    r2 = check_mesh(pts, m["triangles"], m["springs"], reference_normal=-(q @ Z))
    assert r2.flipped_count == len(m["triangles"])


def test_duplicate_triangles_with_many_nodes():
    # n**3 overflows int64 here: the row-wise fallback path must give the same answer
    n = 2_000_001
    pts = np.zeros((n, 3))
    pts[[0, 1, 2, n - 1], :2] = [[0, 0], [1, 0], [0, 1], [1, 1]]
    tris = np.array([[0, 1, 2], [1, n - 1, 2], [2, 0, 1]])
    r = check_mesh(pts, tris, edges_of(tris))
    assert r.problem_counts.get("tri_duplicate") == 2
    assert "triangles [0, 2]" in next(p for p in r.problems if p.startswith("tri_duplicate"))
