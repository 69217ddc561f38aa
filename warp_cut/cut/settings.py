"""CutSettings: the cutting parameters a scene or an API caller gives (SI units)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["CutSettings", "DEFAULT_TRAVEL", "MAX_TRAVEL", "ONE_EVENT_RULE"]

DEFAULT_TRAVEL = 1.0
"""Default travel between cut events, in lip spacings (``benchmarks/results/event_travel.md``)."""
MAX_TRAVEL = 4.0
"""Largest travel between cut events [lip spacings]: farther, several stations fall due in one
event and the slit trails the blade by more than it opens in one."""
ONE_EVENT_RULE = ("give cutting.interval (events on a clock) or cutting.travel (events by the blade's travel), "
                  "not both")
"""Why settings with both event rules are refused."""


@dataclass(frozen=True)
class CutSettings:
    """Cutting parameters (SI). None means the documented default.

    sweep_radius: radius of the swept circle [m] (default: the tool radius).
    interval: cut events on a clock, one every this many seconds of simulated time (0: after
        every step). Give ``interval`` or ``travel``, not both.
    travel: cut events by the blade's travel: one each time the tool's tip has moved this
        fraction of the lip spacing since the last event (and one at once when the tool
        comes back after leaving), none while it rests or hovers still. Neither given: events
        by travel, ``DEFAULT_TRAVEL`` (chosen from ``benchmarks/results/event_travel.md``).
    force_threshold: cutting starts once |tool force| >= this [N] (default 0: any contact).
    spacing: lip station spacing [m] (default: median spring rest length).
    tolerance: Bezier fit tolerance [m] (default 0.1 x spacing).
    lip_offset: half the initial slit width [m] (default 0.25 x sweep radius).
    worker: run the cut's host work in a worker process (``warp_cut.cut.background``): a cut
        event no longer lands in the step that made it, for a loop that must keep its ticks.
    max_lag: with ``worker``, the steps an event may stay in flight before the loop waits for
        its edit (None: never wait; 1: every edit lands two steps after its event, the same
        run to run).
    keep_islands: a piece of skin the incisions cut free (an excision) stays as a free piece
        instead of being removed (default False: removed and counted).
    """

    sweep_radius: float | None = None
    interval: float | None = None
    travel: float | None = None
    force_threshold: float = 0.0
    spacing: float | None = None
    tolerance: float | None = None
    lip_offset: float | None = None
    worker: bool = False
    max_lag: int | None = None
    keep_islands: bool = False

    def __post_init__(self):
        for name in ("sweep_radius", "spacing", "tolerance", "lip_offset"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"cutting.{name} must be > 0 m, got {v}")
        if self.interval is not None and not (np.isfinite(self.interval) and self.interval >= 0):
            raise InputError(f"cutting.interval must be >= 0 s, got {self.interval}")
        if self.travel is not None and not (np.isfinite(self.travel) and 0 < self.travel <= MAX_TRAVEL):
            raise InputError(f"cutting.travel must be in (0, {MAX_TRAVEL:g}] lip spacings, got {self.travel}")
        if self.interval is not None and self.travel is not None:
            raise InputError(ONE_EVENT_RULE)
        if not (np.isfinite(self.force_threshold) and self.force_threshold >= 0):
            raise InputError(f"cutting.force_threshold must be >= 0 N, got {self.force_threshold}")
        for name in ("worker", "keep_islands"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"cutting.{name} must be true or false, got {getattr(self, name)!r}")
        if self.max_lag is not None:
            if isinstance(self.max_lag, bool) or not isinstance(self.max_lag, (int, np.integer)) or self.max_lag < 1:
                raise InputError(f"cutting.max_lag must be an integer >= 1 step, or None, got {self.max_lag!r}")
            if not self.worker:
                raise InputError("cutting.max_lag applies to a cut in a worker process (cutting.worker = true)")

    def event_rule(self, spacing: float) -> tuple[float | None, float | None]:
        """When cut events fall due, for lip spacing ``spacing`` [m]: (interval [s], None) on a
        clock, or (None, distance [m]) by the tip's travel."""
        if self.interval is not None:
            return self.interval, None
        return None, (DEFAULT_TRAVEL if self.travel is None else self.travel) * spacing

    def lip_spacing(self, rest_lengths) -> float:
        """The lip station spacing [m]: ``spacing``, or the median of the tissue's spring rest
        lengths [m] (s,)."""
        return self.spacing or float(np.median(rest_lengths))
