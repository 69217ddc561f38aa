"""Incision: the tool's contact path, its Bezier curve (Stage 2) and the lips' stations.

The path is the sequence of contact points [m], each with the skin's outward normal there
(the skin may be curved: every point has its own). The curve is a C1 chain of cubic Bezier
segments fitted to it within ``tolerance`` (paper Eq. 5-8, ``warp_cut.cut.bezier``); its end
point is the latest contact point, so the incision's end follows the tool.

The incision is a slit with two lips. Its stations are arc-length positions u along the
curve: the start (u = 0) and the end (u = length) each carry one node, every interior station
two, one per lip, offset by +-``lip_offset`` across the curve in the skin's tangent plane
there (along n x t, n the local normal, t the tangent). Walking around the slit - up the
left lip, round the end, back down the right lip - gives each point the slit coordinate

    theta = u (left lip),  theta = length (end),  theta = 2 length - u (right lip),  0 (start)

which Stage 3 uses to pair the border of the grey area with the lips.
"""

from __future__ import annotations

import numpy as np

from ..mesh.geometry import cross3
from .bezier import BezierChain, fit_chain

__all__ = ["Incision", "polyline_distance"]

_SAMPLES_PER_SEGMENT = 48


def closest_on_polyline(points: np.ndarray, poly: np.ndarray):
    """For points (m, 3) and a polyline (k, 3): (segment index (m,), parameter on it in [0, 1]
    (m,), closest point (m, 3) [m], distance (m,) [m]) (every segment tried: O(m k))."""
    a, b = poly[:-1], poly[1:]
    ab = b - a
    denom = np.maximum((ab * ab).sum(axis=1), 1e-300)
    t = np.clip(((points[:, None, :] - a[None]) * ab[None]).sum(axis=2) / denom[None], 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    dist = np.linalg.norm(points[:, None, :] - closest, axis=2)
    k = np.argmin(dist, axis=1)
    rows = np.arange(len(points))
    return k, t[rows, k], closest[rows, k], dist[rows, k]


def closest_on_dense_polyline(points: np.ndarray, poly: np.ndarray):
    """``closest_on_polyline`` for a polyline (k, 3) that densely samples a smooth curve
    (segments much shorter than its radius of curvature): the closest point is searched on
    the segments around each point's nearest vertex (found with one matrix product), so the
    cost is O(m k) multiply-adds and O(m) exact segment tests."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(poly) < 2:
        return closest_on_polyline(points, np.concatenate([poly, poly]))
    if len(poly) < 8:
        return closest_on_polyline(points, poly)
    d2 = (points * points).sum(axis=1)[:, None] - 2.0 * points @ poly.T + (poly * poly).sum(axis=1)[None]
    nearest = np.argmin(d2, axis=1)
    segments = np.clip(nearest[:, None] + np.arange(-2, 2)[None], 0, len(poly) - 2)  # (m, 4)
    a, b = poly[segments], poly[segments + 1]
    ab = b - a
    denom = np.maximum((ab * ab).sum(axis=2), 1e-300)
    t = np.clip(((points[:, None, :] - a) * ab).sum(axis=2) / denom, 0.0, 1.0)
    closest = a + t[..., None] * ab
    dist = np.linalg.norm(points[:, None, :] - closest, axis=2)
    best = np.argmin(dist, axis=1)
    rows = np.arange(len(points))
    return segments[rows, best], t[rows, best], closest[rows, best], dist[rows, best]


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def polyline_distance(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance (m,) [m] of points (m, 3) to a polyline (k, 3)."""
    return closest_on_polyline(points, poly)[3]


def _max_distance(points: np.ndarray, curve: BezierChain) -> float:
    """Largest distance [m] of points to a curve, through a dense polyline of the curve
    (within ~1e-4 of the chord length of the true distance)."""
    s = curve.segment_count
    dense = curve.evaluate(np.linspace(0.0, s, 64 * s + 1))
    return float(closest_on_dense_polyline(points, dense)[3].max())


class Incision:
    """One continuous cut (one contact episode of the tool).

    Args:
        start_point: Where the blade entered the skin [m], shape (3,).
        normal: Unit outward normal of the skin there, shape (3,) (the side convention:
            left = normal x tangent).
        spacing: Lip station spacing [m] (about the local mesh spacing).
        lip_offset: Half the initial width of the slit [m].
        tolerance: Maximum distance of the curve from the contact path [m].
    """

    def __init__(self, start_point, normal, *, spacing: float, lip_offset: float,
                 tolerance: float):
        self.path = [np.asarray(start_point, dtype=np.float64)]
        self.normals = [_unit(normal)]
        """Unit outward normal of the skin at each path point, shape (3,) each."""
        self._path_chord = np.zeros(1)
        """Cumulative chord length [m] of the path at each of its points, shape (len(path),)."""
        self._normal_array = np.array(self.normals)
        """The normals as one array, shape (len(path), 3)."""
        self.spacing = float(spacing)
        self.lip_offset = float(lip_offset)
        self.tolerance = float(tolerance)
        self.curve: BezierChain | None = None
        self._frozen = np.zeros((0, 4, 3))
        self._tail_start = 0
        self._poly = np.repeat(self.path[0][None], 2, axis=0)
        self._cum = np.zeros(2)
        # interior stations: arc-length u and the node of each lip (-1: none yet)
        self.station_u: list[float] = []
        self.left: list[int] = []
        self.right: list[int] = []
        self.start_node = -1
        self.end_node = -1
        self.open_end = True
        """True while the tool cuts: the slit's tip is then its newest lip pair (joined by an
        edge), the tissue ahead of it up to the tool is re-closed after each event, and the
        end node at the curve's end is made only once the tool has gone."""
        self.sweep_radius = 0.0
        """Radius of the swept circle [m] (set by the Cutter)."""
        self.anchor = -1
        """A live node near the tool, where the Cutter starts looking for what it cuts."""
        self.open_chains: list[list[int]] = []
        """Borders of holes the last cut event could not fill (retried at the next one)."""
        self.deferrals = 0
        """Consecutive events that left a hole open."""
        self.pending_links: list[tuple[int, int, float, float]] = []
        """Springs the cut separated whose residual links act once the wound is open there:
        (node i, node j, rest length [m], arc length u [m] where they crossed the cut)."""
        self.first_own_spring = 0
        """Spring slots from this one on were made while this incision cut (slots are never
        reused): the tissue it re-closed ahead of its tip, whose springs leave no residual
        link when it cuts them again (the springs they replaced already did)."""
        self.reached_border = False
        """True once the cut has opened the skin to the tissue's outer border (a notch)."""

    # ----------------------------------------------------------------- curve
    @property
    def length(self) -> float:
        """Arc length of the curve [m]."""
        return float(self._cum[-1])

    @property
    def normal(self) -> np.ndarray:
        """Unit outward normal of the skin where the incision started, shape (3,)."""
        return self.normals[0]

    def extend(self, point, min_step: float, normal=None) -> bool:
        """Append a contact point [m] (with the skin's unit ``normal`` there; default the
        last one) and refit; points closer than min_step [m] to the last one are skipped
        (returns False)."""
        point = np.asarray(point, dtype=np.float64)
        if np.linalg.norm(point - self.path[-1]) < min_step:
            return False
        self._path_chord = np.append(self._path_chord, self._path_chord[-1] + np.linalg.norm(point - self.path[-1]))
        self.path.append(point)
        self.normals.append(self.normals[-1] if normal is None else _unit(normal))
        self._normal_array = np.vstack([self._normal_array, self.normals[-1]])
        self.curve = self._refit()
        u = np.linspace(0.0, self.curve.segment_count, _SAMPLES_PER_SEGMENT * self.curve.segment_count + 1)
        self._poly = self.curve.evaluate(u)
        self._cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self._poly, axis=0), axis=1))])
        return True

    def retraces(self, point, radius: float) -> bool:
        """True if ``point`` [m] lies within ``radius`` [m] (in the skin's tangent plane) of the
        curve short of its end by more than ``radius``: the tool is back over what it has cut
        (a skin bouncing under a tilted blade moves the crossing to and fro), which extends
        nothing."""
        if len(self.path) < 2 or self.length <= radius:
            return False
        behind = self._cum < self.length - radius
        rel = np.asarray(point, dtype=np.float64) - self._poly[behind]
        n = self.normal_at(self._cum[behind])
        # distance in the skin's tangent plane: a skin moving along its normal does not count
        lateral = rel - n * np.einsum("ij,ij->i", rel, n)[:, None]
        return bool(np.min(np.linalg.norm(lateral, axis=1)) < radius)

    def _fit_from(self, start: int, stop: int) -> np.ndarray | None:
        """Controls fitting path[start:stop] and joining the frozen part C1 (None if the
        joined fit misses the tolerance)."""
        pts = np.array(self.path[start:stop])
        ctrl = fit_chain(pts, self.tolerance).controls.copy()
        if len(self._frozen):
            last = self._frozen[-1]
            ctrl[0, 1] = ctrl[0, 0] + (last[3] - last[2])  # equal derivatives at the join
            if len(pts) > 2 and _max_distance(pts, BezierChain(ctrl)) > self.tolerance:
                return None
        return ctrl

    def _refit(self) -> BezierChain:
        """Refit the tail of the path only: once the unfrozen tail spans more than eight
        station spacings, all but its last four are frozen, so the cost of an extension does
        not grow with the incision. Falls back to one fit of the whole path if a C1 join
        cannot meet the tolerance."""
        n = len(self.path)
        tail = np.array(self.path[self._tail_start:])
        chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(tail, axis=0), axis=1))])
        if chord[-1] > 8.0 * self.spacing:
            k = self._tail_start + int(np.searchsorted(chord, chord[-1] - 4.0 * self.spacing))
            piece = self._fit_from(self._tail_start, k + 1)
            if piece is not None:
                self._frozen = np.concatenate([self._frozen, piece])
                self._tail_start = k
        ctrl = self._fit_from(self._tail_start, n)
        if ctrl is None:
            self._frozen, self._tail_start = np.zeros((0, 4, 3)), 0
            ctrl = self._fit_from(0, n)
        return BezierChain(np.concatenate([self._frozen, ctrl]))

    def point_at(self, u) -> np.ndarray:
        """Curve points (m, 3) [m] at arc lengths u (m,) [m] (piecewise-linear between dense samples)."""
        u = np.clip(np.atleast_1d(np.asarray(u, dtype=np.float64)), 0.0, self.length)
        return np.stack([np.interp(u, self._cum, self._poly[:, c]) for c in range(3)], axis=1)

    def tangent_at(self, u) -> np.ndarray:
        """Unit tangents (m, 3) at arc lengths u [m]."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        k = np.clip(np.searchsorted(self._cum, u, side="right") - 1, 0, len(self._poly) - 2)
        d = self._poly[k + 1] - self._poly[k]
        n = np.linalg.norm(d, axis=1, keepdims=True)
        return np.divide(d, n, out=np.zeros_like(d), where=n > 0)

    def normal_at(self, u) -> np.ndarray:
        """Unit outward skin normals (m, 3) at arc lengths u (m,) [m], interpolated between
        the contact points' normals."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        normals, chord = self._normal_array, self._path_chord
        if len(normals) == 1:
            return np.repeat(normals, len(u), axis=0)
        s = u * (chord[-1] / self.length) if self.length > 0 else np.zeros_like(u)
        n = np.stack([np.interp(s, chord, normals[:, c]) for c in range(3)], axis=1)
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)

    def project(self, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u (m,) arc length of the closest curve point [m], side (m,) +1 left / -1 right,
        distance (m,) [m]) of points (m, 3); the side is taken in the skin's tangent plane
        at the closest point."""
        x = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        k, t, closest, dist = closest_on_dense_polyline(x, self._poly)
        u = self._cum[k] + t * np.diff(self._cum)[k]
        lateral = np.einsum("ij,ij->i", cross3(self.tangent_at(u), x - closest), self.normal_at(u))
        return u, np.where(lateral >= 0.0, 1, -1), dist

    def chart(self, points) -> np.ndarray:
        """Slit-chart coordinates (m, 2) [m] of points (m, 3): (u, v), u the arc length of the
        closest curve point and v the signed distance from it (+ left), continued along the
        tangent beyond either end. The chart follows the curve on curved skin, where any one
        plane would fold; (u, v) turns counter-clockwise where the skin does about its
        outward normal."""
        x = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        u, side, dist = self.project(x)
        v = side * dist
        ends = np.array([0.0, self.length])
        for end, mask in zip(ends, (u <= 1e-12, u >= self.length - 1e-12)):
            if mask.any():
                t, n = self.tangent_at(end)[0], self.normal_at(end)[0]
                rel = x[mask] - self.point_at(end)[0]
                u[mask] = end + rel @ t
                v[mask] = rel @ cross3(n, t)
        return np.stack([u, v], axis=1)

    def theta(self, u, side) -> np.ndarray:
        """Slit coordinate of points at arc length u [m] on a side (+1 left, -1 right)."""
        u = np.asarray(u, dtype=np.float64)
        return np.where(np.asarray(side) > 0, u, 2.0 * self.length - u)

    # ----------------------------------------------------------------- stations
    def plan_stations(self, clearance: float | None = None) -> None:
        """Add interior stations every ``spacing`` (the first as soon as it fits, at least half a
        spacing from the start), keeping the last one at least ``clearance`` [m] behind the end
        (default: half a spacing and 1.5 sweep radii): a lip is made once the tool (whose
        footprint on a tilted surface reaches r / sin(angle) behind the axis) has passed it."""
        last = self.station_u[-1] if self.station_u else 0.0
        if clearance is None:
            clearance = max(0.5 * self.spacing, 1.5 * self.sweep_radius)
        if not self.station_u and self.length - clearance >= 0.5 * self.spacing:
            # the first station as soon as there is room: until it exists the slit has no
            # opening (its start and end node alone do not part its sides)
            first = min(self.spacing, self.length - clearance)
            self.station_u.append(first)
            self.left.append(-1)
            self.right.append(-1)
            last = first
        while self.length - (last + self.spacing) >= clearance:
            last += self.spacing
            self.station_u.append(last)
            self.left.append(-1)
            self.right.append(-1)

    def lip_position(self, u: float, side: int) -> np.ndarray:
        """Where a lip node of station u [m] on ``side`` is created [m]."""
        c = self.point_at(u)[0]
        if side == 0:
            return c
        return c + side * self.lip_offset * _unit(cross3(self.normal_at(u)[0], self.tangent_at(u)[0]))

    def lip_nodes(self) -> list[tuple[int, float, int, int]]:
        """Every lip slot as (node or -1, theta, side, station index): start (side 0, index -1),
        interior stations on both lips, end (side 0, index -2; once the tool has gone)."""
        out = [(self.start_node, 0.0, 0, -1)]
        if not self.open_end:
            out.append((self.end_node, self.length, 0, -2))
        for k, u in enumerate(self.station_u):
            out.append((self.left[k], u, 1, k))
            out.append((self.right[k], 2.0 * self.length - u, -1, k))
        return out

    def set_lip_node(self, station: int, side: int, node: int) -> None:
        if station == -1:
            self.start_node = node
        elif station == -2:
            self.end_node = node
        elif side > 0:
            self.left[station] = node
        else:
            self.right[station] = node

    def tip_u(self, active: np.ndarray) -> float:
        """Arc length [m] of the slit's tip: its newest station whose two lip nodes live (0,
        the start, if none)."""
        for k in range(len(self.station_u) - 1, -1, -1):
            a, b = self.left[k], self.right[k]
            if a >= 0 and b >= 0 and active[a] and active[b]:
                return self.station_u[k]
        return 0.0

    def pairs(self) -> np.ndarray:
        """(k, 2) node pairs (left, right) of interior stations that have both lip nodes."""
        pairs = [(a, b) for a, b in zip(self.left, self.right) if a >= 0 and b >= 0]
        return np.array(pairs, dtype=np.int64).reshape(-1, 2)
