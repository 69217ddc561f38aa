"""kernels/gravity.py: a hanging chain settles at the static sag m g N (N + 1) / (2 k)."""

import numpy as np
import pytest
import warp as wp
from conftest import DEVICE, chain_model

from warp_cut import Simulator
from warp_cut.kernels.gravity import gravity_forces


@pytest.mark.parametrize("n_free", [1, 5, 12])
def test_hanging_chain_static_sag(n_free):
    m, k, g = 0.01, 50.0, 9.81
    model = chain_model(n_free, mass=m, stiffness=k, damping=0.5)
    sim = Simulator(model, dt=2e-3, gravity=(0, 0, -g), device=DEVICE)
    for _ in range(60):
        sim.step(100)
        if np.abs(sim.velocities).max() < 1e-7:
            break
    sag = model.points[-1, 2] - sim.positions[-1, 2]
    assert sag == pytest.approx(m * g * n_free * (n_free + 1) / (2 * k), rel=1e-3)


def test_gravity_skips_inactive_and_scales_with_mass():
    mass = wp.array(np.array([1.0, 2.0, 3.0], np.float32), dtype=wp.float32, device=DEVICE)
    flags = wp.array(np.array([1, 0, 3], np.int32), dtype=wp.int32, device=DEVICE)
    f = wp.zeros(3, dtype=wp.vec3, device=DEVICE)
    wp.launch(gravity_forces, dim=3, device=DEVICE, inputs=[mass, flags, wp.vec3(0, 0, -2), f])
    np.testing.assert_allclose(f.numpy(), [[0, 0, -2], [0, 0, 0], [0, 0, -6]])
