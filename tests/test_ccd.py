"""Continuous collision detection against closed-form contact times and an independent search."""

import math

import numpy as np
import pytest
import warp as wp
from conftest import DEVICE

from warp_cut import Material, Simulator, TissueModel, Tool, ToolPath, cylinder_contacts
from warp_cut.kernels.ccd import quartic_roots, vec5d
from warp_cut.sim.ccd import swept_first_contact


# ------------------------------------------------------------------ closed forms
@pytest.mark.parametrize("y", [0.0, 0.0003, -0.0006, 0.0009])
def test_descending_tool_meets_static_node_at_closed_form_time(y):
    # horizontal axis at height h(t) = h0 - s t above a node offset by y across the axis:
    # the distance to the axis sqrt(y^2 + h^2) reaches r at t = (h0 - sqrt(r^2 - y^2)) / s
    r, h0, s, T = 0.001, 0.004, 0.01, 0.5
    start = Tool([-0.01, 0, h0], [0.01, 0, h0], r)
    end = Tool([-0.01, 0, h0 - s * T], [0.01, 0, h0 - s * T], r)
    y = float(np.float32(y))  # node positions are float32 on the device
    hit = swept_first_contact([[0.002, y, 0.0]], start, end, interval=T, t_start=1.0, device=DEVICE)
    expected = 1.0 + (h0 - math.sqrt(r * r - y * y)) / s
    assert hit is not None and hit.node == 0 and hit.node_count == 1
    assert hit.time == pytest.approx(expected, abs=1e-9)
    assert hit.point == pytest.approx([0.002, y, 0.0], abs=1e-9)


def test_node_outside_the_radius_is_never_reached():
    r = 0.001
    start = Tool([-0.01, 0, 0.004], [0.01, 0, 0.004], r)
    end = Tool([-0.01, 0, -0.004], [0.01, 0, -0.004], r)
    assert swept_first_contact([[0.0, 0.0011, 0.0]], start, end, device=DEVICE) is None
    # beyond the end cap: the node never projects onto the segment
    assert swept_first_contact([[0.0101, 0.0, 0.0]], start, end, device=DEVICE) is None


@pytest.mark.parametrize("angle_deg", [30, 50, 70])
def test_tool_sliding_along_its_axis_enters_through_the_tip_cap(angle_deg):
    # axis a at angle theta above the plane, tip moving along -a at speed s; a node at
    # distance d < r from the axis line is reached when the tip's axial coordinate passes it
    th = math.radians(angle_deg)
    a = np.array([math.cos(th), 0.0, math.sin(th)])
    r, L, s, T = 0.001, 0.04, 0.01, 1.0
    node = np.array([0.0005, 0.0004, 0.0], dtype=np.float32).astype(np.float64)
    tip0 = 0.006 * a
    hit = swept_first_contact([node], Tool(tip0, tip0 + L * a, r),
                              Tool(tip0 - s * T * a, tip0 - s * T * a + L * a, r), interval=T, device=DEVICE)
    assert np.linalg.norm(node - a * node.dot(a)) < r  # within reach
    assert hit.time == pytest.approx((0.006 - node.dot(a)) / s, abs=1e-9)


def test_rotating_tool_closed_form():
    # p0 fixed at the origin, p1 moving linearly (L,0,0) -> (0,L,0); node N = (x, y, 0):
    # |N x u|^2 = r^2 |u|^2 gives ((x + y) t - y)^2 = r^2 (2 t^2 - 2 t + 1)
    L, x, y, r = 1.0, 0.5, 0.25, 0.0625  # exact in float32
    hit = swept_first_contact([[x, y, 0.0]], Tool([0, 0, 0], [L, 0, 0], r),
                              Tool([0, 0, 0], [0, L, 0], r), device=DEVICE)
    A, B, C = (x + y) ** 2 - 2 * r * r, -2 * (x + y) * y + 2 * r * r, y * y - r * r
    first = min(t for t in np.roots([A, B, C]).real if 0 <= t <= 1)
    assert hit.tau == pytest.approx(first, abs=1e-12)


# ------------------------------------------------------------------ special cases
def test_node_inside_at_start_is_reached_at_tau_zero_and_inactive_nodes_are_skipped():
    tool = Tool([-0.01, 0, 0], [0.01, 0, 0], 0.001)
    assert swept_first_contact([[0, 0, 0]], tool, tool, device=DEVICE).tau == 0.0
    assert swept_first_contact([[0, 0, 0]], tool, tool, active=[False], device=DEVICE) is None
    assert swept_first_contact([[0, 0, 0]], tool, Tool(tool.p0, tool.p1, 0.0), device=DEVICE) is None


