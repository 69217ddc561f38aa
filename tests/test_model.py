"""warp_cut/model.py and patch.py: building tissues from arrays, generators and mesh files."""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut import InputError, Material, TissueModel
from warp_cut.mesh.checks import check_mesh, triangle_min_angles
from warp_cut.mesh.patch import skin_patch_mesh


@settings(max_examples=25, deadline=None)
@given(st.floats(0.005, 0.2), st.floats(0.005, 0.2), st.floats(0.0008, 0.01))
def test_patch_is_a_valid_well_shaped_mesh(w, h, spacing):
    spacing = min(spacing, min(w, h) / 4)  # at least a few triangles across
    pts, tri = skin_patch_mesh((w, h), spacing)
    model = TissueModel.from_triangles(pts, tri)
    report = check_mesh(pts, tri, model.springs, reference_normal=[0, 0, 1], masses=model.masses)
    assert report.valid, report.problems
    # the border triangles' smallest angle is atan(dx / (2 dy)), 30 deg for dx = 2 dy / sqrt(3);
    # the column count is nx = round(x), x = W sqrt(3) / (2 dy) >= 3.6 (spacing <= W / 4 and
    # H / 4, the row count rounded too), so dx / dy >= (2 / sqrt(3)) x / (x + 1/2) and the
    # angle >= atan(0.506) = 26.8 deg (interior triangles stay above 50 deg)
    assert triangle_min_angles(pts, tri).min() > 25.0
    e1, e2 = pts[tri[:, 1]] - pts[tri[:, 0]], pts[tri[:, 2]] - pts[tri[:, 0]]
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1).sum()
    assert area == pytest.approx(w * h, rel=1e-9)
    # lumped masses account for the whole sheet
    assert model.total_mass == pytest.approx(1100.0 * 2e-3 * w * h, rel=1e-9)
    np.testing.assert_allclose(pts.min(0)[:2], [-w / 2, -h / 2], atol=1e-12)


def test_paper_patch_defaults():
    model = TissueModel.from_patch()
    assert np.allclose(model.stiffness, 160.0) and np.allclose(model.damping, 3.0)
    assert model.material.residual_stress == pytest.approx(2000.0)  # 20 kPa x 0.1
    # border pinned: every node on the rectangle's edge, nothing else
    x, y = model.points[:, 0], model.points[:, 1]
    on_edge = np.isclose(np.abs(x), 0.05) | np.isclose(np.abs(y), 0.03)
    np.testing.assert_array_equal(model.pinned, on_edge)


def test_from_arrays_checks_inputs():
    pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    with pytest.raises(InputError, match="outside"):
        TissueModel.from_arrays(pts, [[0, 3]], 1.0)
    with pytest.raises(InputError, match="itself"):
        TissueModel.from_arrays(pts, [[1, 1]], 1.0)
    with pytest.raises(InputError, match="duplicate"):
        TissueModel.from_arrays(pts, [[0, 1], [1, 0]], 1.0)
    with pytest.raises(InputError, match="masses"):
        TissueModel.from_arrays(pts, [[0, 1]], [1.0, 0.0, 1.0])
    with pytest.raises(InputError, match="finite"):
        TissueModel.from_arrays([[0, 0, np.nan]], [], 1.0)
    with pytest.raises(InputError, match="stiffness"):
        TissueModel.from_arrays(pts, [[0, 1]], 1.0, stiffness=[1.0, 2.0])
    m = TissueModel.from_arrays(pts, [[1, 0]], [1, 2, 3], pinned=[2], stiffness=5.0)
    assert m.springs.tolist() == [[0, 1]] and m.rest_lengths[0] == pytest.approx(1.0)
    assert m.pinned.tolist() == [False, False, True] and m.total_mass == 6.0


@pytest.mark.parametrize("ext", ["obj", "stl", "ply"])
def test_mesh_file_merges_duplicate_vertices(tmp_path, ext):
    pts, tri = skin_patch_mesh((0.02, 0.01), 0.002)
    soup = trimesh.Trimesh(pts[tri].reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3), process=False)
    path = tmp_path / f"patch.{ext}"
    soup.export(path)
    model = TissueModel.from_mesh_file(path, material=Material(density=1000, thickness=1e-3))
    assert model.node_count == len(pts)
    assert model.spring_count == len(trimesh.Trimesh(pts, tri).edges_unique)
    assert model.total_mass == pytest.approx(1000 * 1e-3 * 0.02 * 0.01, rel=1e-6)
    assert model.pinned.sum() == TissueModel.from_patch((0.02, 0.01), 0.002).pinned.sum()


def test_mesh_file_errors(tmp_path):
    with pytest.raises(InputError, match="not found"):
        TissueModel.from_mesh_file(tmp_path / "missing.obj")
    bad = tmp_path / "bad.obj"
    bad.write_text("this is not a mesh\n")
    with pytest.raises(InputError, match="bad.obj"):
        TissueModel.from_mesh_file(bad)


def test_from_triangles_rejects_a_triangle_with_a_repeated_node():
    pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    with pytest.raises(InputError, match=r"triangle 1 \(2, 0, 2\) repeats a node"):
        TissueModel.from_triangles(pts, [[0, 1, 2], [2, 0, 2]])
