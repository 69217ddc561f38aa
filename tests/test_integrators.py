"""Every integrator against closed forms: one test body runs over all of INTEGRATORS.

Closed forms for an undamped linear oscillator (omega^2 = k / m) at step h, per step:
semi-implicit Euler keeps the amplitude and turns by 2 asin(h omega / 2); backward Euler and
one-iteration XPBD (whose single-spring map is the same matrix) shrink the amplitude by
(1 + h^2 omega^2)^(-1/2) and turn by atan(h omega).
"""

import math

import numpy as np
import pytest
from conftest import DEVICE, chain_model

from warp_cut import Simulator, TissueModel, Tool
from warp_cut.solvers import INTEGRATORS

ALL = sorted(INTEGRATORS)


def closed_form(integrator, h, omega):
    """(amplitude ratio per step, phase per step) of the undamped oscillator."""
    if integrator == "semi_implicit":
        return 1.0, 2.0 * math.asin(h * omega / 2.0)
    return 1.0 / math.sqrt(1.0 + (h * omega) ** 2), math.atan(h * omega)


def oscillator_run(integrator, h, steps, k=40.0, m=0.01, amplitude=0.01):
    model = TissueModel.from_arrays([[0, 0, 0], [0.1 + amplitude, 0, 0]], [[0, 1]], m,
                                    pinned=[0], stiffness=k, damping=0.0, rest_lengths=[0.1])
    sim = Simulator(model, dt=h, substeps=1, gravity=None, integrator=integrator, device=DEVICE)
    xs = np.empty(steps)
    for n in range(steps):
        sim.step()
        xs[n] = sim.positions[1, 0] - 0.1
    return xs


def step_matrix(integrator, h, omega):
    """The map (x, h v) -> (x', h v') of one step on x'' = -omega^2 x, in float64."""
    w2 = (h * omega) ** 2
    if integrator == "semi_implicit":  # v' = v - h w^2 x, x' = x + h v'
        return np.array([[1 - w2, 1.0], [-w2, 1.0]])
    # backward Euler: v' = (v - h w^2 x) / (1 + h^2 w^2); XPBD: x' = (1 - e)(x + h v), e = w2/(1+w2)
    return np.array([[1.0, 1.0], [-w2, 1.0]]) / (1 + w2)


@pytest.mark.parametrize("integrator", ALL)
@pytest.mark.parametrize("h_omega", [0.1, 0.6])
def test_oscillator_follows_its_closed_form(integrator, h_omega):
    k, m, amplitude = 40.0, 0.01, 0.01
    omega = math.sqrt(k / m)
    h = h_omega / omega
    ratio, phase = closed_form(integrator, h, omega)
    eig = np.linalg.eigvals(step_matrix(integrator, h, omega))
    assert np.abs(eig) == pytest.approx([ratio, ratio], rel=1e-12)
    assert np.abs(np.angle(eig)) == pytest.approx([phase, phase], rel=1e-12)
    steps = int(4 * 2 * math.pi / phase)
    xs = oscillator_run(integrator, h, steps, k, m, amplitude)
    expected, state = np.empty(steps), np.array([amplitude, 0.0])
    for n in range(steps):
        state = step_matrix(integrator, h, omega) @ state
        expected[n] = state[0]
    # float32: half an ulp of x near 0.11 m per step, another for XPBD's velocity (x' - x) / h,
    # as a random walk; h, k / m rounded to float32 turn the phase by ~ n h omega 2^-22
    tol = 4 * math.sqrt(steps) * float(np.spacing(np.float32(0.1 + amplitude)))
    np.testing.assert_allclose(xs, expected, atol=tol + amplitude * steps * h_omega * 2.0**-22)
    idx = np.flatnonzero((xs[:-1] < 0) & (xs[1:] >= 0))
    if len(idx) > 1:  # the period where the decay leaves zero crossings to measure
        crossings = idx + xs[idx] / (xs[idx] - xs[idx + 1])
        assert np.mean(np.diff(crossings)) == pytest.approx(2 * math.pi / phase, rel=5e-3)


@pytest.mark.parametrize("integrator", ALL)
def test_hanging_chain_static_sag(integrator):
    n_free, m, k, g, h = 6, 0.01, 50.0, 9.81, 1e-3
    model = chain_model(n_free, mass=m, stiffness=k, damping=0.5)
    sim = Simulator(model, dt=h, substeps=1, gravity=(0, 0, -g), integrator=integrator,
                    device=DEVICE)
    for _ in range(80):
        sim.step(100)
        if np.abs(sim.velocities).max() < 1e-7:
            break
    sag = model.points[-1, 2] - sim.positions[-1, 2]
    exact = m * g * n_free * (n_free + 1) / (2 * k)
    if integrator == "xpbd":
        # one iteration per substep: each spring acts with k / (1 + k h^2 (n_i w_i + n_j w_j))
        # (here at most 2 springs per node, w = 1/m), a softer chain by at most that factor
        soften = 1 + k * h * h * 4 / m
        assert exact * (1 - 1e-3) <= sag <= exact * soften * (1 + 1e-3) + 2 * g * h * h
    else:
        assert sag == pytest.approx(exact, rel=1e-3)


