"""Analytic skin surfaces as charts (u, v) [m] -> point [m], and the parameter domains they cover.

Every chart maps a 2D parameter point (u, v) (lengths [m], so a parameter path has about
the length of its image) onto a surface whose outward (or upward) unit normal is
``normal(uv)``; the chart is orientation preserving: d point/du x d point/dv points along the
normal, so a triangle wound counter-clockwise in (u, v) is wound counter-clockwise seen from
outside once mapped. ``uv_of`` is the chart's inverse for points on (or near) the surface and
``offset`` the signed distance [m] of points from it along the normal (exact for the plane,
sphere and cylinder; first order in the distance for the saddle).

Shapes: arrays of parameter points are (..., 2), of points (..., 3); the leading dimensions
are kept. Z is up.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Plane", "Sphere", "Cylinder", "Saddle", "RectDomain", "DiskDomain"]


def _split(uv) -> tuple[np.ndarray, np.ndarray]:
    uv = np.asarray(uv, dtype=np.float64)
    return uv[..., 0], uv[..., 1]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@dataclass(frozen=True)
class Plane:
    """The plane z = 0: (u, v) = (x, y), normal +Z."""

    def point(self, uv) -> np.ndarray:
        u, v = _split(uv)
        return np.stack([u, v, np.zeros_like(u)], axis=-1)

    def normal(self, uv) -> np.ndarray:
        u, _ = _split(uv)
        return np.stack([np.zeros_like(u), np.zeros_like(u), np.ones_like(u)], axis=-1)

    def uv_of(self, points) -> np.ndarray:
        return np.asarray(points, dtype=np.float64)[..., :2].copy()

    def offset(self, points) -> np.ndarray:
        return np.asarray(points, dtype=np.float64)[..., 2].copy()


@dataclass(frozen=True)
class Sphere:
    """A sphere of ``radius`` [m] whose top (apex) is the origin (centre at (0, 0, -radius)).

    (u, v) are geodesic polar coordinates about the apex (azimuthal equidistant chart):
    |uv| is the distance along the sphere from the apex, its direction the azimuth. Radial
    lengths are exact; lengths along circles about the apex shrink by sin(theta) / theta
    (theta = |uv| / radius), e.g. by 11 % at theta = 0.85 rad.
    """

    radius: float

    def _angles(self, uv):
        u, v = _split(uv)
        s = np.hypot(u, v)
        theta = s / self.radius
        safe = np.where(s > 0, s, 1.0)
        return theta, np.where(s > 0, u / safe, 1.0), np.where(s > 0, v / safe, 0.0)

    def normal(self, uv) -> np.ndarray:
        theta, c, s = self._angles(uv)
        sin = np.sin(theta)
        return np.stack([sin * c, sin * s, np.cos(theta)], axis=-1)

    def point(self, uv) -> np.ndarray:
        return self.radius * self.normal(uv) - np.array([0.0, 0.0, self.radius])

    def uv_of(self, points) -> np.ndarray:
        d = np.asarray(points, dtype=np.float64) + np.array([0.0, 0.0, self.radius])
        rho = np.hypot(d[..., 0], d[..., 1])
        theta = np.arctan2(rho, d[..., 2])
        safe = np.where(rho > 0, rho, 1.0)
        scale = np.where(rho > 0, self.radius * theta / safe, 0.0)
        return np.stack([d[..., 0] * scale, d[..., 1] * scale], axis=-1)

    def offset(self, points) -> np.ndarray:
        d = np.asarray(points, dtype=np.float64) + np.array([0.0, 0.0, self.radius])
        return np.linalg.norm(d, axis=-1) - self.radius


@dataclass(frozen=True)
class Cylinder:
    """The outer surface of a cylinder of ``radius`` [m] along X whose crest (top line) is the
    X axis (axis at z = -radius). u = x, v = radius x angle from the crest (positive towards
    +Y); the chart is an isometry."""

    radius: float

    def normal(self, uv) -> np.ndarray:
        u, v = _split(uv)
        phi = v / self.radius
        return np.stack([np.zeros_like(u), np.sin(phi), np.cos(phi)], axis=-1)

    def point(self, uv) -> np.ndarray:
        u, v = _split(uv)
        n = self.normal(uv)
        return np.stack([u, self.radius * n[..., 1], self.radius * (n[..., 2] - 1.0)], axis=-1)

    def uv_of(self, points) -> np.ndarray:
        x = np.asarray(points, dtype=np.float64)
        phi = np.arctan2(x[..., 1], x[..., 2] + self.radius)
        return np.stack([x[..., 0], self.radius * phi], axis=-1)

    def offset(self, points) -> np.ndarray:
        x = np.asarray(points, dtype=np.float64)
        return np.hypot(x[..., 1], x[..., 2] + self.radius) - self.radius


@dataclass(frozen=True)
class Saddle:
    """The hyperbolic paraboloid z = c (x^2 - y^2) / 2 (``curvature`` c [1/m] at the origin,
    where the principal curvatures are +c and -c); (u, v) = (x, y), normal upward."""

    curvature: float

    def point(self, uv) -> np.ndarray:
        u, v = _split(uv)
        return np.stack([u, v, 0.5 * self.curvature * (u * u - v * v)], axis=-1)

    def normal(self, uv) -> np.ndarray:
        u, v = _split(uv)
        c = self.curvature
        return _unit(np.stack([-c * u, c * v, np.ones_like(u)], axis=-1))

    def uv_of(self, points) -> np.ndarray:
        return np.asarray(points, dtype=np.float64)[..., :2].copy()

    def offset(self, points) -> np.ndarray:
        x = np.asarray(points, dtype=np.float64)
        c = self.curvature
        gap = x[..., 2] - 0.5 * c * (x[..., 0] ** 2 - x[..., 1] ** 2)
        return gap / np.sqrt(1.0 + (c * x[..., 0]) ** 2 + (c * x[..., 1]) ** 2)


@dataclass(frozen=True)
class RectDomain:
    """The rectangle |u'| <= half_u, |v'| <= half_v in the parameter plane, where (u', v') are
    (u, v) turned by -``angle`` [rad] (the rectangle is turned by +angle). ``period_v`` [m]:
    v is periodic with this period (a closed cylinder) and only the u sides are borders."""

    half_u: float
    half_v: float
    angle: float = 0.0
    period_v: float | None = None

    def depth(self, uv) -> np.ndarray:
        """Distance [m] of parameter points inside the domain from its border (negative outside)."""
        u, v = _split(uv)
        c, s = np.cos(self.angle), np.sin(self.angle)
        ur, vr = c * u + s * v, -s * u + c * v
        inside_u = self.half_u - np.abs(ur)
        if self.period_v is not None:
            return inside_u
        return np.minimum(inside_u, self.half_v - np.abs(vr))


@dataclass(frozen=True)
class DiskDomain:
    """The disk |uv| <= radius [m] in the parameter plane."""

    radius: float

    def depth(self, uv) -> np.ndarray:
        u, v = _split(uv)
        return self.radius - np.hypot(u, v)
