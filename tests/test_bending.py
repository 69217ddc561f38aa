"""The sheet's bending (physics.bending): a hinge on every interior edge (warp_cut.sim.bending).

Compared against: finite differences of the hinge energy (the force kernel), the plate's energy
1/2 D kappa^2 per area on a lattice wrapped round a cylinder (the stiffness's calibration), a
cantilever plate under its own weight, tip deflection q L^4 / (8 D) (plate theory), the hinges
rebuilt from the triangles after a cut (the editor's incremental hinges and step rows), and the
stable step's bending rows against the eigenvalues of M^-1 B on a sheet with slivers.
"""

import numpy as np
import pytest
import warp as wp
from conftest import DEVICE
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut import CutSettings, Material, Simulator, TissueModel, stable_time_step
from warp_cut.cut.topology import TopologyEditor
from warp_cut.kernels.bending import hinge_forces
from warp_cut.mesh import surfaces
from warp_cut.mesh.patch import skin_patch_mesh
from warp_cut.runner import prepare_simulation
from warp_cut.scene import load_scene
from warp_cut.sim.bending import (
    EQUILATERAL_RATE,
    dihedral_angles,
    flexural_rigidity,
    hinge_caps,
    hinge_rates,
    hinge_stiffness,
    hinges_of,
    mass_caps,
)
from warp_cut.sim.stability import bending_node_rows
from warp_cut.verify.validity import cut_problems

D = flexural_rigidity(20e3, 2e-3)  # Table 1's skin: 1.5e-5 N m


def kernel_forces(x, hinges, rest, stiffness, caps):
    """The hinge kernel's forces [N] (n, 3) on positions x (n, 3)."""
    forces = wp.zeros(len(x), dtype=wp.vec3, device=DEVICE)
    wp.launch(hinge_forces, dim=len(hinges), device=DEVICE,
              inputs=[wp.array(np.asarray(x, np.float32), dtype=wp.vec3, device=DEVICE),
                      wp.array(np.asarray(hinges, np.int32).ravel(), dtype=wp.int32, device=DEVICE),
                      wp.array(np.asarray(rest, np.float32), device=DEVICE),
                      wp.array(np.asarray(stiffness, np.float32), device=DEVICE),
                      wp.array(np.asarray(caps, np.float32), device=DEVICE), 1, len(hinges), forces])
    return forces.numpy().astype(np.float64)


def energy(x, hinges, rest, stiffness):
    return 0.5 * float(np.sum(stiffness * (dihedral_angles(x, hinges) - rest) ** 2))


def central_difference(f, x, step):
    """Gradient (n, 3) of the scalar function f at positions x (n, 3) [m], by central differences."""
    grad = np.zeros_like(x)
    for v in range(len(x)):
        for c in range(3):
            up, down = x.copy(), x.copy()
            up[v, c] += step
            down[v, c] -= step
            grad[v, c] = (f(up) - f(down)) / (2 * step)
    return grad


def finite_difference_forces(x, hinges, rest, stiffness, step=1e-8):
    return -central_difference(lambda y: energy(y, hinges, rest, stiffness), x, step)


def angle_gradient(x, hinge, step=1e-9):
    """d theta / d x (n, 3) of one hinge (4,) by central differences."""
    return central_difference(lambda y: dihedral_angles(y, hinge[None])[0], x, step)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_kernel_forces_are_minus_the_energy_gradient(seed):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(5, 3)) * 1e-3
    hinges = np.array([[0, 1, 2, 3], [1, 2, 0, 4]])
    rest = rng.uniform(-0.5, 0.5, 2)
    stiffness = rng.uniform(1e-6, 1e-4, 2)
    got = kernel_forces(x, hinges, rest, stiffness, np.full(2, 1e30))  # no cap
    want = finite_difference_forces(x, hinges, rest, stiffness)
    assert np.abs(got - want).max() <= 1e-4 * np.abs(want).max()
    np.testing.assert_allclose(got.sum(axis=0), 0.0, atol=1e-5 * np.abs(want).max())  # no net force


