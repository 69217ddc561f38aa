"""Cubic Bezier incision curves (Zhang et al. 2021, stage 2, Eqs. 5-8).

The incision left by the tool is a C1 chain of cubic Bezier segments fitted to the tool's
contact path.  Points are in metres (SI), arrays are float64.  A chain of ``s`` segments
uses the global parameter ``u`` in ``[0, s]``: segment ``i`` covers ``[i, i + 1]`` with
local parameter ``a = u - i`` in ``[0, 1]``.  Evaluation uses the matrix form of Eq. 8,
``P(a) = [a^3 a^2 a 1] M [P0; P1; P2; P3]``.  C1 means equal first derivatives dP/du at
every join, i.e. equal handle vectors ``P3 - P2`` (left) and ``Q1 - Q0`` (right).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["BEZIER_MATRIX", "bernstein", "cubic_basis", "evaluate_cubic",
           "derivative_cubic", "BezierChain", "fit_chain"]

#: Eq. 8 basis matrix M, shape (4, 4): P(a) = [a^3, a^2, a, 1] @ M @ [P0; P1; P2; P3].
BEZIER_MATRIX = np.array([[-1.0, 3.0, -3.0, 1.0],
                          [3.0, -6.0, 3.0, 0.0],
                          [-3.0, 3.0, 0.0, 0.0],
                          [1.0, 0.0, 0.0, 0.0]])
BEZIER_MATRIX.setflags(write=False)

_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)   # nodes/weights on [-1, 1]
_SAMPLES_PER_SEGMENT = 16                             # closest_point / length-table density


def _as_params(a, name="a"):
    a = np.asarray(a, dtype=np.float64)
    if a.ndim > 1:
        raise ValueError(f"{name} must be a scalar or 1-D array, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or inf")
    return np.atleast_1d(a)


def _as_points(p, name):
    p = np.asarray(p, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 1:
        raise ValueError(f"{name} must have shape (n, 3) with n >= 1, got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} contains NaN or inf")
    return p


def _as_control(control):
    c = np.asarray(control, dtype=np.float64)
    if c.shape != (4, 3):
        raise ValueError(f"control must have shape (4, 3), got {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValueError("control contains NaN or inf")
    return c


_POW_COEF = np.array([[1.0, 1, 1, 1], [3, 2, 1, 0], [6, 2, 0, 0]])
_POW_EXP = np.array([[3, 2, 1, 0], [2, 1, 0, 0], [1, 0, 0, 0]])


def _power_rows(a, order=0):
    """Rows of d^order/da^order [a^3, a^2, a, 1] (order 0..2), shape a.shape + (4,)."""
    return _POW_COEF[order] * np.asarray(a)[..., None] ** _POW_EXP[order]


def bernstein(k, n, a):
    """Eq. 6 Bernstein polynomial B_{k,n}(a) = C(n,k) a^k (1-a)^(n-k); ``a`` scalar or (m,)."""
    if int(k) != k or int(n) != n or not 0 <= k <= n:
        raise ValueError(f"need integers 0 <= k <= n, got k={k}, n={n}")
    a = np.asarray(a, dtype=np.float64)
    return math.comb(int(n), int(k)) * a ** int(k) * (1.0 - a) ** int(n - k)


def cubic_basis(a):
    """Eq. 7 cubic basis [B03, B13, B23, B33] at parameters ``a`` (m,) -> (m, 4)."""
    a = _as_params(a)
    b = 1.0 - a
    return np.stack([b**3, 3.0 * a * b**2, 3.0 * a**2 * b, a**3], axis=-1)


def evaluate_cubic(control, a):
    """Points P(a) (m, 3) [m] of one cubic with ``control`` (4, 3) [m] at ``a`` (m,), via Eq. 8."""
    return _power_rows(_as_params(a)) @ BEZIER_MATRIX @ _as_control(control)


def derivative_cubic(control, a):
    """dP/da (m, 3) [m per unit parameter] of one cubic at ``a`` (m,), via Eq. 8."""
    return _power_rows(_as_params(a), 1) @ BEZIER_MATRIX @ _as_control(control)


def _gauss_length(ctrls, a0, a1):
    """16-point Gauss-Legendre arc length over [a0, a1] of cubics ``ctrls`` (m,4,3) -> (m,).
    The speed uses the hodograph 3 sum_k B_{k,2}(a) (P_{k+1} - P_k), exactly 0 when the
    control points coincide."""
    half, mid = 0.5 * (a1 - a0), 0.5 * (a1 + a0)
    a = mid[:, None] + half[:, None] * _GL_X                            # (m, 16)
    w = np.stack([(1 - a) ** 2, 2 * a * (1 - a), a**2], axis=-1)        # (m, 16, 3)
    speed = np.linalg.norm(w @ (3.0 * np.diff(ctrls, axis=1)), axis=-1)
    return half * (speed @ _GL_W)


def _adaptive_length(ctrl, a0=0.0, a1=1.0, atol=None, depth=0):
    """Arc length of one cubic over [a0, a1]: recursive bisection until two 16-point
    Gauss-Legendre estimates agree to ``atol`` (1e-14 of the control polygon length)."""
    if atol is None:
        atol = 1e-14 * np.linalg.norm(np.diff(ctrl, axis=0), axis=1).sum()
    def one(lo, hi):
        return float(_gauss_length(ctrl[None], np.array([lo]), np.array([hi]))[0])
    mid = 0.5 * (a0 + a1)
    whole, halves = one(a0, a1), one(a0, mid) + one(mid, a1)
    if abs(halves - whole) <= atol or depth >= 12:
        return halves
    return (_adaptive_length(ctrl, a0, mid, atol, depth + 1)
            + _adaptive_length(ctrl, mid, a1, atol, depth + 1))


def _eval_chain(ctrl, u, order=0):
    """Eq. 8 on a chain ``ctrl`` (s, 4, 3) at global parameters ``u`` (m,) -> (m, 3)."""
    seg = np.clip(np.floor(u).astype(np.int64), 0, len(ctrl) - 1)
    return ((_power_rows(u - seg, order) @ BEZIER_MATRIX)[:, None] @ ctrl[seg])[:, 0]


def _jet(ctrl, u):
    """P, P', P'' of a chain at global params ``u`` (m,) -> (3, m, 3), Eq. 8 form."""
    seg = np.clip(np.floor(u).astype(np.int64), 0, len(ctrl) - 1)
    w = np.stack([_power_rows(u - seg, o) for o in range(3)]) @ BEZIER_MATRIX
    return (w.transpose(1, 0, 2) @ ctrl[seg]).transpose(1, 0, 2)


