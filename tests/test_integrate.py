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


def run_x(model, h, steps):
    sim = Simulator(model, dt=h, substeps=1, gravity=None, device=DEVICE)
    xs = np.empty(steps)
    for n in range(steps):
        sim.step()
        xs[n] = sim.positions[1, 0] - 0.1
    return xs


def crossing_period(xs, h):
    """Period from linear interpolation of upward zero crossings [s]."""
    idx = np.flatnonzero((xs[:-1] < 0) & (xs[1:] >= 0))
    t = (idx + xs[idx] / (xs[idx] - xs[idx + 1])) * h
    return float(np.mean(np.diff(t)))


@pytest.mark.parametrize("h_omega", [0.05, 0.5, 1.5])
def test_undamped_period_matches_discrete_frequency(h_omega):
    k, m = 40.0, 0.01
    omega = math.sqrt(k / m)
    h = h_omega / omega
    xs = run_x(oscillator(k, m), h, int(40 * 2 * math.pi / (omega * h)))
    omega_discrete = (2.0 / h) * math.asin(h * omega / 2.0)
    assert crossing_period(xs, h) == pytest.approx(2 * math.pi / omega_discrete, rel=2e-3)
    # symplectic: the amplitude neither grows nor decays
    assert np.abs(xs[-200:]).max() == pytest.approx(0.01, rel=0.05 + h_omega ** 2 / 4)


def test_damped_decay_matches_closed_form():
    k, m, D = 40.0, 0.01, 0.02
    omega = math.sqrt(k / m)
    h = 0.05 / omega
    steps = int(10 * 2 * math.pi / (omega * h))
    xs = run_x(oscillator(k, m, damping=D), h, steps)
    # one step maps (x, v) by a matrix with determinant a = 1/(1 + hD/m): |lambda| = sqrt(a)
    a = 1.0 / (1.0 + h * D / m)
    peaks = [i for i in range(1, steps - 1) if xs[i] > xs[i - 1] and xs[i] >= xs[i + 1]]
    rate = np.polyfit(peaks, np.log(xs[peaks]), 1)[0]
    assert rate == pytest.approx(0.5 * math.log(a), rel=0.02)
    # and the continuous rate -D/(2m) per unit time to the order of h
    assert rate / h == pytest.approx(-D / (2 * m), rel=0.05)


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
    model = oscillator(k=160.0, m=1e-5, damping=3.0)
    sim = Simulator(model, dt=1e-3, substeps="auto", gravity=None, device=DEVICE)
    assert sim.substeps == 1
    sim.step(200)
    x = sim.positions[1, 0] - 0.1
    # overdamped relaxation toward rest: x(t) ~ A exp(-k t / D)
    assert 0 < x < 0.01 * math.exp(-160.0 * 0.2 / 3.0) * 2
