"""Real-time pacing of a live run: how many steps are due now, and how fast the run really goes.

The simulation advances in steps of dt [s] (1 ms, a haptic device's period). The clock anchors
simulated time to wall time; the steps due are those whose end lies at or before "now". When the
simulation falls more than ``max_lag`` behind it stops trying to catch up (the motion would
become a burst): the clock re-anchors and counts the time given up in ``behind``. The rate meter
reports the real-time factor over the last second: simulated over wall time (1 when the
simulation keeps up) and simulated over compute time (how much faster it could go).
"""

from __future__ import annotations

import collections
import math
import time

__all__ = ["RealTimeClock", "RateMeter"]


class RealTimeClock:
    """Steps due at a wall time, for a simulation that should run in real time.

    Args:
        max_lag: largest delay [s] the simulation may catch up on; beyond it the clock
            re-anchors and the delay is added to ``behind`` [s].
        now: a wall clock [s] (time.perf_counter; tests pass their own).
    """

    def __init__(self, max_lag: float = 0.1, now=time.perf_counter):
        self.max_lag = float(max_lag)
        self.now = now
        self.behind = 0.0
        """Simulated time [s] given up because the simulation could not keep up."""
        self._wall0 = None
        self._sim0 = 0.0

    def anchor(self, sim_time: float) -> None:
        """Make ``sim_time`` [s] correspond to now (after a pause, a rebuild or a save)."""
        self._wall0 = self.now()
        self._sim0 = float(sim_time)

    def steps_due(self, sim_time: float, dt: float) -> int:
        """Steps of dt [s] to run now to bring ``sim_time`` [s] up to the wall clock."""
        if self._wall0 is None:
            self.anchor(sim_time)
        lag = self._sim0 + (self.now() - self._wall0) - sim_time
        if lag > self.max_lag:  # run one step, ending now; give up the rest
            self.behind += lag - dt
            self.anchor(sim_time + dt)
            lag = dt
        return max(0, math.floor(lag / dt + 1e-9))

    def wait_time(self, sim_time: float, dt: float) -> float:
        """Wall time [s] until the next step is due."""
        if self._wall0 is None:
            return 0.0
        return max(0.0, sim_time + dt - self._sim0 - (self.now() - self._wall0))


class RateMeter:
    """Real-time factors over a sliding window of ``window`` [s] of wall time."""

    def __init__(self, window: float = 1.0, now=time.perf_counter):
        self.window = float(window)
        self.now = now
        self._samples: collections.deque = collections.deque()

    def clear(self) -> None:
        """Forget the samples (a pause or a rebuild breaks the run)."""
        self._samples.clear()

    def add(self, sim_time: float, compute_time: float) -> None:
        """Note the simulated time [s] and the total compute time [s] spent so far, now."""
        t = self.now()
        self._samples.append((t, float(sim_time), float(compute_time)))
        while len(self._samples) > 2 and t - self._samples[1][0] >= self.window:
            self._samples.popleft()

    def factors(self) -> tuple[float | None, float | None]:
        """(simulated / wall time, simulated / compute time) over the window; None until known."""
        if len(self._samples) < 2:
            return None, None
        (w0, s0, c0), (w1, s1, c1) = self._samples[0], self._samples[-1]
        wall, compute, sim = w1 - w0, c1 - c0, s1 - s0
        return (sim / wall if wall > 0 else None, sim / compute if compute > 0 else None)
