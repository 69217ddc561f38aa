"""Incision: the blade's path carried into the rest shape, its Bezier curve (Stage 2) and its lips.

Every cut event finds where the blade crosses the skin as it lies now (``warp_cut.cut.contact.surface``)
and carries that crossing into the rest (material) shape through the triangle it lies in
(``warp_cut.cut.contact.material_point``). The incision keeps both: ``path`` (rest points [m], each with
the rest surface's outward normal there), which the curve is fitted to, and ``contact_path``
(the crossings where the skin was, each with its normal), which the lips are judged against.
The curve is a chain of cubic Bezier segments fitted to ``path`` within ``tolerance`` (paper
Eq. 5-8, ``warp_cut.cut.curve.bezier``): C1 within a fit, tangent-continuous (G1) where the refitted
tail joins the part frozen before; its end point is the latest crossing, so the incision's end
follows the tool.

The incision is a slit with two lips. Its stations are arc lengths u along the curve, one every
``spacing`` from the start; a station carries a lip node on each side, at +-``lip_offset`` across
the curve in the rest surface's tangent plane (along n x t: left is +). The slit ends in one node
where the blade entered (``start_node``, if it entered the tissue and not an earlier wound) and
one at the newest crossing (``tip_node``, while the blade is in the tissue).
"""

from __future__ import annotations

import numpy as np

from ...errors import InputError
from ...mesh.geometry import cross3
from ..tolerances import FIRST_STATION, STATION_GAP, STATION_TURN_DEG
from .bezier import BezierChain, fit_chain
from .samples import CurveSamples, closest_on_polyline

__all__ = ["Incision", "polyline_distance"]

