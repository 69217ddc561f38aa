"""kernels/collision.py: the paper's cylinder test against a float64 numpy oracle, boundaries,
push-out response and the reaction force on the tool."""

import numpy as np
import pytest
import warp as wp
from conftest import DEVICE
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut import Simulator, TissueModel, Tool, ToolStartsInside, cylinder_contacts
from warp_cut.kernels.collision import cylinder_push_out
from warp_cut.sim.collision import axis_distance


def oracle(points, p0, p1, r):
    """Paper Steps 1-2 in float64: angles <= 90 degrees via dot products, then d < r.
    Also returns the margin to the nearest decision boundary [m]."""
    axis = p1 - p0
    L = np.linalg.norm(axis)
    if L == 0 or r == 0:
        return np.zeros(len(points), bool), np.full(len(points), np.inf)
    a = axis / L
    s = (points - p0) @ a
    d = np.linalg.norm((points - p0) - np.outer(s, a), axis=1)
    inside = (s >= 0) & (s <= L) & (d < r)
    margin = np.minimum.reduce([np.abs(s), np.abs(L - s), np.abs(d - r)])
    return inside, margin


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 0.5))
def test_random_points_match_oracle(seed, radius):
    rng = np.random.default_rng(seed)
    p0, p1 = rng.normal(size=3), rng.normal(size=3)
    pts = rng.normal(size=(500, 3))
    got = cylinder_contacts(pts, p0, p1, radius, DEVICE)
    def p32(a):
        return np.asarray(a, np.float32).astype(np.float64)
    want, margin = oracle(p32(pts), p32(p0), p32(p1), np.float32(radius))
    clear = margin > 1e-5  # float32 kernel vs float64 oracle agree away from the boundary
    np.testing.assert_array_equal(got[clear], want[clear])


def test_boundaries_exactly():
    p0, p1, r = np.array([0.0, 0, 0]), np.array([0.0, 0, 2]), 0.5
    pts = np.array([
        [0.25, 0, 0.0],   # angle at p0 exactly 90 degrees, d < r: inside
        [0.25, 0, 2.0],   # angle at p1 exactly 90 degrees: inside
        [0.25, 0, -1e-3],  # just beyond p0: outside
        [0.5, 0, 1.0],    # d == r: outside (strict)
        [0.0, 0.49, 1.0],  # d just below r: inside
        [0.0, 0, 1.0],    # on the axis, d = 0: inside
        [0.0, 0, 2.5],    # on the axis beyond p1: outside
    ])
    np.testing.assert_array_equal(cylinder_contacts(pts, p0, p1, r, DEVICE),
                                  [True, True, False, False, True, True, False])


def test_degenerate_tools_contain_nothing():
    pts = np.random.default_rng(0).normal(size=(100, 3)) * 0.1
    assert not cylinder_contacts(pts, [0, 0, 0], [0, 0, 0], 1.0, DEVICE).any()  # p0 == p1
    assert not cylinder_contacts(pts, [0, 0, -1], [0, 0, 1], 0.0, DEVICE).any()  # r == 0
    assert not cylinder_contacts(np.zeros((1, 3)), [0, 0, -1], [0, 0, 1], 0.0, DEVICE).any()


def push(points, mass, damping, p0, p1, r, h, flags=None):
    n = len(points)
    x = wp.array(np.asarray(points, np.float32), dtype=wp.vec3, device=DEVICE)
    v = wp.zeros(n, dtype=wp.vec3, device=DEVICE)
    force = wp.zeros(1, dtype=wp.vec3, device=DEVICE)
    count = wp.zeros(1, dtype=wp.int32, device=DEVICE)
    psum = wp.zeros(1, dtype=wp.vec3, device=DEVICE)
    flags = np.ones(n, np.int32) if flags is None else np.asarray(flags, np.int32)
    wp.launch(cylinder_push_out, dim=n, device=DEVICE, inputs=[
        x, v, wp.array(np.full(n, mass, np.float32), dtype=wp.float32, device=DEVICE),
        wp.array(np.full(n, damping, np.float32), dtype=wp.float32, device=DEVICE),
        wp.array(flags, dtype=wp.int32, device=DEVICE),
        wp.array(np.array([p0, p1, [r, 0, 0]], np.float32), dtype=wp.vec3, device=DEVICE),
        float(h), wp.zeros(0, dtype=wp.vec3, device=DEVICE), force, count, psum])
    return x.numpy(), v.numpy(), force.numpy()[0], int(count.numpy()[0]), psum.numpy()[0]


