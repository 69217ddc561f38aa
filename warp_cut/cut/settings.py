"""CutSettings: the cutting parameters a scene or an API caller gives (SI units)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["CutSettings"]


@dataclass(frozen=True)
class CutSettings:
    """Cutting parameters (SI). None means the documented default.

    sweep_radius: radius of the swept circle [m] (default: the tool radius).
    interval: time between cut events [s] (default 1/60, one per rendered frame).
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
    interval: float = 1.0 / 60.0
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
        if not (np.isfinite(self.interval) and self.interval >= 0):
            raise InputError(f"cutting.interval must be >= 0 s, got {self.interval}")
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
