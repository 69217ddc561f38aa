"""Where the tool is in the skin: the crossing of its axis with the current, deformed surface.

The cut follows the skin, not a plane fixed at the first contact: skin is curved (arms, domes)
and sags. At every cut event the tool's axis p0 -> p1 (tip first) is intersected with the skin around
it as it is now: a smooth surface fitted to the nodes around the axis - which works the same
where the axis passes through a hole (the slit the cut has opened) - a weighted least-squares
height field
``h(x, y) = a + b x + c y + d x^2 + e x y + f y^2`` over a local frame whose normal is the
nodes' principal direction of least spread, oriented like the triangles' outward normals.

The point is always taken on the fitted surface, leaving out the nodes the tool itself pushes
aside (its dent is not the skin's shape), so the path is smooth from event to event. The
result is a ``Crossing``: the point [m] on the skin, the unit outward normal there and the
axis parameter.
The blade is in the skin when the tool's tip lies inside it (below the fitted surface); the
crossing is then where the axis first meets the surface from the tip. No crossing means the
tool is out of the skin: lifted out (tip above the surface, even if its shaft touches the
skin elsewhere), or beside the tissue (the crossing lies farther than ``reach`` from every
node).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...mesh.geometry import cross3, plane_frame

__all__ = ["Crossing", "axis_triangle_hits", "fit_height_field", "locate_crossing"]

_PARALLEL = 1e-12
"""|det| below this (relative) counts as an axis parallel to a triangle (no hit)."""


@dataclass(frozen=True)
class Crossing:
    """Where the tool's axis crosses the skin.

    Attributes:
        point: The crossing [m], shape (3,) (where the tip is outside: the point of the skin
            below the tip).
        normal: Unit outward normal of the skin there, shape (3,).
        t: Axis parameter of the crossing, 0 at the tip p0 and 1 at p1 (nan: the tip is out).
        pierced: True if the axis passes through a live triangle there, False if it passes
            through a hole and the point lies on the fitted surface.
        tip_height: Height of the tip above the skin [m]: negative while the blade is in it.
    """

    point: np.ndarray
    normal: np.ndarray
    t: float
    pierced: bool
    tip_height: float = -np.inf

    @property
    def inside(self) -> bool:
        """True while the blade is in the skin (the tip below its surface)."""
        return self.tip_height < 0.0


def axis_triangle_hits(p0, p1, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Intersections of the segment p0 -> p1 with triangles (Moller-Trumbore).

    Args:
        p0, p1: Segment ends [m], shape (3,).
        corners: Triangle corners [m], shape (k, 3, 3).

    Returns:
        (hit mask (k,), segment parameter t in [0, 1] (k,); meaningful where hit).
    """
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    d = np.asarray(p1, np.float64) - np.asarray(p0, np.float64)
    e1 = corners[:, 1] - corners[:, 0]
    e2 = corners[:, 2] - corners[:, 0]
    pvec = cross3(d, e2)
    det = np.einsum("ij,ij->i", e1, pvec)
    scale = np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1) * np.linalg.norm(d)
    ok = np.abs(det) > _PARALLEL * np.maximum(scale, 1e-300)
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
    s = np.asarray(p0, np.float64) - corners[:, 0]
    u = np.einsum("ij,ij->i", s, pvec) * inv
    q = cross3(s, e1)
    v = (q @ d) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    hit = ok & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t >= 0.0) & (t <= 1.0)
    return hit, t


