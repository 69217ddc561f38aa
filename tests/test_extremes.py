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
        # E(x_n, v_n) is not what the integrators conserve (semi-implicit Euler keeps
        # E - h/2 x^T K v in the linear regime, the others lose energy): it swings with the
        # modes' phases (between ~0.1 and 1 of its maximum near the step limit), so the
        # maxima of the first and last quarter agree only to the sampling of those swings
        # (10 % below, never above, in these runs); an instability grows exponentially,
        # far past the 5 % allowed
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


def node_sums(model, x, pairs, k, rest=None, smoothing=None):
    """Forces [N] (node_count, 3) in float64 of springs (``rest`` lengths, stiffness k) or of
    residual links (force k along the pair, ``smoothing`` eps: k d / sqrt(d^2 + eps^2))."""
    i, j = pairs.T
    d = x[j] - x[i]
    if rest is not None:
        length = np.linalg.norm(d, axis=1)
        scale = k * (length - rest) / length
    else:
        scale = k / np.sqrt(np.sum(d * d, axis=1) + smoothing**2)
    f = scale[:, None] * d
    out = np.zeros_like(x)
    np.add.at(out, i, f)
    np.add.at(out, j, -f)
    return out


@pytest.mark.parametrize("integrator", ALL)
def test_residual_strain_up_to_0_9(integrator):
    E, t, L0, g = 20e3, 2e-3, 0.002, np.array([0, 0, -9.81])
    mat = Material(residual_strain=0.9, youngs_modulus=E, thickness=t)
    model = TissueModel.from_patch((0.01, 0.01), 0.002, material=mat)
    interior = np.flatnonzero(~model.pinned)
    pairs = np.column_stack([interior[:-1], interior[1:]])
    model.add_residual_links(pairs, np.full(len(pairs), L0))
    sigma_a = E * 0.9 * t * L0  # sigma_r A = 72 mN per link, ~1000 x the nodes' weight
    np.testing.assert_allclose(model.link_force, sigma_a, rtol=1e-12)
    sim = Simulator(model, dt=1e-3, integrator=integrator, device=DEVICE)
    assert outcome(sim, model, 200, check_energy=False) == "bounded"
    if integrator == "xpbd":  # its springs and links, ~300 x softer at this step, settle slower
        sim.step(200)
    x, h = sim.positions, sim.substep
    # the links pull: every linked pair ends closer than it started (XPBD's sheet, far softer
    # under its weight at this step, may sag a pair open by a few percent; its links' pull is
    # checked against implicit Euler's in test_stability's test_xpbd_links_close_...)
    d0, d = (np.linalg.norm(p[pairs[:, 1]] - p[pairs[:, 0]], axis=1) for p in (model.points, x))
    if integrator != "xpbd":
        assert np.all(d < d0)
    # and the sheet has settled where its springs balance links of sigma_r A: the net force
    # on each free node (float64, from the final positions) is m a + D v, under 1 % of
    # what the springs hold once settled (the overdamped sheet relaxes in ~D / k = 20 ms)
    weight = model.masses[:, None] * g
    k, link_force = model.stiffness, model.link_force
    if integrator == "xpbd":
        # its one-iteration fixed point (kernels/xpbd.py, kernels/residual.py), taken at the
        # prediction x~ = x + h^2 g (free nodes): springs of k / (1 + k h^2 W) and links of F / max(1 +
        # F h^2 W / r, 1 + h^2 (K_i w_i + K_j w_j)), W = n_i w_i + n_j w_j (n counting springs
        # and links, w = 1/m, K the node's spring stiffness sum), balance the weight
        w = np.where(model.pinned, 0.0, 1.0 / model.masses)
        n = np.bincount(np.concatenate([model.springs.ravel(), model.links.ravel()]),
                        minlength=model.node_count)
        K = np.bincount(model.springs.ravel(), weights=np.repeat(k, 2), minlength=model.node_count)
        x = x + h * h * g * ~model.pinned[:, None]  # the prediction moves the free nodes only
        i, j = model.springs.T
        k = k / (1 + k * h * h * (n[i] * w[i] + n[j] * w[j]))
        i, j = model.links.T
        r = np.sqrt(np.sum((x[j] - x[i]) ** 2, axis=1) + model.link_smoothing**2)
        link_force = link_force / np.maximum(1 + link_force * h * h * (n[i] * w[i] + n[j] * w[j]) / r,
                                             1 + h * h * (K[i] * w[i] + K[j] * w[j]))
    outside = node_sums(model, x, model.links, link_force, smoothing=model.link_smoothing) + weight
    net = node_sums(model, x, model.springs, k, rest=model.rest_lengths) + outside
    held = np.abs(outside[interior]).max()  # what the springs hold
    if integrator != "xpbd":  # XPBD's links at this step are softened (by F h^2 W / r ~ 100)
        assert held > sigma_a
    assert np.abs(net[interior]).max() < 0.01 * held


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
    # the fragment falls freely (damped by its own D only), no spring pulls it back; both
    # rules give v' = a (v - h g) with a = m / (m + h D), but semi-implicit Euler and
    # backward Euler move by the damped v' and XPBD by its undamped prediction v - h g
    m, D, g, h = model.masses[a], model.damping[a], 9.81, sim.substep
    assert sim.substeps == 1
    v = z = 0.0
    for _ in range(100):
        z += h * (v - h * g) if integrator == "xpbd" else h * m * (v - h * g) / (m + h * D)
        v = m * (v - h * g) / (m + h * D)
    # float32 positions: 100 additions of ~h v, each to half an ulp of |z| < 1 mm
    assert x[a, 2] == pytest.approx(z, abs=100 * float(np.spacing(np.float32(abs(z)))))
    assert sim.velocities[a, 2] == pytest.approx(v, rel=1e-5)


