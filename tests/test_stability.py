"""warp_cut/stability.py: the computed stable step is safe, and instability is caught, never a NaN."""

import math

import numpy as np
import pytest
from conftest import DEVICE, chain_model
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut import Material, SimulationUnstable, Simulator, TissueModel, stable_time_step
from warp_cut.cut.topology import TopologyEditor
from warp_cut.mesh.triangulate import delaunay
from warp_cut.sim.stability import ElementRates, node_stiffness_sums
from warp_cut.solvers import INTEGRATORS


def tangent_stiffness(model, x):
    """(K over the free nodes' coordinates at positions ``x``, the (3 n,) mask of those
    coordinates): each spring k [u u^T + (1 - L0 / L)(I - u u^T)], negative across a compressed
    one; at rest a spring is stiff only along itself."""
    n = model.node_count
    K = np.zeros((3 * n, 3 * n))
    for (i, j), k, rest in zip(model.springs, model.stiffness, model.rest_lengths):
        d = x[j] - x[i]
        length = np.linalg.norm(d)
        uu = np.outer(d, d) / length ** 2
        block = k * (uu + (1.0 - rest / length) * (np.eye(3) - uu))
        for a, b, s in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            K[3 * a:3 * a + 3, 3 * b:3 * b + 3] += s * block
    free = np.repeat(~model.pinned, 3)
    return K[np.ix_(free, free)], free


def generalized_max(L, w):
    """lambda_max(W^-1 L) for positive weights w."""
    r = 1.0 / np.sqrt(w)
    return np.linalg.eigvalsh(L * r[:, None] * r[None, :]).max()


def iteration_eigenvalues(K, m, D, h):
    """Eigenvalues of one semi-implicit step with implicit damping, per coordinate masses m and
    damping D: [x; v] -> [x + h v'; v'], v' = (M + h D)^-1 (M v - h K x)."""
    a = m / (m + h * D)
    B = -h * K / (m + h * D)[:, None]
    eye = np.eye(len(m))
    return np.linalg.eigvals(np.block([[eye + h * B, h * np.diag(a)], [B, np.diag(a)]]))


def exact_limit(model, damping_per_mass=0.0):
    """Exact linear stability limit of semi-implicit Euler from the eigenvalues of M^-1 K
    (rest configuration, free nodes only), for mass-proportional damping c."""
    K, free = tangent_stiffness(model, model.points)
    w2 = generalized_max(K, np.repeat(model.masses, 3)[free])
    c = damping_per_mass
    return (c + math.sqrt(c * c + 4 * w2)) / w2


