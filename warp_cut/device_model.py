"""DeviceModel: the device mirror of a TissueModel (float32 / int32 Warp arrays).

Derived from the model in one place, so no component keeps its own copy of the topology.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .kernels import NODE_ACTIVE, NODE_PINNED

__all__ = ["DeviceModel"]


class DeviceModel:
    """Device arrays of a model (counts follow Newton's ``*_count`` naming).

    rest_positions: (node_count,) vec3 [m]; node_mass (node_count,) float32 [kg];
    node_damping (node_count,) float32 [N s/m]; node_flags (node_count,) int32;
    spring_indices (2 * spring_count,) int32; spring_rest_length [m] and spring_stiffness [N/m]
    (spring_count,) float32; link_indices (2 * link_count,) int32; link_force [N] and
    link_smoothing [m] (link_count,) float32.
    """

    def __init__(self, model, device: str = "cpu", active: np.ndarray | None = None):
        self.device = device
        self.node_count = model.node_count
        self.spring_count = model.spring_count
        self.link_count = model.link_count
        flags = np.full(model.node_count, NODE_ACTIVE, dtype=np.int32)
        if active is not None:
            flags[~active] = 0
        flags[model.pinned] |= NODE_PINNED
        f32 = lambda a: wp.array(np.asarray(a, dtype=np.float32), dtype=wp.float32, device=device)
        i32 = lambda a: wp.array(np.asarray(a, dtype=np.int32).ravel(), dtype=wp.int32, device=device)
        self.rest_positions = wp.array(model.points.astype(np.float32), dtype=wp.vec3, device=device)
        self.node_mass = f32(model.masses)
        self.node_damping = f32(model.damping)
        self.node_flags = i32(flags)
        self.spring_indices = i32(model.springs)
        self.spring_rest_length = f32(model.rest_lengths)
        self.spring_stiffness = f32(model.stiffness)
        self.link_indices = i32(model.links)
        self.link_force = f32(model.link_force)
        self.link_smoothing = f32(model.link_smoothing)