def test_hinges_of_a_patch_are_its_interior_edges_with_both_opposite_corners():
    points, tri = skin_patch_mesh((0.02, 0.014), 0.002)
    hinges = hinges_of(tri)
    counts = {}
    for t in tri:
        for k in range(3):
            e = tuple(sorted((int(t[k]), int(t[(k + 1) % 3]))))
            counts[e] = counts.get(e, 0) + 1
    interior = {e for e, c in counts.items() if c == 2}
    assert {(int(a), int(b)) for a, b, _, _ in hinges} == interior
    assert len(hinges) == len(interior)
    # k and l lie on opposite sides of the edge in the plane, and the flat sheet has angle 0
    a, b, k, l = (points[hinges[:, c], :2] for c in range(4))

    def side(p):
        d, q = b - a, p - a
        return d[:, 0] * q[:, 1] - d[:, 1] * q[:, 0]

    assert np.all(side(k) * side(l) < 0)
    np.testing.assert_allclose(dihedral_angles(points, hinges), 0.0, atol=1e-12)


@pytest.mark.parametrize("axis", [0, 1])
def test_a_lattice_wrapped_round_a_cylinder_holds_the_plates_energy(axis):
    # 1/2 D kappa^2 per unit area in cylindrical bending, bent along the lattice's rows or across
    # them (at a slant it holds more: see warp_cut.sim.bending)
    points, tri = skin_patch_mesh((0.04, 0.04), 0.001)
    hinges = hinges_of(tri)
    k_h = hinge_stiffness(points, hinges, D)
    radius = 0.05
    across = 1 - axis
    phi = points[:, across] / radius
    bent = points.copy()
    bent[:, across] = radius * np.sin(phi)
    bent[:, 2] = radius * (1 - np.cos(phi))
    inner = np.all(np.abs(points[hinges][:, :, :2]) < 0.015, axis=(1, 2))  # away from the border
    area = 0.5 * np.linalg.norm(np.cross(points[tri[:, 1]] - points[tri[:, 0]],
                                         points[tri[:, 2]] - points[tri[:, 0]]), axis=1)
    inner_area = area[np.all(np.abs(points[tri][:, :, :2]) < 0.015, axis=(1, 2))].sum()
    held = energy(bent, hinges[inner], 0.0, k_h[inner])
    assert held == pytest.approx(0.5 * D / radius**2 * inner_area, rel=0.05)


def test_an_equilateral_hinge_is_at_its_cap_and_a_sliver_is_held_no_harder():
    h = np.sqrt(3) / 2
    hinges = np.array([[0, 1, 2, 3]])
    flat = np.array([[0, 0, 0], [1, 0, 0], [0.5, h, 0], [0.5, -h, 0]]) * 1e-3
    k_h, cap = hinge_stiffness(flat, hinges, D), hinge_caps(flat, hinges, D)
    np.testing.assert_allclose(cap, EQUILATERAL_RATE * D / 1e-6)
    np.testing.assert_allclose(k_h * 4 / (h * 1e-3) ** 2, cap, rtol=1e-12)  # k |g|^2, each |g| = 1/height
    # the same hinge with its corner k pressed to 1 % of the height: k_h |g|^2 would grow 1e4-fold
    sliver = flat.copy()
    sliver[2, 1] *= 0.01
    k_s, cap_s = hinge_stiffness(sliver, hinges, D), hinge_caps(sliver, hinges, D)
    bent = sliver.copy()
    bent[2, 2] = 1e-6  # lift k by 1 um
    f = kernel_forces(bent, hinges, [0.0], k_s, cap_s)
    theta = abs(dihedral_angles(bent, hinges)[0])
    g = np.linalg.norm(angle_gradient(bent, hinges[0], step=1e-8), axis=1)
    capped = cap_s[0] / np.sum(g**2)
    assert capped < 0.1 * k_s[0]
    np.testing.assert_allclose(np.linalg.norm(f, axis=1), capped * theta * g, rtol=2e-3)


def test_a_cantilever_plate_bends_under_its_weight_as_plate_theory_says():
    # q L^4 / (8 D) for a plate in cylindrical bending; 10 hinges along the span give 1.16 of it
    # (the discrete hinges are coarse; a factor 1.5 off in k_h would fail)
    rigidity = 1e-3  # N m: deflection 2 % of the length, linear
    mat = Material(bending_rigidity=rigidity, damping=3e-3)
    points, tri = skin_patch_mesh((0.022, 0.02), 0.002)
    x0 = points[:, 0].min()
    clamped = points[:, 0] < x0 + 0.0025  # three columns of nodes: the edge is held level
    model = TissueModel.from_triangles(points, tri, material=mat, pinned=clamped)
    sim = Simulator(model, dt=2e-4, device=DEVICE, residual_stress=False)
    sim.step(1500)  # 0.3 s: the first mode (about 230 rad/s) is damped out
    length = points[:, 0].max() - (x0 + 0.002)
    q = mat.density * mat.thickness * 9.81
    expected = q * length**4 / (8 * rigidity)
    tip = points[:, 0] > points[:, 0].max() - 1e-6
    deflection = float(np.mean(points[tip, 2] - sim.positions[tip, 2]))
    assert deflection == pytest.approx(expected, rel=0.2)
    assert sim.kinetic_energy() < 1e-11


