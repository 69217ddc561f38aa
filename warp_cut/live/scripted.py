"""Scripted scalpel strokes: a LiveCut driven by a program instead of a hand (tests, benchmarks).

``straight_cut`` sets the targets a user would: down along the blade's axis into the tissue,
along the heading, up along the axis out of it and back to where the scene starts the
scalpel, each time waiting until
the scalpel has arrived, whether the run steps on its own thread (real time) or not (then the
script steps it).
"""

from __future__ import annotations

import time

import numpy as np

from .engine import LiveCut

__all__ = ["straight_cut", "stroke_targets", "wait_until_arrived"]


def wait_until_arrived(live: LiveCut, *, timeout: float = 120.0, settle: float = 0.0) -> None:
    """Wait until the scalpel is at its target, then ``settle`` [s] more of simulated time.
    Steps the run itself when no thread does. Raises TimeoutError after ``timeout`` [s] of wall
    time, RuntimeError if the run stopped with an error."""
    threaded = live.running
    deadline = time.perf_counter() + timeout
    end = None
    while True:
        if live.error:
            raise RuntimeError(f"the run stopped: {live.error}")
        if live.arrived and end is None:
            end = live.status().time + settle
        if end is not None and live.status().time >= end - 1e-9:
            return
        if time.perf_counter() > deadline:
            raise TimeoutError(f"the scalpel did not arrive within {timeout} s")
        if threaded:
            time.sleep(0.01)
        else:
            live.advance(live.steps_per_frame)


def stroke_targets(live: LiveCut, length: float, depth: float = 0.004) -> dict:
    """The tips [m] of a straight stroke from the scalpel's target now: ``in`` (along the axis
    to ``depth`` [m] below the rest surface), ``along`` (``length`` [m] along the heading) and
    ``out`` (back up along the axis)."""
    start = live.target
    axis = start.axis
    below = depth + float(start.tip[2]) - live.surface_height(*start.tip[:2])
    tip_in = start.tip - (below / axis[2]) * axis
    heading = np.radians(start.heading_deg)
    tip_end = tip_in + length * np.array([np.cos(heading), np.sin(heading), 0.0])
    return {"in": tip_in, "along": tip_end, "out": tip_end + (start.tip - tip_in)}


def straight_cut(live: LiveCut, length: float, *, depth: float = 0.004, settle: float = 0.1,
                 back_to_start: bool = True, timeout: float = 300.0) -> None:
    """Cut ``length`` [m] along the scalpel's heading, ``depth`` [m] below the rest surface:
    in along the axis, along, out along the axis, back to the start pose (unless
    ``back_to_start`` is false); ``settle`` [s] after each move."""
    for tip in stroke_targets(live, length, depth).values():
        live.set_target(tip)
        wait_until_arrived(live, timeout=timeout, settle=settle)
    if back_to_start:
        live.return_to_start()
        wait_until_arrived(live, timeout=timeout, settle=settle)
