"""EventClock: when a cut event is due, the same for the cut in the step and in a worker."""

from __future__ import annotations

import math

__all__ = ["EventClock"]


class EventClock:
    """Cut events every ``interval`` seconds of simulated time, at the step nearest each."""

    def __init__(self):
        self.last = -math.inf
        """Time [s] of the last event."""

    def due(self, time: float, dt: float, interval: float) -> bool:
        """Whether an event is due at the end of the step ending at ``time`` [s] (step ``dt``
        [s]) with events every ``interval`` [s] (0: every step); if so, it is taken."""
        if time - self.last < interval - 0.5 * dt:  # the step nearest
            return False
        self.last = time
        return True