_SAMPLES_PER_SEGMENT = 48


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
    return float(CurveSamples(dense).closest(points)[3].max())


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
                 tolerance: float, contact_point=None, contact_normal=None):
        self.path = [np.asarray(start_point, dtype=np.float64)]
        """Rest points [m] of the blade's crossings, shape (3,) each: what the curve fits."""
        self.normals = [_unit(normal)]
        """Unit outward normal of the rest surface at each path point, shape (3,) each."""
        self.contact_path = [np.asarray(start_point if contact_point is None else contact_point, np.float64)]
        """The same crossings where the skin was then [m], shape (3,) each."""
        self.contact_normals = [_unit(normal if contact_normal is None else contact_normal)]
        """The skin's unit outward normal at each contact point then, shape (3,) each."""
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
        self._samples = CurveSamples(np.repeat(self.path[0][None], 2, axis=0))
        """The curve sampled densely (``_SAMPLES_PER_SEGMENT`` per Bezier segment)."""
        self.station_u: list[float] = []
        """Arc length u [m] of each station, increasing."""
        self.left: list[int] = []
        """Each station's left lip node (-1: none, where the slit runs into an opening)."""
        self.right: list[int] = []
        """Each station's right lip node (-1: none)."""
        self.start_node = -1
        """The node where the slit starts in the tissue (-1: it starts in an opening)."""
        self.tip_node = -1
        """The node at the slit's newest end (-1: none yet, or it ends in an opening)."""
        self.cut_point: np.ndarray | None = None
        """Rest point [m] (3,) where the last event's cut ended (None: nothing cut yet); the next
        event cuts on from it."""
        self.sweep_radius = 0.0
        """Radius of the swept circle [m] (set by the Cutter)."""
        self.slit_nodes: set[int] = set()
        """Every node the incision put on its slit: lips, tip, start, and the points the fill put
        on the slit's edges."""
        self.pending_links: list[tuple[float, float]] = []
        """Separated springs whose residual link waits for a lip pair near where they crossed:
        (arc length u [m], rest length [m])."""
        self.starts_on_tissue = True
        """False when the blade entered in an opening (an earlier wound): the slit then has no
        start node, it opens into that wound (set by the Cutter)."""
        self.entry: np.ndarray | None = None
        """Where the blade entered [m] (rest) when the start was moved into an earlier wound its
        swept disc reached (``tissue_at_rest.joined_start``), until the blade's travel keeps or
        undoes that move (``Cutter``); None otherwise."""
        self.reached_border = False
        """True once the slit has run into an opening or the tissue's edge (it ends there open)."""
        self.resume_u = 0.0
        """Arc length [m] where the slit's newest run begins: past an opening it crossed (an
        earlier wound), the slit goes on from that opening's border; stations and lip pairs
        before it belong to the slit short of the opening."""

    @property
    def end_node(self) -> int:
        """The slit's end node (the tip), -1 if none."""
        return self.tip_node

    # ----------------------------------------------------------------- curve
    @property
    def length(self) -> float:
        """Arc length of the curve [m]."""
        return float(self._samples.cum[-1])

    @property
    def normal(self) -> np.ndarray:
        """Unit outward normal of the skin where the incision started, shape (3,)."""
        return self.normals[0]

    def extend(self, point, min_step: float, normal=None, contact_point=None, contact_normal=None) -> bool:
        """Append a rest point [m] (with the rest surface's unit ``normal`` there; default the
        last one) and refit; points closer than min_step [m] to the last one are skipped
        (returns False). ``contact_point`` / ``contact_normal``: the crossing where the skin was
        (default: the rest point and normal)."""
        point = np.asarray(point, dtype=np.float64)
        if np.linalg.norm(point - self.path[-1]) < min_step:
            return False
        self._path_chord = np.append(self._path_chord, self._path_chord[-1] + np.linalg.norm(point - self.path[-1]))
        self.path.append(point)
        self.normals.append(self.normals[-1] if normal is None else _unit(normal))
        self._normal_array = np.vstack([self._normal_array, self.normals[-1]])
        self.contact_path.append(point if contact_point is None else np.asarray(contact_point, np.float64))
        self.contact_normals.append(self.normals[-1] if contact_normal is None else _unit(contact_normal))
        self._set_curve()
        return True

    def _set_curve(self) -> None:
        """Refit the curve to the path and sample it densely (``point_at`` interpolates those)."""
        self.curve = self._refit()
        u = np.linspace(0.0, self.curve.segment_count, _SAMPLES_PER_SEGMENT * self.curve.segment_count + 1)
        self._samples = CurveSamples(self.curve.evaluate(u))

    @property
    def uncut(self) -> bool:
        """True while nothing of the incision is cut yet (no event has made its slit)."""
        return self.cut_point is None and not self.station_u and self.tip_node < 0 and self.start_node < 0

    def turns_back(self, point) -> bool:
        """True if ``point`` [m] (rest) lies nearer the path's start than its end while nothing is
        cut: the crossing came back along the path (a tool lowered straight down with its axis
        tilted sweeps the crossing backwards as it goes in, then forwards as it travels)."""
        point = np.asarray(point, dtype=np.float64)
        return (self.uncut and len(self.path) >= 2
                and np.linalg.norm(point - self.path[0]) < np.linalg.norm(point - self.path[-1]))

    def turn_back(self) -> None:
        """Reverse the path while nothing is cut (``uncut``): the incision then starts where the
        crossing reached farthest back and runs on the way the blade now travels.

        Raises:
            InputError: Some of the incision is cut already.
        """
        if not self.uncut:
            raise InputError("an incision can only turn back before any of it is cut")
        for name in ("path", "normals", "contact_path", "contact_normals"):
            setattr(self, name, getattr(self, name)[::-1])
        self._path_changed()

    def start_at(self, point) -> None:
        """Move the start of the path to the rest point ``point`` [m] (3,) while nothing is cut
        (``uncut``): a start beside an earlier wound that the blade's swept disc reaches is
        moved into it.

        Raises:
            InputError: Some of the incision is cut already.
        """
        if not self.uncut:
            raise InputError("an incision's start can only move before any of it is cut")
        self.path[0] = np.asarray(point, dtype=np.float64).copy()
        self._path_changed()

    def restart_at(self, point, min_step: float) -> None:
        """Start the path at the rest point ``point`` [m] while nothing is cut (``uncut``),
        leaving out the path points after the start within ``min_step`` [m] of it.

        Raises:
            InputError: Some of the incision is cut already.
        """
        if not self.uncut:
            raise InputError("an incision's start can only move before any of it is cut")
        point = np.asarray(point, dtype=np.float64)
        keep = [0] + [k for k in range(1, len(self.path)) if np.linalg.norm(self.path[k] - point) >= min_step]
        for name in ("path", "normals", "contact_path", "contact_normals"):
            values = getattr(self, name)
            setattr(self, name, [values[k] for k in keep])
        self.path[0] = point.copy()
        self._path_changed()

    def _path_changed(self) -> None:
        """Rebuild what is derived from the whole path (chord lengths, the fit, the samples)."""
        self._normal_array = np.array(self.normals)
        self._path_chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(np.array(self.path), axis=0),
                                                                         axis=1))])
        self._frozen, self._tail_start = np.zeros((0, 4, 3)), 0
        self._set_curve()

    def retraces(self, point, radius: float) -> bool:
        """True if ``point`` [m] lies within ``radius`` [m] (in the skin's tangent plane) of the
        curve short of its end by more than ``radius``: the tool is back over what it has cut
        (a skin bouncing under a tilted blade moves the crossing to and fro), which extends
        nothing."""
        if len(self.path) < 2 or self.length <= radius:
            return False
        behind = self._samples.cum < self.length - radius
        rel = np.asarray(point, dtype=np.float64) - self._samples.points[behind]
        n = self.normal_at(self._samples.cum[behind])
        # distance in the skin's tangent plane: a skin moving along its normal does not count
        lateral = rel - n * np.einsum("ij,ij->i", rel, n)[:, None]
        return bool(np.min(np.linalg.norm(lateral, axis=1)) < radius)

    def _fit_from(self, start: int, stop: int) -> np.ndarray | None:
        """Controls fitting path[start:stop] and joining the frozen part with one tangent (G1:
        the new piece's first handle turned onto the frozen part's last tangent, its own length
        kept, so a short piece after a long frozen segment does not overshoot); None if the
        joined fit misses the tolerance at the path's points or halfway between them."""
        pts = np.array(self.path[start:stop])
        ctrl = fit_chain(pts, self.tolerance).controls.copy()
        if len(self._frozen):
            last = self._frozen[-1]
            handle = float(np.linalg.norm(ctrl[0, 1] - ctrl[0, 0]))
            ctrl[0, 1] = ctrl[0, 0] + handle * _unit(last[3] - last[2])
            between = np.concatenate([pts, 0.5 * (pts[1:] + pts[:-1])])
            if len(pts) > 2 and _max_distance(between, BezierChain(ctrl)) > self.tolerance:
                return None
        return ctrl

    def _refit(self) -> BezierChain:
        """Refit the tail of the path only: once the unfrozen tail spans more than eight
        station spacings, all but its last four are frozen, so the cost of an extension does
        not grow with the incision. Falls back to one fit of the whole path if the join
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
        cum, poly = self._samples.cum, self._samples.points
        return np.stack([np.interp(u, cum, poly[:, c]) for c in range(3)], axis=1)

    def tangent_at(self, u) -> np.ndarray:
        """Unit tangents (m, 3) at arc lengths u [m]."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        return self._samples.unit[self._samples.segment_at(u)]

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
        k, t, closest, dist = self._samples.closest(x)
        cum = self._samples.cum
        u = cum[k] + t * (cum[k + 1] - cum[k])
        lateral = np.einsum("ij,ij->i", cross3(self.tangent_at(u), x - closest), self.normal_at(u))
        return u, np.where(lateral >= 0.0, 1, -1), dist

    # ----------------------------------------------------------------- stations
    def next_stations(self, upto: float) -> list[float]:
        """Arc lengths [m] of the stations after the last one up to ``upto`` (the first
        ``FIRST_STATION`` spacings after the start, or after ``resume_u``), a spacing apart, or
        nearer where the curve turns (``stations_from``)."""
        if self.station_u and self.station_u[-1] >= self.resume_u:
            first = self.next_station_after(self.station_u[-1])
        else:
            first = self.resume_u + FIRST_STATION * self.spacing
        return self.stations_from(first, upto)

    def next_station_after(self, u: float) -> float:
        """Arc length [m] of the station after the one at ``u`` [m]: a spacing on, or where the
        curve's tangent has turned ``STATION_TURN_DEG`` from its direction at ``u`` if that comes
        first (but no nearer than ``STATION_GAP`` spacings). The band runs straight from station
        to station: round a sharp corner a spacing's chord would cut across the tissue inside it."""
        s = self.spacing
        ahead = u + s * np.linspace(STATION_GAP, 1.0, 9)
        turned = self.tangent_at(ahead) @ self.tangent_at([u])[0] < np.cos(np.radians(STATION_TURN_DEG))
        return float(ahead[np.argmax(turned)]) if turned.any() else u + s

    def stations_from(self, first: float, upto: float) -> list[float]:
        """Arc lengths [m] of stations from ``first`` up to ``upto`` (``next_station_after`` each
        from the one before; a rounding margin of 1e-9 spacings keeps one on ``upto``)."""
        out, u = [], first
        while u <= upto + 1e-9 * self.spacing:
            out.append(float(u))
            u = self.next_station_after(u)
        return out

    def add_station(self, u: float, left: int, right: int) -> None:
        """A new station at arc length ``u`` [m] with its lip nodes (-1 for a missing one)."""
        self.station_u.append(float(u))
        self.left.append(int(left))
        self.right.append(int(right))

    def lip_position(self, u: float, side: int) -> np.ndarray:
        """Rest position [m] of a lip node of the station at ``u`` [m] on ``side`` (+1 left, -1
        right; 0: on the curve)."""
        c = self.point_at(u)[0]
        if side == 0:
            return c
        return c + side * self.lip_offset * _unit(cross3(self.normal_at(u)[0], self.tangent_at(u)[0]))

    def lip_node_set(self) -> set[int]:
        """Every lip, start and tip node of the slit (live or not)."""
        nodes = {v for v in self.left + self.right if v >= 0}
        return nodes | {v for v in (self.start_node, self.tip_node) if v >= 0}

    def provisional_nodes(self, active: np.ndarray, points: np.ndarray) -> set[int]:
        """The live nodes of the slit past its newest live lip pair (the tip, and points the fill
        put on the edges to it), ``points`` the rest positions by node slot [m]: the next event
        re-meshes them with the slit it cuts on."""
        k = self.last_pair(active)
        keep = {self.start_node} | {v for v in self.left + self.right if v >= 0}
        nodes = np.array(sorted(v for v in self.slit_nodes - keep if active[v]), dtype=np.int64)
        if not len(nodes) or k < 0:
            return set(nodes.tolist())
        u = self.project(points[nodes])[0]
        return set(nodes[u >= self.station_u[k]].tolist())

    def last_pair(self, active: np.ndarray) -> int:
        """Index of the newest station (from ``resume_u`` on) whose two lip nodes live, or -1."""
        for k in range(len(self.station_u) - 1, -1, -1):
            if self.station_u[k] < self.resume_u:
                return -1
            a, b = self.left[k], self.right[k]
            if a >= 0 and b >= 0 and active[a] and active[b]:
                return k
        return -1

    def pairs(self) -> np.ndarray:
        """(k, 2) node pairs (left, right) of the stations that have both lip nodes."""
        pairs = [(a, b) for a, b in zip(self.left, self.right) if a >= 0 and b >= 0]
        return np.array(pairs, dtype=np.int64).reshape(-1, 2)
