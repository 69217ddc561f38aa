"""kernels/springs.py: spring forces against a numpy oracle, Newton's third law, extremes."""

import numpy as np
import warp as wp
from conftest import DEVICE
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.kernels.springs import spring_forces


def launch(x, springs, L0, k):
    n = len(x)
    f = wp.zeros(n, dtype=wp.vec3, device=DEVICE)
    wp.launch(spring_forces, dim=len(L0), device=DEVICE, inputs=[
        wp.array(np.asarray(x, np.float32), dtype=wp.vec3, device=DEVICE),
        wp.array(np.asarray(springs, np.int32).ravel(), dtype=wp.int32, device=DEVICE),
        wp.array(np.asarray(L0, np.float32), dtype=wp.float32, device=DEVICE),
        wp.array(np.asarray(k, np.float32), dtype=wp.float32, device=DEVICE), 1, len(L0), f])
    return f.numpy().astype(np.float64)


def oracle(x, springs, L0, k):
    f = np.zeros_like(x)
    for (i, j), l0, kk in zip(springs, L0, k):
        d = x[j] - x[i]
        L = np.linalg.norm(d)
        if L > 0:
            f[i] += kk * (L - l0) * d / L
            f[j] -= kk * (L - l0) * d / L
    return f


def test_stretched_spring_pulls_ends_together():
    f = launch([[0, 0, 0], [2, 0, 0]], [[0, 1]], [1.0], [3.0])
    np.testing.assert_allclose(f, [[3, 0, 0], [-3, 0, 0]], rtol=1e-6)


def test_compressed_spring_pushes_ends_apart():
    f = launch([[0, 0, 0], [0, 0.5, 0]], [[0, 1]], [1.0], [4.0])
    np.testing.assert_allclose(f, [[0, -2, 0], [0, 2, 0]], rtol=1e-6)


def test_zero_length_spring_is_finite_and_zero():
    f = launch([[1, 1, 1], [1, 1, 1]], [[0, 1]], [0.3], [100.0])
    assert np.all(np.isfinite(f)) and np.all(f == 0)


def test_deleted_slots_are_skipped_not_wrapped():
    # -1 would index the last node if a kernel forgot the check
    f = launch([[0, 0, 0], [1, 0, 0], [5, 0, 0]], [[0, 1], [-1, 2], [2, -1]], [0.5, 1, 1], [1, 1, 1])
    np.testing.assert_allclose(f, [[0.5, 0, 0], [-0.5, 0, 0], [0, 0, 0]], atol=1e-7)


@settings(max_examples=30, deadline=None)
@given(st.integers(2, 40), st.integers(1, 120), st.integers(0, 2**31 - 1))
def test_random_networks_match_oracle_and_third_law(n, s, seed):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    springs = rng.integers(0, n, size=(s, 2))
    springs = springs[springs[:, 0] != springs[:, 1]]
    if len(springs) == 0:
        return
    L0 = rng.uniform(0, 2, len(springs))
    k = rng.uniform(0, 1000, len(springs))
    f = launch(x, springs, L0, k)
    expected = oracle(x.astype(np.float32).astype(np.float64), springs, L0, k)
    scale = np.abs(expected).max() + 1.0
    np.testing.assert_allclose(f, expected, atol=2e-5 * scale)
    # internal forces cancel (Newton's third law), up to float32 summation error
    np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-5 * scale * np.sqrt(len(springs)))