def test_fast_tool_passing_between_two_steps_is_caught():
    # the tool crosses the node completely within one step: both end poses miss it
    r = 0.001
    start = Tool([-0.01, -0.01, 0], [0.01, -0.01, 0], r)
    end = Tool([-0.01, 0.01, 0], [0.01, 0.01, 0], r)
    node = np.array([[0.0, 0.0, 0.0]])
    assert not cylinder_contacts(node, start.p0, start.p1, r, DEVICE).any()
    assert not cylinder_contacts(node, end.p0, end.p1, r, DEVICE).any()
    hit = swept_first_contact(node, start, end, interval=1e-3, device=DEVICE)
    assert hit.tau == pytest.approx((0.01 - r) / 0.02, abs=1e-12)


def test_simultaneous_nodes_are_reported_together():
    # the axis runs along y above x = 3 mm; nodes 0 and 2 mirror each other across it
    r, h0 = 0.001, 0.003
    start = Tool([0.003, -0.01, h0], [0.003, 0.01, h0], r)
    end = Tool([0.003, -0.01, -h0], [0.003, 0.01, -h0], r)
    pts = [[0.003, 0.0005, 0], [0.0, 0.0, 0.0], [0.003, -0.0005, 0]]
    hit = swept_first_contact(pts, start, end, device=DEVICE)
    assert hit.node == 0 and hit.node_count == 2
    assert hit.point == pytest.approx([0.003, 0.0, 0.0], abs=1e-9)
    assert hit.tau == pytest.approx((h0 - r) / (2 * h0), abs=1e-12)


# ------------------------------------------------------------------ independent search
def _inside(q, u, r):
    """The paper's test for rows of relative positions q and axes u, float64."""
    uu = np.einsum("ij,ij->i", u, u)
    qu = np.einsum("ij,ij->i", q, u)
    c = np.cross(q, u)
    return (qu >= 0) & (qu <= uu) & (np.einsum("ij,ij->i", c, c) < r * r * uu)


def _brute_first_entry(x, v, p0a, p1a, p0b, p1b, r, samples):
    """First tau by dense sampling, refined by bisection on the predicate (None if unseen)."""
    t = np.linspace(0.0, 1.0, samples)[:, None]
    q = x + t * v - (p0a + t * (p0b - p0a))
    u = p1a + t * (p1b - p1a) - (p0a + t * (p0b - p0a))
    hit = np.flatnonzero(_inside(q, u, r))
    if len(hit) == 0:
        return None
    k = hit[0]
    if k == 0:
        return 0.0
    lo, hi = t[k - 1, 0], t[k, 0]
    for _ in range(60):
        m = 0.5 * (lo + hi)
        tm = np.array([[m]])
        qm = x + tm * v - (p0a + tm * (p0b - p0a))
        um = p1a + tm * (p1b - p1a) - (p0a + tm * (p0b - p0a))
        lo, hi = (lo, m) if _inside(qm, um, r)[0] else (m, hi)
    return hi


def _inside_near(x, v, p0a, p1a, p0b, p1b, r, tau, width, samples=2001):
    """Whether the float64 predicate holds anywhere in [tau - width, tau + width]."""
    t = np.clip(np.linspace(tau - width, tau + width, samples), 0.0, 1.0)[:, None]
    q = x + t * v - (p0a + t * (p0b - p0a))
    u = p1a + t * (p1b - p1a) - (p0a + t * (p0b - p0a))
    return bool(_inside(q, u, r).any())


def test_rotating_and_moving_cases_match_an_independent_search(rng):
    samples = 20_001
    contacts = misses = 0
    for _ in range(100):
        p0a = rng.uniform(-0.01, 0.01, 3)
        p1a = p0a + rng.normal(size=3) * 0.02
        p0b = p0a + rng.normal(size=3) * 0.008
        p1b = p1a + rng.normal(size=3) * 0.015
        r = rng.uniform(0.0005, 0.003)
        x = (0.5 * (p0a + p1b) + rng.normal(size=3) * 0.004).astype(np.float32).astype(np.float64)
        v = (rng.normal(size=3) * 0.004).astype(np.float32).astype(np.float64)
        hit = swept_first_contact([x], Tool(p0a, p1a, r), Tool(p0b, p1b, r), velocities=[v],
                                  device=DEVICE)
        brute = _brute_first_entry(x, v, p0a, p1a, p0b, p1b, r, samples)
        if brute is None:
            # no sample inside: the search finds no contact, unless one lasts less than a
            # sampling step; a reported contact must then be real, within a step of its tau
            misses += 1
            assert hit is None or _inside_near(x, v, p0a, p1a, p0b, p1b, r, hit.tau,
                                               1.0 / (samples - 1)), hit
            continue
        contacts += 1
        assert hit is not None and hit.tau == pytest.approx(brute, abs=1e-9)
    # both branches are exercised by this seed (the random poses give either)
    assert contacts >= 15 and misses >= 15, (contacts, misses)