def energy_bounded_run(model, h, steps):
    """Max displacement every 100 steps after a random perturbation along the chain axis
    (the linear regime the limit speaks of)."""
    sim = Simulator(model, dt=h, substeps=1, gravity=None, device=DEVICE)
    rng = np.random.default_rng(0)
    free = ~model.pinned
    x0 = model.points.copy()
    x0[free, 2] += rng.normal(scale=1e-3, size=free.sum())
    sim.set_state(positions=x0)
    amp = []
    for _ in range(steps // 100):
        sim.step(100)
        amp.append(np.abs(sim.positions - model.points).max())
    return np.array(amp)


def test_estimate_is_below_the_exact_limit():
    for n in (1, 4, 10):
        model = chain_model(n, mass=0.01, stiffness=100.0)
        est = stable_time_step(model, include_damping=False).step
        assert est <= exact_limit(model) * (1 + 1e-12)
        if n > 2:  # an interior node has two springs to free nodes: sqrt(2 m / sum k)
            assert est == pytest.approx(math.sqrt(2 * 0.01 / 200.0))
    # a single oscillator is exactly at its limit 2 / omega
    one = chain_model(1, mass=0.01, stiffness=100.0)
    assert stable_time_step(one).step == pytest.approx(exact_limit(one))


def test_undamped_chain_at_095_of_computed_limit_stays_bounded():
    model = chain_model(8, mass=0.01, stiffness=100.0)
    h = 0.95 * stable_time_step(model).step
    amp = energy_bounded_run(model, h, 20000)
    # bounded: within 20 x the 1 mm start (an unstable mode grows exponentially and is caught,
    # next test); the displacement itself swings with the modes' phases, no closer bound
    assert np.all(np.isfinite(amp)) and amp.max() < 0.02


def test_well_above_exact_limit_is_caught_not_nan():
    model = chain_model(8, mass=0.01, stiffness=100.0)
    h = 1.5 * exact_limit(model)
    with pytest.raises(SimulationUnstable) as info:
        energy_bounded_run(model, h, 20000)
    err = info.value
    assert 0 <= err.node < model.node_count and err.step == pytest.approx(h)
    assert err.safe_step == pytest.approx(stable_time_step(model).step)
    assert "stable step" in str(err) and "node" in str(err)


def test_damped_limit_is_safe_and_larger():
    m, k, D = 1e-3, 100.0, 0.5
    model = chain_model(6, mass=m, stiffness=k, damping=D)
    lim = stable_time_step(model)
    assert lim.step > lim.undamped_step
    assert lim.step <= exact_limit(model, D / m) * (1 + 1e-12)
    amp = energy_bounded_run(model, 0.95 * lim.step, 5000)
    assert amp.max() < 0.01  # bounded (10 x the start); it decays, being damped


def test_auto_substeps_respect_the_limit():
    model = TissueModel.from_patch((0.02, 0.02), 0.002)
    sim = Simulator(model, dt=0.05, substeps="auto", device=DEVICE)
    assert sim.substep <= 0.5 * sim.step_limit.step + 1e-15
    assert sim.substeps == math.ceil(0.05 / (0.5 * sim.step_limit.step))
    auto = Simulator(model, dt="auto", device=DEVICE)
    assert auto.substeps == 1 and auto.dt == pytest.approx(0.5 * auto.step_limit.step)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_compressed_sheet_needs_no_shorter_step(seed):
    """Springs squeezed to 0.3 of their rest length (as a tool piles nodes up) are negative
    across themselves: buckling modes that grow at their physical rate whatever the step (real
    eigenvalues above 1). At 0.95 x the limit, which ignores positions, no mode oscillates and
    grows - the numerical instability the limit guards against; past the exact limit of the
    positive modes one does, so the check can fail."""
    rng = np.random.default_rng(seed)
    rest = np.column_stack([rng.uniform(0, 0.01, (12, 2)), np.zeros(12)])
    tris = delaunay(rest[:, :2])
    edges = np.unique(np.sort(np.vstack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1), axis=0)
    model = TissueModel.from_arrays(rest, edges, 10.0 ** rng.uniform(-6, -4, 12), pinned=[0], damping=0.0,
                                    stiffness=rng.uniform(50, 500, len(edges)))
    centre = rest.mean(axis=0)
    squeezed = centre + 0.3 * (rest - centre)
    squeezed[:, 2] += rng.normal(scale=1e-4, size=12)
    K, free = tangent_stiffness(model, squeezed)
    m = np.repeat(model.masses, 3)[free]
    w2 = np.linalg.eigvalsh(K / np.sqrt(np.outer(m, m)))
    assert (w2 < 0).sum() > 0  # it does buckle

    def oscillating_growth(h):
        ev = iteration_eigenvalues(K, m, np.zeros_like(m), h)
        growing = ev[np.abs(ev) > 1.0 + 1e-9]
        return int(np.sum((np.abs(growing.imag) > 1e-9) | (growing.real < 0)))

    limit = stable_time_step(model).step
    assert oscillating_growth(0.95 * limit) == 0
    assert oscillating_growth(1.05 * 2.0 / np.sqrt(w2.max())) > 0


def iteration_spectral_radius(model, h):
    """Spectral radius of one semi-implicit step with implicit damping, linearised at rest
    (free nodes)."""
    K, free = tangent_stiffness(model, model.points)
    return np.abs(iteration_eigenvalues(K, np.repeat(model.masses, 3)[free],
                                        np.repeat(model.damping, 3)[free], h)).max()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_damped_per_node_limit_is_stable_with_uneven_masses(seed):
    """Light and heavy nodes mixed (as lip nodes after a cut): 0.95 x the estimate is stable
    by the eigenvalues of the iteration itself."""
    rng = np.random.default_rng(seed)
    n = 7
    pts = np.column_stack([np.arange(n) * 0.1, np.zeros(n), np.zeros(n)])
    masses = 10.0 ** rng.uniform(-6, -2, n)
    model = TissueModel.from_arrays(pts, np.column_stack([np.arange(n - 1), np.arange(1, n)]), masses,
                                    pinned=[0], stiffness=rng.uniform(50, 500, n - 1),
                                    damping=3.0, material=Material(damping=3.0))
    h = 0.95 * stable_time_step(model).step
    assert iteration_spectral_radius(model, h) <= 1.0 + 1e-9


def scalar_stiffness(model):
    """(L over the free nodes, the (n,) free mask): the scalar Laplacian of the springs and of
    the residual links at their largest stiffness F / eps, plus the foundation's k_f A_i on
    the diagonal - what the element bounds speak of (K <= L x I_3)."""
    L = np.diag(np.asarray(foundation_diagonal(model), dtype=np.float64))
    links = np.asarray(model.links).reshape(-1, 2)
    pairs = np.vstack([model.springs, links])
    k = np.concatenate([model.stiffness, model.link_force / model.link_smoothing])
    for (i, j), kk in zip(pairs, k):
        L[np.ix_([i, j], [i, j])] += kk * np.array([[1.0, -1.0], [-1.0, 1.0]])
    free = ~model.pinned & model.active
    return L[np.ix_(free, free)], free


def foundation_diagonal(model):
    """k_f A_i [N/m] per node (0 without a foundation)."""
    k_f = model.foundation_stiffness
    return k_f * model.node_areas if k_f > 0 else np.zeros(model.node_count)


@st.composite
def random_sheets(draw):
    """A jittered Delaunay sheet of 5-14 nodes with random masses (1e-6 - 1e-3 kg), stiffness,
    damping (some nodes undamped), pins, residual links and foundation."""
    seed = draw(st.integers(0, 2 ** 32 - 1))
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 15))
    pts = np.column_stack([rng.uniform(0, 0.01, (n, 2)), np.zeros(n)])
    tris = delaunay(pts[:, :2])
    edges = np.unique(np.sort(np.vstack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1), axis=0)
    damping = np.where(rng.random(n) < 0.2, 0.0, 10.0 ** rng.uniform(-4, 0.5, n))
    material = Material(foundation_stiffness=float(rng.choice([0.0, 1e6])))
    pinned = np.flatnonzero(rng.random(n) < 0.25)
    model = TissueModel.from_arrays(pts, edges, 10.0 ** rng.uniform(-6, -3, n), pinned=pinned,
                                    triangles=tris, stiffness=10.0 ** rng.uniform(1, 3, len(edges)),
                                    damping=damping, material=material)
    if rng.random() < 0.5:
        pairs = rng.choice(n, size=(3, 2))
        pairs = pairs[pairs[:, 0] != pairs[:, 1]]
        if len(pairs):
            model.add_residual_links(pairs, np.full(len(pairs), 0.002), area=0.05 / model.material.residual_stress,
                                     smoothing=1e-3)
    return model


