"""kernels/residual.py: residual-stress link magnitude sigma_r * A, direction, and the d -> 0 limit."""

import numpy as np
import pytest
import warp as wp
from conftest import DEVICE

from warp_cut import InputError, Material, TissueModel
from warp_cut.kernels.residual import residual_link_forces


def launch(x, links, F, eps):
    f = wp.zeros(len(x), dtype=wp.vec3, device=DEVICE)
    wp.launch(residual_link_forces, dim=len(F), device=DEVICE, inputs=[
        wp.array(np.asarray(x, np.float32), dtype=wp.vec3, device=DEVICE),
        wp.array(np.asarray(links, np.int32).ravel(), dtype=wp.int32, device=DEVICE),
        wp.array(np.asarray(F, np.float32), dtype=wp.float32, device=DEVICE),
        wp.array(np.asarray(eps, np.float32), dtype=wp.float32, device=DEVICE), f])
    return f.numpy().astype(np.float64)


def test_magnitude_is_sigma_r_times_area_far_from_contact():
    mat = Material(youngs_modulus=20e3, residual_strain=0.1, thickness=2e-3)
    model = TissueModel.from_arrays([[0, 0, 0], [0.01, 0, 0]], [], 1e-6, material=mat)
    model.add_residual_links([[0, 1]], [2e-3])
    expected_F = 20e3 * 0.1 * (2e-3 * 2e-3)  # sigma_r * thickness * rest length = 8 mN
    assert np.isclose(model.link_force[0], expected_F)
    f = launch(model.points, model.links, model.link_force, model.link_smoothing)
    d = 0.01
    eps = model.link_smoothing[0]
    magnitude = expected_F * d / np.sqrt(d * d + eps * eps)
    np.testing.assert_allclose(f[0], [magnitude, 0, 0], rtol=1e-5)  # node 0 pulled toward node 1
    np.testing.assert_allclose(f[1], [-magnitude, 0, 0], rtol=1e-5)
    assert magnitude > 0.995 * expected_F  # |d| = 20 eps: within 0.2 % of sigma_r A


def test_pulls_together_in_any_direction():
    rng = np.random.default_rng(1)
    for _ in range(20):
        x = rng.normal(size=(2, 3))
        f = launch(x, [[0, 1]], [2.0], [1e-3])
        d = x[1] - x[0]
        assert np.dot(f[0], d) > 0 and np.dot(f[1], d) < 0
        np.testing.assert_allclose(f[0] + f[1], 0, atol=1e-6)


def test_smooth_and_finite_as_distance_goes_to_zero():
    eps = 1e-3
    prev = None
    for d in [1e-2, 1e-3, 1e-4, 1e-6, 1e-9, 0.0]:
        f = launch([[0, 0, 0], [d, 0, 0]], [[0, 1]], [1.0], [eps])
        assert np.all(np.isfinite(f))
        expected = d / np.sqrt(d * d + eps * eps)
        assert abs(f[0, 0] - expected) < 1e-5
        if prev is not None:
            assert f[0, 0] <= prev + 1e-7  # decreases monotonically toward zero
        prev = f[0, 0]
    assert prev == 0.0


def test_deleted_links_are_skipped():
    f = launch([[0, 0, 0], [1, 0, 0]], [[-1, 1], [0, -1]], [1.0, 1.0], [0.1, 0.1])
    assert np.all(f == 0)


def test_area_override_and_validation():
    model = TissueModel.from_arrays([[0, 0, 0], [1, 0, 0]], [], 1.0)
    model.add_residual_links([[0, 1]], [0.5], area=3e-6)
    assert np.isclose(model.link_force[0], model.material.residual_stress * 3e-6)
    with pytest.raises(InputError):
        model.add_residual_links([[0, 5]], [0.5])
