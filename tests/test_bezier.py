"""Tests for warp_cut.cut.curve.bezier (paper stage 2, Eqs. 5-8) against independent answers."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.cut.curve.bezier import (
    BEZIER_MATRIX,
    BezierChain,
    bernstein,
    cubic_basis,
    derivative_cubic,
    evaluate_cubic,
    fit_chain,
)

RNG = np.random.default_rng(20210)


# ---------------------------------------------------------------- independent references
def de_casteljau(control, a):
    """Points of one cubic by repeated linear interpolation (no Bernstein, no matrix)."""
    pts = np.repeat(np.asarray(control, float)[None], len(a), axis=0)
    a = np.asarray(a, float)[:, None, None]
    while pts.shape[1] > 1:
        pts = (1 - a) * pts[:, :-1] + a * pts[:, 1:]
    return pts[:, 0]


def dense_polyline(chain, per_segment=400):
    a = np.linspace(0.0, 1.0, per_segment + 1)
    return np.concatenate([de_casteljau(c, a)[: None if i == len(chain.controls) - 1 else -1]
                           for i, c in enumerate(chain.controls)])


def distance_to_polyline(points, poly):
    """Exact distance of each point to a polyline (segment projection)."""
    a, b = poly[:-1], poly[1:]
    ab = b - a
    out = np.empty(len(points))
    for i, x in enumerate(points):
        t = np.clip(((x - a) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-300), 0.0, 1.0)
        out[i] = np.sqrt((((a + t[:, None] * ab) - x) ** 2).sum(1)).min()
    return out


def curve_distance(points, chain, coarse=32, fine=1000):
    """Distance of points to a chain, independent of the library: around the three nearest
    vertices of a coarse de Casteljau sampling, a window of +-2 coarse steps is resampled
    finely; the distance to that fine polyline is within ``sag`` = max|P''| h^2 / 8 of the
    true distance (returned with it)."""
    s, c = chain.segment_count, chain.controls

    def at(u):
        seg = np.minimum(np.floor(u).astype(int), s - 1)
        out = np.empty(u.shape + (3,))
        for i in range(s):
            m = seg == i
            out[m] = de_casteljau(c[i], u[m] - i)
        return out

    u_c = np.linspace(0.0, s, s * coarse + 1)
    near = np.argsort(((points[:, None] - at(u_c)[None]) ** 2).sum(-1), axis=1)[:, :3]
    best = np.full(len(points), np.inf)
    for k in near.T:
        lo, hi = np.clip(u_c[k] - 2.0 / coarse, 0, s), np.clip(u_c[k] + 2.0 / coarse, 0, s)
        poly = at(lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, fine))  # (m, fine, 3)
        a, ab = poly[:, :-1], np.diff(poly, axis=1)
        x = points[:, None]
        t = np.clip(((x - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0.0, 1.0)
        best = np.minimum(best, np.sqrt(((a + t[..., None] * ab - x) ** 2).sum(-1)).min(1))
    acc = 6.0 * np.maximum(np.linalg.norm(c[:, 0] - 2 * c[:, 1] + c[:, 2], axis=1),
                           np.linalg.norm(c[:, 1] - 2 * c[:, 2] + c[:, 3], axis=1)).max()
    return best, acc * (4.0 / coarse / (fine - 1)) ** 2 / 8.0 + 1e-15


def join_derivatives(chain):
    """(left, right) first derivatives at every join, from the controls (B'(1), B'(0))."""
    c = chain.controls
    return 3.0 * (c[:-1, 3] - c[:-1, 2]), 3.0 * (c[1:, 1] - c[1:, 0])


def assert_c1(chain, rel=1e-9):
    left, right = join_derivatives(chain)
    if len(left):
        scale = np.maximum(np.linalg.norm(left, axis=1), 1e-300)
        assert np.all(np.linalg.norm(left - right, axis=1) <= rel * scale)
        # and the library's evaluation agrees just either side of each join
        u = np.arange(1, chain.segment_count, dtype=float)
        d_minus = chain.derivative(u - 1e-7)
        np.testing.assert_allclose(d_minus, left, rtol=0, atol=1e-5 * scale.max())


def assert_fit(path, chain, tol):
    np.testing.assert_array_equal(chain.evaluate([0.0])[0], path[0])
    np.testing.assert_array_equal(chain.evaluate([float(chain.segment_count)])[0], path[-1])
    np.testing.assert_array_equal(chain.controls[0, 0], path[0])
    np.testing.assert_array_equal(chain.controls[-1, 3], path[-1])
    d, sag = curve_distance(path, chain)
    assert np.all(d <= tol * (1 + 1e-6) + sag), (d.max(), tol, sag)
    assert_c1(chain)


# ---------------------------------------------------------------- Eqs. 6-8
def test_matrix_constant_eq8():
    expected = [[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 3, 0, 0], [1, 0, 0, 0]]
    np.testing.assert_array_equal(BEZIER_MATRIX, expected)
    assert BEZIER_MATRIX.shape == (4, 4) and BEZIER_MATRIX.dtype == np.float64


def test_basis_hand_values_eq7():
    a = np.array([0, 1 / 3, 1 / 2, 2 / 3, 1])
    expected = np.array([[1, 0, 0, 0],
                         [8 / 27, 12 / 27, 6 / 27, 1 / 27],
                         [1 / 8, 3 / 8, 3 / 8, 1 / 8],
                         [1 / 27, 6 / 27, 12 / 27, 8 / 27],
                         [0, 0, 0, 1]])
    np.testing.assert_allclose(cubic_basis(a), expected, rtol=0, atol=1e-15)
    for k in range(4):  # Eq. 6 with n = 3 is Eq. 7
        np.testing.assert_allclose(bernstein(k, 3, a), expected[:, k], rtol=0, atol=1e-15)


@given(st.floats(0.0, 1.0))
def test_partition_of_unity(a):
    assert abs(cubic_basis([a]).sum() - 1.0) < 1e-14
    assert abs(sum(bernstein(k, 7, a) for k in range(8)) - 1.0) < 1e-13
    assert np.all(cubic_basis([a]) >= 0.0)


def test_basis_maximum_at_k_over_3():
    a = np.linspace(0.0, 1.0, 30001)
    b = cubic_basis(a)
    for k in range(4):
        assert abs(a[np.argmax(b[:, k])] - k / 3) <= 1e-4


def test_bernstein_general_and_errors():
    a = RNG.random(20)
    np.testing.assert_allclose(bernstein(2, 5, a), 10 * a**2 * (1 - a) ** 3, rtol=1e-14)
    for k, n in [(-1, 3), (4, 3), (1.5, 3)]:
        with pytest.raises(ValueError):
            bernstein(k, n, a)


def test_matrix_form_equals_bernstein_sum_and_de_casteljau():
    for _ in range(20):
        control = RNG.normal(size=(4, 3))
        a = RNG.random(50)
        eq5 = sum(bernstein(k, 3, a)[:, None] * control[k] for k in range(4))
        np.testing.assert_allclose(evaluate_cubic(control, a), eq5, rtol=0, atol=1e-13)
        np.testing.assert_allclose(evaluate_cubic(control, a), de_casteljau(control, a), atol=1e-13)


def test_endpoints_exact():
    control = RNG.normal(size=(4, 3))
    p = evaluate_cubic(control, [0.0, 1.0])
    np.testing.assert_array_equal(p[0], control[0])
    np.testing.assert_array_equal(p[1], control[3])


def test_derivative():
    control = RNG.normal(size=(4, 3))
    d = derivative_cubic(control, [0.0, 1.0])
    np.testing.assert_allclose(d[0], 3 * (control[1] - control[0]), atol=1e-14)
    np.testing.assert_allclose(d[1], 3 * (control[3] - control[2]), atol=1e-14)
    a, h = RNG.random(10) * 0.9 + 0.05, 1e-6
    fd = (de_casteljau(control, a + h) - de_casteljau(control, a - h)) / (2 * h)
    np.testing.assert_allclose(derivative_cubic(control, a), fd, atol=1e-8)


# ---------------------------------------------------------------- chain geometry
def test_arc_length_straight_and_parabola():
    p0, p3 = np.array([0.01, -0.02, 0.03]), np.array([0.05, 0.01, -0.02])
    straight = BezierChain([[p0, p0 + 0.1 * (p3 - p0), p0 + 0.8 * (p3 - p0), p3]])  # uneven speed
    assert straight.length() == pytest.approx(np.linalg.norm(p3 - p0), rel=1e-13)
    # y = x^2 on [0, 1] as a degree-elevated quadratic; length sqrt(5)/2 + asinh(2)/4.
    q0, q1, q2 = np.array([0.0, 0, 0]), np.array([0.5, 0, 0]), np.array([1.0, 1, 0])
    parab = BezierChain([[q0, q0 / 3 + 2 * q1 / 3, 2 * q1 / 3 + q2 / 3, q2]])
    assert parab.length() == pytest.approx(math.sqrt(5) / 2 + math.asinh(2) / 4, rel=1e-12)


def test_arc_length_quarter_circle():
    r, k = 0.03, 4.0 / 3.0 * math.tan(math.pi / 8)
    quarter = BezierChain([[[r, 0, 0], [r, k * r, 0], [k * r, r, 0], [0, r, 0]]])
    poly = dense_polyline(quarter, 1 << 16)
    ref = np.linalg.norm(np.diff(poly, axis=0), axis=1).sum()   # chord error ~1e-11 rel
    assert quarter.length() == pytest.approx(ref, rel=1e-9)
    # the classic k = 4/3 tan(pi/8) quarter circle is ~1.4e-4 too long (radial error 2.7e-4)
    assert quarter.length() == pytest.approx(math.pi * r / 2, rel=3e-4)
    # a tightly fitted chain of a 3/4 circle matches the analytic arc length
    th = np.linspace(0.0, 1.5 * math.pi, 120)
    chain = fit_chain(np.c_[r * np.cos(th), r * np.sin(th), np.zeros_like(th)], 1e-8)
    assert chain.length() == pytest.approx(1.5 * math.pi * r, rel=1e-6)


def test_closest_point_straight_chain():
    a, b = np.array([0.0, 0.0, 0.0]), np.array([0.04, 0.02, -0.01])
    chain = BezierChain([[a, a + 0.2 * (b - a), a + 0.4 * (b - a), a + 0.5 * (b - a)],
                         [a + 0.5 * (b - a), a + 0.6 * (b - a), a + 0.9 * (b - a), b]])
    x = RNG.normal(scale=0.03, size=(200, 3)) + 0.5 * (a + b)
    t = np.clip((x - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    proj = a + t[:, None] * (b - a)
    params, pts, dist = chain.closest_point(x)
    np.testing.assert_allclose(pts, proj, atol=1e-12)
    np.testing.assert_allclose(dist, np.linalg.norm(x - proj, axis=1), atol=1e-12)
    np.testing.assert_allclose(chain.evaluate(params), pts, atol=0)
    assert np.all((params >= 0) & (params <= 2))


def test_closest_point_curved_vs_brute_force():
    th = np.linspace(0, 2.0, 40)
    chain = fit_chain(np.c_[0.02 * np.cos(th), 0.02 * np.sin(th), 0.002 * th], 1e-6)
    x = RNG.normal(scale=0.01, size=(100, 3)) + [0.01, 0.01, 0.002]
    params, pts, dist = chain.closest_point(x)
    samples = dense_polyline(chain, 2000)          # points on the curve: an upper bound
    assert np.all(dist <= np.sqrt(((x[:, None] - samples[None]) ** 2).sum(-1)).min(1) + 1e-15)
    d_ref, sag = curve_distance(x, chain)          # fine polyline: within sag of the truth
    assert np.all(np.abs(dist - d_ref) <= sag + 1e-13)
    np.testing.assert_allclose(np.linalg.norm(chain.evaluate(params) - x, axis=1), dist, atol=0)


def test_sampling_and_flat_controls():
    a, b = np.zeros(3), np.array([0.03, 0.0, 0.04])   # length 0.05
    chain = BezierChain([[a, a + 0.05 * (b - a), a + 0.3 * (b - a), a + 0.5 * (b - a)],
                         [a + 0.5 * (b - a), a + 0.7 * (b - a), a + 0.95 * (b - a), b]])
    pts, tans = chain.sample_by_arclength(0.004)
    s = np.linalg.norm(pts - a, axis=1)
    np.testing.assert_allclose(s[:-1], 0.004 * np.arange(len(s) - 1), atol=1e-13)
    assert s[-1] == pytest.approx(0.05, abs=1e-15)
    np.testing.assert_allclose(tans, np.tile((b - a) / 0.05, (len(s), 1)), atol=1e-12)
    pts, tans = chain.sample(7)
    assert pts.shape == tans.shape == (7, 3)
    np.testing.assert_array_equal(pts[[0, -1]], [a, b])
    flat = chain.control_points_flat()
    assert flat.shape == (7, 3)
    np.testing.assert_array_equal(flat[3], chain.controls[0, 3])
    back = BezierChain.from_control_points_flat(flat)
    np.testing.assert_array_equal(back.controls, chain.controls)


# ---------------------------------------------------------------- fitting
def test_fit_straight_line():
    t = np.sort(RNG.random(30)) ** 2
    d = np.array([1.0, -2.0, 0.5]) / math.sqrt(5.25)
    path = np.array([0.01, 0.02, 0.0]) + 0.05 * t[:, None] * d
    path = np.vstack([[0.01, 0.02, 0.0], path, path[-1] + 0.01 * d])
    chain = fit_chain(path, 1e-6)
    assert_fit(path, chain, 1e-6)
    rel = chain.control_points_flat() - path[0]
    off_line = rel - (rel @ d)[:, None] * d
    assert np.abs(off_line).max() < 1e-12


def test_fit_recovers_known_cubic():
    control = np.array([[0.0, 0, 0], [0.01, 0.03, 0], [0.04, -0.01, 0.01], [0.05, 0.02, 0.0]])
    a = np.sort(np.r_[0.0, RNG.random(60), 1.0]) ** 1.3                       # uneven sampling
    path = de_casteljau(control, a)
    chain = fit_chain(path, 1e-7)
    assert_fit(path, chain, 1e-7)
    truth = de_casteljau(control, np.linspace(0, 1, 4001))
    assert distance_to_polyline(dense_polyline(chain, 50)[::5], truth).max() < 1e-6
    loose = fit_chain(path, 1e-5)
    assert loose.segment_count == 1
    assert_fit(path, loose, 1e-5)


@pytest.mark.parametrize("tol", [1e-4, 1e-6])
def test_fit_circle_arc_and_sine(tol):
    th = np.linspace(0.0, 2.5, 80)
    arc = np.c_[0.02 * np.cos(th), 0.02 * np.sin(th), 0.001 * th]
    assert_fit(arc, fit_chain(arc, tol), tol)
    x = np.linspace(0.0, 0.1, 200)
    sine = np.c_[x, 0.01 * np.sin(60.0 * x), 0.002 * np.cos(30.0 * x)]
    chain = fit_chain(sine, tol)
    assert_fit(sine, chain, tol)
    assert chain.segment_count < 40


@st.composite
def smooth_walks(draw):
    n = draw(st.integers(3, 40))
    seed = draw(st.integers(0, 2**32 - 1))
    max_turn = draw(st.floats(0.0, 0.6))
    rng = np.random.default_rng(seed)
    d, pts = np.array([1.0, 0.0, 0.0]), [rng.normal(scale=0.05, size=3)]
    for _ in range(n - 1):
        axis = rng.normal(size=3)
        axis -= axis @ d * d
        axis /= np.linalg.norm(axis)
        ang = rng.uniform(0.0, max_turn)
        d = math.cos(ang) * d + math.sin(ang) * axis
        pts.append(pts[-1] + d * rng.uniform(2e-4, 2e-3))
    return np.array(pts), draw(st.sampled_from([1e-6, 1e-5, 1e-4]))


@settings(max_examples=25, deadline=None)
@given(smooth_walks())
def test_fit_random_smooth_paths(case):
    path, tol = case
    chain = fit_chain(path, tol)
    assert_fit(path, chain, tol)
    assert chain.length() <= 1.3 * np.linalg.norm(np.diff(path, axis=0), axis=1).sum() + 2 * tol


# ---------------------------------------------------------------- degenerate input
def test_degenerate_single_and_coincident_points():
    p = np.array([[0.01, 0.02, 0.03]])
    for path in (p, np.repeat(p, 5, axis=0)):
        chain = fit_chain(path, 1e-5)
        assert chain.segment_count == 1
        np.testing.assert_array_equal(chain.controls[0], np.repeat(p, 4, axis=0))
        assert chain.length() == 0.0
        np.testing.assert_array_equal(chain.sample_by_arclength(1e-3)[0], p)


def test_degenerate_two_points_and_duplicates():
    a, b = np.array([0.0, 0.01, 0.0]), np.array([0.03, 0.01, 0.04])
    chain = fit_chain([a, b], 1e-5)
    np.testing.assert_allclose(chain.controls[0], [a, a + (b - a) / 3, a + 2 * (b - a) / 3, b],
                               atol=1e-16)
    np.testing.assert_array_equal(chain.controls[0, 3], b)
    assert fit_chain([a, a, b, b, b], 1e-5).controls.tolist() == chain.controls.tolist()
    th = np.linspace(0, 1.5, 30)
    arc = np.c_[0.02 * np.cos(th), 0.02 * np.sin(th), np.zeros(30)]
    dup = np.repeat(arc, RNG.integers(1, 4, size=30), axis=0)
    np.testing.assert_allclose(fit_chain(dup, 1e-6).controls, fit_chain(arc, 1e-6).controls,
                               atol=1e-15)
    assert_fit(dup, fit_chain(dup, 1e-6), 1e-6)


def test_collinear_with_backtracking():
    x = np.array([0.0, 0.01, 0.02, 0.015, 0.03, 0.04])
    path = np.c_[x, 2 * x, -x]
    chain = fit_chain(path, 1e-6)
    assert_fit(path, chain, 1e-6)


@pytest.mark.parametrize("path, tol", [
    (np.array([[0.0, 0, 0], [np.nan, 0, 0]]), 1e-3),
    (np.array([[0.0, 0, 0], [np.inf, 0, 0]]), 1e-3),
    (np.zeros((4, 2)), 1e-3),
    (np.zeros(3), 1e-3),
    (np.zeros((0, 3)), 1e-3),
    (np.zeros((3, 3)), 0.0),
    (np.zeros((3, 3)), -1e-3),
    (np.zeros((3, 3)), float("nan")),
])
def test_fit_rejects_bad_input(path, tol):
    with pytest.raises(ValueError):
        fit_chain(path, tol)


def test_other_value_errors():
    with pytest.raises(ValueError):
        evaluate_cubic(np.zeros((3, 3)), [0.5])
    with pytest.raises(ValueError):
        evaluate_cubic(np.zeros((4, 3)), [np.nan])
    with pytest.raises(ValueError):
        BezierChain(np.zeros((2, 3, 3)))
    chain = BezierChain(np.zeros((1, 4, 3)))
    with pytest.raises(ValueError):
        chain.evaluate([1.5])
    with pytest.raises(ValueError):
        fit_chain(np.zeros((3, 3)), 1e-3, max_segments=0)
    with pytest.raises(RuntimeError):
        th = np.linspace(0, 6, 200)
        fit_chain(np.c_[np.cos(th), np.sin(th), 0 * th], 1e-12, max_segments=3)
