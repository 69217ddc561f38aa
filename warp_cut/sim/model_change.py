"""ModelChange: the notice a topology edit sends to whatever derives from the model.

An edit (the cut's ``TopologyEditor``, or a replica applying another process's edit) changes
the model's slot tables in place. The device mirror finds the changed rows itself
(``SlotTable`` remembers them); the solver needs to know which nodes the edit touched to rate
the stable step again there, and the simulation where to place the nodes it made. One typed
record carries that (as Newton's ``notify_model_changed`` does), so no caller passes loose
arrays or sets solver flags from outside.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .stability import StepLimit

__all__ = ["ModelChange"]


def _slots(values) -> np.ndarray:
    return np.asarray(sorted({int(v) for v in values}), dtype=np.int64)


@dataclass(frozen=True)
class ModelChange:
    """What one topology edit changed (slot indices, sorted, unique).

    Attributes:
        new_nodes: Nodes the edit made, (k,).
        new_positions: Their current positions [m], (k, 3) (they start at rest: zero velocity).
        touched_nodes: Nodes whose springs, triangles, residual links or mass changed, (t,)
            (deleted ones included: their elements are gone).
        deleted_nodes, deleted_springs, deleted_triangles, deleted_links: Slots the edit deleted.
        hinge_nodes: Nodes of the hinges the edit made or deleted, (h,).
        step_limit: The stable step after the edit when the edit's maker already worked it out
            with the simulation's own integrator (a worker's replica, ``warp_cut.cut.cut_worker``),
            else None: the solver works it out.
    """

    new_nodes: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    new_positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    touched_nodes: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    deleted_nodes: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    deleted_springs: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    deleted_triangles: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    deleted_links: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    hinge_nodes: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    step_limit: StepLimit | None = None

    @classmethod
    def of(cls, *, new_nodes=(), new_positions=None, touched_nodes=(), deleted_nodes=(),
           deleted_springs=(), deleted_triangles=(), deleted_links=(), hinge_nodes=()) -> ModelChange:
        """A change from any iterables of slots (sorted and made unique here); the new nodes'
        positions (k, 3) [m] follow ``new_nodes`` in the order given."""
        new = np.asarray(list(new_nodes), dtype=np.int64)
        positions = np.zeros((0, 3)) if new_positions is None else np.asarray(new_positions, np.float64)
        if positions.shape != (len(new), 3):
            raise ValueError(f"new_positions must have shape ({len(new)}, 3), got {positions.shape}")
        order = np.argsort(new, kind="stable")
        return cls(new[order], positions[order], _slots(touched_nodes), _slots(deleted_nodes),
                   _slots(deleted_springs), _slots(deleted_triangles), _slots(deleted_links),
                   _slots(hinge_nodes))

    def with_limit(self, limit: StepLimit) -> ModelChange:
        """This change carrying the stable step its maker worked out."""
        return replace(self, step_limit=limit)

    def with_positions(self, positions) -> ModelChange:
        """This change with the new nodes placed at ``positions`` (k, 3) [m] instead."""
        return replace(self, new_positions=np.asarray(positions, np.float64).reshape(-1, 3))