@settings(max_examples=60, deadline=None)
@given(random_sheets())
def test_element_bounds_hold_and_the_limit_is_stable(model):
    """Lambda_M and Lambda_D bound the largest eigenvalues of M^-1 K and D^-1 K from above (by
    the eigenvalues themselves), and the damped limit is stable by the iteration's spectral
    radius, for any damping (zero at some nodes, not proportional to the masses)."""
    L, free = scalar_stiffness(model)
    if not free.any():
        return
    m, D = model.masses[free], model.damping[free]
    (mass_rate, _), (damping_rate, _) = ElementRates(model).bounds()
    assert generalized_max(L, m) <= mass_rate * (1 + 1e-9) + 1e-9
    if (D > 0).all():
        assert generalized_max(L, D) <= damping_rate * (1 + 1e-9) + 1e-9
    else:  # an undamped node: no damping bound, the step is the undamped one's at least
        assert damping_rate == np.inf
    limit = stable_time_step(model)
    if np.isfinite(limit.step):
        assert np.abs(iteration_eigenvalues(L, m, D, 0.999 * limit.step)).max() <= 1.0 + 1e-9


@pytest.mark.parametrize("size, spacing", [((0.04, 0.04), 0.002), ((0.03, 0.02), 0.001)])
def test_patch_bound_is_close_to_its_largest_frequency(size, spacing):
    """On the patch lattice (pinned border) the element bound lies within 15 % above the exact
    lambda_max(M^-1 K) (inside, a regular lattice's triangle rates 9 k / m, its largest
    frequency; the lighter nodes by the border add the rest); Gershgorin's row sums (12 k / m
    inside) lie 25 % or more above it."""
    model = TissueModel.from_patch(size, spacing, pinned="border")
    (mass_rate, _), _ = ElementRates(model).bounds()
    L, free = scalar_stiffness(model)
    exact = generalized_max(L, model.masses[free])
    gershgorin = (node_stiffness_sums(model)[free] / model.masses[free]).max()
    assert exact <= mass_rate * (1 + 1e-12) and mass_rate < 1.15 * exact
    assert gershgorin > 1.25 * exact


