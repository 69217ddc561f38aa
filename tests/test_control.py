"""warp_cut/control.py: keyframed tool poses are np.interp of each coordinate, held outside."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.sim.control import ToolPath


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 6))
def test_pose_matches_interp_of_each_coordinate(seed, count):
    rng = np.random.default_rng(seed)
    times = np.cumsum(rng.uniform(0.1, 1.0, count))
    p0, p1 = rng.normal(size=(count, 3)), rng.normal(size=(count, 3))
    path = ToolPath(times, p0, p1, 0.001)
    for t in np.concatenate([rng.uniform(times[0] - 1, times[-1] + 1, 50), times]):
        a, b = path.endpoints_at(t)
        np.testing.assert_allclose(a, [np.interp(t, times, p0[:, c]) for c in range(3)], atol=1e-12)
        np.testing.assert_allclose(b, [np.interp(t, times, p1[:, c]) for c in range(3)], atol=1e-12)
