"""Shared test set-up: Warp on the test device, quietly; small helpers for building models.

The device is ``cpu`` unless ``--device`` (or the environment variable ``WARP_CUT_TEST_DEVICE``)
names another, e.g. ``cuda:0``; tests import it as ``DEVICE``. A test that only makes sense on
one kind of device is marked ``@pytest.mark.cpu_only(reason=...)`` and skipped elsewhere.
"""

import os

import numpy as np
import pytest
import warp as wp
from hypothesis import settings

from warp_cut.sim.warp_config import quiet_warp

quiet_warp()
wp.init()

settings.register_profile("reproducible", derandomize=True, database=None)
settings.load_profile("reproducible")  # the property tests draw the same examples on every machine and run

DEVICE = os.environ.get("WARP_CUT_TEST_DEVICE", "cpu")
"""The Warp device the tests run on (set by ``pytest_configure`` before tests import it)."""


def pytest_addoption(parser):
    parser.addoption("--device", default=None,
                     help="Warp device for the warp_cut tests: cpu (default), cuda or cuda:N "
                          "(or set WARP_CUT_TEST_DEVICE)")


def chain_model(n_free, *, mass=0.01, stiffness=10.0, spacing=0.1, damping=0.0, axis=(0, 0, -1)):
    """A straight chain: node 0 pinned, n_free free nodes below it along ``axis``."""
    from warp_cut import Material, TissueModel

    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    pts = np.outer(np.arange(n_free + 1) * spacing, axis)
    springs = np.column_stack([np.arange(n_free), np.arange(1, n_free + 1)])
    return TissueModel.from_arrays(pts, springs, mass, pinned=[0], stiffness=stiffness,
                                   damping=damping, material=Material(damping=damping))


def grid_without(cells, n: int = 6, spacing: float = 1e-3):
    """A flat grid of n x n nodes ``spacing`` [m] apart (node id = n row + column), every cell
    split on one diagonal, the cells (row, column) of ``cells`` left out (an opening)."""
    from warp_cut import TissueModel

    g = np.stack(np.meshgrid(np.arange(n), np.arange(n)), axis=-1).reshape(-1, 2) * spacing
    points = np.column_stack([g, np.zeros(len(g))])
    triangles = []
    for r in range(n - 1):
        for c in range(n - 1):
            if (r, c) in cells:
                continue
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            triangles += [[a, b, e], [a, e, d]]
    return TissueModel.from_triangles(points, np.array(triangles))


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def pytest_configure(config):
    global DEVICE
    config.addinivalue_line("markers", "invalid_usd: the test writes broken USD files on purpose")
    config.addinivalue_line("markers", "cpu_only(reason): the test only makes sense on the CPU")
    DEVICE = config.getoption("--device") or DEVICE
    try:
        device = wp.get_device(DEVICE)
    except (ValueError, RuntimeError) as error:
        raise pytest.UsageError(f"--device / WARP_CUT_TEST_DEVICE: {DEVICE!r} is not a device "
                                f"here ({error}); devices: {wp.get_devices()}") from error
    DEVICE = device.alias
    wp.set_device(DEVICE)  # launches that name no device run there too


def pytest_report_header(config):
    return f"warp_cut test device: {DEVICE} (Warp {wp.__version__})"


def pytest_terminal_summary(terminalreporter, config):
    if config.get_verbosity() < 0:  # -q hides the header; say it once at the end
        terminalreporter.write_line(pytest_report_header(config))


def pytest_collection_modifyitems(config, items):
    if wp.get_device(DEVICE).is_cpu:
        return
    for item in items:
        marker = item.get_closest_marker("cpu_only")
        if marker is not None:
            reason = marker.kwargs.get("reason") or (marker.args[0] if marker.args else "")
            item.add_marker(pytest.mark.skip(reason=f"CPU only on {DEVICE}: {reason}"))


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
