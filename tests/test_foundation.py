"""The foundation (physics.foundation): each node held to its rest position by k_f x its area.

Compared against: the settling of a large supported sheet under gravity, rho t g / k_f away from
its border, for every integrator; the stable step of a node held by the foundation alone,
2 sqrt(rho t / k_f); the lumped areas recomputed from the triangles after a cut (device column
and incremental stable-step element rates against full recomputations).
"""

import numpy as np
import pytest
from conftest import DEVICE

from warp_cut import CutSettings, Material, SceneError, Simulator, TissueModel, stable_time_step
from warp_cut.scene import DEFAULT_FOUNDATION_STIFFNESS, load_scene, parse_scene
from warp_cut.sim.model import lumped_masses
from warp_cut.sim.stability import ElementRates, node_stiffness_sums
from warp_cut.solvers import INTEGRATORS

K_F = 1.0e5  # N/m^3: settles 0.216 mm under gravity


@pytest.mark.parametrize("integrator", sorted(INTEGRATORS))
def test_supported_sheet_settles_by_rho_t_g_over_kf(integrator):
    # damping near critical for the support's mode omega^2 = k_f / (rho t), so it settles fast
    mat = Material(foundation_stiffness=K_F, damping=3e-3)
    model = TissueModel.from_patch((0.06, 0.06), 0.002, material=mat, pinned="border")
    sim = Simulator(model, dt=1e-3, integrator=integrator, device=DEVICE)
    sim.step(300)
    far = np.all(np.abs(model.points[:, :2]) < 0.02, axis=1)  # >= 1 cm from the border
    sag = model.points[far, 2] - sim.positions[far, 2]
    expected = mat.density * mat.thickness * 9.81 / K_F
    np.testing.assert_allclose(sag, expected, rtol=0.02)
    pinned = model.pinned
    np.testing.assert_allclose(sim.positions[pinned], model.points[pinned], atol=2e-9)  # float32


def test_without_foundation_nothing_holds_the_sheet():
    model = TissueModel.from_patch((0.06, 0.06), 0.002, material=Material(damping=3e-3), pinned="border")
    sim = Simulator(model, dt=1e-3, device=DEVICE)
    sim.step(100)
    assert (model.points[:, 2] - sim.positions[:, 2]).max() > 10 * 1100 * 2e-3 * 9.81 / K_F


def test_stable_step_of_a_node_held_by_the_foundation_alone():
    mat = Material(foundation_stiffness=K_F, damping=0.0, stiffness=0.0)
    model = TissueModel.from_patch((0.02, 0.02), 0.002, material=mat, pinned="none")
    limit = stable_time_step(model, include_damping=False)
    # omega^2 = k_f A / m = k_f / (rho t) for every node, whatever its area
    assert limit.step == pytest.approx(2 * np.sqrt(mat.density * mat.thickness / K_F), rel=1e-9)
    bare = TissueModel.from_patch((0.02, 0.02), 0.002, material=Material(stiffness=0.0), pinned="none")
    assert stable_time_step(bare).step == np.inf


def test_row_sums_add_kf_times_the_lumped_area():
    with_support = TissueModel.from_patch((0.02, 0.01), 0.002, material=Material(foundation_stiffness=K_F))
    without = TissueModel.from_patch((0.02, 0.01), 0.002)
    area = lumped_masses(with_support.points, with_support.triangles, 1.0)
    np.testing.assert_allclose(node_stiffness_sums(with_support) - node_stiffness_sums(without),
                               K_F * area, rtol=1e-12)


def test_cut_keeps_areas_and_rows_of_the_foundation_in_sync():
    mat = Material(foundation_stiffness=K_F)
    model = TissueModel.from_patch((0.03, 0.02), 0.002, material=mat, pinned="border")
    sim = Simulator(model, dt=1e-3, gravity=None, device=DEVICE, cutting=CutSettings())
    cutter = sim.cutter
    y = 0.5 * 0.002 * np.sqrt(3) / 2
    cutter.start_incision(sim, np.array([-0.008, y, 0.0]), [0, 0, 1], 0.0006)
    for x in np.linspace(-0.008, 0.008, 30)[1:]:
        cutter.extend_incision(sim, np.array([x, y, 0.0]))
    cutter.end_incision(sim)
    assert cutter.totals["lip_nodes"] > 0
    live = model.active
    area = lumped_masses(model.points, model.triangles, 1.0)[live]
    device_area = sim.device_model.node_area.numpy()[: model.node_count][live]
    np.testing.assert_allclose(device_area, area, rtol=1e-5)  # float32 on the device
    full = ElementRates(model)  # rated from scratch, against the solver's incremental update
    rates = sim.solver.limits.rates
    n = model.node_count
    np.testing.assert_allclose(rates.sums[:n][live], full.sums[:n][live], rtol=1e-9)
    for kind in ElementRates.KINDS:
        for incremental, fresh in zip(rates.rates[kind], full.rates[kind]):
            alive = {"triangles": model.triangle_table, "springs": model.spring_table,
                     "links": model.link_table, "foundation": model.node_table}[kind].alive
            np.testing.assert_allclose(incremental[: len(alive)][alive], fresh[: len(alive)][alive], rtol=1e-9)
    assert sim.step_limit.step == pytest.approx(stable_time_step(model).step, rel=1e-9)


def test_scene_keys_of_the_foundation():
    on = parse_scene({"physics": {"foundation": True}}, "x.toml")
    assert on.material.foundation_stiffness == DEFAULT_FOUNDATION_STIFFNESS
    given = parse_scene({"physics": {"foundation": True}, "material": {"foundation_stiffness": 3e5}}, "x.toml")
    assert given.build_model().foundation_stiffness == 3e5
    off = parse_scene({"material": {"foundation_stiffness": 3e5}}, "x.toml")
    assert off.material.foundation_stiffness == 0.0  # counts only when the scene asks for it
    with pytest.raises(SceneError, match=r"\[material.foundation_stiffness\] must be in \(0, 10000000000.0\]"):
        parse_scene({"physics": {"foundation": True}, "material": {"foundation_stiffness": -1.0}}, "x.toml")
    with pytest.raises(SceneError, match=r"\[physics.foundation\] must be true or false"):
        parse_scene({"physics": {"foundation": "yes"}}, "x.toml")
    scene = load_scene("skin_press", ["physics.foundation=true", "duration=0.05"])
    assert scene.build_model().foundation_stiffness == DEFAULT_FOUNDATION_STIFFNESS