def test_a_hub_node_is_bounded_by_its_element_not_its_valence():
    """A lip node joined to 14 border nodes (as a fan fill leaves one) under heavy damping:
    Gershgorin's row sum 2 x 14 k sets a step 1.8 x shorter than the exact overdamped limit;
    the element bound stays within 10 % of the exact one and is never above it."""
    n = 14
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    rim = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(n)]) * 0.001
    pts = np.vstack([[0.0, 0.0, 0.0], rim, 2 * rim])
    fan = [(0, 1 + i, 1 + (i + 1) % n) for i in range(n)]
    ring = [t for i in range(n) for t in ((1 + i, 1 + n + i, 1 + n + (i + 1) % n),
                                          (1 + i, 1 + n + (i + 1) % n, 1 + (i + 1) % n))]
    tris = np.array(fan + ring)
    edges = np.unique(np.sort(np.vstack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1), axis=0)
    model = TissueModel.from_arrays(pts, edges, 2e-6, pinned=np.arange(1 + n, 1 + 2 * n), triangles=tris,
                                    stiffness=160.0, damping=3.0)
    L, free = scalar_stiffness(model)
    exact = 2.0 / generalized_max(L, model.damping[free])  # overdamped: 2 / lambda_max(D^-1 K)
    limit = stable_time_step(model).step
    gershgorin = 2.0 * 3.0 / node_stiffness_sums(model).max()
    assert limit <= exact * (1 + 1e-9) * (1 + 1e-3)  # the mass adds a little above 2 D / lambda
    assert limit > 0.9 * exact and exact > 1.5 * gershgorin


# ------------------------------------------------------------------ XPBD's explicit part
K_F = 1.0e5  # N/m^3


def founded_sheet(damping):
    """A free patch whose springs have no stiffness, held by the foundation alone: every node
    is an oscillator of omega^2 = k_f / (rho t), with damping rate D / m of its own mass."""
    mat = Material(foundation_stiffness=K_F, damping=damping, stiffness=0.0)
    return TissueModel.from_patch((0.01, 0.01), 0.002, material=mat, pinned="none")


def xpbd_mode_radius(omega, c, h):
    """Spectral radius of one XPBD substep of an explicit mode omega [1/s] with damping rate c
    [1/s]: x~ = x + h v - h^2 omega^2 x, then h v' = (x~ - x) / (1 + h c)."""
    a = 1.0 / (1.0 + h * c)
    p = 1.0 - (h * omega) ** 2
    return np.abs(np.linalg.eigvals(np.array([[p, 1.0], [a * (p - 1.0), a]]))).max()