def test_push_out_to_surface_and_reaction():
    m, D, h, r = 2.0, 3.0, 0.01, 0.5
    pts = [[0.1, 0.2, 1.0], [0.0, 0.0, 0.5], [2.0, 0, 1.0]]
    x, v, force, count, psum = push(pts, m, D, [0, 0, 0], [0, 0, 2], r, h)
    assert count == 2
    np.testing.assert_allclose(psum, [0.1, 0.2, 1.5], rtol=1e-6)
    # radial push to distance r, axial coordinate kept
    np.testing.assert_allclose(np.hypot(x[0, 0], x[0, 1]), r, rtol=1e-6)
    np.testing.assert_allclose(x[0, :2] / np.linalg.norm(x[0, :2]), np.array([0.1, 0.2]) / np.hypot(0.1, 0.2),
                               rtol=1e-6)
    assert x[0, 2] == pytest.approx(1.0)
    # on the axis (d = 0): a defined perpendicular direction, finite
    assert np.all(np.isfinite(x[1])) and np.hypot(x[1, 0], x[1, 1]) == pytest.approx(r, rel=1e-6)
    np.testing.assert_array_equal(x[2], [2.0, 0, 1.0])
    dx = x[:2] - np.asarray(pts[:2], np.float32)
    np.testing.assert_allclose(v[:2], dx / h, rtol=1e-5)
    np.testing.assert_allclose(force, -(m + h * D) * dx.sum(axis=0) / h**2, rtol=1e-5)


def test_pinned_nodes_counted_not_moved():
    x, v, force, count, _ = push([[0.1, 0, 1.0]], 1.0, 0.0, [0, 0, 0], [0, 0, 2], 0.5, 0.01, flags=[3])
    assert count == 1 and np.all(force == 0)
    np.testing.assert_allclose(x[0], [0.1, 0, 1.0])


def test_held_contact_reaction_equals_spring_force_whatever_the_damping():
    # node 1 is held by a fixed vertical tool against a spring pulling it toward node 0
    k, L0, r = 100.0, 0.05, 0.01
    for D in (0.0, 3.0):
        model = TissueModel.from_arrays([[0, 0, 0], [0.1, 0, 0]], [[0, 1]], 1e-3, pinned=[0],
                                        stiffness=k, damping=D, rest_lengths=[L0])
        sim = Simulator(model, dt=1e-3, gravity=None, device=DEVICE)
        tool = Tool([0.1 - r - 1e-3, 0, -0.01], [0.1 - r - 1e-3, 0, 0.01], r)
        sim.step(3000, tool=tool)
        x1 = sim.positions[1]
        stretch = np.linalg.norm(x1) - L0
        # the spring drags the node (and so the tool) toward node 0 with force k * stretch
        # the reaction is I dx / h^2 with dx ~ 1 mm, the difference of float32 coordinates near
        # 0.1 m (half an ulp, 3.7e-9 m, each): a few 1e-6 relative, hence 2e-5
        np.testing.assert_allclose(sim.tool_force, [-k * stretch, 0, 0], rtol=2e-5, atol=1e-6)
        assert x1[0] == pytest.approx(0.1 - 1e-3, abs=1e-6)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_axis_distance_is_the_distance_to_the_axis_line(seed):
    """Points built at known distances from a tilted axis (beyond its ends too: the line, not
    the segment), and from p0 when p0 = p1."""
    rng = np.random.default_rng(seed)
    p0 = rng.uniform(-0.01, 0.01, 3)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    side = np.cross(axis, rng.normal(size=3))
    side /= np.linalg.norm(side)
    along, gap = rng.uniform(-0.05, 0.08, 20), rng.uniform(0.0, 0.01, 20)
    points = p0 + along[:, None] * axis + gap[:, None] * side
    tool = Tool(p0=p0, p1=p0 + 0.03 * axis, radius=0.001)
    np.testing.assert_allclose(axis_distance(points, tool), gap, atol=1e-12)
    at_a_point = Tool(p0=p0, p1=p0, radius=0.001)
    np.testing.assert_allclose(axis_distance(points, at_a_point), np.linalg.norm(points - p0, axis=1), atol=1e-12)


def test_tool_starting_inside_is_rejected():
    model = TissueModel.from_patch((0.02, 0.02), 0.002)
    sim = Simulator(model, device=DEVICE)
    with pytest.raises(ToolStartsInside, match="starts inside"):
        sim.step(tool=Tool([0, 0, -0.01], [0, 0, 0.01], 0.002))
