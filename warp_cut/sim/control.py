"""Control: what the user drives, the tool. A pose per step, as a 1 kHz haptic loop sends."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["Tool", "ToolPath"]


def _vec3(value, name: str) -> np.ndarray:
    """``value`` as three finite floats [m], shape (3,).

    Raises:
        InputError: Another shape, or a non-finite value.
    """
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be three finite numbers [m], got {value!r}")
    return arr


@dataclass(frozen=True, eq=False)
class Tool:
    """A cylindrical tool pose.

    Attributes:
        p0: The tip [m], shape (3,).
        p1: The other end of the axis [m], shape (3,).
        radius: Cylinder radius [m], >= 0.

    Raises:
        InputError: A non-finite end point or a negative or non-finite radius.
    """

    p0: np.ndarray
    p1: np.ndarray
    radius: float

    def __post_init__(self):
        object.__setattr__(self, "p0", _vec3(self.p0, "tool.p0"))
        object.__setattr__(self, "p1", _vec3(self.p1, "tool.p1"))
        r = float(self.radius)
        if not np.isfinite(r) or r < 0:
            raise InputError(f"tool.radius must be a finite length >= 0 m, got {self.radius}")
        object.__setattr__(self, "radius", r)

    @property
    def length(self) -> float:
        """|p1 - p0| [m]."""
        return float(np.linalg.norm(self.p1 - self.p0))


class ToolPath:
    """Keyframed tool motion, linear in between and held constant outside the keyframe range.

    Args:
        times: Keyframe times [s], shape (k,), strictly increasing.
        p0: Tips [m], shape (k, 3).
        p1: Other axis ends [m], shape (k, 3).
        radius: Cylinder radius [m], >= 0.

    Raises:
        InputError: Mismatched or empty keyframes, times not increasing, or non-finite values.
    """

    def __init__(self, times, p0, p1, radius: float):
        self.times = np.asarray(times, dtype=np.float64).ravel()
        self.p0 = np.asarray(p0, dtype=np.float64).reshape(-1, 3)
        self.p1 = np.asarray(p1, dtype=np.float64).reshape(-1, 3)
        if len(self.times) == 0 or len(self.p0) != len(self.times) or len(self.p1) != len(self.times):
            raise InputError("tool keyframes need matching t, p0 and p1 (at least one)")
        if np.any(np.diff(self.times) <= 0):
            raise InputError("tool keyframe times must be strictly increasing")
        if not (np.all(np.isfinite(self.p0)) and np.all(np.isfinite(self.p1))
                and np.all(np.isfinite(self.times))):
            raise InputError("tool keyframes must be finite")
        self.radius = Tool(self.p0[0], self.p1[0], radius).radius

    def endpoints_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The tool's end points at a time.

        Args:
            t: Time [s].

        Returns:
            p0 and p1 [m], each shape (3,).
        """
        # linear between keyframes, held outside (np.interp's rule), one lookup for all six
        times = self.times
        if t <= times[0] or len(times) == 1:
            return self.p0[0].copy(), self.p1[0].copy()
        if t >= times[-1]:
            return self.p0[-1].copy(), self.p1[-1].copy()
        k = int(np.searchsorted(times, t, side="right")) - 1
        w = (t - times[k]) / (times[k + 1] - times[k])
        p0 = self.p0[k] + w * (self.p0[k + 1] - self.p0[k])
        p1 = self.p1[k] + w * (self.p1[k + 1] - self.p1[k])
        return p0, p1

    def pose_at(self, t: float) -> Tool:
        """The Tool at time ``t`` [s] (keyframes were validated once, so no checks here)."""
        p0, p1 = self.endpoints_at(t)
        tool = object.__new__(Tool)
        object.__setattr__(tool, "p0", p0)
        object.__setattr__(tool, "p1", p1)
        object.__setattr__(tool, "radius", self.radius)
        return tool