@pytest.mark.parametrize("D", [0.0, 1e-3, 3e-3])
def test_xpbd_limit_of_the_foundation_is_exact(D):
    # damping lowers the limit from 2 / omega toward sqrt(2) / omega, most on the lightest node
    model = founded_sheet(D)
    limit = INTEGRATORS["xpbd"].step_limit(model)
    omega = math.sqrt(K_F / (model.material.density * model.material.thickness))
    assert math.sqrt(2) / omega <= limit.step <= 2 / omega * (1 + 1e-9)
    if D == 0:
        assert limit.step == pytest.approx(2 / omega, rel=1e-9)
    rates = model.damping / model.masses
    assert max(xpbd_mode_radius(omega, c, 0.999 * limit.step) for c in rates) <= 1.0 + 1e-9
    assert xpbd_mode_radius(omega, rates.max(), 1.001 * limit.step) > 1.0 + 1e-7


@pytest.mark.parametrize("scale, grows", [(0.95, False), (1.05, True)])
def test_xpbd_run_on_either_side_of_its_limit(scale, grows):
    model = founded_sheet(3e-3)
    h = scale * INTEGRATORS["xpbd"].step_limit(model).step
    sim = Simulator(model, dt=h, substeps=1, gravity=None, integrator="xpbd", device=DEVICE)
    x0 = model.points.copy()
    x0[:, 2] += 1e-6
    sim.set_state(positions=x0)
    if grows:  # the lightest node's mode grows 1.23 x a step, caught by the guard
        with pytest.raises(SimulationUnstable):
            sim.step(300)
    else:
        sim.step(300)
        assert np.abs(sim.positions[:, 2] - model.points[:, 2]).max() < 1e-6


# ------------------------------------------------------------------ XPBD's links: constraints
def linked_chain(masses, damping, F=0.05, eps=1e-3):
    """Node 0 pinned, the others free, all at the origin, each joined to the next by a
    residual link only (no springs): at distance 0 a link is an isotropic spring F / eps."""
    n = len(masses)
    model = TissueModel.from_arrays(np.zeros((n, 3)), np.zeros((0, 2), int), masses, pinned=[0],
                                    damping=damping)
    model.add_residual_links(np.column_stack([np.arange(n - 1), np.arange(1, n)]),
                             np.full(n - 1, 0.002), area=F / model.material.residual_stress,
                             smoothing=eps)
    return model


def xpbd_link_radius(model, h, F=0.05, eps=1e-3):
    """Spectral radius of one XPBD substep of the linked chain, linearised at rest (one
    coordinate per node, the links being isotropic there): x~ = x + h v, the links' Jacobi
    pass x' = (I + J) x~ with rows ``w_i (x~_j - x~_i) / (n_i w_i + n_j w_j + eps / (F h^2))``,
    then h v' = A (x' - x), A = (1 + h D / m)^-1."""
    n = model.node_count
    w = np.where(model.pinned, 0.0, 1.0 / model.masses)
    valence = np.bincount(model.links.ravel(), minlength=n)
    J = np.zeros((n, n))
    for i, j in model.links:
        g = 1.0 / (valence[i] * w[i] + valence[j] * w[j] + eps / (F * h * h))
        for a, b in ((i, j), (j, i)):
            J[a, b] += w[a] * g
            J[a, a] -= w[a] * g
    free = ~model.pinned
    P = np.eye(int(free.sum())) + J[np.ix_(free, free)]
    A = np.diag(1.0 / (1.0 + h * model.damping[free] / model.masses[free]))
    step = np.block([[P, P], [A @ (P - np.eye(len(P))), A @ P]])
    return np.abs(np.linalg.eigvals(step)).max()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_xpbd_links_are_stable_at_any_step(seed):
    """Masses over four decades and damping up to 3 N s/m: one substep of the link constraints
    never amplifies, from far below the explicit limit 2 / omega (omega^2 = F / (eps m)) to a
    second, where the explicit links (the XPBD of before, fuzz case 4087729486: 102 x the
    substeps after four strokes) would need 1e5 times as many."""
    rng = np.random.default_rng(seed)
    model = linked_chain(10.0 ** rng.uniform(-6, -2, 7), rng.uniform(0, 3, 7))
    assert INTEGRATORS["xpbd"].step_limit(model).step == math.inf
    for h in np.logspace(-7, 0, 15):
        assert xpbd_link_radius(model, h) <= 1.0 + 1e-9, h


