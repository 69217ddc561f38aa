"""State: what a step advances (positions and velocities of the nodes)."""

from __future__ import annotations

import numpy as np
import warp as wp

__all__ = ["State"]


class State:
    """Node state on the device.

    Args:
        positions: Node positions [m], shape (node_count, 3).
        velocities: Node velocities [m/s], shape (node_count, 3) (default zero).
        device: Warp device.

    Attributes:
        positions: Node positions [m], shape (node_count,) vec3.
        velocities: Node velocities [m/s], shape (node_count,) vec3.
        forces: Force accumulator the force kernels add into [N], shape (node_count,) vec3.
    """

    def __init__(self, positions: np.ndarray, velocities: np.ndarray | None = None,
                 device: str = "cpu"):
        x = np.asarray(positions, dtype=np.float32).reshape(-1, 3)
        v = np.zeros_like(x) if velocities is None else np.asarray(velocities, np.float32).reshape(-1, 3)
        self.positions = wp.array(x, dtype=wp.vec3, device=device)
        self.velocities = wp.array(v, dtype=wp.vec3, device=device)
        self.forces = wp.zeros(len(x), dtype=wp.vec3, device=device)

    @property
    def node_count(self) -> int:
        """Node slots the state holds."""
        return self.positions.shape[0]

    def grown(self, capacity: int) -> State:
        """A state of ``capacity`` node slots on the same device holding this one's positions
        and velocities (the new slots zero), for a model whose node table grew."""
        x = np.zeros((capacity, 3), np.float32)
        v = np.zeros((capacity, 3), np.float32)
        x[: self.node_count] = self.positions.numpy()
        v[: self.node_count] = self.velocities.numpy()
        return State(x, v, device=self.positions.device)
