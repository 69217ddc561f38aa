"""Tick latency of a fixed-rate loop: the wall time of every step and the tool force it returns.

A haptic device asks for a tool force once per tick (1 ms); an answer later than the tick is
felt as a jolt. So a run measures every step on its own (one ``Simulator.step`` call per
tick, as a haptic loop makes it) and reports the distribution: ``tick_ms`` {p50, p99, max,
over_budget} with the budget the step dt, over the ticks after the first (which loads the
kernels and records the launches). The force a device would render must also stay
continuous when the cut edits the mesh under the tool: ``tool_force_jump_n`` is the largest
change of the tool force from one tick to the next, overall and across the ticks that follow
a topology edit (a cut event).
"""

from __future__ import annotations

import gc
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

__all__ = ["TickLog", "Pacer", "wait_until", "frozen_gc"]


def wait_until(deadline: float, spin: float = 2e-3) -> None:
    """Return at the wall time ``deadline`` (``time.perf_counter`` seconds), at once if it has
    passed: sleep until ``spin`` [s] before it, then spin (a sleep wakes up late)."""
    remaining = deadline - time.perf_counter()
    if remaining > spin:
        time.sleep(remaining - spin)
    while time.perf_counter() < deadline:
        pass


class Pacer:
    """Holds a loop to one tick per ``period`` [s] of wall time, as a haptic device paces it:
    ``wait(k)`` returns once ``k + 1`` periods have passed since ``start`` (when it was made,
    or when the loop sets it as it starts; at once if the loop is late; ``wait_until``)."""

    def __init__(self, period: float):
        self.period = float(period)
        self.start = time.perf_counter()

    def wait(self, k: int) -> None:
        wait_until(self.start + (k + 1) * self.period)


class TickLog:
    """Wall time [s] and tool force [N] of every tick, and which ticks followed a cut event.

    Args:
        capacity: ticks expected (the arrays grow if more are stepped).
        budget: a tick's deadline [s], normally the step dt.
        cpu_time: also record the thread's CPU time per tick (``cpu_seconds``): the tick
            without the time the operating system gave other processes.
    """

    def __init__(self, capacity: int, budget: float, *, cpu_time: bool = False):
        self.budget = float(budget)
        self.count = 0
        self.seconds = np.zeros(max(1, int(capacity)))
        """Wall time of each tick [s], valid up to ``count``."""
        self.cpu_seconds = np.zeros(len(self.seconds)) if cpu_time else None
        """CPU time of the stepping thread in each tick [s] (with ``cpu_time``), else None."""
        self.forces = np.zeros((len(self.seconds), 3))
        """Tool force after each tick [N], (ticks, 3)."""
        self.after_edit = np.zeros(len(self.seconds), dtype=bool)
        """True for a tick whose step is the first after a topology edit."""
        self._edited = False
        self._frame_start = 0

    def step(self, sim, tool=None) -> None:
        """One tick: ``sim.step(1, tool=tool)``, timed, and its tool force recorded."""
        version = sim.model.topology_version
        if self.cpu_seconds is not None:
            cpu = time.thread_time()
        start = time.perf_counter()
        sim.step(1, tool=tool)
        elapsed = time.perf_counter() - start
        k = self.count
        if k == len(self.seconds):
            self._grow()
        if self.cpu_seconds is not None:
            self.cpu_seconds[k] = time.thread_time() - cpu
        self.seconds[k] = elapsed
        self.forces[k] = sim.tool_force
        self.after_edit[k] = self._edited
        self._edited = sim.model.topology_version != version
        self.count = k + 1

    def _grow(self) -> None:
        n = len(self.seconds)
        self.seconds = np.concatenate([self.seconds, np.zeros(n)])
        if self.cpu_seconds is not None:
            self.cpu_seconds = np.concatenate([self.cpu_seconds, np.zeros(n)])
        self.forces = np.concatenate([self.forces, np.zeros((n, 3))])
        self.after_edit = np.concatenate([self.after_edit, np.zeros(n, dtype=bool)])

    def frame_max_ms(self) -> float:
        """Largest tick [ms] since the previous call (0 when no tick was stepped)."""
        start, self._frame_start = self._frame_start, self.count
        return float(self.seconds[start:self.count].max() * 1e3) if self.count > start else 0.0

    def force_jumps(self) -> np.ndarray:
        """|F(k) - F(k - 1)| [N] for ticks k = 1 .. count - 1."""
        return np.linalg.norm(np.diff(self.forces[: self.count], axis=0), axis=1)

    def tick_metrics(self, cpu: bool = False) -> dict:
        """``tick_ms``: p50, p99, max [ms] and over_budget (how many are longer than the
        budget) of the ticks after the first; first_ms, the first tick (it loads the kernels
        and records the launches: a haptic loop takes it before the device's clock starts);
        budget_ms; ticks, all of them. Of the CPU times with ``cpu``."""
        ms = (self.cpu_seconds if cpu else self.seconds)[: self.count] * 1e3
        out = {"p50": None, "p99": None, "max": None, "over_budget": 0,
               "first_ms": float(ms[0]) if len(ms) else None, "budget_ms": self.budget * 1e3,
               "ticks": int(len(ms))}
        steady = ms[1:]
        if len(steady):
            out.update(p50=float(np.percentile(steady, 50)), p99=float(np.percentile(steady, 99)),
                       max=float(steady.max()),
                       over_budget=int(np.count_nonzero(steady > self.budget * 1e3)))
        return out

    def force_jump_metrics(self) -> dict:
        """``tool_force_jump_n``: max and p99 of the tick-to-tick force change [N], the tick of
        the largest (max_at_tick, counted from 0), and max_after_cut: the largest change into a
        tick that follows a topology edit (None without edits; cut_ticks counts those ticks)."""
        jumps = self.force_jumps()
        if not len(jumps):
            return {"max": None, "p99": None, "max_at_tick": None, "max_after_cut": None, "cut_ticks": 0}
        after = self.after_edit[1: self.count]
        return {"max": float(jumps.max()), "p99": float(np.percentile(jumps, 99)),
                "max_at_tick": int(np.argmax(jumps)) + 1,
                "max_after_cut": float(jumps[after].max()) if after.any() else None,
                "cut_ticks": int(np.count_nonzero(after))}

    def metrics(self) -> dict:
        """The metrics.json entries: ``tick_ms`` and ``tool_force_jump_n``."""
        return {"tick_ms": self.tick_metrics(), "tool_force_jump_n": self.force_jump_metrics()}


@contextmanager
def frozen_gc() -> Iterator[None]:
    """Collect garbage once, then leave every object alive so far out of later collections
    (``gc.freeze``) until the block ends.

    A full collection walks every tracked object, and after importing Warp, numpy and
    warp_cut those are over a hundred thousand: tens of milliseconds inside one tick when it
    happens mid-loop. Frozen, later collections walk only what the loop itself allocates.
    """
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()
