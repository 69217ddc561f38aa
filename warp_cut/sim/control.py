"""Control: what the user drives, the tool. A pose per step, as a 1 kHz haptic loop sends."""

from __future__ import annotations

from bisect import bisect_right
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
        ends = np.stack([self.p0, self.p1], axis=1)
        self.p0, self.p1 = ends[:, 0], ends[:, 1]  # views: one copy of the keyframes
        self._ends = ends
        """p0 and p1 of each keyframe [m], shape (k, 2, 3)."""
        self._moves = np.diff(ends, axis=0)
        """Their change from each keyframe to the next [m], shape (k - 1, 2, 3)."""
        self._keys = self.times.tolist()
        """The keyframe times [s] as floats, for a ``bisect`` lookup in every step."""

    def endpoints_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The tool's end points at a time.

        Args:
            t: Time [s].

        Returns:
            p0 and p1 [m], each shape (3,).
        """
        # linear between keyframes, held outside (np.interp's rule), one lookup for all six
        times = self._keys
        if t <= times[0] or len(times) == 1:
            ends = self._ends[0].copy()
        elif t >= times[-1]:
            ends = self._ends[-1].copy()
        else:
            k = bisect_right(times, t) - 1
            ends = self._ends[k] + (t - times[k]) / (times[k + 1] - times[k]) * self._moves[k]
        return ends[0], ends[1]

    def pose_at(self, t: float) -> Tool:
        """The Tool at time ``t`` [s] (keyframes were validated once, so no checks here)."""
        p0, p1 = self.endpoints_at(t)
        tool = object.__new__(Tool)
        object.__setattr__(tool, "p0", p0)
        object.__setattr__(tool, "p1", p1)
        object.__setattr__(tool, "radius", self.radius)
        return tool