@pytest.mark.parametrize("integrator", ALL)
def test_free_fall_is_the_exact_discrete_sum(integrator):
    model = TissueModel.from_arrays([[0, 0, 0.0]], [], 0.5, damping=0.0)
    h, n, g = 1e-3, 200, 9.81
    sim = Simulator(model, dt=h, substeps=1, gravity=(0, 0, -g), integrator=integrator,
                    device=DEVICE)
    sim.step(n)
    # all three reduce to v_n = n h g, x_n = x_0 + h^2 g n (n + 1) / 2 without springs
    x_n = -g * h * h * n * (n + 1) / 2
    # XPBD reads v back from float32 positions, (x' - x) / h: n rounding errors of ulp(x) / h
    v_tol = n * 2 * float(np.spacing(np.float32(abs(x_n)))) / h if integrator == "xpbd" else 1e-5 * g * n * h
    assert sim.velocities[0, 2] == pytest.approx(-g * n * h, abs=v_tol)
    assert sim.positions[0, 2] == pytest.approx(x_n, rel=1e-5)


@pytest.mark.parametrize("integrator", ALL)
def test_pinned_nodes_never_move(integrator):
    model = chain_model(5, damping=0.1)
    sim = Simulator(model, dt=1e-3, integrator=integrator, device=DEVICE)
    sim.step(300)
    np.testing.assert_array_equal(sim.positions[0], model.points[0])
    assert np.all(sim.velocities[0] == 0)
    assert sim.positions[5, 2] < model.points[5, 2]  # the rest fell


@pytest.mark.parametrize("integrator", ALL)
def test_residual_link_closes_a_gap_at_constant_force(integrator):
    # two free nodes joined only by a residual link, far apart compared with its smoothing:
    # each feels F toward the other, so the gap closes as d0 - (F / m) t^2
    m, d0 = 1e-3, 0.02
    model = TissueModel.from_arrays([[0, 0, 0], [d0, 0, 0]], [], m, damping=0.0)
    model.add_residual_links([[0, 1]], [0.002], smoothing=1e-4)
    F = float(model.link_force[0])
    h, n = 1e-4, 200
    sim = Simulator(model, dt=h, substeps=1, gravity=None, integrator=integrator, device=DEVICE)
    sim.step(n)
    gap = sim.positions[1, 0] - sim.positions[0, 0]
    # all three: x_n = x_0 + a h^2 n (n + 1) / 2 at constant a = F / m (the continuous
    # a t^2 / 2 to 1 / n), F times d / sqrt(d^2 + eps^2) > 1 - 2e-5 at d > 16 mm
    closed = F / m * h * h * n * (n + 1)
    # float32: each step rounds x (ulp(d0) / 2); XPBD's velocity is the difference of rounded
    # positions, so its errors add up twice (n^2 / 2 of them at worst)
    ulp = float(np.spacing(np.float32(d0)))
    rounding = (n * n / 2 if integrator == "xpbd" else n) * ulp / 2
    assert d0 - gap == pytest.approx(closed, rel=2e-5, abs=2 * rounding)


@pytest.mark.parametrize("integrator", ALL)
def test_held_tool_reaction_equals_the_spring_force(integrator):
    k, L0, r = 100.0, 0.05, 0.01
    model = TissueModel.from_arrays([[0, 0, 0], [0.1, 0, 0]], [[0, 1]], 1e-3, pinned=[0],
                                    stiffness=k, damping=3.0, rest_lengths=[L0])
    sim = Simulator(model, dt=1e-3, substeps=1, gravity=None, integrator=integrator,
                    device=DEVICE)
    tool = Tool([0.1 - r - 1e-3, 0, -0.01], [0.1 - r - 1e-3, 0, 0.01], r)
    sim.step(2000, tool=tool)
    x1 = sim.positions[1]
    assert x1[0] == pytest.approx(0.1 - 1e-3, abs=1e-6)  # held on the tool's surface
    stretch = np.linalg.norm(x1) - L0
    # the reaction is I dx / h^2 with dx ~ 1 mm, the difference of float32 coordinates near
    # 0.1 m (half an ulp, 3.7e-9 m, each): a few 1e-6 relative, hence 2e-5
    np.testing.assert_allclose(sim.tool_force, [-k * stretch, 0, 0], rtol=2e-5, atol=1e-6)
    assert sim.contacts.count == 1
