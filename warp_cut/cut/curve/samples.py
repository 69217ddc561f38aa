"""CurveSamples: a smooth curve sampled densely as a polyline, with what every question asked of
it reuses (segment vectors, unit tangents, arc lengths), and the closest point on it.

The incision asks its curve for the closest point, the tangent and the arc length several times
per cut event; each answer used to recompute these per-segment arrays. Shapes: ``points`` (k, 3)
[m], per-segment arrays (k - 1, ...).
"""

from __future__ import annotations

import numpy as np

__all__ = ["CurveSamples", "closest_on_polyline"]


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


class CurveSamples:
    """A polyline (k, 3) [m] densely sampling a smooth curve (segments much shorter than its
    radius of curvature; k >= 2).

    Attributes:
        points: The samples (k, 3) [m].
        cum: Arc length [m] at each sample (k,), from 0.
        step: Each segment's length [m] (k - 1,).
        segments: Each segment's vector (k - 1, 3) [m].
        unit: Each segment's unit vector (k - 1, 3) (0 for a segment of no length).
    """

    def __init__(self, points: np.ndarray):
        self.points = np.asarray(points, dtype=np.float64)
        self.segments = np.diff(self.points, axis=0)
        self.step = np.linalg.norm(self.segments, axis=1)
        self.cum = np.concatenate([[0.0], np.cumsum(self.step)])
        n = self.step[:, None]
        self.unit = np.divide(self.segments, n, out=np.zeros_like(self.segments), where=n > 0)
        self._length2 = np.maximum((self.segments * self.segments).sum(axis=1), 1e-300)
        self._square = (self.points * self.points).sum(axis=1)

    def segment_at(self, u: np.ndarray) -> np.ndarray:
        """Index (m,) of the segment holding each arc length of ``u`` (m,) [m] (the first or
        last one beyond the ends)."""
        return np.clip(np.searchsorted(self.cum, u, side="right") - 1, 0, len(self.points) - 2)

    def closest(self, points: np.ndarray):
        """``closest_on_polyline`` of points (m, 3): the closest point is searched on the
        segments around each point's nearest sample (found with one matrix product), so the cost
        is O(m k) multiply-adds and O(m) exact segment tests."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if len(self.points) < 8:
            return closest_on_polyline(points, self.points)
        d2 = (points * points).sum(axis=1)[:, None] - 2.0 * points @ self.points.T + self._square[None]
        nearest = np.argmin(d2, axis=1)
        segments = np.clip(nearest[:, None] + np.arange(-2, 2)[None], 0, len(self.points) - 2)  # (m, 4)
        a, ab = self.points[segments], self.segments[segments]
        t = np.clip(((points[:, None, :] - a) * ab).sum(axis=2) / self._length2[segments], 0.0, 1.0)
        closest = a + t[..., None] * ab
        dist = np.linalg.norm(points[:, None, :] - closest, axis=2)
        best = np.argmin(dist, axis=1)
        rows = np.arange(len(points))
        return segments[rows, best], t[rows, best], closest[rows, best], dist[rows, best]