def test_xpbd_linked_chain_runs_far_past_the_explicit_limit():
    """The kernel, at 1000 x the explicit links' limit: the light chain (damping rates up to
    3e6 1/s, so it creeps) closes up step after step instead of growing (the explicit links
    grew ~500 x past 1.05 x their limit)."""
    masses, F, eps = np.array([1e-3, 1e-6, 1e-5, 1e-6]), 0.05, 1e-3
    model = linked_chain(masses, 3.0, F, eps)
    h = 1000 * 2.0 / math.sqrt(F / eps / masses[1:].min())
    sim = Simulator(model, dt=h, substeps=1, gravity=None, integrator="xpbd", device=DEVICE)
    assert sim.substeps == 1
    x0 = np.zeros((4, 3))
    x0[1:, 0] = [2e-4, -1e-4, 3e-4]
    sim.set_state(positions=x0)
    spread = [np.abs(x0).max()]
    for _ in range(10):
        sim.step(10)
        spread.append(np.abs(sim.positions).max())
    assert np.all(np.diff(spread) < 0) and spread[-1] < 0.05 * spread[0]


def test_xpbd_link_pulls_with_its_force_at_small_steps():
    """Far outside eps (d = 1 cm >> 10 um) a link pulls a free node with F: in N steps of h it
    moves F h^2 N (N + 1) / (2 m) toward the pinned node, the explicit prediction's sum
    (F t^2 / (2 m) = 0.1 mm at t = N h = 2 ms; no damping, no gravity)."""
    m, F, eps, L, t = 1e-3, 0.05, 1e-5, 0.01, 2e-3
    model = linked_chain([m, m], 0.0, F, eps)
    sim = Simulator(model, dt=1e-5, substeps=1, gravity=None, integrator="xpbd", device=DEVICE)
    x0 = np.zeros((2, 3))
    x0[0, 0] = -L  # the free node at the origin, where float32 resolves the small steps
    sim.set_state(positions=x0)
    n = round(t / 1e-5)
    sim.step(n)
    assert -sim.positions[1, 0] == pytest.approx(F * 1e-10 * n * (n + 1) / (2 * m), rel=1e-4)


def _linked_pair_closing(integrator: str, strain: float) -> np.ndarray:
    """How much each residual link closes its pair [m] on a 1 cm sheet (k = 160 N/m springs,
    nodes of 6 mg, so at h = 1 ms one Jacobi pass softens its springs ~400 times), no gravity,
    after 0.3 s (settled: the overdamped sheet relaxes in ~D / k = 20 ms)."""
    material = Material(residual_strain=strain, youngs_modulus=20e3, thickness=2e-3)
    model = TissueModel.from_patch((0.01, 0.01), 0.002, material=material)
    interior = np.flatnonzero(~model.pinned)
    pairs = np.column_stack([interior[:-1], interior[1:]])
    model.add_residual_links(pairs, np.full(len(pairs), 0.002))
    sim = Simulator(model, dt=1e-3, integrator=integrator, gravity=None, device=DEVICE)
    sim.step(300)
    return np.linalg.norm(np.diff(model.points[pairs], axis=1)[:, 0] , axis=1) - \
        np.linalg.norm(np.diff(sim.positions[pairs], axis=1)[:, 0], axis=1)


