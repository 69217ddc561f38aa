"""Strokes: a scalpel path drawn on a Surface, and the tool poses that draw it.

A stroke is a path in the surface's parameter plane (``line``, ``arc``, ``zigzag``) and a tool:
a cylinder of radius r and length L, tip p0, back end p1 = p0 + L a. Its unit axis a leans
back against the direction of travel T by the tilt angle alpha from the tangent plane, in the
plane of the local normal n and T:

    a = cos(alpha) (-T) + sin(alpha) n        (alpha = 90 deg: vertical)

The tool comes in along its own axis from outside the tissue until the tip is ``depth`` below
the tangent plane at the path's start (the tip then sits depth / sin(alpha) down the axis from
the surface point), travels along the path at ``speed`` with the axis through the path's
surface point P(s) at every moment (s: arc length along the surface), and is lifted out
along its axis at the end. The start and end heights are chosen so the tool touches no mesh
node (the Simulator's premise: the tool starts outside).

The ideal entry trace is P(s) for s from 0 (where the axis enters the skin) to the path's
length (where it leaves): ``Stroke.trace``, with the normals and travel tangents there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .control import Tool, ToolPath

__all__ = ["ParamPath", "line", "arc", "zigzag", "Stroke", "inside_cylinder"]

_STEP = 1e-4
"""Sampling step of parameter paths [m]."""


@dataclass(frozen=True, eq=False)
class ParamPath:
    """A path in a Surface's parameter plane: ``uv`` (k, 2) [m], a dense polyline, and the
    ``kind`` that made it ("line", "arc", "zigzag")."""

    uv: np.ndarray
    kind: str

    @property
    def length(self) -> float:
        """Length in the parameter plane [m]."""
        return float(np.linalg.norm(np.diff(self.uv, axis=0), axis=1).sum())


def _heading(angle) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def _samples(length: float) -> np.ndarray:
    if not (np.isfinite(length) and length > 0):
        raise InputError(f"a stroke's length must be > 0 m, got {length}")
    return np.linspace(0.0, length, max(2, math.ceil(length / _STEP) + 1))


def line(start, heading: float, length: float) -> ParamPath:
    """A straight path from ``start`` (2,) [m] in direction ``heading`` [rad] (angle from +u)."""
    s = _samples(length)
    return ParamPath(np.asarray(start, np.float64) + s[:, None] * _heading(heading), "line")


def arc(start, heading: float, length: float, turn_radius: float) -> ParamPath:
    """A circular arc of ``length`` [m] leaving ``start`` in direction ``heading`` [rad],
    turning left for a positive ``turn_radius`` [m], right for a negative one."""
    if not (np.isfinite(turn_radius) and turn_radius != 0):
        raise InputError(f"arc turn_radius must be a non-zero length, got {turn_radius}")
    s = _samples(length)
    phi = heading + s / turn_radius
    centre = np.asarray(start, np.float64) + turn_radius * _heading(heading + math.pi / 2)
    offset = turn_radius * np.column_stack([np.cos(phi - math.pi / 2), np.sin(phi - math.pi / 2)])
    return ParamPath(centre + offset, "arc")


def zigzag(start, heading: float, length: float, amplitude: float, wavelength: float) -> ParamPath:
    """A zigzag about the line from ``start`` in direction ``heading`` [rad], ``length`` [m]
    along that line: a triangle wave of ``amplitude`` [m] (half the peak-to-peak) and
    ``wavelength`` [m], starting on the line, with corners rounded over a tenth of a wavelength
    (so the tool's lean turns smoothly)."""
    if not (amplitude >= 0 and wavelength > 0):
        raise InputError(f"zigzag amplitude must be >= 0 and wavelength > 0 m, got {amplitude}, {wavelength}")
    s = _samples(length)
    lateral = amplitude * (4.0 * np.abs((s / wavelength + 0.75) % 1.0 - 0.5) - 1.0)  # 0, A, 0, -A, 0
    width = max(1, int(round(0.05 * wavelength / (s[1] - s[0]))))
    padded = np.pad(lateral, width, mode="edge")
    lateral = np.convolve(padded, np.ones(2 * width + 1) / (2 * width + 1), mode="same")[width:-width]
    lateral -= lateral[0]
    along, across = _heading(heading), _heading(heading + math.pi / 2)
    uv = np.asarray(start, np.float64) + s[:, None] * along + lateral[:, None] * across
    return ParamPath(uv, "zigzag")


def inside_cylinder(points, p0, p1, radius: float) -> np.ndarray:
    """Mask (n,) of points (n, 3) [m] inside the cylinder p0 -> p1 of ``radius`` [m] (the
    collision test of the Simulator: projects onto the axis segment, distance below radius)."""
    x = np.asarray(points, dtype=np.float64)
    axis = np.asarray(p1, np.float64) - p0
    t = (x - p0) @ axis / max(float(axis @ axis), 1e-300)
    closest = p0 + np.clip(t, 0.0, 1.0)[:, None] * axis
    return (t >= 0.0) & (t <= 1.0) & (np.linalg.norm(x - closest, axis=1) < radius)


class Stroke:
    """Tool poses drawing ``path`` on ``surface`` (see the module docstring).

    Args:
        surface: a ``warp_cut.mesh.surfaces.Surface``.
        path: a ``ParamPath`` inside the surface's parameter domain.
        tilt: angle alpha of the axis from the tangent plane [rad], in (0, pi/2].
        radius, tool_length: the tool cylinder [m].
        depth: how far the tip goes below the tangent plane [m].
        speed: travel speed along the surface [m/s].
        plunge_speed: speed in and out along the axis [m/s] (default max(2 speed, 2 cm/s)).
        margin: extra radius [m] the tool keeps from every node at its start and end poses.
    """

    def __init__(self, surface, path: ParamPath, *, tilt: float, radius: float, depth: float,
                 speed: float, tool_length: float = 0.04, plunge_speed: float | None = None,
                 margin: float = 5e-4):
        if not (0 < tilt <= math.pi / 2 + 1e-12):
            raise InputError(f"stroke tilt must be in (0, pi/2] rad, got {tilt}")
        for name, value in (("radius", radius), ("depth", depth), ("speed", speed),
                            ("tool_length", tool_length)):
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"stroke {name} must be > 0, got {value}")
        self.surface, self.path = surface, path
        self.tilt, self.radius, self.depth = float(tilt), float(radius), float(depth)
        self.speed, self.tool_length = float(speed), float(tool_length)
        self.plunge_speed = float(plunge_speed or max(2.0 * speed, 0.02))
        self.border_distance = float(surface.depth(path.uv).min())
        """Smallest distance [m] of the path from the border of the mesh's parameter domain."""
        if self.border_distance < 0:
            raise InputError(f"the stroke's path leaves the mesh (by {-self.border_distance:.3g} m)")
        self._frame(surface, path.uv)
        self.reach = self.depth / math.sin(self.tilt)
        """Distance [m] from the surface point to the tip, along the axis."""
        self.clear_in = self._clearance(0, margin)
        self.clear_out = self._clearance(-1, margin)
        self.t_in = (self.clear_in + self.reach) / self.plunge_speed
        self.t_travel = self.length / self.speed
        self.t_out = (self.clear_out + self.reach) / self.plunge_speed
        self.duration = self.t_in + self.t_travel + self.t_out
        """Time [s] from the start pose (outside) to the end pose (outside)."""

    def _frame(self, surface, uv) -> None:
        """The trace P(s) (k, 3) [m], its arc length s (k,) [m], normals and travel tangents."""
        self.trace = surface.point(uv[:, 0], uv[:, 1])
        self.normals = surface.normal(uv[:, 0], uv[:, 1])
        seg = np.linalg.norm(np.diff(self.trace, axis=0), axis=1)
        self.arclength = np.concatenate([[0.0], np.cumsum(seg)])
        d = np.gradient(self.trace, self.arclength, axis=0)
        d -= np.einsum("ij,ij->i", d, self.normals)[:, None] * self.normals
        self.tangents = d / np.linalg.norm(d, axis=1, keepdims=True)
        self.axes = (-math.cos(self.tilt) * self.tangents + math.sin(self.tilt) * self.normals)
        self.axes /= np.linalg.norm(self.axes, axis=1, keepdims=True)

    @property
    def length(self) -> float:
        """Length of the in-skin path along the surface [m]."""
        return float(self.arclength[-1])

    def _clearance(self, k: int, margin: float) -> float:
        """Distance [m] up the axis from the surface point at sample k where the tip can wait
        without the tool (radius + margin) touching a mesh node."""
        p, a = self.trace[k], self.axes[k]
        c = max(1e-3, self.radius * math.cos(self.tilt) / max(math.sin(self.tilt), 1e-3))
        while c < 1.0:
            tip = p + c * a
            if not inside_cylinder(self.surface.points, tip, tip + self.tool_length * a,
                                   self.radius + margin).any():
                return c
            c *= 1.25
        raise InputError("no start height keeps the tool outside the tissue (within 1 m)")

    def _at(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """(surface point, unit axis) at arc length s [m]."""
        s = min(max(s, 0.0), self.length)
        k = int(np.clip(np.searchsorted(self.arclength, s, side="right") - 1, 0, len(self.arclength) - 2))
        w = (s - self.arclength[k]) / max(self.arclength[k + 1] - self.arclength[k], 1e-300)
        p = (1 - w) * self.trace[k] + w * self.trace[k + 1]
        a = (1 - w) * self.axes[k] + w * self.axes[k + 1]
        return p, a / np.linalg.norm(a)

    def tip(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(tip p0 [m], unit axis) at time t [s] since the stroke began (held outside [0, duration])."""
        if t <= self.t_in:
            p, a = self.trace[0], self.axes[0]
            height = self.clear_in - max(t, 0.0) / self.t_in * (self.clear_in + self.reach)
            return p + height * a, a
        if t <= self.t_in + self.t_travel:
            p, a = self._at(self.speed * (t - self.t_in))
            return p - self.reach * a, a
        p, a = self.trace[-1], self.axes[-1]
        done = min((t - self.t_in - self.t_travel) / self.t_out, 1.0)
        return p + (-self.reach + done * (self.clear_out + self.reach)) * a, a

    def pose(self, t: float) -> Tool:
        """The tool at time t [s] since the stroke began."""
        p0, a = self.tip(t)
        return Tool(p0, p0 + self.tool_length * a, self.radius)

    __call__ = pose

    def tool_path(self, step: float = 1e-3) -> ToolPath:
        """The stroke as keyframes every ``step`` [s] (and at the phase changes)."""
        times = np.union1d(np.arange(0.0, self.duration, step),
                           [self.t_in, self.t_in + self.t_travel, self.duration])
        tips = [self.tip(t) for t in times]
        p0 = np.array([p for p, _ in tips])
        p1 = p0 + self.tool_length * np.array([a for _, a in tips])
        return ToolPath(times, p0, p1, self.radius)
