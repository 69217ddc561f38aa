"""ToolContacts: what the tool's contact with the tissue did, step by step (one record).

The solver sums the push-out reactions over a step's substeps (``warp_cut.solvers.readout``);
the simulator folds each step's sums in here: the step's force and contacts (the haptic signal)
and what the run keeps of them (the largest force, the first contact, discrete and exact).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ToolContacts"]


@dataclass
class ToolContacts:
    """The tool's contacts over the last step and the run so far (SI units).

    Attributes:
        force: Reaction of the tissue on the tool over the last step [N], (3,).
        count: Mean number of nodes in contact per substep over the last step.
        centroid: Mean position [m] of the nodes in contact during the last step, or None.
        max_force: Largest |force| of any step so far [N].
        first_time: Time [s] at the end of the first step with a contact, or None.
        first_point: Mean position [m] of the nodes in contact during that step, or None.
        first_time_exact: Exact first-contact time [s] of the swept tool (continuous detection),
            or None.
        first_point_exact: Mean position [m] of the nodes the swept tool reaches first, or None.
    """

    force: np.ndarray
    count: float = 0.0
    centroid: np.ndarray | None = None
    max_force: float = 0.0
    first_time: float | None = None
    first_point: np.ndarray | None = None
    first_time_exact: float | None = None
    first_point_exact: np.ndarray | None = None

    @classmethod
    def none(cls) -> ToolContacts:
        """No contact yet."""
        return cls(np.zeros(3))

    @property
    def first_known(self) -> bool:
        """Whether a first contact (discrete or exact) has been found."""
        return self.first_time is not None or self.first_time_exact is not None

    def no_tool(self) -> None:
        """A step without a tool: no force, no contact."""
        self.force = np.zeros(3)
        self.count = 0.0
        self.centroid = None

    def record_step(self, force_sum: np.ndarray, count_sum: int, position_sum: np.ndarray,
                    substeps: int, time: float) -> None:
        """Fold in a step's sums over its ``substeps``: force [N] (3,), contacts, positions of
        the nodes in contact [m] (3,); ``time`` [s] is the step's end."""
        self.force = force_sum / substeps
        self.count = count_sum / substeps
        self.max_force = max(self.max_force, math.sqrt(self.force.dot(self.force)))
        self.centroid = position_sum / count_sum if count_sum else None
        if count_sum and self.first_time is None:
            self.first_time = time
            self.first_point = self.centroid

    def record_exact(self, time: float, point: np.ndarray) -> None:
        """The exact first contact of the swept tool (continuous detection)."""
        self.first_time_exact = time
        self.first_point_exact = point