@pytest.mark.parametrize("strain", [0.05, 0.3, 0.9])
def test_xpbd_links_close_their_pairs_as_much_as_the_springs_let_them(strain):
    """XPBD far above the springs' explicit limit (h^2 k w ~ 26): its links close their pairs
    within 25 % of implicit Euler's closing (the springs' equilibrium). A link softened less
    than the springs that hold it (F / r << k: its own compliance only) closed its pairs too far,
    off by 2.4 (strain 0.9) to 47 (0.05) times the reference's closing, and on the small
    triangles a cut makes crushed
    them flat (fuzz case 1773829024, stroke 3: a triangle of 27 deg at rest at 0.01 deg)."""
    xpbd, reference = _linked_pair_closing("xpbd", strain), _linked_pair_closing("implicit_euler", strain)
    assert reference.min() > 0
    assert np.abs(xpbd - reference).max() < 0.25 * reference.max()


def test_element_rates_follow_an_edit_that_makes_and_deletes_nodes_past_the_capacity():
    """A fill that is opened back a station makes lip nodes and deletes them in one edit; their
    slots may lie past the capacity the rates last grew to (an IndexError before)."""
    model = TissueModel.from_patch((0.01, 0.01), 0.002, material=Material(foundation_stiffness=1e6))
    rates = ElementRates(model)
    editor = TopologyEditor(model)
    editor.begin()
    spare = model.node_table.capacity - model.node_table.count
    made = editor.add_nodes(np.zeros((spare + 3, 3)))
    editor.delete_nodes(made)
    editor.finish()
    rates.update(editor.model_change(np.zeros((len(made), 3))))
    fresh = ElementRates(model).limit()
    assert rates.limit().step == pytest.approx(fresh.step, rel=1e-12)


# ------------------------------------------------------------------ links that do not act
@pytest.mark.parametrize("integrator", ["semi_implicit", "xpbd", "implicit_euler"])
def test_links_limit_no_step_where_residual_stress_is_off(integrator):
    """A solver without residual stress never applies the links, so they cannot shorten its
    step: its limit is that of the same sheet without links (fuzz case 3495060231, XPBD without
    residual stress: 1 -> 21 substeps after two strokes while the links the cut made did
    nothing). With residual stress the stiff links (F / eps = 500 N/m) shorten it."""
    def sheet(with_links: bool):
        model = TissueModel.from_patch((0.01, 0.008), 0.002)
        if with_links:
            pairs = np.array([[0, 5], [3, 9], [7, 12]])
            model.add_residual_links(pairs, np.full(3, 0.002), area=0.5 / model.material.residual_stress,
                                     smoothing=1e-3)
        return model

    cls = INTEGRATORS[integrator]
    bare = cls.step_limit(sheet(False)).step
    assert cls.step_limit(sheet(True), links=False).step == bare
    assert cls.limit_tracker(sheet(True), links=False).limit.step == bare
    if integrator == "semi_implicit":  # implicit Euler and XPBD solve their links implicitly
        assert cls.step_limit(sheet(True)).step < bare
    sims = [Simulator(sheet(w), dt=1e-3, device=DEVICE, integrator=integrator, residual_stress=False, gravity=None)
            for w in (False, True)]
    assert sims[1].step_limit.step == sims[0].step_limit.step and sims[1].substeps == sims[0].substeps


def test_element_rates_without_links_follow_an_edit_that_makes_links():
    """The tracker of a solver without residual stress stays equal to the limit of the sheet
    without its links when an edit makes links (rated again at the nodes it touched)."""
    model = TissueModel.from_patch((0.01, 0.008), 0.002)
    rates = ElementRates(model, links=False)
    before = rates.limit().step
    editor = TopologyEditor(model)
    editor.begin()
    editor.make_links([(0, 5), (3, 9)], [0.002, 0.002])
    editor.finish()
    rates.update(editor.model_change(np.zeros((0, 3))))
    assert model.link_count == 2
    assert rates.limit().step == before
    assert ElementRates(model).limit().step < before
