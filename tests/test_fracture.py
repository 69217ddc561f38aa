"""warp_cut/experiments/wound.py, warp_cut/cut/wound/reference_slit.py, warp_cut/sim/statics.py: a slit in a prestressed
sheet opens like linear elastic fracture mechanics says.

Compared against: Griffith's ellipse gap(x) = (4 T / E2D) sqrt(a^2 - x^2) with E2D = 2 k / sqrt(3)
for the regular lattice of springs k and E t for van Gelder's material springs (the spring
network's own static equilibrium, solved in numpy); a pinned border close to the cut lowers the
opening; the simulator relaxes to that same static equilibrium; and the real scalpel's cut of
``wound_gape``, once its sheet has settled, opens as the ellipse says.
"""

import numpy as np
import pytest
from conftest import DEVICE

from warp_cut import InputError, Material, Simulator, TissueModel
from warp_cut.cut.tolerances import MIN_ANGLE_DEG
from warp_cut.cut.wound.reference_slit import open_slit
from warp_cut.experiments.wound import (
    cutter_comparison,
    griffith_gap,
    quasi_static_cut,
    scene_cut_comparisons,
    slit_comparison,
)
from warp_cut.mesh.geometry import triangle_min_angles
from warp_cut.mesh.triangulate import border_loop_count
from warp_cut.scene import load_scene
from warp_cut.sim.statics import spring_network_forces, static_equilibrium


@pytest.fixture(scope="module")
def traction():
    """Sheet 80 x 69 mm (1 mm lattice), slit 2a = 20 mm, T = 0.08 N/m, border under dead loads."""
    return {model: slit_comparison(stiffness_model=model) for model in ("constant", "material")}


@pytest.mark.parametrize("stiffness_model", ["constant", "material"])
def test_slit_opens_into_griffiths_ellipse(traction, stiffness_model):
    c = traction[stiffness_model]
    assert c.tension == pytest.approx(0.08) and c.half_length == pytest.approx(0.010)
    expected_modulus = {"constant": 2 * 160.0 / np.sqrt(3), "material": 20e3 * 2e-3}[stiffness_model]
    assert c.modulus == pytest.approx(expected_modulus)
    assert c.middle().sum() >= 15  # stations over the middle 80 %
    assert c.max_error() < 0.10
    assert c.centre_ratio() == pytest.approx(1.0, abs=0.02)
    # the two springs sheets are the same membrane: the same opening
    np.testing.assert_allclose(traction["constant"].gap / traction["constant"].closed_form,
                               traction["material"].gap / traction["material"].closed_form, atol=0.01)


def test_a_pinned_border_lowers_the_opening(traction):
    pinned = slit_comparison(stiffness_model="constant", border="pinned")
    free = traction["constant"]
    np.testing.assert_allclose(pinned.x, free.x)
    assert np.all(pinned.gap < free.gap)
    assert 0.75 < pinned.centre_ratio() < 0.95  # border 4 half-lengths away


def test_the_opening_is_linear_in_the_tension():
    lo = slit_comparison(rows=40, columns=40, half_length=5, residual_strain=0.001)
    hi = slit_comparison(rows=40, columns=40, half_length=5, residual_strain=0.004)
    np.testing.assert_allclose(hi.gap, 4 * lo.gap, rtol=0.01)


def lattice_with_slit(damping):
    s = 0.001
    mat = Material(residual_strain=0.02, residual_stress_model="prestress", damping=damping)
    model = TissueModel.from_patch((30 * s, 32 * s * np.sqrt(3) / 2), s, material=mat, pinned="border")
    return model, open_slit(model, [-5 * s, 0, 0], [5 * s, 0, 0])


def test_slit_keeps_the_uncut_sheet_with_the_traction_released():
    model, slit = lattice_with_slit(0.0)
    assert len(slit.lower) == len(slit.upper) == 9 and slit.length == pytest.approx(0.010)
    forces = spring_network_forces(model.points, model.springs, model.rest_lengths, model.stiffness)
    free = ~model.pinned & model.active
    line = np.zeros(model.node_count, bool)
    line[np.concatenate([slit.lower, slit.upper])] = True
    assert np.abs(forces[free & ~line]).max() < 1e-12  # away from the faces: still in equilibrium
    # each face node is pulled to its own side by the released traction T x spacing
    T = model.material.membrane_tension
    np.testing.assert_allclose(forces[slit.upper, 1], T * 0.001, rtol=0.02)
    np.testing.assert_allclose(forces[slit.lower, 1], -T * 0.001, rtol=0.02)
    assert model.masses[model.active].sum() == pytest.approx(1100 * 2e-3 * model.triangle_areas.sum())


