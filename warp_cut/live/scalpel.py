"""The scalpel held in a live run: its pose and its motion towards the pose the user sets.

A pose is the tip p0 [m], the tilt [deg] (angle of the axis above the XY plane; 90 is upright)
and the heading [deg] (the direction in the XY plane the blade cuts towards; the axis leans
back from the tip, away from it). The scene files' scalpel, axis (-0.5, 0, 0.866) from the tip,
has tilt 60 and heading 0.

The user moves a target pose (drag handle, sliders); the tool follows it at a bounded speed and
turn rate, so the simulation sees a continuous motion with one pose per step, as a haptic
device sends, and a cut follows the path the blade really took.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..sim.control import Tool

__all__ = ["ScalpelPose", "ToolMotion", "Trajectory", "MIN_TILT_DEG"]

MIN_TILT_DEG = 5.0
"""Smallest tilt [deg]: the blade always points down into the tissue from above."""


@dataclass(frozen=True, eq=False)
class ScalpelPose:
    """Tip position (3,) [m], tilt above the XY plane [deg] and heading in it [deg]."""

    tip: np.ndarray
    tilt_deg: float
    heading_deg: float

    def __post_init__(self):
        tip = np.asarray(self.tip, dtype=np.float64)
        if tip.shape != (3,) or not np.all(np.isfinite(tip)):
            raise InputError(f"scalpel tip must be three finite numbers [m], got {self.tip!r}")
        tilt, heading = float(self.tilt_deg), float(self.heading_deg)
        if not (math.isfinite(tilt) and MIN_TILT_DEG <= tilt <= 90.0):
            raise InputError(f"scalpel tilt must be in [{MIN_TILT_DEG}, 90] deg, got {self.tilt_deg}")
        if not math.isfinite(heading):
            raise InputError(f"scalpel heading must be a finite angle [deg], got {self.heading_deg}")
        object.__setattr__(self, "tip", tip)
        object.__setattr__(self, "tilt_deg", tilt)
        object.__setattr__(self, "heading_deg", (heading + 180.0) % 360.0 - 180.0)

    @property
    def axis(self) -> np.ndarray:
        """Unit direction (3,) from the tip along the tool."""
        tilt, heading = math.radians(self.tilt_deg), math.radians(self.heading_deg)
        return np.array([-math.cos(tilt) * math.cos(heading), -math.cos(tilt) * math.sin(heading),
                         math.sin(tilt)])

    def tool(self, length: float, radius: float) -> Tool:
        """The cylinder of this pose: p0 the tip, p1 = tip + length x axis [m]."""
        return Tool(self.tip, self.tip + length * self.axis, radius)

    def moved(self, *, tip=None, tilt_deg=None, heading_deg=None) -> ScalpelPose:
        """A copy with the given parts replaced."""
        return ScalpelPose(self.tip if tip is None else tip,
                           self.tilt_deg if tilt_deg is None else tilt_deg,
                           self.heading_deg if heading_deg is None else heading_deg)

    @classmethod
    def from_axis(cls, tip, axis) -> ScalpelPose:
        """The pose with tip (3,) [m] whose axis points along ``axis`` (3,); an axis lower than
        MIN_TILT_DEG above the XY plane (or pointing down) is raised to it."""
        a = np.asarray(axis, dtype=np.float64)
        norm = float(np.linalg.norm(a))
        if not (np.all(np.isfinite(a)) and norm > 0):
            raise InputError(f"scalpel axis must be a finite non-zero vector, got {axis!r}")
        a = a / norm
        tilt = math.degrees(math.asin(min(1.0, max(-1.0, a[2]))))
        horizontal = math.hypot(a[0], a[1])
        heading = math.degrees(math.atan2(-a[1], -a[0])) if horizontal > 1e-12 else 0.0
        return cls(tip, min(90.0, max(MIN_TILT_DEG, tilt)), heading)

    @classmethod
    def from_tool(cls, tool: Tool) -> ScalpelPose:
        """The pose of a Tool (its tip and axis)."""
        return cls.from_axis(tool.p0, tool.p1 - tool.p0)


def _turn(a: np.ndarray, b: np.ndarray, angle: float) -> np.ndarray:
    """Unit vector ``angle`` [rad] from unit a towards unit b along the great circle (b if closer)."""
    full = math.acos(min(1.0, max(-1.0, float(np.dot(a, b)))))
    if full <= angle or full < 1e-12:
        return b
    w = math.sin(full)
    f = angle / full
    out = (math.sin((1.0 - f) * full) * a + math.sin(f * full) * b) / w
    return out / np.linalg.norm(out)


@dataclass(frozen=True, eq=False)
class Trajectory:
    """The tool's motion from ``start`` at ``t0`` [s] towards ``target``: the tip at ``speed``
    [m/s], the axis at ``turn_rate`` [rad/s], stopping there. A pure function of time, so the
    Simulator may evaluate it at any step of a batch (``Simulator.step(n, tool=trajectory)``)."""

    start: ScalpelPose
    target: ScalpelPose
    t0: float
    speed: float
    turn_rate: float
    length: float
    radius: float

    def __post_init__(self):
        shift = self.target.tip - self.start.tip
        dist = float(np.linalg.norm(shift))
        a0, a1 = self.start.axis, self.target.axis
        angle = math.acos(min(1.0, max(-1.0, float(a0 @ a1))))
        arrival = self.t0 + max(dist / self.speed, angle / self.turn_rate)
        for name, value in (("_shift", shift), ("_dist", dist), ("_axes", (a0, a1)),
                            ("_arrival", arrival), ("_end", self.target.tool(self.length, self.radius))):
            object.__setattr__(self, name, value)

    def _tip_axis(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        elapsed = max(0.0, t - self.t0)
        step = min(self._dist, self.speed * elapsed)
        tip = self.start.tip + (self._shift * (step / self._dist) if self._dist > 0 else 0.0)
        return tip, _turn(*self._axes, self.turn_rate * elapsed)

    def pose(self, t: float) -> ScalpelPose:
        """The scalpel pose at time t [s]."""
        if t >= self._arrival:
            return self.target
        return ScalpelPose.from_axis(*self._tip_axis(t))

    def __call__(self, t: float) -> Tool:
        """The Tool at time t [s] (the poses were checked when made: no checks per step)."""
        if t >= self._arrival:
            return self._end
        tip, axis = self._tip_axis(t)
        tool = object.__new__(Tool)
        object.__setattr__(tool, "p0", tip)
        object.__setattr__(tool, "p1", tip + self.length * axis)
        object.__setattr__(tool, "radius", self.radius)
        return tool


class ToolMotion:
    """The tool the user drives: the pose now, the target pose, and the limits of the motion.

    Args:
        pose: the pose at ``time``.
        length: tool length [m] (> 0); radius: tool radius [m] (>= 0).
        speed: largest tip speed [m/s] (> 0); turn_rate: largest turn rate of the axis [deg/s].
        time: simulated time of ``pose`` [s].
    """

    def __init__(self, pose: ScalpelPose, *, length: float, radius: float, speed: float = 0.02,
                 turn_rate: float = 90.0, time: float = 0.0):
        if not (math.isfinite(length) and length > 0):
            raise InputError(f"tool length must be > 0 m, got {length}")
        self.length = float(length)
        self.radius = float(Tool(pose.tip, pose.tip, radius).radius)
        self.pose = pose
        self.target = pose
        self.time = float(time)
        self.speed = 0.0
        self.turn_rate = 0.0
        self.set_limits(speed, turn_rate)

    def set_limits(self, speed: float, turn_rate: float) -> None:
        """Largest tip speed [m/s] and axis turn rate [deg/s], both > 0."""
        if not (math.isfinite(speed) and speed > 0):
            raise InputError(f"tool speed must be > 0 m/s, got {speed}")
        if not (math.isfinite(turn_rate) and turn_rate > 0):
            raise InputError(f"tool turn rate must be > 0 deg/s, got {turn_rate}")
        self.speed, self.turn_rate = float(speed), float(turn_rate)

    def trajectory(self) -> Trajectory:
        """The motion from the current pose towards the current target (fixed from now on)."""
        return Trajectory(self.pose, self.target, self.time, self.speed,
                          math.radians(self.turn_rate), self.length, self.radius)

    def advance(self, trajectory: Trajectory, t: float) -> None:
        """Record that the tool followed ``trajectory`` up to time t [s]."""
        self.pose = trajectory.pose(t)
        self.time = float(t)

    @property
    def tool(self) -> Tool:
        """The tool at the current pose."""
        return self.pose.tool(self.length, self.radius)

    @property
    def arrived(self) -> bool:
        """Whether the tool is at its target (within 1 um and 0.01 deg)."""
        return (float(np.linalg.norm(self.pose.tip - self.target.tip)) < 1e-6
                and math.degrees(math.acos(min(1.0, float(self.pose.axis @ self.target.axis)))) < 1e-2)