def _foot_newton(ctrl, u, x, lo, hi, steps):
    """Newton on (P(u) - x).P'(u) = 0 within [lo, hi]; a step is kept only if it does not
    move the point farther (1e-12 relative slack lets flat minima converge). -> (u, |P-x|^2)"""
    for _ in range(steps):
        p, d1, d2 = _jet(ctrl, u)
        r = p - x
        fu = (r * r).sum(1)
        num, den = (r * d1).sum(1), (d1 * d1).sum(1) + (r * d2).sum(1)
        un = np.clip(u - np.divide(num, den, out=np.zeros_like(num), where=den > 0), lo, hi)
        fn = ((_eval_chain(ctrl, un) - x) ** 2).sum(1)
        ok = fn <= fu * (1.0 + 1e-12)
        u, fu = np.where(ok, un, u), np.where(ok, fn, fu)
    return u, fu


class BezierChain:
    """Chain of ``s`` cubic Bezier segments, ``controls`` shape (s, 4, 3) in metres.

    Segment ``i`` has controls ``controls[i]``; consecutive segments share end points.
    """

    def __init__(self, controls):
        c = np.array(controls, dtype=np.float64)
        if c.ndim != 3 or c.shape[1:] != (4, 3) or c.shape[0] < 1:
            raise ValueError(f"controls must have shape (s, 4, 3) with s >= 1, got {c.shape}")
        if not np.all(np.isfinite(c)):
            raise ValueError("controls contain NaN or inf")
        c.setflags(write=False)
        self.controls = c

    @classmethod
    def from_control_points_flat(cls, flat):
        """Inverse of :meth:`control_points_flat`: (3s+1, 3) shared-end-point list -> chain."""
        f = _as_points(flat, "flat")
        if len(f) < 4 or (len(f) - 1) % 3:
            raise ValueError(f"flat control list needs 3s+1 >= 4 rows, got {len(f)}")
        idx = 3 * np.arange((len(f) - 1) // 3)[:, None] + np.arange(4)
        return cls(f[idx])

    @property
    def segment_count(self):
        """Number of cubic segments ``s``."""
        return self.controls.shape[0]

    def _eval(self, u, order=0):
        return _eval_chain(self.controls, u, order)

    def _global(self, u):
        u = _as_params(u, "u")
        if np.any((u < 0.0) | (u > self.segment_count)):
            raise ValueError(f"u must lie in [0, {self.segment_count}]")
        return u

    def evaluate(self, u):
        """Points (m, 3) [m] at global parameters ``u`` (m,) in [0, s]."""
        return self._eval(self._global(u))

    def derivative(self, u):
        """dP/du (m, 3) [m per unit parameter]; at a join the right segment is used (C1 => same)."""
        return self._eval(self._global(u), 1)

    def tangent(self, u):
        """Unit tangents (m, 3) at ``u`` (m,); a central chord where the speed vanishes,
        zero rows where the curve is a point."""
        u = self._global(u)
        d = self._eval(u, 1)
        weak = np.linalg.norm(d, axis=1) <= 1e-12 * np.ptp(self.controls.reshape(-1, 3), 0).max()
        d[weak] = (self._eval(np.minimum(u[weak] + 1e-6, self.segment_count))
                   - self._eval(np.maximum(u[weak] - 1e-6, 0.0)))
        n = np.linalg.norm(d, axis=1, keepdims=True)
        return np.divide(d, n, out=np.zeros_like(d), where=n > 0)

    def sample(self, count):
        """``count`` points (count, 3) and unit tangents (count, 3) uniform in ``u``."""
        if int(count) != count or count < 1:
            raise ValueError(f"count must be a positive integer, got {count}")
        u = np.linspace(0.0, self.segment_count, int(count))
        return self._eval(u), self.tangent(u)

    def segment_lengths(self):
        """Arc length [m] of each segment, shape (s,), adaptive Gauss-Legendre (~1e-13 rel)."""
        return np.array([_adaptive_length(c) for c in self.controls])

    def length(self):
        """Total arc length [m]."""
        return float(self.segment_lengths().sum())

    def _length_table(self):
        """Cumulative arc length [m] at 16 nodes per segment (Gauss-Legendre per interval)."""
        s, k = self.segment_count, _SAMPLES_PER_SEGMENT
        nodes = np.linspace(0.0, s, s * k + 1)
        seg = np.minimum(np.arange(s * k) // k, s - 1)
        sub = _gauss_length(self.controls[seg], nodes[:-1] - seg, nodes[1:] - seg)
        return nodes, seg, sub, np.concatenate([[0.0], np.cumsum(sub)])

    def param_at_arclength(self, dist):
        """Global parameters (m,) at arc-length distances ``dist`` (m,) [m] from the start."""
        dist = _as_params(dist, "dist")
        nodes, seg, sub, cum = self._length_table()
        if np.any((dist < 0) | (dist > cum[-1] * (1 + 1e-12))):
            raise ValueError(f"dist must lie in [0, {cum[-1]}]")
        i = np.clip(np.searchsorted(cum, dist, side="right") - 1, 0, len(sub) - 1)
        rem, lo, hi = dist - cum[i], nodes[i], nodes[i + 1]
        u = lo + (hi - lo) * np.divide(rem, sub[i], out=np.zeros_like(rem), where=sub[i] > 0)
        ctrl, base = self.controls[seg[i]], seg[i].astype(np.float64)
        for _ in range(5):  # Newton on L(lo -> u) - rem = 0
            f = _gauss_length(ctrl, lo - base, u - base) - rem
            sp = np.linalg.norm(self._eval(u, 1), axis=1)
            u = np.clip(u - np.divide(f, sp, out=np.zeros_like(f), where=sp > 1e-300), lo, hi)
        return u

    def sample_by_arclength(self, spacing):
        """Points (m, 3) and unit tangents (m, 3) every ``spacing`` metres, end point included."""
        if not np.isfinite(spacing) or spacing <= 0:
            raise ValueError(f"spacing must be a positive finite length, got {spacing}")
        total = self._length_table()[3][-1]
        d = np.arange(0.0, total, spacing) if total > 0 else np.zeros(1)
        if total > 0 and total - d[-1] > 1e-9 * spacing:
            d = np.append(d, total)
        u = self.param_at_arclength(d)
        u[-1] = self.segment_count if total > 0 else 0.0         # exact end point
        return self._eval(u), self.tangent(u)

    def closest_point(self, points):
        """Closest chain points to ``points`` (m, 3) [m].

        Returns ``(params (m,), closest_points (m, 3), distances (m,))``.  Dense sampling picks
        a bracket of width 2/16 in ``u``; golden-section search then Newton polish refine it.
        """
        x = _as_points(points, "points")
        s = self.segment_count
        h = 1.0 / _SAMPLES_PER_SEGMENT
        grid = np.linspace(0.0, s, s * _SAMPLES_PER_SEGMENT + 1)
        g = self._eval(grid)
        best = np.empty(len(x), dtype=np.int64)
        step = max(1, 4_000_000 // len(grid))
        for i in range(0, len(x), step):
            best[i:i + step] = np.argmin(((x[i:i + step, None] - g[None]) ** 2).sum(-1), axis=1)
        def f(u):
            return ((self._eval(u) - x) ** 2).sum(1)
        lo, hi = np.clip(grid[best] - h, 0, s), np.clip(grid[best] + h, 0, s)
        r = (math.sqrt(5.0) - 1.0) / 2.0
        c, d = hi - r * (hi - lo), lo + r * (hi - lo)
        fc, fd = f(c), f(d)
        for _ in range(60):
            left = fc < fd
            hi, lo = np.where(left, d, hi), np.where(left, lo, c)
            new = np.where(left, hi - r * (hi - lo), lo + r * (hi - lo))
            fn = f(new)
            c, d, fc, fd = (np.where(left, new, d), np.where(left, c, new),
                            np.where(left, fn, fd), np.where(left, fc, fn))
        u = np.where(f(grid[best]) < np.minimum(fc, fd), grid[best], np.where(fc < fd, c, d))
        u = _foot_newton(self.controls, u, x, 0.0, s, 4)[0]
        pts = self._eval(u)
        return u, pts, np.linalg.norm(pts - x, axis=1)

    def control_points_flat(self):
        """Shared-end-point control list (3s+1, 3) for USD ``BasisCurves`` (type cubic, bezier)."""
        return np.concatenate([self.controls[0], self.controls[1:, 1:].reshape(-1, 3)])


def _straight(p0, p1):
    c = p0 + (p1 - p0) * np.array([0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0])[:, None]
    c[0], c[3] = p0, p1     # exact end points
    return BezierChain(c[None])


def _unit_tangents(q, cum):
    """Bessel (3-point parabola, chord-length) unit tangents at every point of q (N>=3, 3)."""
    h = np.diff(cum)
    m = np.diff(q, axis=0) / h[:, None]
    w = (h[1:] / (h[:-1] + h[1:]))[:, None]
    t = np.empty_like(q)
    t[1:-1] = w * m[:-1] + (1.0 - w) * m[1:]
    t[0] = m[0] + h[0] / (h[0] + h[1]) * (m[0] - m[1])
    t[-1] = m[-1] + h[-1] / (h[-1] + h[-2]) * (m[-1] - m[-2])
    chord = np.vstack([m, m[-1:]])
    bad = (np.linalg.norm(t, axis=1) < 1e-9) | ((t * chord).sum(1) <= 0.0)
    t[bad] = chord[bad]
    return t / np.linalg.norm(t, axis=1)[:, None]


# P''(0)/6, P''(1)/6 of segment [J_i, J_i + h_i, J_i+1 - h_i+1, J_i+1] on (J_i, h_i, J_i+1, h_i+1);
# _BEND is the quadratic form of the bending energy integral_0^1 |P''(a)|^2 da on those unknowns.
_D0, _D1 = np.array([-1.0, -2.0, 1.0, -1.0]), np.array([1.0, 1.0, -1.0, 2.0])
_BEND = np.kron(12.0 * (np.outer(_D0, _D0) + 0.5 * (np.outer(_D0, _D1) + np.outer(_D1, _D0))
                        + np.outer(_D1, _D1)), np.eye(3))


def _solve_block_tridiagonal(diag, upper, rhs):
    """Block Thomas algorithm for a symmetric block-tridiagonal system (P, b, b)."""
    xu, xb = np.zeros_like(upper), np.zeros_like(rhs)
    d, r = diag[0], rhs[0]
    for p in range(len(diag) - 1):
        sol = np.linalg.solve(d, np.column_stack([upper[p], r]))
        xu[p], xb[p] = sol[:, :-1], sol[:, -1]
        d, r = diag[p + 1] - upper[p].T @ xu[p], rhs[p + 1] - upper[p].T @ xb[p]
    x = np.empty_like(rhs)
    x[-1] = np.linalg.solve(d, r)
    for p in range(len(diag) - 2, -1, -1):
        x[p] = xb[p] - xu[p] @ x[p + 1]
    return x


def _solve_chain(u, pts, metric, s, first, last, guess, bend, ridge=1e-12):
    """Least-squares C1 chain with ``s`` segments for points ``pts`` (m,3) at params ``u``.

    Unknowns per join j: the join point J_j and one handle vector h_j shared by both
    sides; segment i = [J_i, J_i + h_i, J_{i+1} - h_{i+1}, J_{i+1}], so C1 holds by
    construction and residuals are linear.  J_0 = first and J_s = last are pinned.
    ``metric`` (m,3,3) weights each residual (tangent-distance minimisation); a faint
    bending energy (``bend`` * integral |P''|^2) stops hooks and wiggles where data are
    sparse; a fainter ridge towards ``guess`` (2s+2, 3) keeps every unknown well posed.
    Each segment couples two joins, so the normal matrix is block-tridiagonal (6 x 6).
    """
    seg = np.clip(np.floor(u).astype(np.int64), 0, s - 1)
    b = cubic_basis(u - seg)
    coef = np.stack([b[:, 0] + b[:, 1], b[:, 1], b[:, 2] + b[:, 3], -b[:, 2]], axis=1)
    cc = coef[:, :, None] * coef[:, None, :]
    data = (cc[:, :, None, :, None] * metric[:, None, :, None, :]).reshape(len(u), 144)
    blocks = np.bincount((seg[:, None] * 144 + np.arange(144)).ravel(), data.ravel(),
                         minlength=s * 144).reshape(s, 12, 12) + bend * _BEND
    local = (coef[:, :, None] * (metric @ pts[:, :, None])[:, None, :, 0]).reshape(-1)
    local = np.bincount((seg[:, None] * 12 + np.arange(12)).ravel(), local,
                        minlength=s * 12).reshape(s, 12)
    diag = np.zeros((s + 1, 6, 6)) + ridge * np.eye(6)
    diag[:-1] += blocks[:, :6, :6]
    diag[1:] += blocks[:, 6:, 6:]
    upper = blocks[:, :6, 6:].copy()
    rhs = ridge * guess.reshape(s + 1, 6)
    rhs[:-1] += local[:, :6]
    rhs[1:] += local[:, 6:]
    for j, v in ((0, first), (s, last)):                        # eliminate pinned end points
        rhs[j] -= diag[j][:, :3] @ v
        diag[j][:3, :], diag[j][:, :3] = 0.0, 0.0
        if j < s:
            rhs[j + 1] -= upper[j][:3, :].T @ v
            upper[j][:3, :] = 0.0
        if j > 0:
            rhs[j - 1] -= upper[j - 1][:, :3] @ v
            upper[j - 1][:, :3] = 0.0
        diag[j][:3, :3], rhs[j][:3] = np.eye(3), v
    x = _solve_block_tridiagonal(diag, upper, rhs)
    joint, handle = x[:, :3], x[:, 3:]
    joint[0], joint[-1] = first, last                            # exact, not just solved
    return np.stack([joint[:-1], joint[:-1] + handle[:-1], joint[1:] - handle[1:], joint[1:]],
                    axis=1)


def _fit_segments(q, cum, tan, s, tol, u=None, iterations=40):
    """Fit ``s`` segments (start params ``u`` or chord length) -> (controls, max error, u).

    Tangent-distance minimisation: residuals are weighted by I - (1 - w) t t^T at the foot
    points.  Like Levenberg-Marquardt, w shrinks (towards fast TDM) after a step that lowers
    the summed squared distance and grows (towards plain, monotone point-distance steps)
    after one that does not.  The bending weight scales with tol / length, so its bias
    stays well under ``tol``.
    """
    u = cum[1:-1] / cum[-1] * s if u is None else u             # chord-length parameters
    pts, t = q[1:-1], tan[1:-1]
    at = np.linspace(0.0, cum[-1], s + 1)
    gj = np.stack([np.interp(at, cum, q[:, d]) for d in range(3)], axis=1)
    gt = np.stack([np.interp(at, cum, tan[:, d]) for d in range(3)], axis=1)
    gh = gt / np.linalg.norm(gt, axis=1)[:, None] * cum[-1] / (3.0 * s)
    guess = np.stack([gj, gh], axis=1).reshape(-1, 3)
    bend = min(1e-2, 0.1 * tol / cum[-1])      # bias well under tol
    best, w, stall = (None, np.inf, np.inf, u), 0.3, 0
    for it in range(iterations):
        metric = np.eye(3) - (1.0 - w) * t[:, :, None] * t[:, None, :]
        ctrl = _solve_chain(u, pts, metric, s, q[0], q[-1], guess, bend)
        un, f = _foot_newton(ctrl, u, pts, 0.0, s, 2)            # Newton reparametrisation
        total, worst = float(f.sum()), float(np.sqrt(f.max(initial=0.0)))
        if total < best[2]:
            stall = stall + 1 if total > best[2] * (1.0 - 1e-3) else 0
            best, u, w = (ctrl, worst, total, un), un, max(1e-4, 0.1 * w)
            d = _eval_chain(ctrl, u, 1)
            n = np.linalg.norm(d, axis=1, keepdims=True)
            t = np.where(n > 0, d / np.maximum(n, 1e-300), t)
        else:
            stall, w = stall + 1, min(1.0, 10.0 * w)
        if best[1] <= tol or stall >= 4 or (it >= 12 and best[1] > 2.0 * tol):
            break                       # done, stalled, or clearly needs more segments
    return best[0], best[1], best[3]


def _distinct_points(p, eps) -> list[int]:
    """Indices of the points of ``p`` (n, 3) kept when each one closer than ``eps`` [m] to the
    last one kept is dropped (the first is always kept)."""
    if len(p) < 2 or (np.sqrt((np.diff(p, axis=0) ** 2).sum(axis=1)) > eps).all():
        return list(range(len(p)))  # the usual path: no duplicates
    keep = [0]
    for i in range(1, len(p)):
        if np.linalg.norm(p[i] - p[keep[-1]]) > eps:
            keep.append(i)
    return keep


def fit_chain(path, tolerance, max_segments=1000):
    """Fit a C1 chain of cubic Beziers to a contact path (Schneider-style).

    ``path`` (n, 3) [m]; ``tolerance`` [m] bounds the distance of every path point to the
    curve.  The chain starts at ``path[0]`` and ends at ``path[-1]`` exactly, and the
    derivative at the end of segment i equals the derivative at the start of segment i+1.
    Per round: chord-length parameters, least squares for all control points with one
    shared handle per join (=> C1), Newton reparametrisation; if a point is still out of
    tolerance the segment count grows (error ~ h^4 guides the step).  Joins are not pinned to
    path points, so segments keep equal parametric speed, which equal handles demand.  If
    ``(n - 2) // 3`` segments still fail, every path point becomes a join (exact
    interpolation with Bessel tangents).
    Raises ``ValueError`` on bad input, ``RuntimeError`` if ``max_segments`` is too small.
    """
    p = _as_points(path, "path")
    tolerance = float(tolerance)
    if not np.isfinite(tolerance) or tolerance <= 0.0:
        raise ValueError(f"tolerance must be a positive finite length in metres, got {tolerance}")
    if int(max_segments) != max_segments or max_segments < 1:
        raise ValueError(f"max_segments must be a positive integer, got {max_segments}")
    eps = 1e-9 * tolerance          # consecutive points closer than this are duplicates
    keep = _distinct_points(p, eps)
    if len(keep) <= 2:              # single / coincident points, or a two-point path
        return _straight(p[0], p[-1])
    q = p[keep].copy()
    q[-1] = p[-1]                   # the curve ends exactly where the tool is
    tol = tolerance * (1.0 - 1e-8)  # margin for the dropped near-duplicates
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    tan = _unit_tangents(q, cum)
    # >= 3 interior points per segment keeps least squares over-determined (6 unknowns per
    # join vs 2 normal-direction residuals per point); nearer interpolation it loops wildly.
    cap = min(int(max_segments), max(1, (len(q) - 2) // 3))
    s, u = 1, None
    while True:
        ctrl, worst, u = _fit_segments(q, cum, tan, s, tol, u)
        ones = np.ones(s)
        loops = _gauss_length(ctrl, 0.0 * ones, ones).sum() > 1.25 * cum[-1] + 2.0 * tol
        if worst <= tol and not loops:
            return BezierChain(ctrl)
        if s >= cap:
            break
        grow = min(2.0, max(1.5, (worst / tol) ** 0.25))        # error ~ h^4
        s_new = min(cap, max(s + 1, math.ceil(s * grow)))
        s, u = s_new, u * (s_new / s)                            # warm start: scaled params
    if len(q) - 1 > max_segments:
        raise RuntimeError(f"tolerance {tolerance} m not reached within {max_segments} segments")
    h = np.diff(cum)                # fallback: interpolate every point, Bessel handles
    beta = (np.r_[h[:1], h] + np.r_[h, h[-1:]])[:, None] / 6.0 * tan
    return BezierChain(np.stack([q[:-1], q[:-1] + beta[:-1], q[1:] - beta[1:], q[1:]], axis=1))