def test_slit_must_follow_mesh_edges():
    model = TissueModel.from_patch((0.02, 0.02), 0.002, pinned="border")
    with pytest.raises(InputError, match="start and end at mesh nodes"):
        open_slit(model, [-0.0051, 0.0003, 0], [0.005, 0.0003, 0])


def test_simulator_relaxes_to_the_static_equilibrium():
    model, slit = lattice_with_slit(damping=2e-3)
    static = static_equilibrium(model)
    assert static.converged
    sim = Simulator(model, dt=1e-3, gravity=None, device=DEVICE)
    sim.step(100)
    x, ref = sim.positions, static.positions
    gap, ref_gap = x[slit.upper, 1] - x[slit.lower, 1], ref[slit.upper, 1] - ref[slit.lower, 1]
    np.testing.assert_allclose(gap, ref_gap, rtol=1e-3)
    T, modulus = model.material.membrane_tension, 2 * 160 / np.sqrt(3)
    assert gap.max() < griffith_gap(0.0, 0.005, T, modulus)  # the close pinned border lowers it


def test_cli_refuses_a_bad_scene_before_running(tmp_path):
    from warp_cut.cli import main

    out = tmp_path / "wound"
    assert main(["experiment", "wound", "--scene", str(tmp_path / "missing.toml"), "--out", str(out),
                 "--quiet"]) == 2
    assert not out.exists()
    assert main(["experiment", "wound", "--set", "cutting.interval=-1", "--out", str(out), "--quiet"]) == 2
    assert not out.exists()  # a bad override too


def test_the_scalpels_cut_opens_like_fracture_mechanics_once_the_sheet_has_settled():
    """``wound_gape`` run as it is (a 4 cm cut, T = 4 N/m, 2 mm lattice), its cut sheet solved for
    static equilibrium: with the border loaded as a large plate the lips' gap follows Griffith's
    ellipse (median over the middle 80 % within 5 %, every station there within 10 %;
    docs/wound.md). The cut opened 0.63 of it before its springs carried the tension and its
    lips followed the gape. The pinned border holds it back, and at the scene's end it is still
    opening."""
    now, pinned, plate = scene_cut_comparisons(load_scene("wound_gape"))
    assert plate.half_length == pytest.approx(0.020, rel=0.01) and plate.tension == pytest.approx(4.0)
    assert abs(plate.median_ratio() - 1.0) < 0.05 and plate.max_error() < 0.10
    assert pinned.median_ratio() < plate.median_ratio() - 0.05
    assert now.median_ratio() < pinned.median_ratio()


def test_the_opening_does_not_depend_on_where_the_cut_events_fell():
    """The same straight cut (``wound_gape``'s, on a 100 x 80 mm patch) made in 40 and in 114
    events without dynamics, then settled under a loaded border: each event re-meshes its own
    region (a constrained Delaunay refinement in the rest shape, so there is nothing left to
    flip inside it), and the regions fall differently, but both cuts open as the ellipse says,
    every station within 10 %, medians within 3 % of each other. Both are sound meshes in the
    rest shape: every triangle the cut made has its smallest angle at least the cut's 20 deg
    there (``MIN_ANGLE_DEG``), and the slit, inside the tissue, is one border loop more than
    the uncut patch has: no hole. (With the earlier cut, before its flips, the median ranged
    from 0.97 to 1.08 and single stations reached 1.3: docs/wound.md.)"""
    scene = load_scene("wound_gape", ["tissue.size=[0.1, 0.08]"])
    loops = border_loop_count(scene.build_model().triangles)
    ratios = []
    for events in (40, 114):
        cutter, x = quasi_static_cut(scene, events)
        model = cutter.model
        made = model.triangles[cutter.live_new_triangles()]
        assert len(made) > 50 and triangle_min_angles(model.points, made).min() >= MIN_ANGLE_DEG
        assert border_loop_count(model.triangles) == loops + 1
        c = cutter_comparison(f"{events} events", cutter, x, scene)
        assert c.middle().sum() >= 15 and c.max_error() < 0.10
        ratios.append(c.median_ratio())
    assert abs(ratios[0] - ratios[1]) < 0.03