def test_without_bending_the_plate_sags_far_more():
    mat = Material(damping=3e-3)
    points, tri = skin_patch_mesh((0.022, 0.02), 0.002)
    x0 = points[:, 0].min()
    model = TissueModel.from_triangles(points, tri, material=mat, pinned=points[:, 0] < x0 + 0.0025)
    assert model.hinge_table.live_count == 0
    sim = Simulator(model, dt=2e-4, device=DEVICE, residual_stress=False)
    sim.step(1500)
    tip = points[:, 0] > points[:, 0].max() - 1e-6
    with_bending = mat.density * mat.thickness * 9.81 * (points[:, 0].max() - x0 - 0.002) ** 4 / (8 * 1e-3)
    assert np.mean(points[tip, 2] - sim.positions[tip, 2]) > 4 * with_bending


@pytest.mark.parametrize("background", [False, True])
def test_a_cut_keeps_hinges_and_step_rows_as_rebuilt_from_scratch(background):
    scene = load_scene("straight_incision", ["physics.bending=true", "physics.foundation=true", "duration=0.5"])
    # in the background each edit lands two steps after its event (max_lag 1), whatever the load
    model, sim, path, _ = prepare_simulation(scene, cut_in_background=background, max_lag=1 if background else None)
    with sim:
        sim.step(500, tool=path)
        if background:  # the worker's edits, hinges included, reach the loop's model
            sim.cutter.flush(sim)
            assert sim.cutter.edits_applied > 0
            assert sim.model.hinge_table.live_count == len(hinges_of(sim.model.triangles))
            return
        hinges = model.hinges
        assert sim.cutter.incisions and model.node_table.count > len(scene.build_model().points)
        assert {tuple(h) for h in hinges.tolist()} == {tuple(h) for h in hinges_of(model.triangles).tolist()}
        assert len(sim.model.hinge_table.live_slots()) == len(hinges)
        rates = sim.solver.limits.rates
        np.testing.assert_allclose(rates.bend[: model.node_count], bending_node_rows(model), rtol=1e-12)
        assert cut_problems(sim) == []
        model.hinge_table.kill([int(model.hinge_table.live_slots()[0])])  # the check sees a lost hinge
        assert any(p.startswith("hinges:") for p in cut_problems(sim))


def test_the_step_rows_bound_the_bending_on_a_sheet_with_slivers():
    rng = np.random.default_rng(3)
    points, tri = skin_patch_mesh((0.012, 0.01), 0.002)
    interior = np.all(np.abs(points[:, :2]) < 0.0045, axis=1)
    points[interior, :2] += rng.uniform(-0.9e-3, 0.9e-3, (interior.sum(), 2))  # slivers, no flips
    model = TissueModel.from_triangles(points, tri, material=Material(bending_rigidity=D))
    hinges = model.hinges
    table = model.hinge_table
    k_h, caps = table.live("stiffness"), table.live("cap")
    n = len(points)
    B = np.zeros((3 * n, 3 * n))
    for h, k, cap in zip(hinges, k_h, caps):
        grad = angle_gradient(points, h)
        k_eff = min(k, cap / np.sum(grad**2))
        B += k_eff * np.outer(grad.ravel(), grad.ravel())
    free = np.repeat(~model.pinned, 3)
    m = np.repeat(model.masses, 3)
    scaled = B[np.ix_(free, free)] / np.sqrt(np.outer(m[free], m[free]))
    largest = np.linalg.eigvalsh(scaled)[-1]
    rows = bending_node_rows(model)
    bound = np.max(rows[~model.pinned] / model.masses[~model.pinned])
    assert largest <= bound
    assert bound < 20 * largest  # and not so loose that the step becomes useless
    assert stable_time_step(model).step < stable_time_step(
        TissueModel.from_triangles(points, tri, material=Material())).step


