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


def pytest_configure(config):
    config.addinivalue_line("markers", "invalid_usd: the test writes broken USD files on purpose")


@pytest.fixture(autouse=True)
def _exported_usd_passes_checks(request):
    """Every USD stage a test leaves in its tmp_path passes the per-time-sample checker and
    the pxr.UsdValidation validators."""
    if "tmp_path" not in request.fixturenames or request.node.get_closest_marker("invalid_usd"):
        yield
        return
    tmp = request.getfixturevalue("tmp_path")  # before the test, so it outlives this check
    yield
    from warp_cut.io.usd_check import check_usd, validate_usd

    for path in sorted(tmp.rglob("*.usd*")):
        if path.parent.name.endswith("_clips") or path.name.startswith("."):
            continue
        assert check_usd(path) == [], path
        assert validate_usd(path) == [], path
