"""Step-limit trackers: each solver's stable step, kept up to date edit by edit.

A solver class says how its stable step follows a topology edit (``limit_tracker``): the
semi-implicit step is bounded element by element (``warp_cut.sim.stability.ElementRates``), so
an edit rates again only the elements at the nodes it touched; the other integrators' limits
(the explicit parts of XPBD and backward Euler) are worked out again from the model. A tracker
is host-side state of the model alone, so it outlives the solver's device arrays (a solver
remade after a reallocation keeps it) and can run where the edit is made (a cut worker's
replica, which then sends the limit with the edit).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from ..sim.model_change import ModelChange
from ..sim.stability import ElementRates, StepLimit

__all__ = ["StepLimitTracker", "IncrementalLimit", "RecomputedLimit", "GivenLimit"]


class StepLimitTracker(Protocol):
    """The stable step of one integrator for one model, followed through edits."""

    limit: StepLimit

    def update(self, change: ModelChange) -> StepLimit:
        """The limit after ``change`` (also kept as ``limit``)."""


class IncrementalLimit:
    """The semi-implicit step's element bounds: an edit rates again the elements at the nodes
    it touched (``ElementRates.update``)."""

    def __init__(self, model, links: bool = True):
        self.rates = ElementRates(model, links)
        self.limit = self.rates.limit()

    def update(self, change: ModelChange) -> StepLimit:
        self.rates.update(change)
        self.limit = self.rates.limit()
        return self.limit


class RecomputedLimit:
    """A limit worked out from the whole model after every edit (``compute(model)``)."""

    def __init__(self, model, compute: Callable[[object], StepLimit]):
        self.model = model
        self._compute = compute
        self.limit = compute(model)

    def update(self, change: ModelChange) -> StepLimit:
        self.limit = self._compute(self.model)
        return self.limit


class GivenLimit:
    """The limit an edit's maker sent with the edit (``ModelChange.step_limit``): nothing here
    follows the model, so a later edit without a limit needs the integrator's own tracker
    built afresh (``SolverBase.notify_model_changed``)."""

    def __init__(self, limit: StepLimit):
        self.limit = limit

    def update(self, change: ModelChange) -> StepLimit:
        if change.step_limit is None:
            raise ValueError("GivenLimit follows only changes that carry their step limit")
        self.limit = change.step_limit
        return self.limit