def test_an_edit_that_makes_and_deletes_triangles_keeps_the_hinges():
    """A flip and its undo in one edit (a sliver pass flipping a triangle it made): the
    triangles made and deleted again leave dead slots among the edit's new ones, which the
    hinges' refresh must not read (it raised ValueError on a cut with bending before)."""
    model = TissueModel.from_patch((0.01, 0.01), 0.002, material=Material(bending_rigidity=D), pinned="none")
    a, b, k, l = (int(v) for v in model.hinges[len(model.hinges) // 2])
    editor = TopologyEditor(model)
    editor.begin()
    old = sorted(editor.triangles_with_edge(a, b))
    editor.delete_triangles(old)
    flipped = [editor.add_triangle(tri, model.points) for tri in ((a, l, k), (l, b, k))]
    editor.delete_triangles(flipped)
    for tri in ((a, b, k), (b, a, l)):
        editor.add_triangle(tri, model.points)
    editor.finish(positions=model.points)
    assert {tuple(h) for h in model.hinges.tolist()} == {tuple(h) for h in hinges_of(model.triangles).tolist()}


def test_mass_caps_hold_each_hinge_within_the_rate_budget_at_its_lightest_node():
    hinges = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])
    masses = np.array([4.0, 1.0, 2.0, 8.0, 0.5])
    caps = np.array([3.0, 3.0])
    np.testing.assert_allclose(hinge_rates(caps, hinges, masses), [2 * 3.0 / 1.0, 2 * 3.0 / 0.5])
    capped = mass_caps(caps, hinges, masses, budget=4.0)  # cap <= budget x least mass / 2
    np.testing.assert_allclose(capped, [2.0, 1.0])
    np.testing.assert_allclose(mass_caps(caps, hinges, masses, budget=np.inf), caps)


def test_a_sheets_own_hinges_set_the_budget_and_keep_their_shape_caps():
    model = TissueModel.from_patch((0.02, 0.014), 0.002, material=Material(bending_rigidity=D))
    table = model.hinge_table
    caps, hinges = table.live("cap"), model.hinges
    np.testing.assert_allclose(caps, hinge_caps(model.points, hinges, D))
    assert model.bending_budget == pytest.approx(np.max(2 * caps / model.masses[hinges].min(axis=1)))
    assert TissueModel.from_patch((0.02, 0.014), 0.002).bending_budget == np.inf


def test_a_thin_blades_small_triangles_do_not_shorten_the_bending_step():
    """A 0.45 mm blade zigzagging through a 1.8 mm jittered disk leaves nodes with 1 % of the
    median mass round its slit. Their hinges, capped by shape alone, set a stable step 7.8
    times shorter than the uncut sheet's (and a run 100 times slower); capped by their nodes'
    masses too (``mass_caps``), every hinge holds within the sheet's budget and the step
    shortens no more than the springs' own does."""
    def zigzag_cut(material):
        s = surfaces.jittered_delaunay(radius=0.012, spacing=0.0018, jitter=0.15, seed=5)
        model = TissueModel.from_surface(s, material=material)
        sim = Simulator(model, dt=1e-3, gravity=None, cutting=CutSettings(), device=DEVICE)
        before = sim.step_limit.step
        xs = np.linspace(-0.008, 0.008, 49)
        path = np.stack([xs, 0.003 * np.abs((xs / 0.004) % 2 - 1) - 0.0015, np.zeros_like(xs)], axis=1)
        sim.cutter.start_incision(sim, path[0], [0, 0, 1], 0.00045)
        for point in path[1:]:
            sim.cutter.extend_incision(sim, point)
        sim.cutter.end_incision(sim)
        return model, sim, before

    model, sim, before = zigzag_cut(Material(bending_rigidity=D))
    masses = model.masses[model.active]
    assert masses.min() < 0.05 * np.median(masses)  # the small triangles are there
    table = model.hinge_table
    slots = table.live_slots()
    assert np.all(hinge_rates(table.column("cap")[slots], table.column("nodes")[slots], model.masses)
                  <= model.bending_budget * (1 + 1e-12))
    _, plain, plain_before = zigzag_cut(Material())
    springs_drop = plain_before / plain.step_limit.step
    assert before / sim.step_limit.step < 1.5 * springs_drop
    assert cut_problems(sim) == []
