"""warp_cut/verify/mesh_surface.py and the real mesh tests/data/mni152_brain_top.obj.

The chart is checked against independent computations: on a dome mesh against the analytic
sphere it samples, and on the brain mesh against a brute-force search over every triangle;
the polygon domain against the distances of a square worked by hand."""

import math
from pathlib import Path

import numpy as np
import pytest

from warp_cut import InputError
from warp_cut.mesh import surfaces
from warp_cut.mesh.checks import cuttable_problems
from warp_cut.mesh.surfaces import surface_problems
from warp_cut.verify.mesh_surface import PolygonDomain, border_polygon, load_mesh_surface, mesh_surface

BRAIN = Path(__file__).parent / "data" / "mni152_brain_top.obj"


@pytest.fixture(scope="module")
def brain():
    return load_mesh_surface(BRAIN, name="brain_top")


def brute_force_point(surface, uv):
    """The mesh point above uv (2,): every triangle's projection tested for containment."""
    corners = surface.uv[surface.triangles]
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    det = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    w1 = ((uv - a)[:, 0] * (c - a)[:, 1] - (uv - a)[:, 1] * (c - a)[:, 0]) / det
    w2 = ((b - a)[:, 0] * (uv - a)[:, 1] - (b - a)[:, 1] * (uv - a)[:, 0]) / det
    w = np.column_stack([1 - w1 - w2, w1, w2])
    hit = np.flatnonzero((w >= -1e-12).all(axis=1))
    assert len(hit) >= 1
    k = hit[0]
    return w[k] @ surface.points[surface.triangles[k]]


def test_brain_mesh_file_is_small_cuttable_and_disk_like(brain):
    assert BRAIN.stat().st_size < 1_000_000
    assert "McConnell Brain Imaging Centre" in BRAIN.read_text()[:2000]  # the licence notice travels with it
    assert cuttable_problems(brain.points, brain.triangles) == []
    assert surface_problems(brain) == []  # check_mesh, normals vs the chart, on the surface, one border loop
    assert 1000 <= len(brain.points) <= 4000
    assert 2e-3 <= brain.spacing <= 3e-3
    extent = brain.points.max(axis=0) - brain.points.min(axis=0)
    assert 0.07 < extent[0] < 0.1 and 0.07 < extent[1] < 0.1  # metres: a 9 cm cap


def test_chart_hits_nodes_exactly_and_matches_a_brute_force_ray_cast(brain):
    assert np.abs(brain.point(brain.uv[:, 0], brain.uv[:, 1]) - brain.points).max() < 1e-12
    rng = np.random.default_rng(3)
    uv = rng.uniform(-0.03, 0.03, (40, 2))
    uv = uv[brain.depth(uv) > 1e-3]
    got = brain.chart.point(uv)
    want = np.array([brute_force_point(brain, q) for q in uv])
    assert np.abs(got - want).max() < 1e-12
    assert np.abs(brain.uv_of(got) - uv).max() < 1e-12  # the ray runs along the plane's normal
    n = brain.chart.normal(uv)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    assert (n @ brain.chart.axes[2] > 0.3).all()  # outward, on the plane's side
    assert np.abs(brain.offset(got)).max() < 1e-12


def test_chart_of_a_dome_mesh_follows_the_sphere_it_samples():
    dome = surfaces.dome(0.04, 0.025, 0.002)
    surf = mesh_surface(dome.points, dome.triangles, name="dome_mesh")
    assert surf.spacing == pytest.approx(0.002, rel=0.15)
    rng = np.random.default_rng(0)
    points = dome.point(*rng.uniform(-0.015, 0.015, (2, 200)))
    uv = surf.uv_of(points)
    sag = 0.002 ** 2 / (8 * 0.04) * 4  # chord sag of an edge of up to 2 spacings
    assert np.abs(surf.chart.point(uv) - points).max() < sag
    analytic = dome.chart.normal(dome.uv_of(points))
    cosines = np.einsum("ij,ij->i", surf.normal(uv[:, 0], uv[:, 1]), analytic)
    assert cosines.min() > math.cos(math.radians(2.0))


def test_polygon_domain_depth_of_a_square():
    square = PolygonDomain(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))
    got = square.depth(np.array([[0.5, 0.5], [0.1, 0.5], [2.0, 0.5], [1.5, 1.5]]))
    assert got == pytest.approx([0.5, 0.1, -1.0, -math.sqrt(0.5)])


def test_border_polygon_walks_the_loop_in_winding_order():
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    loop = border_polygon(tri).tolist()
    assert sorted(loop) == [0, 1, 2, 3]
    i = loop.index(0)
    assert loop[i:] + loop[:i] == [0, 1, 2, 3]  # counter-clockwise, as the triangles


def test_a_mesh_that_is_no_height_field_or_no_disk_is_refused():
    tube = surfaces.cylinder(0.01, 0.02, 2 * math.pi, 0.002)
    with pytest.raises(InputError):
        mesh_surface(tube.points, tube.triangles)  # two border loops
    flat = surfaces.flat_grid(0.01, 0.002)
    folded = flat.points.copy()
    over = flat.points[:, 0] > 0.002
    folded[over, 0] = 0.004 - folded[over, 0]  # the strip beyond x = 2 mm laid back over itself
    folded[over, 2] = 1e-3
    with pytest.raises(InputError):
        mesh_surface(folded, flat.triangles)
