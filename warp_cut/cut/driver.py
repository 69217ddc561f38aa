"""The cut driver: what a simulation holds to cut its tissue, whichever process does the work.

Two drivers implement ``CutDriver``: the ``Cutter`` runs every cut event in the step that
makes it (reproducible: the cut of a run is the same on any machine), the
``BackgroundCutter`` runs the same Cutter in a worker process and applies its edits between
the loop's ticks (a 1 kHz haptic loop keeps its ticks). ``make_cut_driver`` builds the one a
``CutSettings`` asks for (``worker``); the simulator, the run loop, the CLI and the live
session hold a ``CutDriver`` and never ask which.

A driver acts on the simulation through the ``CutHost`` protocol (``warp_cut.cut.host``) it
is given at every call, so the cut never imports the simulator.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from ..sim.model import TissueModel
from .background import BackgroundCutter
from .cutter import Cutter
from .host import CutHost
from .settings import CutSettings

__all__ = ["CutDriver", "make_cut_driver"]


class CutDriver(Protocol):
    """A cut attached to a simulation: ``after_step(host)`` after every step; the measures of
    the cut as of the latest edit applied.

    Attributes:
        settings: The cutting parameters (a new value applies from the next event).
    """

    settings: CutSettings

    def after_step(self, host: CutHost) -> None:
        """Advance the cut after a step of ``host``."""

    def flush(self, host: CutHost) -> None:
        """Apply every edit still in flight (nothing to do for a cut in the step)."""

    def end_incision(self, host: CutHost) -> None:
        """End the incision in progress now (its edit applied on return)."""

    def close(self) -> None:
        """Release what outlives the simulation (a worker process); idempotent."""

    @property
    def totals(self) -> dict:
        """The cut's counters (``metrics.json`` -> ``cut``)."""

    @property
    def unfilled_holes(self) -> int:
        """Holes left open."""

    @property
    def incisions(self) -> list:
        """The incisions; each has ``pairs()``, its paired lip nodes (k, 2)."""

    @property
    def incision_controls(self) -> np.ndarray | None:
        """Control points [m] of the latest incision's Bezier chain, (3 s + 1, 3), or None."""

    def incision_width(self, positions: np.ndarray) -> float:
        """Median distance [m] between paired lip nodes at ``positions`` (node_count, 3)."""

    def metrics(self, positions: np.ndarray) -> dict:
        """``cut``, ``incision`` and ``latency_ms`` of metrics.json (after ``flush``)."""

    def gap_profile(self, positions: np.ndarray) -> dict:
        """The opening of every incision along its length (after ``flush``)."""

    def live_new_triangles(self) -> np.ndarray:
        """Rows (into ``model.triangles``) of the live triangles the cut made (after ``flush``)."""

    def latency_summary(self) -> dict:
        """p50 / p99 / max latency per stage of the cut events [ms] (after ``flush``)."""

    def call(self, host: CutHost, name: str, *args):
        """The Cutter's ``name(*args)`` (or attribute ``name``), after every edit in flight
        has been applied."""


def make_cut_driver(model: TissueModel, settings: CutSettings, device: str,
                    limit_tracker: Callable) -> CutDriver:
    """The driver ``settings`` asks for: a ``BackgroundCutter`` with ``settings.worker``, else a
    ``Cutter`` on ``device``. ``limit_tracker(model)`` is the simulation's integrator's
    step-limit tracker (``SolverBase.limit_tracker``): a worker follows the stable step with it
    on its replica and sends the limit with every edit."""
    if settings.worker:
        return BackgroundCutter(model, settings, limit_tracker=limit_tracker)
    return Cutter(model, settings, device)