@dataclass(frozen=True)
class HeightField:
    """A local surface: ``centre + x e1 + y e2 + h(x, y) n`` with ``h`` quadratic.

    Attributes:
        centre: Origin of the local frame [m], shape (3,).
        normal: The frame's normal n (outward), shape (3,).
        e1, e2: The frame's tangents, shape (3,) each.
        coeffs: (a, b, c, d, e, f) of ``h = a + b x + c y + d x^2 + e x y + f y^2`` [m, 1, 1/m].
    """

    centre: np.ndarray
    normal: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    coeffs: np.ndarray

    def height(self, x, y):
        a, b, c, d, e, f = self.coeffs
        return a + b * x + c * y + d * x * x + e * x * y + f * y * y

    def normal_at(self, x: float, y: float) -> np.ndarray:
        """Unit outward normal of the surface at local coordinates (x, y) [m]."""
        _, b, c, d, e, f = self.coeffs
        hx, hy = b + 2.0 * d * x + e * y, c + e * x + 2.0 * f * y
        n = self.normal - hx * self.e1 - hy * self.e2
        return n / np.linalg.norm(n)

    def axis_crossing(self, p0, p1) -> float | None:
        """Parameter t in [0, 1] where the axis p0 + t (p1 - p0) leaves the skin: its first
        meeting with the surface from the tip p0, which must be inside (below the surface);
        None when the tip is outside (the blade is not in the skin, even if the shaft meets
        the surface elsewhere) or the axis does not meet it."""
        p0, p1 = np.asarray(p0, np.float64), np.asarray(p1, np.float64)
        rel, d = p0 - self.centre, p1 - p0
        x0, y0, z0 = rel @ self.e1, rel @ self.e2, rel @ self.normal
        dx, dy, dz = d @ self.e1, d @ self.e2, d @ self.normal
        a, b, c, dd, e, f = self.coeffs
        # g(t) = z(t) - h(x(t), y(t)), a quadratic in t
        q2 = -(dd * dx * dx + e * dx * dy + f * dy * dy)
        q1 = dz - (b * dx + c * dy + 2.0 * dd * x0 * dx + e * (x0 * dy + y0 * dx) + 2.0 * f * y0 * dy)
        q0 = z0 - self.height(x0, y0)
        if q0 >= 0.0:
            return None  # the tip is outside the skin
        roots = _quadratic_roots(q2, q1, q0)
        inside = [t for t in roots if -1e-12 <= t <= 1.0 + 1e-12]
        return min(max(min(inside), 0.0), 1.0) if inside else None

    def tip_height(self, p0) -> float:
        """Height [m] of point ``p0`` above the surface (along the frame's normal)."""
        rel = np.asarray(p0, np.float64) - self.centre
        return float(rel @ self.normal - self.height(rel @ self.e1, rel @ self.e2))

    def local(self, point) -> tuple[float, float]:
        rel = np.asarray(point, np.float64) - self.centre
        return float(rel @ self.e1), float(rel @ self.e2)


def _quadratic_roots(a: float, b: float, c: float) -> list[float]:
    """Real roots of a t^2 + b t + c (a linear or constant equation when a is negligible)."""
    scale = max(abs(a), abs(b), abs(c), 1e-300)
    if abs(a) <= 1e-12 * scale:
        return [] if abs(b) <= 1e-300 else [-c / b]
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        return []
    root = np.sqrt(disc)
    q = -0.5 * (b + np.copysign(root, b))  # the stable form
    out = [q / a]
    if q != 0.0:
        out.append(c / q)
    return out


def _plane_frame(points: np.ndarray, w: np.ndarray, outward: np.ndarray):
    """Weighted centre and principal frame (e1, e2, normal) of points (k, 3); the normal is the
    direction of least spread, turned to agree with ``outward``."""
    centre = w @ points
    rel = points - centre
    _, vectors = np.linalg.eigh((rel * w[:, None]).T @ rel)
    normal = vectors[:, 0] if vectors[:, 0] @ outward >= 0.0 else -vectors[:, 0]
    e1, e2 = plane_frame(normal)
    return centre, e1, e2, normal


def _quadratic_form(points: np.ndarray, w: np.ndarray, outward: np.ndarray):
    """(e1, e2, (d, e, f)) of the weighted least-squares quadratic height field of points
    (k, 3) over their own principal frame: the surface's second-order shape (zeros when the
    points do not determine it)."""
    centre, e1, e2, normal = _plane_frame(points, w, outward)
    rel = points - centre
    x, y, z = rel @ e1, rel @ e2, rel @ normal
    if len(points) >= 6:
        basis = np.column_stack([np.ones_like(x), x, y, x * x, x * y, y * y])
        sw = np.sqrt(w)
        sol, _, rank, _ = np.linalg.lstsq(basis * sw[:, None], z * sw, rcond=1e-10)
        if rank == 6:
            return e1, e2, sol[3:]
    return e1, e2, np.zeros(3)


