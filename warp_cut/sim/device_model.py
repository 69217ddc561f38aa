"""DeviceModel: the device mirror of a TissueModel (float32 / int32 Warp arrays).

Derived from the model's slot tables in one place, so no component keeps its own copy of the
topology. Arrays are allocated at the tables' capacity; kernels skip dead and unused slots.
After an edit, ``sync`` copies only the changed slots (through a numpy view of the array on the
CPU, a scatter launch per column on a GPU), unless a table outgrew its capacity, which
reallocates.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels import NODE_ACTIVE, NODE_PINNED
from ..kernels.scatter import scatter_float32, scatter_int32, scatter_vec3

__all__ = ["DeviceModel", "write_slots"]

_SCATTER = {wp.vec3: scatter_vec3, wp.float32: scatter_float32, wp.int32: scatter_int32}


def _node_flags(model, slots) -> np.ndarray:
    """NODE_ACTIVE | NODE_PINNED bits of node slots, shape (k,) int32."""
    table = model.node_table
    flags = np.where(table.alive_buffer()[slots], NODE_ACTIVE, 0).astype(np.int32)
    flags[table.buffer("pinned")[slots]] |= NODE_PINNED
    return flags


def _columns(model):
    """(device attribute, table, host values for slots, warp dtype) of every mirrored column."""
    n, s, l, h = model.node_table, model.spring_table, model.link_table, model.hinge_table
    return [
        ("rest_positions", n, lambda idx: n.buffer("points")[idx], wp.vec3),
        ("node_mass", n, lambda idx: n.buffer("masses")[idx], wp.float32),
        # the lumped area, derived from the lumped mass (mass = density x thickness x area), so
        # it follows every edit that changes a mass
        ("node_area", n, lambda idx: n.buffer("masses")[idx] / model.material.areal_density,
         wp.float32),
        ("node_damping", n, lambda idx: n.buffer("damping")[idx], wp.float32),
        ("node_flags", n, lambda idx: _node_flags(model, idx), wp.int32),
        ("spring_indices", s, lambda idx: s.buffer("pairs")[idx], wp.int32),
        ("spring_rest_length", s, lambda idx: s.buffer("rest_length")[idx], wp.float32),
        ("spring_stiffness", s, lambda idx: s.buffer("stiffness")[idx], wp.float32),
        ("link_indices", l, lambda idx: l.buffer("pairs")[idx], wp.int32),
        ("link_force", l, lambda idx: l.buffer("force")[idx], wp.float32),
        ("link_smoothing", l, lambda idx: l.buffer("smoothing")[idx], wp.float32),
        ("hinge_indices", h, lambda idx: h.buffer("nodes")[idx], wp.int32),
        ("hinge_rest_angle", h, lambda idx: h.buffer("rest_angle")[idx], wp.float32),
        ("hinge_stiffness", h, lambda idx: h.buffer("stiffness")[idx], wp.float32),
        ("hinge_cap", h, lambda idx: h.buffer("cap")[idx], wp.float32),
    ]


def _to_warp(values: np.ndarray, dtype, device) -> wp.array:
    """Host values as a flat Warp array of ``dtype`` (vec3, float32 or int32) on ``device``."""
    if dtype is wp.vec3:
        return wp.array(np.asarray(values, np.float32).reshape(-1, 3), dtype=wp.vec3, device=device)
    np_type = np.float32 if dtype is wp.float32 else np.int32
    return wp.array(np.asarray(values, np_type).ravel(), dtype=dtype, device=device)


def write_slots(dest: wp.array, idx: np.ndarray, values: np.ndarray, view: np.ndarray | None = None) -> None:
    """dest[idx] = values for a flat vec3, float32 or int32 Warp array.

    Args:
        dest: The array written, shape (capacity,).
        idx: Entries to write, shape (k,) int.
        values: Their values, shape (k, 3) for vec3 arrays, else (k,).
        view: ``dest.numpy()`` kept by the caller (CPU arrays), to skip making it again.
    """
    if not len(idx):
        return
    if dest.device.is_cpu:  # host memory: a numpy view, no launch and no temporary arrays
        (dest.numpy() if view is None else view)[idx] = values
        return
    src = _to_warp(values, dest.dtype, dest.device)
    wp.launch(_SCATTER[dest.dtype], dim=len(idx), device=dest.device,
              inputs=[dest, wp.array(np.asarray(idx, np.int32), dtype=wp.int32, device=dest.device), src])


class DeviceModel:
    """Device arrays of a model (counts follow Newton's ``*_count`` naming; slots, dead included).

    Args:
        model: The TissueModel mirrored.
        device: Warp device, e.g. ``"cpu"`` or ``"cuda:0"``.

    Attributes:
        rest_positions: Rest positions [m], shape (node capacity,) vec3.
        node_mass: Lumped masses [kg], shape (node capacity,) float32.
        node_area: Lumped areas [m^2] (mass / (density x thickness)), for the foundation,
            shape (node capacity,) float32.
        node_damping: Damping D [N s/m], shape (node capacity,) float32.
        node_flags: NODE_ACTIVE | NODE_PINNED bits, shape (node capacity,) int32.
        spring_indices: Spring end nodes, flat, shape (2 * spring capacity,) int32; -1 for dead
            slots.
        spring_rest_length: Rest lengths [m], shape (spring capacity,) float32.
        spring_stiffness: Stiffness [N/m], shape (spring capacity,) float32.
        link_indices: Residual-link end nodes, flat, shape (2 * link capacity,) int32; -1 for
            dead slots.
        link_force: Link force sigma_r A [N], shape (link capacity,) float32.
        link_smoothing: Link smoothing length [m], shape (link capacity,) float32.
        hinge_indices: Hinge nodes [a, b, k, l], flat, shape (4 * hinge capacity,) int32; -1 for
            dead slots (``warp_cut.sim.bending``).
        hinge_rest_angle: Rest dihedral angles [rad], shape (hinge capacity,) float32.
        hinge_stiffness: Hinge stiffness k_h [N m], shape (hinge capacity,) float32.
        hinge_cap: The most a hinge holds, k_h |d theta / d x|^2 [N/m] (``sim.bending.hinge_caps``),
            shape (hinge capacity,) float32.
        node_count: Used node slots.
        spring_count: Used spring slots.
        link_count: Used link slots.
        hinge_count: Used hinge slots.
        used_slots: The four counts above on the device, (4,) int32 (node, spring, link, hinge),
            for a launch recorded over a table's capacity to stop at its used slots.
    """

    def __init__(self, model, device: str = "cpu"):
        self.device = device
        self.model = model
        self.used_slots = wp.zeros(4, dtype=wp.int32, device=device)
        self._allocate()

    @property
    def foundation_stiffness(self) -> float:
        """k_f [N/m^3] of the model's support (0: none, the foundation is not compiled)."""
        return self.model.foundation_stiffness

    @property
    def bending(self) -> bool:
        """Whether the model's sheet resists bending (hinges launched; ``material.bending_rigidity`` > 0)."""
        return self.model.material.bending_rigidity > 0

    def _allocate(self) -> None:
        """Upload every column at its table's capacity and forget the tables' changes."""
        model = self.model
        model.triangle_table.take_dirty()  # not mirrored: its changes are only forgotten
        for name, table, values, dtype in _columns(model):
            table.take_dirty()
            setattr(self, name, _to_warp(values(np.arange(table.capacity)), dtype, self.device))
        # host views of the CPU arrays, for writing changed slots without a launch
        self._views = ({name: getattr(self, name).numpy() for name, _, _, _ in _columns(model)}
                       if wp.get_device(self.device).is_cpu else {})
        self._counts()

    def _counts(self) -> None:
        """Read the used slot counts from the tables (and mirror them in ``used_slots``)."""
        self.node_count = self.model.node_table.count
        self.spring_count = self.model.spring_table.count
        self.link_count = self.model.link_table.count
        self.hinge_count = self.model.hinge_table.count
        counts = np.array([self.node_count, self.spring_count, self.link_count, self.hinge_count], np.int32)
        write_slots(self.used_slots, np.arange(4), counts)

    def sync(self) -> bool:
        """Copy the model's changed slots to the device.

        Returns:
            True if arrays were reallocated (a table outgrew its capacity): solvers holding
            them must rebind.
        """
        model = self.model
        tables = {id(t): t for _, t, _, _ in _columns(model)}
        changes = {key: t.take_dirty() for key, t in tables.items()}
        model.triangle_table.take_dirty()  # not mirrored: its changes are only forgotten
        if any(grown for _, grown in changes.values()):
            self._allocate()
            return True
        for name, table, values, _ in _columns(model):
            slots = changes[id(table)][0]
            if not len(slots):
                continue
            if name.endswith("_indices"):  # stored flat: slot s of width w owns entries ws .. ws + w - 1
                rows = np.asarray(values(slots))
                width = rows.shape[1]
                idx = (width * slots[:, None] + np.arange(width)).ravel()
                write_slots(getattr(self, name), idx, rows.ravel(), self._views.get(name))
            else:
                write_slots(getattr(self, name), slots, values(slots), self._views.get(name))
        self._counts()
        return False
