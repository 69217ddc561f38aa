"""warp_cut/mesh/surfaces.py: generated skin meshes against their analytic surfaces.

Each mesh is compared with closed-form geometry written out here (not the module's charts):
nodes on the sphere / cylinder / saddle / plane, triangle normals along the analytic outward
normal, edge lengths near the requested spacing; its topology is checked with trimesh
(winding, edge use, Euler number) and the Delaunay disk's smallest angle against the bound
derived in ``jittered_delaunay``'s docstring.
"""

import math

import numpy as np
import pytest
import trimesh

import warp_cut as wc
from warp_cut import InputError
from warp_cut.mesh import surfaces as S
from warp_cut.mesh.geometry import triangle_min_angles
from warp_cut.mesh.triangulate import boundary_edges

H = 0.002


def sphere_normal(x, rc):
    d = x + [0.0, 0.0, rc]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def cylinder_normal(x, r):
    d = np.stack([np.zeros(len(x)), x[:, 1], x[:, 2] + r], axis=1)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def saddle_normal(x, c):
    d = np.stack([-c * x[:, 0], c * x[:, 1], np.ones(len(x))], axis=1)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


# name -> (surface, closed-form residual of "x on the surface", closed-form normal, border loops)
CASES = {
    "flat": (lambda: S.flat_grid(0.03, H), lambda x: x[:, 2], lambda x: np.tile([0, 0, 1.0], (len(x), 1)), 1),
    "flat_turned": (lambda: S.flat_grid((0.03, 0.02), H, angle=0.4), lambda x: x[:, 2],
                    lambda x: np.tile([0, 0, 1.0], (len(x), 1)), 1),
    "delaunay": (lambda: S.jittered_delaunay(0.015, H, 0.25, seed=3), lambda x: x[:, 2],
                 lambda x: np.tile([0, 0, 1.0], (len(x), 1)), 1),
    "dome": (lambda: S.dome(0.04, 0.025, H), lambda x: np.linalg.norm(x + [0, 0, 0.04], axis=1) - 0.04,
             lambda x: sphere_normal(x, 0.04), 1),
    "hemisphere_jittered": (lambda: S.dome(0.015, 0.015, H, jitter=0.2, seed=1),
                            lambda x: np.linalg.norm(x + [0, 0, 0.015], axis=1) - 0.015,
                            lambda x: sphere_normal(x, 0.015), 1),
    "cylinder_half": (lambda: S.cylinder(0.03, 0.04, math.pi, H), lambda x: np.hypot(x[:, 1], x[:, 2] + 0.03) - 0.03,
                      lambda x: cylinder_normal(x, 0.03), 1),
    "cylinder_full_jittered": (lambda: S.cylinder(0.01, 0.03, 2 * math.pi, H, jitter=0.5, seed=2),
                               lambda x: np.hypot(x[:, 1], x[:, 2] + 0.01) - 0.01,
                               lambda x: cylinder_normal(x, 0.01), 2),
    "saddle": (lambda: S.saddle(0.03, 30.0, H), lambda x: x[:, 2] - 15.0 * (x[:, 0] ** 2 - x[:, 1] ** 2),
               lambda x: saddle_normal(x, 30.0), 1),
    "saddle_negative_jittered": (lambda: S.saddle(0.03, -30.0, H, jitter=0.4, seed=5),
                                 lambda x: x[:, 2] + 15.0 * (x[:, 0] ** 2 - x[:, 1] ** 2),
                                 lambda x: saddle_normal(x, -30.0), 1),
}


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    make, residual, normal, loops = CASES[request.param]
    return request.param, make(), residual, normal, loops