def spring_diagonals(model, x):
    """Per node, the sum over its springs of the diagonal of the stiffness block
    k [a I + (1 - a) u u^T] at x [N/m], (node_count, 3): u the unit spring direction,
    a = max(0, 1 - L0 / L) (kernels/implicit.py)."""
    i, j = model.springs.T
    d = x[j] - x[i]
    length = np.linalg.norm(d, axis=1)
    u = d / length[:, None]
    a = np.maximum(0.0, 1.0 - model.rest_lengths / length)[:, None]
    blocks = model.stiffness[:, None] * (a + (1.0 - a) * u * u)
    out = np.zeros((model.node_count, 3))
    np.add.at(out, i, blocks)
    np.add.at(out, j, blocks)
    return out


def contact_inertia(model, x, h, integrator):
    """Each node's effective inertia I [kg], (node_count, 3), in the push-out's reaction
    I (N' - N) / h^2 (kernels/collision.py): m + h D for semi-implicit Euler, m + h^2 (sum of
    its springs' k) for XPBD, the diagonal of the system matrix at x for backward Euler."""
    m, D = model.masses[:, None], model.damping[:, None]
    if integrator == "semi_implicit":
        return np.repeat(m + h * D, 3, axis=1)
    if integrator == "xpbd":
        k_sum = np.zeros(model.node_count)
        np.add.at(k_sum, model.springs.ravel(), np.repeat(model.stiffness, 2))
        return np.repeat(m + h * h * k_sum[:, None], 3, axis=1)
    return m + h * D + h * h * spring_diagonals(model, x)


def push_out_reaction(x, tool, inertia, free, h):
    """What the push-out of one substep does to nodes at ``x`` (n, 3), by hand: each node inside
    the cylinder (between its end planes, closer than r to the axis) is counted; each free one
    is moved along its radial direction n to the surface, by r - d, and pushes back on the tool
    with -I (r - d) n / h^2. Returns (the tool force [N] (3,), the count in contact, the sum of
    the nodes' reactions' magnitudes [N]: the force's bound)."""
    axis = tool.p1 - tool.p0
    length = np.linalg.norm(axis)
    rel = x - tool.p0
    along = rel @ (axis / length)
    radial = rel - np.outer(along, axis / length)
    d = np.linalg.norm(radial, axis=1)
    inside = (along >= 0) & (along <= length) & (d < tool.radius)
    pushed = inside & free
    push = (tool.radius - d[pushed])[:, None] * radial[pushed] / d[pushed, None]
    reactions = inertia[pushed] * push / h**2
    return -reactions.sum(axis=0), int(inside.sum()), float(np.linalg.norm(reactions, axis=1).sum())


@pytest.mark.parametrize("integrator", ALL)
def test_tool_faster_than_one_radius_per_step(integrator):
    model = TissueModel.from_patch((0.02, 0.02), 0.001)
    # one substep a step: the push-out (the substep's last move of a node) happens once a step
    sim = Simulator(model, dt=1e-3, substeps=1, integrator=integrator, device=DEVICE)
    r = 0.0005
    # an upright tool through the sheet, across it at 5 m/s: 10 radii per step
    def path(t):
        return Tool([-0.015 + 5.0 * t, 0, -0.003], [-0.015 + 5.0 * t, 0, 0.01], r)
    h, free = sim.substep, ~model.pinned
    forces, pushing_steps = [], 0
    for _ in range(8):
        x, v = sim.positions, sim.velocities
        sim.step(1, tool=path)
        # each step the tool lands 10 radii on, on nodes it has not touched: the substep finds
        # them at x + h v (their in-step acceleration is gravity's, along the upright axis,
        # which moves no node towards it), each with its own inertia and push r - d
        expected, count, bound = push_out_reaction(x + h * v, path(sim.time),
                                                   contact_inertia(model, x, h, integrator), free, h)
        force = sim.tool_force
        assert np.all(np.isfinite(force)) and sim.contacts.count == count
        # float32 positions: ~1e-10 m on pushes of ~1e-4 m
        assert np.linalg.norm(force) <= bound * (1 + 1e-4)
        np.testing.assert_allclose(force, expected, rtol=0, atol=1e-4 * bound)
        forces.append(np.linalg.norm(force))
        pushing_steps += bound > 0
    assert np.all(np.isfinite(sim.positions))
    assert sim.contacts.max_force == pytest.approx(max(forces))
    assert pushing_steps >= 2 and max(forces) > 0  # the tool did push free nodes


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