def fit_height_field(points: np.ndarray, weights: np.ndarray, outward: np.ndarray,
                     rest_points: np.ndarray | None = None, rest_weights: np.ndarray | None = None
                     ) -> HeightField:
    """Weighted least-squares local surface through ``points``.

    The plane part (height, tilt) comes from ``points``; the curvature from ``rest_points``
    when given (the same skin at rest, with no tool pressing into it: curvature from the
    displaced nodes around a tool would be the tool's dent), else from ``points``.

    Args:
        points: Node positions [m], shape (k, 3), k >= 3.
        weights: Their weights, shape (k,), > 0.
        outward: A vector the fitted normal must agree with (the triangles' mean normal).
        rest_points: Rest positions [m] of nodes around the same place, shape (j, 3).
        rest_weights: Their weights, shape (j,).

    Returns:
        The height field (a plane when the curvature cannot be determined).
    """
    w = np.asarray(weights, np.float64) / np.sum(weights)
    centre, e1, e2, normal = _plane_frame(points, w, outward)
    if rest_points is None:
        r1, r2, curv = _quadratic_form(points, w, outward)
    else:
        rw = np.asarray(rest_weights, np.float64) / np.sum(rest_weights)
        r1, r2, curv = _quadratic_form(rest_points, rw, outward)
    # the quadratic form x^T Q x in the current frame (the rest frame turned into it)
    q_rest = np.array([[curv[0], 0.5 * curv[1]], [0.5 * curv[1], curv[2]]])
    turn = np.array([[e1 @ r1, e1 @ r2], [e2 @ r1, e2 @ r2]])
    q = turn @ q_rest @ turn.T
    rel = points - centre
    x, y, z = rel @ e1, rel @ e2, rel @ normal
    z_plane = z - (q[0, 0] * x * x + 2.0 * q[0, 1] * x * y + q[1, 1] * y * y)
    basis = np.column_stack([np.ones_like(x), x, y])
    sw = np.sqrt(w)
    abc = np.linalg.lstsq(basis * sw[:, None], z_plane * sw, rcond=1e-10)[0]
    return HeightField(centre, normal, e1, e2, np.concatenate([abc, [q[0, 0], 2.0 * q[0, 1], q[1, 1]]]))