# ------------------------------------------------------------------ kernel level
@wp.kernel
def _quartic_kernel(coeffs: wp.array(dtype=vec5d), roots: wp.array(dtype=vec5d)):
    i = wp.tid()
    roots[i] = quartic_roots(coeffs[i])


def test_quartic_roots_in_unit_interval():
    cases = [[0.1, 0.35, 0.6, 0.9], [0.2, 0.5, 1.5, -0.3], [0.45, 0.45, 0.7, 2.0]]
    # a double root touches zero without a sign change: rounding may or may not show it
    polys = [np.polynomial.polynomial.polyfromroots(c) for c in cases]
    polys.append(np.array([1.0, 0.0, 1.0, 0.0, 0.0]))  # 1 + t^2: no real root
    coeffs = wp.array(np.array(polys, dtype=np.float64), dtype=vec5d, device=DEVICE)
    out = wp.zeros(len(polys), dtype=vec5d, device=DEVICE)
    wp.launch(_quartic_kernel, dim=len(polys), inputs=[coeffs, out], device=DEVICE)
    got = out.numpy()
    assert got[0][:4] == pytest.approx([0.1, 0.35, 0.6, 0.9], abs=1e-12)
    assert got[1][:2] == pytest.approx([0.2, 0.5], abs=1e-12) and np.all(got[1][2:] > 1)
    found = got[2][got[2] <= 1]
    assert np.any(np.abs(found - 0.7) < 1e-12)
    assert np.all((np.abs(found - 0.45) < 1e-6) | (np.abs(found - 0.7) < 1e-12))
    assert np.all(got[3] > 1)


# ------------------------------------------------------------------ simulator hook
def test_simulator_reports_exact_first_contact_on_a_patch():
    # gravity off: the patch stays flat; a horizontal tool descends at speed s onto the row
    # of nodes at y = 0; contact when the axis height equals r
    model = TissueModel.from_patch((0.02, 0.02), 0.002, material=Material(), pinned="border")
    assert np.any(np.abs(model.points[:, 1]) < 1e-12)
    r, h0, s = 0.001, 0.00431, 0.02
    path = ToolPath([0.0, 1.0], [[-0.004, 0, h0], [-0.004, 0, h0 - s]],
                    [[0.004, 0, h0], [0.004, 0, h0 - s]], r)
    sim = Simulator(model, dt=1e-3, gravity=None, residual_stress=False, device=DEVICE)
    sim.step(200, tool=path)
    exact = (h0 - r) / s
    assert sim.contacts.first_time_exact == pytest.approx(exact, abs=1e-9)
    # the per-step test sees it at the end of the step holding the exact time
    assert sim.contacts.first_time == pytest.approx(math.ceil(exact / 1e-3) * 1e-3, abs=1e-12)
    assert sim.contacts.first_point_exact[2] == pytest.approx(0.0, abs=1e-9)
    assert abs(sim.contacts.first_point_exact[1]) < 1e-9


def test_simulator_catches_a_tool_the_per_step_test_misses():
    model = TissueModel.from_patch((0.02, 0.02), 0.002, material=Material(), pinned="border")
    r = 0.0005
    # a thin tool sweeps across the whole patch within one step (40 m/s), 0.2 mm below its
    # surface: both ends of the step leave it clear of every node
    path = ToolPath([0.0, 1e-3], [[-0.03, -0.012, -0.0002], [-0.03, 0.028, -0.0002]],
                    [[0.03, -0.012, -0.0002], [0.03, 0.028, -0.0002]], r)
    path_start_clear = Tool(path.p0[0], path.p1[0], r)
    assert not cylinder_contacts(model.points, path_start_clear.p0, path_start_clear.p1, r, DEVICE).any()
    sim = Simulator(model, dt=1e-3, gravity=None, residual_stress=False, device=DEVICE)
    sim.step(3, tool=path)
    assert sim.contacts.first_time is None
    assert sim.contacts.first_time_exact is not None and 0 < sim.contacts.first_time_exact < 1e-3
