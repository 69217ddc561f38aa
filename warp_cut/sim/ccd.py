"""Continuous collision detection of the swept tool (kernels in ``warp_cut.kernels.ccd``).

A discrete test sees contact only at the end of a step, so it reports first contact up to one
step late and can miss a fast tool passing a node entirely between two steps. Here the tool's
end points move linearly from one pose to the next and each node moves linearly with its
velocity; the exact first time a node enters the cylinder is found per node on the device and
reduced to the earliest time, node and point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from ..errors import InputError
from ..kernels import NODE_ACTIVE
from ..kernels.ccd import NO_CONTACT, earliest_contact_nodes, swept_cylinder_first_contact
from .control import Tool

__all__ = ["SweptContact", "ContinuousDetector", "swept_first_contact", "TIE_TOLERANCE"]

TIE_TOLERANCE = 1.0e-9
"""Nodes reached within this fraction of the interval of the earliest count as reached together."""


@dataclass(frozen=True)
class SweptContact:
    """The first contact of a swept tool with the nodes within one interval.

    Attributes:
        tau: Fraction of the interval, in [0, 1].
        time: t_start + tau * interval [s].
        node: Lowest index among the nodes reached first.
        point: Mean position [m], shape (3,), of the nodes reached first (within
            TIE_TOLERANCE), at that time.
        node_count: How many nodes were reached first.
    """

    tau: float
    time: float
    node: int
    point: np.ndarray
    node_count: int


def _vec3d(x) -> wp.vec3d:
    """Three numbers as a Warp float64 vector."""
    return wp.vec3d(*np.asarray(x, dtype=np.float64))


class ContinuousDetector:
    """Reusable device buffers for ``first_contact`` on one device (resized with the node count).

    Args:
        device: Warp device the detection runs on.
    """

    def __init__(self, device: str = "cpu"):
        self.device = device
        self._size = -1

    def _buffers(self, n: int) -> None:
        """(Re)allocate the per-node and reduction buffers for ``n`` nodes."""
        if n == self._size:
            return
        d = self.device
        self._tau = wp.empty(n, dtype=wp.float64, device=d)
        self._earliest = wp.empty(1, dtype=wp.float64, device=d)
        self._node = wp.empty(1, dtype=wp.int32, device=d)
        self._point = wp.empty(1, dtype=wp.vec3d, device=d)
        self._count = wp.empty(1, dtype=wp.int32, device=d)
        self._size = n

    def first_contact(self, positions: wp.array, velocities: wp.array | None, node_flags: wp.array,
                      start: Tool, end: Tool, *, t_start: float = 0.0,
                      interval: float = 0.0, overlap: float = 0.0) -> SweptContact | None:
        """First contact of the tool moving linearly from ``start`` to ``end`` (radius of ``end``).

        Args:
            positions: Node positions at the start [m], shape (n,) vec3, on this device.
            velocities: Node velocities [m/s], shape (n,) vec3, or None (nodes held still);
                nodes move by ``interval * velocity`` over the interval.
            node_flags: NODE_ACTIVE bits, shape (n,) int32 (inactive nodes are skipped).
            start: The tool pose at ``t_start``.
            end: The tool pose at ``t_start + interval``.
            t_start: Time of ``start`` [s].
            interval: Duration of the motion [s] (0: nodes held still).
            overlap: Extends the motion linearly past ``end`` by this fraction of the
                interval, so a contact exactly at the end (where a per-step test and this one
                may round differently) is found in this interval.

        Returns:
            The first contact, or None if no node is reached.
        """
        n = positions.shape[0]
        if n == 0 or end.radius <= 0.0:
            return None
        self._buffers(n)
        if overlap:
            grow = float(overlap)
            end = Tool(end.p0 + grow * (end.p0 - start.p0), end.p1 + grow * (end.p1 - start.p1),
                       end.radius)
            interval = float(interval) * (1.0 + grow)
        vel = positions if velocities is None else velocities
        span = 0.0 if velocities is None else float(interval)
        self._earliest.fill_(NO_CONTACT)
        wp.launch(swept_cylinder_first_contact, dim=n, device=self.device,
                  inputs=[positions, vel, node_flags, span, _vec3d(start.p0), _vec3d(start.p1),
                          _vec3d(end.p0), _vec3d(end.p1), float(end.radius), self._tau,
                          self._earliest])
        tau = float(self._earliest.numpy()[0])
        if tau > 1.0:
            return None
        self._node.fill_(n)
        self._point.zero_()
        self._count.zero_()
        wp.launch(earliest_contact_nodes, dim=n, device=self.device,
                  inputs=[self._tau, self._earliest, TIE_TOLERANCE, positions, vel, span,
                          self._node, self._point, self._count])
        count = int(self._count.numpy()[0])
        point = self._point.numpy()[0].astype(np.float64) / count
        return SweptContact(tau=tau, time=float(t_start) + tau * float(interval),
                            node=int(self._node.numpy()[0]), point=point, node_count=count)


def swept_first_contact(points, start: Tool, end: Tool, *, velocities=None, interval: float = 1.0,
                        t_start: float = 0.0, active=None, device: str = "cpu") -> SweptContact | None:
    """First contact of nodes with the tool moving linearly from one pose to the next.

    Args:
        points: Node positions [m], shape (n, 3).
        start: The tool pose at ``t_start``.
        end: The tool pose at ``t_start + interval``.
        velocities: Node velocities [m/s], shape (n, 3), or None (nodes still).
        interval: Duration of the motion [s], > 0.
        t_start: Time of ``start`` [s].
        active: Mask of the nodes to test, shape (n,) bool, or None (all).
        device: Warp device the detection runs on.

    Returns:
        The first contact, or None if the tool reaches no node.

    Raises:
        InputError: Bad shapes, non-finite values, a non-positive interval, or poses that are
            not Tools.
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
        raise InputError(f"points must be finite with shape (n, 3), got {pts.shape}")
    interval = float(interval)
    if not (np.isfinite(interval) and interval > 0):
        raise InputError(f"interval must be a positive duration [s], got {interval}")
    if not (isinstance(start, Tool) and isinstance(end, Tool)):
        raise InputError("start and end must be Tool poses")
    flags = np.full(len(pts), NODE_ACTIVE, dtype=np.int32)
    if active is not None:
        mask = np.asarray(active, dtype=bool)
        if mask.shape != (len(pts),):
            raise InputError(f"active must have shape ({len(pts)},), got {mask.shape}")
        flags[~mask] = 0
    x = wp.array(pts.astype(np.float32), dtype=wp.vec3, device=device)
    v = None
    if velocities is not None:
        vel = np.asarray(velocities, dtype=np.float64)
        if vel.shape != pts.shape or not np.all(np.isfinite(vel)):
            raise InputError(f"velocities must be finite with shape {pts.shape}, got {vel.shape}")
        v = wp.array(vel.astype(np.float32), dtype=wp.vec3, device=device)
    f = wp.array(flags, dtype=wp.int32, device=device)
    return ContinuousDetector(device).first_contact(x, v, f, start, end, t_start=t_start,
                                                    interval=interval)