def locate_crossing(p0, p1, positions: np.ndarray, corners: np.ndarray, *, reach: float,
                    fit_radius: float, exclude: float = 0.0, rest_positions: np.ndarray | None = None
                    ) -> Crossing | None:
    """Where the axis p0 -> p1 crosses the skin around it.

    The point lies on the surface fitted to the nodes around the axis, leaving out those
    within ``exclude`` of the axis (the tool pushes them aside: they show the tool's dent, not
    the skin; all count if fewer than 6 would remain), its curvature taken from the nodes'
    rest positions when given; so the path is smooth from event to event. ``pierced`` tells
    whether the axis also passes through a live triangle there.

    Args:
        p0, p1: The tool's axis, tip first [m], shape (3,).
        positions: Positions of the live nodes around the axis [m], shape (k, 3).
        corners: Live triangles with a corner among them, as corner positions [m],
            shape (m, 3, 3), wound counter-clockwise seen from outside.
        reach: A crossing counts only if the nodes within this distance of it [m] surround
            it (else it is beside the tissue, beyond its edge).
        fit_radius: Length scale of the fitted surface's weights [m].
        exclude: Nodes closer than this to the axis line are left out of the fit [m].
        rest_positions: The same nodes' rest positions [m], shape (k, 3), or None.

    Returns:
        The crossing (with the tip outside: ``inside`` False, the skin below the tip), or None
        when the axis is beside the tissue or its skin cannot be fitted.
    """
    if len(positions) < 3 or len(corners) == 0:
        return None
    p0, p1 = np.asarray(p0, np.float64), np.asarray(p1, np.float64)
    tri_normals = cross3(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    outward = tri_normals.sum(axis=0)
    if not np.linalg.norm(outward) > 0:
        return None
    hit, t_hit = axis_triangle_hits(p0, p1, corners)
    keep = _away_from_axis(positions, p0, p1, exclude)
    guess = p0 + (t_hit[hit].max() if hit.any() else 0.5) * (p1 - p0)
    t = None
    for _ in range(2):  # fit around the guess, cross, refit around the crossing
        surface = _fit_around(positions, keep, guess, outward, fit_radius, rest_positions)
        t = surface.axis_crossing(p0, p1)
        if t is None:
            return _outside(surface, p0, positions, reach)
        guess = p0 + t * (p1 - p0)
    if not _over_the_skin(positions, guess, surface, reach):
        return None
    return Crossing(guess, surface.normal_at(*surface.local(guess)), t, bool(hit.any()),
                    surface.tip_height(p0))


def _over_the_skin(positions: np.ndarray, point: np.ndarray, surface: HeightField, reach: float) -> bool:
    """True if ``point`` lies within the tissue's outline: nodes within ``reach`` [m] of it
    surround it, leaving no angular gap wider than a half-turn in the surface's tangent plane
    (inside the tissue, a slit or the tool's own hole they do; beyond the tissue's edge they
    lie on one side only)."""
    rel = positions - point
    near = np.linalg.norm(rel, axis=1) <= reach
    if near.sum() < 3:
        return False
    angles = np.sort(np.arctan2(rel[near] @ surface.e2, rel[near] @ surface.e1))
    gaps = np.diff(np.concatenate([angles, [angles[0] + 2.0 * np.pi]]))
    return float(gaps.max()) <= np.pi


def _outside(surface: HeightField, p0: np.ndarray, positions: np.ndarray, reach: float) -> Crossing | None:
    """The skin below a tip that is outside it (None if that is beside the tissue, or the axis
    runs below the skin without the tip being inside)."""
    height = surface.tip_height(p0)
    if height < 0.0:
        return None
    x, y = surface.local(p0)
    foot = surface.centre + x * surface.e1 + y * surface.e2 + surface.height(x, y) * surface.normal
    if not _over_the_skin(positions, foot, surface, reach):
        return None
    return Crossing(foot, surface.normal_at(x, y), float("nan"), False, height)


def _away_from_axis(positions: np.ndarray, p0, p1, exclude: float) -> np.ndarray:
    """Mask of the nodes at least ``exclude`` [m] from the axis line (all of them when
    fewer than 6 are)."""
    d = p1 - p0
    rel = positions - p0
    along = rel @ d / max(float(d @ d), 1e-300)
    dist = np.linalg.norm(rel - along[:, None] * d, axis=1)
    keep = dist >= exclude
    return keep if keep.sum() >= 6 else np.ones(len(positions), dtype=bool)


def _weights(positions: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Gaussian weights of ``radius`` [m] around ``centre`` (at least the 8 nearest nodes count
    fully)."""
    dist = np.linalg.norm(positions - centre, axis=1)
    scale = max(radius, float(np.sort(dist)[min(7, len(dist) - 1)]))
    return np.exp(-((dist / scale) ** 2)) + 1e-12


def _fit_around(positions: np.ndarray, keep: np.ndarray, centre: np.ndarray, outward: np.ndarray,
                radius: float, rest_positions: np.ndarray | None) -> HeightField:
    """The height field of the kept nodes around ``centre`` (curvature from the rest positions
    of all of them, when given)."""
    w = _weights(positions[keep], centre, radius)
    if rest_positions is None:
        return fit_height_field(positions[keep], w, outward)
    return fit_height_field(positions[keep], w, outward, rest_positions, _weights(positions, centre, radius))
