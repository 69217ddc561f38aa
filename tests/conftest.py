"""Shared test set-up: Warp on the CPU, quietly; small helpers for building models."""

import numpy as np
import pytest
import warp as wp

if hasattr(wp, "LOG_WARNING"):
    wp.config.log_level = wp.LOG_WARNING
wp.init()

DEVICE = "cpu"


def chain_model(n_free, *, mass=0.01, stiffness=10.0, spacing=0.1, damping=0.0, axis=(0, 0, -1)):
    """A straight chain: node 0 pinned, n_free free nodes below it along ``axis``."""
    from warp_cut import Material, TissueModel

    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    pts = np.outer(np.arange(n_free + 1) * spacing, axis)
    springs = np.column_stack([np.arange(n_free), np.arange(1, n_free + 1)])
    return TissueModel.from_arrays(pts, springs, mass, pinned=[0], stiffness=stiffness,
                                   damping=damping, material=Material(damping=damping))


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