def edge_lengths(surf):
    e = np.unique(np.sort(surf.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    return np.linalg.norm(surf.points[e[:, 0]] - surf.points[e[:, 1]], axis=1)


def test_nodes_lie_on_the_analytic_surface(case):
    _, surf, residual, _, _ = case
    assert surf.points.dtype == np.float64 and surf.points.shape[1] == 3
    assert surf.triangles.dtype == np.int64
    np.testing.assert_allclose(residual(surf.points), 0.0, atol=1e-12)


def test_triangle_normals_follow_the_analytic_normal(case):
    """Chord triangles of a surface with curvature radius R tilt by at most ~ spacing / R
    from the normal at their centroid (R >= 1 cm here, spacing 2 mm: cos > 0.97)."""
    _, surf, _, normal, _ = case
    p = surf.points[surf.triangles]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    cos = np.einsum("ij,ij->i", n, normal(p.mean(axis=1)))
    assert cos.min() > 0.97


def test_chart_agrees_with_closed_form(case):
    _, surf, _, normal, _ = case
    uv = surf.uv
    np.testing.assert_allclose(surf.point(uv[:, 0], uv[:, 1]), surf.points, atol=1e-15)
    np.testing.assert_allclose(surf.normal(uv[:, 0], uv[:, 1]), normal(surf.points), atol=1e-12)
    back = surf.uv_of(surf.points)
    period = getattr(surf.domain, "period_v", None)
    diff = back - uv
    if period:
        diff[:, 1] = (diff[:, 1] + period / 2) % period - period / 2
    np.testing.assert_allclose(diff, 0.0, atol=1e-12)
    # the offset is the signed distance along the normal, for points lifted off the surface
    np.testing.assert_allclose(surf.offset(surf.points + 1e-4 * normal(surf.points)), 1e-4, rtol=2e-3)


def test_edges_are_about_the_spacing(case):
    """Lattice edges are one spacing, with half-spacing edges on the u borders; jitter and the
    chart's stretch (dome rim, saddle corners) change them by the amounts the generators
    document. A Delaunay edge is a chord of an empty circle of radius <= (1/sqrt(3) + j)
    spacing (1.65 spacings at j = 0.25), a little more next to the border ring."""
    name, surf, *_ = case
    length = edge_lengths(surf) / H
    assert abs(np.median(length) - 1.0) < 0.1, name
    longest = 2.0 if surf.name in ("jittered_delaunay", "dome") else 1.8
    assert length.min() > 0.35 and length.max() < longest, (name, length.min(), length.max())


def test_trimesh_finds_a_consistent_manifold(case):
    _, surf, _, _, loops = case
    mesh = trimesh.Trimesh(surf.points, surf.triangles, process=False)
    assert mesh.is_winding_consistent
    _, uses = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    assert uses.max() <= 2
    assert mesh.euler_number == 2 - loops  # a disk (1) or an open tube (0)
    assert len(np.unique(np.sort(surf.triangles, axis=1), axis=0)) == len(surf.triangles)
    assert mesh.area_faces.min() > 0.05 * H * H
    # every border node is on exactly two border edges: the border is not pinched
    per_node = np.bincount(boundary_edges(surf.triangles).ravel(), minlength=len(surf.points))
    assert set(np.unique(per_node)) <= {0, 2}


def test_border_nodes_are_the_pinned_set(case):
    _, surf, *_ = case
    model = wc.TissueModel.from_surface(surf)
    border = np.zeros(len(surf.points), bool)
    border[boundary_edges(surf.triangles).ravel()] = True
    np.testing.assert_array_equal(model.pinned, border)
    assert model.triangle_count == len(surf.triangles)


@pytest.mark.parametrize("jitter, bound", [(0.0, 15.0), (0.25, 15.0), (0.3, 13.2)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_delaunay_smallest_angle_bound(jitter, seed, bound):
    """Interior triangles: >= asin((1 - 2j) / (2 (1/sqrt(3) + j))) (17.6 deg at j = 0.25,
    13.2 deg at 0.3); border triangles below 15 deg are trimmed off. So the smallest angle
    is at least min(15, bound(j))."""
    surf = S.jittered_delaunay(0.015, H, jitter, seed=seed)
    derived = math.degrees(math.asin((1 - 2 * jitter) / (2 * (1 / math.sqrt(3) + jitter))))
    assert derived >= bound - 0.05
    assert triangle_min_angles(surf.points, surf.triangles).min() >= min(15.0, derived)
    # the disk is filled: its area is that of the polygon of border points, close to pi R^2
    assert abs(trimesh.Trimesh(surf.points, surf.triangles).area / (math.pi * 0.015 ** 2) - 1) < 0.03


def test_turned_grid_rows_follow_the_angle():
    angle = 0.4
    surf = S.flat_grid(0.03, H, angle=angle)
    e = np.sort(surf.triangles[:, [0, 1]], axis=1)
    d = surf.points[e[:, 1]] - surf.points[e[:, 0]]
    full = np.linalg.norm(d, axis=1) > 0.9 * H  # lattice edges (not the half-spacing border ones)
    directions = np.degrees(np.arctan2(d[full, 1], d[full, 0])) % 60.0
    offset = (directions - math.degrees(angle) % 60.0 + 30.0) % 60.0 - 30.0
    assert np.abs(offset).max() < 1.0


def test_dome_and_cylinder_extent():
    dome = S.dome(0.04, 0.025, H)
    rim = np.hypot(dome.points[:, 0], dome.points[:, 1])
    assert rim.max() == pytest.approx(0.025, rel=1e-9)
    assert dome.points[:, 2].max() == pytest.approx(0.0, abs=1e-15)  # the apex is the origin
    half = S.cylinder(0.03, 0.04, math.radians(120), H)
    phi = np.arctan2(half.points[:, 1], half.points[:, 2] + 0.03)
    assert phi.max() == pytest.approx(math.radians(60)) and phi.min() == pytest.approx(-math.radians(60))
    assert np.ptp(half.points[:, 0]) == pytest.approx(0.04)


@pytest.mark.parametrize("make", [
    lambda: S.flat_grid(0.03, -1.0),
    lambda: S.jittered_delaunay(0.015, H, jitter=0.5),
    lambda: S.jittered_delaunay(0.003, H),
    lambda: S.dome(0.02, 0.03, H),
    lambda: S.cylinder(0.01, 0.03, 7.0, H),
    lambda: S.cylinder(0.01, 0.03, 1.0, H, jitter=1.0),
    lambda: S.saddle(0.03, float("nan"), H),
])
def test_bad_arguments_are_refused(make):
    with pytest.raises(InputError):
        make()


def test_trimming_removes_border_slivers_without_pinching():
    """A point just below the bottom border of a 3 x 2 grid makes two slivers; trimming takes
    both (the second once the first has exposed it) and that point with them."""
    from warp_cut.mesh.triangulate import delaunay, topology_problems, trim_border_slivers

    grid = [(x, y) for y in (0.0, 1.0) for x in (0.0, 1.0, 2.0)]
    uv = np.array(grid + [(1.0, -0.05)])
    tri = delaunay(uv)
    pts = np.column_stack([uv, np.zeros(len(uv))])
    assert triangle_min_angles(pts, tri).min() < 5.0
    kept, trimmed = trim_border_slivers(pts, tri, 15.0)
    assert 6 not in kept and len(trimmed) == 4
    assert triangle_min_angles(pts[kept], trimmed).min() >= 15.0 - 1e-9
    assert topology_problems(trimmed, len(kept), 1) == []


def test_topology_check_catches_a_pinch_and_a_wrong_loop_count():
    from warp_cut.mesh.triangulate import topology_problems

    bowtie = np.array([[0, 1, 2], [0, 3, 4]])  # two triangles sharing only node 0
    assert any("pinched" in p for p in topology_problems(bowtie, 5, 1))
    strip = np.array([[0, 1, 2], [1, 3, 2]])
    assert topology_problems(strip, 4, 1) == []
    assert any("border loops" in p for p in topology_problems(strip, 4, 2))
