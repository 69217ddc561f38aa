"""What a viewer draws at one moment: the ViewFrame, built from a Simulator or read from a run.

The live view and the player of finished runs draw the same thing: the live nodes of the tissue
(compact numbering, as in the USD export and final_mesh.ply), its triangles, the node classes,
the incision's Bezier control points, the tool and the tool force.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..mesh.geometry import compact_surface

__all__ = ["ViewFrame", "SimulatorFrames"]


@dataclass(frozen=True, eq=False)
class ViewFrame:
    """One drawable state.

    time: simulated time [s].
    points: positions of the live nodes [m], shape (k, 3), float32.
    faces: triangles as indices into ``points``, shape (t, 3), int32.
    node_class: class of each point (``warp_cut.cut.classes.NodeClass``), shape (k,), int8.
    topology: a key that changes whenever ``faces`` or the point count change.
    incision: control points of the incision's cubic Bezier chain [m], (3 s + 1, 3), or None.
    tool: (p0 (3,), p1 (3,), radius) [m] of the tool, or None when there is none.
    force: reaction of the tissue on the tool [N], shape (3,).
    """

    time: float
    points: np.ndarray
    faces: np.ndarray
    node_class: np.ndarray
    topology: object
    incision: np.ndarray | None = None
    tool: tuple | None = None
    force: np.ndarray = field(default_factory=lambda: np.zeros(3))


class SimulatorFrames:
    """Builds ViewFrames from a Simulator; the compact numbering is recomputed only when the
    model's ``topology_version`` changes. ``generation`` tells models apart (a rebuilt
    simulation starts its versions again)."""

    def __init__(self, generation: int = 0):
        self.generation = generation
        self._version = None
        self._keep = np.zeros(0, np.int64)
        self._faces = np.zeros((0, 3), np.int32)

    def _topology(self, model) -> None:
        if self._version == model.topology_version:
            return
        keep, faces = compact_surface(model.active, model.triangles)
        self._version, self._keep, self._faces = model.topology_version, keep, faces.astype(np.int32)

    def __call__(self, sim) -> ViewFrame:
        """The Simulator's current state as a ViewFrame (arrays copied)."""
        model = sim.model
        self._topology(model)
        points = np.array(sim.state.positions.numpy()[self._keep], dtype=np.float32)
        pose = sim.tool_pose
        tool = None if pose is None else (pose.p0.copy(), pose.p1.copy(), float(pose.radius))
        incision = sim.incision_controls
        return ViewFrame(time=float(sim.time), points=points, faces=self._faces,
                         node_class=np.asarray(model.node_class)[self._keep].astype(np.int8),
                         topology=(self.generation, self._version),
                         incision=None if incision is None else np.array(incision, dtype=np.float64),
                         tool=tool, force=np.array(sim.tool_force, dtype=np.float64))
