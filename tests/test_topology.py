"""warp_cut/topology.py: one edit changes nodes, springs, triangles, links and masses together."""

import numpy as np
import pytest

from warp_cut import Material, TissueModel
from warp_cut.cut.topology import NodePositions, TopologyEditor
from warp_cut.mesh.checks import check_mesh


def square():
    """Two triangles: 0-1-2 and 0-2-3 (CCW from +z), unit square, diagonal 0-2."""
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    mat = Material(density=1000.0, thickness=1e-3, youngs_modulus=2e4, residual_strain=0.1)
    return TissueModel.from_triangles(pts, [[0, 1, 2], [0, 2, 3]], material=mat)


def live_mass_balance(model):
    areal = model.material.density * model.material.thickness
    return model.total_mass, areal * model.triangle_areas.sum()


def test_deleting_a_spring_makes_a_residual_link_and_removes_its_triangles():
    mat = Material(density=1000.0, thickness=1e-3, youngs_modulus=2e4, residual_strain=0.1)
    model = TissueModel.from_patch((0.01, 0.01), 0.002, material=mat)
    ed = TopologyEditor(model)
    centre = int(np.argmin(np.linalg.norm(model.points, axis=1)))
    slot = next(iter(ed.node_springs[centre]))
    i, j = model.spring_table.column("pairs")[slot]
    L0 = model.spring_table.column("rest_length")[slot]
    bounded = ed.triangles_with_edge(i, j)
    ed.begin()
    ed.delete_springs([slot])
    report = ed.finish()
    assert len(bounded) == 2 and sorted(report.deleted_triangles) == sorted(bounded)
    # both ends survive: a link of sigma_r * thickness * L0 (SPEC section 1)
    assert model.links.tolist() == [[i, j]] and report.removed_fragments == []
    assert model.link_force[0] == pytest.approx(2e4 * 0.1 * 1e-3 * L0)
    total, expected = live_mass_balance(model)
    assert total == pytest.approx(expected)


def test_fragments_left_without_triangles_are_removed_and_reported():
    model = square()
    ed = TopologyEditor(model)
    ed.begin()
    ed.delete_springs([ed.spring_between(0, 2)])
    report = ed.finish()
    assert model.triangle_count == 0 and len(report.deleted_triangles) == 2
    assert sorted(report.removed_fragments) == [0, 1, 2, 3] and model.active_node_count == 0
    assert model.link_count == 0 and model.spring_count == 0  # nothing refers to them


def test_deleting_a_node_takes_springs_triangles_links_without_new_links():
    model = square()
    model.add_residual_links([[1, 3]], [np.sqrt(2)])
    ed = TopologyEditor(model)
    ed.begin()
    ed.delete_nodes([3])
    report = ed.finish()
    assert not model.active[3] and model.link_count == 0
    assert report.residual_links == []  # an end is gone: nothing to pull together
    assert model.triangles.tolist() == [[0, 1, 2]]
    assert sorted(map(tuple, model.springs.tolist())) == [(0, 1), (0, 2), (1, 2)]
    # lumped masses now come from the one remaining triangle, and they account for it
    np.testing.assert_allclose(model.masses[:3], 1000 * 1e-3 * 0.5 / 3)
    total, expected = live_mass_balance(model)
    assert total == pytest.approx(expected)
    assert check_mesh(model.points, model.triangles, model.springs, active=model.active,
                      masses=model.masses, reference_normal=[0, 0, 1]).valid


def test_adding_a_triangle_brings_its_springs_with_rest_lengths_from_positions():
    model = square()
    ed = TopologyEditor(model)
    ed.begin()
    positions = NodePositions(model.points.copy())
    new = int(ed.add_nodes([[2.0, 0.5, 0.0]])[0])
    positions[new] = [2.0, 0.5, 0.0]
    ed.add_triangle((1, new, 2), positions)
    report = ed.finish()
    assert new == 4 and model.triangle_count == 3 and len(report.new_springs) == 2
    rest = dict(zip(map(tuple, model.springs.tolist()), model.rest_lengths))
    assert rest[(1, 4)] == pytest.approx(np.hypot(1.0, 0.5))
    total, expected = live_mass_balance(model)
    assert total == pytest.approx(expected)
    rep = check_mesh(model.points, model.triangles, model.springs, active=model.active,
                     masses=model.masses, reference_normal=[0, 0, 1])
    assert rep.valid, rep.problems


def test_no_index_points_at_a_deleted_node():
    model = TissueModel.from_patch((0.01, 0.01), 0.002)
    ed = TopologyEditor(model)
    rng = np.random.default_rng(3)
    for _ in range(5):
        ed.begin()
        live = np.flatnonzero(model.active)
        ed.delete_nodes(rng.choice(live, 3, replace=False))
        ed.finish()
        dead = ~model.active
        for arr in (model.springs, model.triangles, model.links):
            assert not dead[arr.ravel()].any()
