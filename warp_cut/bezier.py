"""Cubic Bezier incision curves (Zhang et al. 2021, stage 2, Eqs. 5-8).

The incision left by the tool is a C1 chain of cubic Bezier segments fitted to
the tool's contact path.  Points are in metres (SI), arrays are float64.  A chain
of ``s`` segments uses the global parameter ``u`` in ``[0, s]``: segment ``i``
covers ``[i, i + 1]`` with local parameter ``a = u - i`` in ``[0, 1]``.
Evaluation uses the matrix form of Eq. 8, ``P(a) = [a^3 a^2 a 1] M [P0..P3]``.
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


def _power_rows(a, order=0):
    """Rows of d^order/da^order [a^3, a^2, a, 1], shape (m, 4)."""
    one, zero = np.ones_like(a), np.zeros_like(a)
    if order == 0:
        return np.stack([a**3, a**2, a, one], axis=-1)
    if order == 1:
        return np.stack([3.0 * a**2, 2.0 * a, one, zero], axis=-1)
    return np.stack([6.0 * a, 2.0 * one, zero, zero], axis=-1)


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
    """16-point Gauss-Legendre speed integral over [a0, a1] for rows ctrls (m,4,3)."""
    half, mid = 0.5 * (a1 - a0), 0.5 * (a1 + a0)
    a = mid[:, None] + half[:, None] * _GL_X                            # (m, 16)
    w = _power_rows(a, 1) @ BEZIER_MATRIX                               # (m, 16, 4)
    speed = np.linalg.norm(np.einsum("mgk,mkd->mgd", w, ctrls), axis=-1)
    return half * (speed @ _GL_W)


def _adaptive_length(ctrl, a0, a1, depth=0):
    one = lambda lo, hi: float(_gauss_length(ctrl[None], np.array([lo]), np.array([hi]))[0])
    mid = 0.5 * (a0 + a1)
    whole, halves = one(a0, a1), one(a0, mid) + one(mid, a1)
    if abs(halves - whole) <= 1e-14 * abs(halves) + 1e-300 or depth >= 30:
        return halves
    return _adaptive_length(ctrl, a0, mid, depth + 1) + _adaptive_length(ctrl, mid, a1, depth + 1)


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
        seg = np.clip(np.floor(u).astype(np.int64), 0, self.segment_count - 1)
        w = _power_rows(u - seg, order) @ BEZIER_MATRIX                  # Eq. 8, (m, 4)
        return np.einsum("mk,mkd->md", w, self.controls[seg])

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
        """Unit tangents (m, 3) at ``u`` (m,); zero rows where the curve is degenerate."""
        u = self._global(u)
        d = self._eval(u, 1)
        n = np.linalg.norm(d, axis=1)
        weak = n <= 1e-12 * max(np.ptp(self.controls.reshape(-1, 3), axis=0).max(), 1e-300)
        if np.any(weak):   # zero-speed point (e.g. coincident handle): use a central chord
            h = 1e-6
            d[weak] = (self._eval(np.minimum(u[weak] + h, self.segment_count))
                       - self._eval(np.maximum(u[weak] - h, 0.0)))
            n = np.linalg.norm(d, axis=1)
        return np.divide(d, n[:, None], out=np.zeros_like(d), where=n[:, None] > 0)

    def sample(self, count):
        """``count`` points (count, 3) and unit tangents (count, 3) uniform in ``u``."""
        if int(count) != count or count < 1:
            raise ValueError(f"count must be a positive integer, got {count}")
        u = np.linspace(0.0, self.segment_count, int(count))
        return self._eval(u), self.tangent(u)

    def segment_lengths(self):
        """Arc length [m] of each segment, shape (s,), adaptive Gauss-Legendre (~1e-13 rel)."""
        return np.array([_adaptive_length(c, 0.0, 1.0) for c in self.controls])

    def length(self):
        """Total arc length [m]."""
        return float(self.segment_lengths().sum())

    def param_at_arclength(self, dist):
        """Global parameters (m,) at arc-length distances ``dist`` (m,) [m] from the start."""
        dist = _as_params(dist, "dist")
        s, k = self.segment_count, _SAMPLES_PER_SEGMENT
        nodes = np.linspace(0.0, s, s * k + 1)
        seg = np.minimum(np.arange(s * k) // k, s - 1)
        sub = _gauss_length(self.controls[seg], nodes[:-1] - seg, nodes[1:] - seg)
        cum = np.concatenate([[0.0], np.cumsum(sub)])
        if np.any((dist < 0) | (dist > cum[-1] * (1 + 1e-12))):
            raise ValueError(f"dist must lie in [0, {cum[-1]}]")
        i = np.clip(np.searchsorted(cum, dist, side="right") - 1, 0, s * k - 1)
        rem, lo, hi = dist - cum[i], nodes[i], nodes[i + 1]
        u = lo + (hi - lo) * np.divide(rem, sub[i], out=np.zeros_like(rem), where=sub[i] > 0)
        ctrl, base = self.controls[seg[i]], seg[i].astype(np.float64)
        for _ in range(5):  # Newton on L(lo -> u) - rem = 0
            f = _gauss_length(ctrl, lo - base, u - base) - rem
            sp = np.linalg.norm(self._eval(u, 1), axis=1)
            step = np.divide(f, sp, out=np.zeros_like(f), where=sp > 1e-300)
            u = np.clip(u - step, lo, hi)
        return u

    def sample_by_arclength(self, spacing):
        """Points (m, 3) and unit tangents (m, 3) every ``spacing`` metres, end point included."""
        if not np.isfinite(spacing) or spacing <= 0:
            raise ValueError(f"spacing must be a positive finite length, got {spacing}")
        total = float(np.sum(_gauss_length(self.controls, np.zeros(self.segment_count),
                                           np.ones(self.segment_count))))
        d = np.arange(0.0, total, spacing)
        if total > 0 and (total - d[-1]) > 1e-9 * spacing:
            d = np.append(d, total)
        u = self.param_at_arclength(d if total > 0 else np.zeros(1))
        if total > 0:
            u[-1] = self.segment_count          # exact end point
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
        f = lambda u: ((self._eval(u) - x) ** 2).sum(1)
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
        u, fu = np.where(fc < fd, c, d), np.minimum(fc, fd)
        fg = f(grid[best])
        u, fu = np.where(fg < fu, grid[best], u), np.minimum(fg, fu)
        for _ in range(3):  # Newton on (P - x).P' = 0, accepted only if it improves
            p, d1, d2 = self._eval(u), self._eval(u, 1), self._eval(u, 2)
            num, den = ((p - x) * d1).sum(1), (d1 * d1).sum(1) + ((p - x) * d2).sum(1)
            un = np.clip(u - np.divide(num, den, out=np.zeros_like(num), where=den > 0), 0, s)
            fn = f(un)
            u, fu = np.where(fn < fu, un, u), np.minimum(fn, fu)
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


def _chain_controls(q, tan, joins, beta):
    a, b = joins[:-1], joins[1:]
    return np.stack([q[a], q[a] + beta[:-1, None] * tan[a], q[b] - beta[1:, None] * tan[b], q[b]],
                    axis=1)


def _solve_handles(q, tan, joins, seg, u, pts, beta0):
    """Least-squares shared handle lengths beta (one per join => C1), lightly regularised."""
    a, b = joins[seg], joins[seg + 1]
    bas = cubic_basis(u)
    b1, b2 = bas[:, 1], bas[:, 2]
    r0 = (bas[:, 0] + b1)[:, None] * q[a] + (b2 + bas[:, 3])[:, None] * q[b] - pts
    cos = (tan[a] * tan[b]).sum(1)
    reg = 1e-6
    lhs = np.diag(np.full(len(joins), reg))
    rhs = reg * beta0
    np.add.at(lhs, (seg, seg), b1 * b1)
    np.add.at(lhs, (seg + 1, seg + 1), b2 * b2)
    np.add.at(lhs, (seg, seg + 1), -b1 * b2 * cos)
    np.add.at(lhs, (seg + 1, seg), -b1 * b2 * cos)
    np.add.at(rhs, seg, -b1 * (tan[a] * r0).sum(1))
    np.add.at(rhs, seg + 1, b2 * (tan[b] * r0).sum(1))
    return np.maximum(np.linalg.solve(lhs, rhs), 1e-3 * beta0)


def _reparametrise(ctrl, seg, u, pts):
    """One Newton step (Schneider) per point; keeps the better parameter. -> (errors, u)."""
    c = ctrl[seg]
    ev = lambda v, o: np.einsum("mk,mkd->md", _power_rows(v, o) @ BEZIER_MATRIX, c)
    diff = ev(u, 0) - pts
    d1, d2 = ev(u, 1), ev(u, 2)
    num, den = (diff * d1).sum(1), (d1 * d1).sum(1) + (diff * d2).sum(1)
    un = np.clip(u - np.divide(num, den, out=np.zeros_like(num), where=den > 0), 0.0, 1.0)
    e_old, e_new = np.linalg.norm(diff, axis=1), np.linalg.norm(ev(un, 0) - pts, axis=1)
    return np.minimum(e_old, e_new), np.where(e_new < e_old, un, u)


def fit_chain(path, tolerance, max_segments=1000):
    """Fit a C1 chain of cubic Beziers to a contact path (Schneider-style, shared handles).

    ``path`` (n, 3) [m]; ``tolerance`` [m] bounds the distance of every path point to the
    curve.  The chain starts at ``path[0]`` and ends at ``path[-1]`` exactly.  Segment joins
    lie on path points; one handle length per join (shared by both sides) gives equal first
    derivatives, i.e. true C1 in the global parameter.  Raises ``ValueError`` on bad input and
    ``RuntimeError`` if more than ``max_segments`` segments would be needed.
    """
    p = _as_points(path, "path")
    tolerance = float(tolerance)
    if not np.isfinite(tolerance) or tolerance <= 0.0:
        raise ValueError(f"tolerance must be a positive finite length in metres, got {tolerance}")
    if int(max_segments) != max_segments or max_segments < 1:
        raise ValueError(f"max_segments must be a positive integer, got {max_segments}")
    eps = 1e-9 * tolerance          # consecutive points closer than this are duplicates
    keep = [0]
    for i in range(1, len(p)):
        if np.linalg.norm(p[i] - p[keep[-1]]) > eps:
            keep.append(i)
    if len(keep) <= 2:              # single / coincident points, or a two-point path
        return _straight(p[0], p[-1])
    q = p[keep].copy()
    q[-1] = p[-1]                   # the curve ends exactly where the tool is
    tol = tolerance * (1.0 - 1e-8)
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    tan = _unit_tangents(q, cum)
    joins = np.array([0, len(q) - 1])
    while True:
        if len(joins) - 1 > max_segments:
            raise RuntimeError(f"tolerance {tolerance} m not reached within {max_segments} segments")
        idx = np.setdiff1d(np.arange(len(q)), joins)
        seg = np.searchsorted(joins, idx, side="right") - 1
        span = cum[joins[1:]] - cum[joins[:-1]]
        beta0 = (np.concatenate([span[:1], span]) + np.concatenate([span, span[-1:]])) / 6.0
        u = (cum[idx] - cum[joins[seg]]) / span[seg]          # chord-length parametrisation
        seg_err = np.zeros(len(span))
        for _ in range(12):
            beta = _solve_handles(q, tan, joins, seg, u, q[idx], beta0)
            ctrl = _chain_controls(q, tan, joins, beta)
            if len(idx) == 0:
                return BezierChain(ctrl)
            err, u = _reparametrise(ctrl, seg, u, q[idx])
            seg_err = np.zeros(len(span))
            np.maximum.at(seg_err, seg, err)
            if seg_err.max() <= tol:
                return BezierChain(ctrl)
        order = np.lexsort((-err, seg))                        # per segment, worst point first
        first = order[np.r_[True, seg[order][1:] != seg[order][:-1]]]
        split = idx[first[seg_err[seg[first]] > tol]]
        joins = np.union1d(joins, split)
