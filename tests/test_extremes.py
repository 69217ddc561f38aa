"""Stability at the extremes, for every integrator: the outcome is finite and bounded (energy
does not grow when nothing dissipates), or SimulationUnstable is raised while the state is
still finite - never a NaN. And the semi-implicit step limit: 0.95 x the exact linear limit
stays bounded, 1.05 x is caught."""

import itertools
import math

import numpy as np
import pytest
from conftest import DEVICE, chain_model
from test_stability import exact_limit

from warp_cut import Material, SimulationUnstable, Simulator, TissueModel, Tool
from warp_cut.solvers import INTEGRATORS

ALL = sorted(INTEGRATORS)


def energy(sim, model):
    """Kinetic + spring potential energy [J] (float64 from the device state)."""
    x, v = sim.positions, sim.velocities
    i, j = model.springs.T
    stretch = np.linalg.norm(x[j] - x[i], axis=1) - model.rest_lengths
    return 0.5 * np.sum(model.masses[:, None] * v * v) + 0.5 * np.sum(model.stiffness * stretch**2)


def outcome(sim, model, steps, check_energy):
    """Step one step at a time. Returns "unstable" if SimulationUnstable was raised (asserting
    the state was still finite then), else asserts bounded and finite and returns "bounded"."""
    energies = []
    try:
        for _ in range(steps):
            sim.step(1)
            energies.append(energy(sim, model))
    except SimulationUnstable as err:
        assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.velocities))
        assert "stable step" in str(err)
        return "unstable"
    assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.velocities))
    if check_energy:
        e = np.array(energies)
        start = e[: len(e) // 4].max()
        assert e[-len(e) // 4:].max() <= start * 1.05, "energy grew without a source"
    return "bounded"


def perturbed_chain(k, m, D):
    model = chain_model(4, mass=m, stiffness=k, spacing=0.01, damping=D)
    rng = np.random.default_rng(1)
    x0 = model.points + np.vstack([[0, 0, 0], rng.normal(scale=1e-3, size=(4, 3))])
    return model, x0


@pytest.mark.parametrize("integrator", ALL)
def test_stiffness_mass_damping_step_matrix(integrator):
    results = {}
    for k, m, D, h in itertools.product((1e-2, 1e6), (1e-9, 1.0), (0.0, 1e4), (1e-3, 1 / 30)):
        model, x0 = perturbed_chain(k, m, D)
        sim = Simulator(model, dt=h, substeps=1, gravity=None, integrator=integrator,
                        device=DEVICE)
        sim.set_state(positions=x0)
        results[(k, m, D, h)] = outcome(sim, model, 150, check_energy=(D == 0))
    if integrator != "semi_implicit":
        # unconditionally stable for the linear springs: every case bounded
        assert set(results.values()) == {"bounded"}, results
    else:
        for (k, m, D, h), result in results.items():
            c, w2 = D / m, k / m
            limit = (c + math.sqrt(c * c + 4 * 4 * w2)) / (4 * w2)  # omega_max^2 <= 4 k / m
            if h < 0.5 * limit:
                assert result == "bounded", (k, m, D, h)
        assert "unstable" in results.values()  # the stiff, light, undamped chain at 1/30 s


@pytest.mark.parametrize("integrator", ALL)
def test_residual_strain_up_to_0_9(integrator):
    mat = Material(residual_strain=0.9)
    model = TissueModel.from_patch((0.01, 0.01), 0.002, material=mat)
    interior = np.flatnonzero(~model.pinned)
    pairs = np.column_stack([interior[:-1], interior[1:]])
    model.add_residual_links(pairs, np.full(len(pairs), 0.002))
    sim = Simulator(model, dt=1e-3, integrator=integrator, device=DEVICE)
    assert outcome(sim, model, 200, check_energy=False) == "bounded"


@pytest.mark.parametrize("integrator", ALL)
def test_zero_length_and_coincident_springs(integrator):
    # nodes 1 and 2 coincide: a zero-length spring (L0 = 0) and a spring of L0 = 1 cm whose
    # ends start on top of each other (no direction: no force until they separate)
    pts = [[0, 0, 0], [0.01, 0, 0], [0.01, 0, 0], [0.02, 0, 0]]
    springs = [[0, 1], [1, 2], [2, 3], [0, 3]]
    model = TissueModel.from_arrays(pts, springs, 1e-3, pinned=[0], stiffness=100.0,
                                    damping=0.01, rest_lengths=[0.01, 0.0, 0.01, 0.02])
    coincident = TissueModel.from_arrays(pts, [[0, 1], [1, 2], [2, 3]], 1e-3, pinned=[0],
                                         stiffness=100.0, damping=0.01,
                                         rest_lengths=[0.01, 0.01, 0.01])
    for m in (model, coincident):
        # substeps fixed: the Gershgorin estimate sees an unbounded transverse stiffness in a
        # spring of zero length and L0 > 0 and would ask for ~1e6 substeps
        sim = Simulator(m, dt=1e-3, substeps=1, integrator=integrator, device=DEVICE)
        assert outcome(sim, m, 200, check_energy=False) == "bounded"


@pytest.mark.parametrize("integrator", ALL)
def test_one_node_fragments_and_deleted_slots(integrator):
    # a patch, then a cut's leftovers made by hand in the device arrays: springs deleted
    # (negative indices) around free node a, left as a one-node fragment, and free node b's
    # slot deleted (no ACTIVE flag)
    model = TissueModel.from_patch((0.01, 0.01), 0.002)
    a, b = np.flatnonzero(~model.pinned)[[0, 5]]
    sim = Simulator(model, dt=1e-3, integrator=integrator, device=DEVICE)
    dm = sim.device_model
    idx = dm.spring_indices.numpy().reshape(-1, 2)
    touched = np.any((idx == a) | (idx == b), axis=1)
    idx[touched] = -1
    dm.spring_indices.assign(idx.ravel())
    flags = dm.node_flags.numpy()
    flags[b] = 0
    dm.node_flags.assign(flags)
    sim.solver.topology_changed()
    x_deleted = sim.positions[b].copy()
    sim.step(100)
    x = sim.positions
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(sim.velocities))
    np.testing.assert_array_equal(x[b], x_deleted)  # a deleted slot is never touched
    # the fragment falls freely (damped by its own D only), no spring pulls it back
    m12, D12, g, h = model.masses[a], model.damping[a], 9.81, 1e-3
    v = 0.0
    z = 0.0
    for _ in range(100):
        v = (m12 * v - h * m12 * g) / (m12 + h * D12)
        z += h * v
    if integrator != "xpbd":  # XPBD damps after the step: a slightly different sum
        assert x[a, 2] == pytest.approx(z, rel=1e-3)
    assert x[a, 2] < 0.5 * z


@pytest.mark.parametrize("integrator", ALL)
def test_tool_faster_than_one_radius_per_step(integrator):
    model = TissueModel.from_patch((0.02, 0.02), 0.001)
    sim = Simulator(model, dt=1e-3, integrator=integrator, device=DEVICE)
    r = 0.0005
    # 10 radii per step, sweeping through the sheet from below to above and across
    def path(t):
        return Tool([-0.015 + 5.0 * t, 0, -0.003 + 2.0 * t], [-0.015 + 5.0 * t, 0, 0.01 + 2.0 * t], r)
    for _ in range(8):
        sim.step(1, tool=path)
        assert np.all(np.isfinite(sim.tool_force))
    assert np.all(np.isfinite(sim.positions))
    assert sim.max_tool_force < 1e6


@pytest.mark.parametrize("scale, expect", [(0.95, "bounded"), (1.05, "unstable")])
@pytest.mark.parametrize("which", ["chain", "patch", "damped chain"])
def test_semi_implicit_limit_095_bounded_105_caught(scale, expect, which):
    if which == "patch":
        model = TissueModel.from_patch((0.01, 0.008), 0.002,
                                       material=Material(damping=0.0))
        c = 0.0
    else:
        D = 0.0 if which == "chain" else 2e-4
        model = chain_model(6, mass=1e-3, stiffness=100.0, spacing=0.01, damping=D)
        c = D / 1e-3
    h = scale * exact_limit(model, c)
    sim = Simulator(model, dt=h, substeps=1, gravity=None, device=DEVICE)
    rng = np.random.default_rng(3)
    free = ~model.pinned
    x0 = model.points.copy()
    x0[free] += rng.normal(scale=1e-6, size=(free.sum(), 3))  # the linear regime
    sim.set_state(positions=x0)
    assert outcome(sim, model, 3000, check_energy=(c == 0 and scale < 1)) == expect
    # and the computed estimate never exceeds the exact limit
    assert sim.step_limit.step <= exact_limit(model, c) * (1 + 1e-9)


@pytest.mark.parametrize("integrator", ["implicit_euler", "xpbd"])
def test_unconditionally_stable_integrators_far_above_the_explicit_limit(integrator):
    model = chain_model(6, mass=1e-3, stiffness=100.0, spacing=0.01, damping=0.0)
    for scale in (1.05, 10.0, 1000.0):
        h = scale * exact_limit(model)
        sim = Simulator(model, dt=h, substeps=1, gravity=None, integrator=integrator,
                        device=DEVICE)
        x0 = model.points.copy()
        x0[1:, 0] += 1e-3
        sim.set_state(positions=x0)
        assert outcome(sim, model, 300, check_energy=True) == "bounded"
