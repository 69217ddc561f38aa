"""kernels/integrate.py through the Simulator: closed-form answers of semi-implicit Euler."""

import math

import numpy as np
import pytest
from conftest import DEVICE, chain_model

from warp_cut import Simulator, TissueModel


def oscillator(k=40.0, m=0.01, damping=0.0, amplitude=0.01):
    """Node 0 pinned at the origin, node 1 at rest length 0.1 m + amplitude along x."""
    model = TissueModel.from_arrays([[0, 0, 0], [0.1 + amplitude, 0, 0]], [[0, 1]], m,
                                    pinned=[0], stiffness=k, damping=damping, rest_lengths=[0.1])
    return model


def run_x(model, h, steps, velocities=False):
    """x - L0 of node 1 after each of ``steps`` steps [m] (and its velocity [m/s])."""
    sim = Simulator(model, dt=h, substeps=1, gravity=None, device=DEVICE)
    xs, vs = np.empty(steps), np.empty(steps)
    for n in range(steps):
        sim.step()
        xs[n] = sim.positions[1, 0] - 0.1
        vs[n] = sim.velocities[1, 0]
    return (xs, vs) if velocities else xs


@pytest.mark.parametrize("h_omega", [0.05, 0.5, 1.5])
def test_undamped_oscillator_is_the_discrete_closed_form(h_omega):
    """Semi-implicit Euler on x'' = -w^2 x: v' = v - h w^2 x, x' = x + h v'. The step turns by
    theta = 2 asin(h w / 2) and keeps Q = v^2 + w^2 x^2 - h w^2 x v exactly (expand one step);
    from x_0 = A, v_0 = 0 this gives x_n = A cos((n + 1/2) theta) / cos(theta / 2): the
    amplitude A / sqrt(1 - (h w)^2 / 4) is 51 % above A at h w = 1.5, and exact."""
    k, m, A = 40.0, 0.01, 0.01
    omega = math.sqrt(k / m)
    h = h_omega / omega
    steps = int(40 * 2 * math.pi / (omega * h))
    xs, vs = run_x(oscillator(k, m, amplitude=A), h, steps, velocities=True)
    theta = 2.0 * math.asin(h * omega / 2.0)
    n = np.arange(1, steps + 1)
    exact = A * np.cos((n + 0.5) * theta) / math.cos(theta / 2)
    # float32: x is read as (0.1 + x) - 0.1, half an ulp of 0.11 per step as a random walk,
    # and h, k / m rounded to float32 (relative 2^-24 each) turn the phase by ~ n theta 2^-22
    tol = 2 * math.sqrt(steps) * float(np.spacing(np.float32(0.1 + A))) + A * steps * theta * 2.0**-22
    np.testing.assert_allclose(xs, exact, rtol=0, atol=tol)
    q = vs**2 + omega**2 * xs**2 - h * omega**2 * xs * vs
    np.testing.assert_allclose(q, omega**2 * A**2, rtol=2 * tol / A)


def semi_implicit_orbit(k, m, D, h, steps, x0):
    """x after each step of the semi-implicit map with implicit damping, in float64:
    v' = (m v - h k x) / (m + h D), x' = x + h v' (the oscillator's closed form, step by step)."""
    x, v, xs = x0, 0.0, np.empty(steps)
    for n in range(steps):
        v = (m * v - h * k * x) / (m + h * D)
        x += h * v
        xs[n] = x
    return xs


def test_damped_decay_matches_closed_form():
    k, m, D, A = 40.0, 0.01, 0.02, 0.01
    omega = math.sqrt(k / m)
    h = 0.05 / omega
    steps = int(10 * 2 * math.pi / (omega * h))
    xs = run_x(oscillator(k, m, damping=D, amplitude=A), h, steps)
    # one step maps (x, v) by a matrix with determinant a = 1/(1 + hD/m): |lambda| = sqrt(a),
    # the envelope shrinks by sqrt(a) per step (a third of the amplitude over the run)
    a = 1.0 / (1.0 + h * D / m)
    w2 = (h * omega) ** 2
    step = np.array([[1 - a * w2, a], [-a * w2, a]])  # (x, h v) -> (x', h v')
    assert np.abs(np.linalg.eigvals(step)) == pytest.approx([math.sqrt(a)] * 2, rel=1e-12)
    expected = semi_implicit_orbit(k, m, D, h, steps, A)
    # float32 as in the undamped test: half an ulp of 0.11 per step, parameters to 2^-24
    tol = 2 * math.sqrt(steps) * float(np.spacing(np.float32(0.1 + A))) + A * steps * h * omega * 2.0**-22
    np.testing.assert_allclose(xs, expected, rtol=0, atol=tol)
    assert np.abs(xs[-200:]).max() < 0.8 * A  # the decay is there to see


def test_free_fall_is_exact_discrete_sum():
    model = TissueModel.from_arrays([[0, 0, 1.0]], [], 0.5, damping=0.0)
    h, n = 1e-3, 200
    sim = Simulator(model, dt=h, substeps=1, gravity=(0, 0, -9.81), device=DEVICE)
    sim.step(n)
    # v_n = n h g, x_n = x_0 + h^2 g n (n + 1) / 2
    assert sim.velocities[0, 2] == pytest.approx(-9.81 * n * h, rel=1e-5)
    assert sim.positions[0, 2] == pytest.approx(1.0 - 9.81 * h * h * n * (n + 1) / 2, rel=1e-5)


def test_velocity_constant_without_forces():
    model = TissueModel.from_arrays([[0, 0, 0], [1, 0, 0]], [], 1.0, damping=0.0)
    sim = Simulator(model, dt=1e-2, substeps=1, gravity=None, device=DEVICE)
    sim.set_state(velocities=[[1, 2, 3], [-1, 0, 0.5]])
    sim.step(100)
    np.testing.assert_allclose(sim.velocities, [[1, 2, 3], [-1, 0, 0.5]], rtol=1e-6)
    np.testing.assert_allclose(sim.positions, [[1, 2, 3], [0, 0, 0.5]], atol=1e-5)


def test_pinned_nodes_never_move():
    model = chain_model(5, damping=0.1)
    sim = Simulator(model, dt=1e-3, device=DEVICE)
    sim.step(300)
    np.testing.assert_array_equal(sim.positions[0], model.points[0])
    assert np.all(sim.velocities[0] == 0)
    assert sim.positions[5, 2] < model.points[5, 2]  # the rest fell


def test_large_damping_does_not_force_a_tiny_step():
    # D/m = 3e5 1/s: an explicit damping update would need h < 2 m / D = 6.7 us
    k, m, D, h = 160.0, 1e-5, 3.0, 1e-3
    model = oscillator(k=k, m=m, damping=D)
    sim = Simulator(model, dt=h, substeps="auto", gravity=None, device=DEVICE)
    assert sim.substeps == 1
    xs = np.empty(200)
    for n in range(200):
        sim.step()
        xs[n] = sim.positions[1, 0] - 0.1
    # overdamped relaxation toward rest, x(t) ~ A exp(-k t / D) (2e-7 m left of 1 cm at
    # 0.2 s): exactly the discrete map's values, to float32 - each step rounds x near 0.1 m to
    # half an ulp and the map contracts errors by 1 - h k / D, so they stay below
    # ulp / 2 / (h k / D) ~ 7e-8 m
    expected = semi_implicit_orbit(k, m, D, h, 200, 0.01)
    tol = 0.5 * float(np.spacing(np.float32(0.11))) / (h * k / D)
    np.testing.assert_allclose(xs, expected, rtol=0, atol=tol)
