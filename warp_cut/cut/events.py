"""EventClock: when a cut event is due, the same for the cut in the step and in a worker."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["EventClock"]


class EventClock:
    """Cut events on a clock (every ``interval`` seconds of simulated time, at the step nearest
    each) or by the blade's travel (each time the tool's tip has moved ``distance`` metres
    since the last event, at once when the tool comes back after ``reset``, never while it is
    still)."""

    def __init__(self):
        self.last = -math.inf
        """Time [s] of the last event."""
        self.tip: list[float] | None = None
        """The tool's tip at the last event [m], three floats (None: none since the tool came)."""

    def due(self, time: float, dt: float, tip, interval: float | None, distance: float | None) -> bool:
        """Whether an event is due at the end of the step ending at ``time`` [s] (step ``dt``
        [s]) with the tool's tip at ``tip`` [m] (3,): on the clock every ``interval`` [s] (0:
        every step) when ``distance`` is None, else each ``distance`` [m] of the tip's travel.
        If so, it is taken. ``tip`` None: no tool (by travel, then none is due until it is
        back, and then at once)."""
        if distance is not None and tip is None:
            self.reset()
            return False
        tip = None if tip is None else np.asarray(tip, dtype=float).tolist()  # floats: math.dist's fast path
        if distance is None:
            if time - self.last < interval - 0.5 * dt:  # the step nearest
                return False
        elif self.tip is not None and math.dist(tip, self.tip) < distance:
            return False
        self.last, self.tip = time, tip
        return True

    def reset(self) -> None:
        """The tool has gone: by travel, the next event is due as soon as it is back."""
        self.tip = None
