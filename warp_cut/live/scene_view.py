"""Drawing a ViewFrame in a viser scene: tissue, node classes, incision, tool and tool force.

The tissue is a mesh in the normal-tissue colour with its edges drawn over it; the nodes of the
other classes are dots in their class colours (``NODE_CLASS_COLORS``), as in ``preview.png``.
Arrays that keep their size are updated in place (positions every frame); a node, a class or
an incision that changes re-sends that object alone.
"""

from __future__ import annotations

import numpy as np

from ..cut.classes import NODE_CLASS_COLORS, NodeClass
from ..io.usd_export import axis_quaternion
from .frames import ViewFrame

__all__ = ["SceneView", "CLASS_RGB", "rgb255", "FORCE_SCALE"]

FORCE_SCALE = 0.1
"""Length of the force arrow per newton [m/N]."""

_EDGE_RGB = (115, 77, 64)
_INCISION_RGB = (115, 5, 5)
_TOOL_RGB = (191, 199, 209)
_FORCE_RGB = (20, 150, 60)


def rgb255(color) -> tuple[int, int, int]:
    """An RGB colour in [0, 1] as integers in [0, 255]."""
    return tuple(int(round(255 * float(c))) for c in color)


CLASS_RGB = np.array([rgb255(NODE_CLASS_COLORS[c]) for c in NodeClass], dtype=np.uint8)
"""Colour (0-255) of each node class, shape (len(NodeClass), 3)."""


def mesh_spacing(frame: ViewFrame) -> float:
    """Median edge length [m] of the frame's triangles (1 mm without triangles)."""
    if not len(frame.faces):
        return 1e-3
    p = frame.points[frame.faces]
    edges = np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2)
    return float(np.median(edges))


class SceneView:
    """Draws ViewFrames into ``server.scene`` (viser) under ``root``.

    Args:
        server: a viser.ViserServer.
        spacing: mesh spacing [m]; sizes of the dots and lines follow it.
        edges: draw the triangle edges over the surface.
    """

    def __init__(self, server, spacing: float, *, root: str = "/run", edges: bool = True):
        self.server = server
        self.root = root
        self.spacing = float(spacing)
        self.edges = edges
        self.frames_shown = 0
        self._topology = None
        self._dots_key = None
        self._incision = None
        self._tool_shape = None
        self.handles: dict = {}
        server.scene.set_up_direction("+z")

    def look_at(self, frame: ViewFrame) -> None:
        """Point the initial camera of new pages at the tissue, from above and in front (the
        tissue a little left of the middle, clear of the control panel on the right)."""
        lo, hi = frame.points.min(axis=0), frame.points.max(axis=0)
        self.aim(0.5 * (lo + hi) + [0.15 * (hi[0] - lo[0]), 0.0, 0.0], float(np.max(hi - lo)))

    def aim(self, target, size: float) -> None:
        """Point the initial camera of new pages at ``target`` (3,) [m] from above and in front,
        at a distance that shows about ``size`` [m]."""
        camera = self.server.initial_camera
        camera.look_at = np.asarray(target, dtype=np.float64)
        camera.position = camera.look_at + np.array([0.0, -0.55, 0.75]) * size
        camera.up = (0.0, 0.0, 1.0)
        camera.near = 0.01 * size

    def show(self, frame: ViewFrame) -> None:
        """Draw ``frame`` (replacing the previous one)."""
        with self.server.atomic():
            self._tissue(frame)
            self._dots(frame)
            self._incision_curve(frame)
            self._tool(frame)
        self.frames_shown += 1

    def _tissue(self, frame: ViewFrame) -> None:
        scene = self.server.scene
        if frame.topology != self._topology:
            self._topology = frame.topology
            self.handles["surface"] = scene.add_mesh_simple(
                f"{self.root}/tissue", frame.points, frame.faces,
                color=tuple(CLASS_RGB[NodeClass.NORMAL]), side="double", cast_shadow=False,
                receive_shadow=False)
            if self.edges:
                self.handles["edges"] = scene.add_mesh_simple(
                    f"{self.root}/edges", frame.points, frame.faces, color=_EDGE_RGB,
                    wireframe=True, cast_shadow=False, receive_shadow=False)
            return
        self.handles["surface"].vertices = frame.points
        if self.edges:
            self.handles["edges"].vertices = frame.points

    def _dots(self, frame: ViewFrame) -> None:
        marked = np.flatnonzero(frame.node_class != NodeClass.NORMAL)
        # dots sit a little above the surface so that it does not hide half of each
        points = frame.points[marked] + np.array([0.0, 0.0, 0.25 * self.spacing], np.float32)
        key = (frame.topology, frame.node_class[marked].tobytes())
        if key != self._dots_key:
            self._dots_key = key
            colors = CLASS_RGB[frame.node_class[marked]] if len(marked) else np.zeros((0, 3), np.uint8)
            self.handles["dots"] = self.server.scene.add_point_cloud(
                f"{self.root}/classes", points, colors, point_size=0.45 * self.spacing,
                point_shape="circle", point_shading="flat", precision="float32")
        elif len(marked):
            self.handles["dots"].points = points

    def _incision_curve(self, frame: ViewFrame) -> None:
        controls = frame.incision
        if controls is None or len(controls) < 4:
            if self._incision is not None:
                self.handles.pop("incision").remove()
                self._incision = None
            return
        if self._incision is not None and np.array_equal(controls, self._incision):
            return
        self._incision = controls.copy()
        lifted = controls + np.array([0.0, 0.0, 0.3 * self.spacing])
        handles = np.delete(lifted, np.arange(0, len(lifted), 3), axis=0)
        self.handles["incision"] = self.server.scene.add_spline_cubic_bezier(
            f"{self.root}/incision", points=lifted[::3], control_points=handles,
            thickness=0.25 * self.spacing, color=_INCISION_RGB)

    def _tool(self, frame: ViewFrame) -> None:
        scene = self.server.scene
        if frame.tool is None:
            for name in ("tool", "force"):
                if name in self.handles:
                    self.handles[name].visible = False
            return
        p0, p1, radius = frame.tool
        length = float(np.linalg.norm(p1 - p0))
        if length <= 0:
            return
        wxyz, middle = np.array(axis_quaternion(p1 - p0)), 0.5 * (p0 + p1)
        if self._tool_shape != (radius, length):
            self._tool_shape = (radius, length)
            self.handles["tool"] = scene.add_cylinder(
                f"{self.root}/tool", radius=max(radius, 1e-5), height=length, color=_TOOL_RGB,
                wxyz=wxyz, position=middle, cast_shadow=False, receive_shadow=False)
        else:
            self.handles["tool"].wxyz, self.handles["tool"].position = wxyz, middle
            self.handles["tool"].visible = True
        arrow = np.array([[p0, p0 + FORCE_SCALE * np.asarray(frame.force)]], dtype=np.float32)
        if "force" not in self.handles:
            self.handles["force"] = scene.add_arrows(
                f"{self.root}/force", arrow, _FORCE_RGB, shaft_radius=0.15 * self.spacing,
                head_radius=0.4 * self.spacing, head_length=1.0 * self.spacing)
        else:
            self.handles["force"].points = arrow
            self.handles["force"].visible = True
