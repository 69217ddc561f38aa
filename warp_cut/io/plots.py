"""Pictures of a run (matplotlib, no display needed): a look without a USD viewer.

* ``preview.png`` - the final mesh seen along its mean normal (from above for a flat patch; in
  perspective when the surface is curved), node classes coloured, the incision curve and the
  tool's axis drawn;
* ``tool_force.png`` - the tool force over time;
* ``width.png`` - the incision width over time (when the time series has ``incision_width_m``),
  with its peak, plateau and settling time marked.

Each file is written atomically. Figures are built with the object API (no pyplot state).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from ..cut.classes import NODE_CLASS_COLORS, NodeClass
from ..cut.curve.bezier import BezierChain
from ..cut.wound.width_curve import analyse_width
from .files import atomic_path

__all__ = ["FinalFrame", "RunPicture", "plot_preview", "plot_series", "write_run_plots",
           "new_figure", "save_figure", "WIDTH_COLUMN"]

WIDTH_COLUMN = "incision_width_m"
"""Time-series column holding the incision width [m]."""

_MM = 1e3


@dataclass
class RunPicture:
    """What the preview shows.

    Attributes:
        positions: Node positions [m], shape (n, 3).
        triangles: Node indices, shape (t, 3).
        active: Live nodes, shape (n,) bool.
        node_class: ``NodeClass`` per node, shape (n,) int.
        incision: Control points of the incision's Bezier chain [m], shape (3 s + 1, 3), or None.
        tool: The tool's end points (p0, p1) [m], each shape (3,), or None.
        time: Simulated time [s].
    """

    positions: np.ndarray
    triangles: np.ndarray
    active: np.ndarray
    node_class: np.ndarray
    incision: np.ndarray | None = None
    tool: tuple | None = None
    time: float = 0.0


class FinalFrame:
    """Run observer that keeps the final state as a RunPicture.

    Attributes:
        picture: The final state, set by ``finish`` (None before, or if no frame was seen).
    """

    def __init__(self):
        self._sim = None
        self.picture: RunPicture | None = None

    def on_frame(self, sim, frame: int) -> None:
        """Remember the simulator (the picture is taken once, at ``finish``)."""
        self._sim = sim

    def finish(self, metrics: dict | None = None) -> None:
        """Take the picture of the last frame seen."""
        sim = self._sim
        if sim is None:
            return
        m = sim.model
        pose = getattr(sim, "tool_pose", None)
        self.picture = RunPicture(
            positions=sim.positions, triangles=np.asarray(m.triangles).reshape(-1, 3),
            active=np.asarray(m.active, dtype=bool), node_class=np.asarray(m.node_class),
            incision=sim.incision_controls, time=sim.time,
            tool=None if pose is None else (pose.p0.copy(), pose.p1.copy()))


def new_figure(width=6.4, height=4.8):
    """A matplotlib Figure of ``width`` x ``height`` [inch] at 120 dpi on an Agg canvas (no pyplot)."""
    fig = Figure(figsize=(width, height), dpi=120)
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig, path) -> Path:
    """Write ``fig`` as PNG to ``path`` atomically.

    Returns:
        The path written.
    """
    path = Path(path)
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png")
    return path


CURVED_DEG = 25.0
"""A mesh whose triangles turn more than this [deg] from their mean normal is drawn in a
perspective view; a flatter one is drawn as seen along its mean normal."""

TURN_AREA_FRACTION = 0.98
"""The turn that decides the view is the one this fraction of the surface's area stays within:
a few small triangles tilted at a wound's lips do not make a flat patch curved."""


def _view(picture: RunPicture):
    """(unit mean normal of the live surface, the angle [deg] to it within which its triangles'
    normals lie over ``TURN_AREA_FRACTION`` of its area)."""
    x = np.asarray(picture.positions, dtype=np.float64)
    tri = np.asarray(picture.triangles, dtype=np.int64).reshape(-1, 3)
    if not len(tri):
        return np.array([0.0, 0.0, 1.0]), 0.0
    n = np.cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]])
    mean = n.sum(axis=0)
    mean = mean / np.linalg.norm(mean) if np.linalg.norm(mean) > 0 else np.array([0.0, 0.0, 1.0])
    area = np.linalg.norm(n, axis=1)
    turn = np.degrees(np.arccos(np.clip((n @ mean) / np.maximum(area, 1e-300), -1.0, 1.0)))
    order = np.argsort(turn)
    covered = np.cumsum(area[order]) / max(area.sum(), 1e-300)
    k = min(int(np.searchsorted(covered, TURN_AREA_FRACTION)), len(order) - 1)
    return mean, float(turn[order[k]])


def _plane_axes(normal: np.ndarray) -> np.ndarray:
    """(2, 3) in-plane axes for a view along ``normal``: x as close to the world X as it can be
    (the world XY when the normal is +Z)."""
    e1 = np.array([1.0, 0.0, 0.0]) - normal[0] * normal
    if np.linalg.norm(e1) < 1e-6:
        e1 = np.array([0.0, 1.0, 0.0]) - normal[1] * normal
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(normal, e1)])


def _class_points(picture: RunPicture):
    """(class, mask of the live nodes of that class) for every class but the normal one."""
    active = np.asarray(picture.active, dtype=bool)
    classes = np.asarray(picture.node_class)
    return [(cls, active & (classes == cls)) for cls in NodeClass
            if cls != NodeClass.NORMAL and (active & (classes == cls)).any()]


def _curve(picture: RunPicture) -> np.ndarray | None:
    if picture.incision is None or len(picture.incision) < 4:
        return None
    chain = BezierChain.from_control_points_flat(picture.incision)
    return chain.evaluate(np.linspace(0.0, chain.segment_count, 64 * chain.segment_count)) * _MM


def plot_preview(path, picture: RunPicture, title: str = "") -> Path:
    """Draw the final mesh with node classes coloured, the incision and the tool axis: as seen
    along the surface's mean normal (from above, for a flat patch in XY), or in perspective
    when the surface is curved (see ``CURVED_DEG``).

    Args:
        path: The PNG file.
        picture: What to draw.
        title: Figure title (default: the time and the view).

    Returns:
        The path written.
    """
    normal, turn = _view(picture)
    if turn > CURVED_DEG:
        return _plot_perspective(path, picture, normal, title)
    return _plot_along_normal(path, picture, normal, title)


def _plot_along_normal(path, picture: RunPicture, normal: np.ndarray, title: str) -> Path:
    axes = _plane_axes(normal)
    x = (np.asarray(picture.positions, dtype=np.float64) @ axes.T) * _MM
    tri = np.asarray(picture.triangles, dtype=np.int64).reshape(-1, 3)
    fig = new_figure(7.0, 5.6)
    ax = fig.add_subplot(1, 1, 1)
    if len(tri):
        ax.add_collection(PolyCollection(x[tri], facecolors=[NODE_CLASS_COLORS[NodeClass.NORMAL]],
                                         edgecolors=[(0.45, 0.3, 0.25)], linewidths=0.3))
    for cls, sel in _class_points(picture):
        ax.scatter(x[sel, 0], x[sel, 1], s=10, color=NODE_CLASS_COLORS[cls], zorder=3,
                   label=f"{cls.name.lower()} ({int(sel.sum())})")
    curve = _curve(picture)
    if curve is not None:
        c = curve @ axes.T
        ax.plot(c[:, 0], c[:, 1], color=(0.45, 0.02, 0.02), lw=1.5, zorder=4, label="incision")
    if picture.tool is not None:
        p0, p1 = ((np.asarray(p) @ axes.T) * _MM for p in picture.tool)
        ax.plot([p0[0], p1[0]], [p0[1], p1[1]], color=(0.3, 0.3, 0.35), lw=2.5, alpha=0.7,
                zorder=5, label="tool axis")
        ax.plot([p0[0]], [p0[1]], "o", color=(0.3, 0.3, 0.35), ms=4, zorder=5)
    active = np.asarray(picture.active, dtype=bool)
    pts = x[active] if active.any() else x
    if len(pts):
        pad = 0.03 * max(np.ptp(pts[:, 0]), np.ptp(pts[:, 1]), 1e-3)
        ax.set_xlim(pts[:, 0].min() - pad, pts[:, 0].max() + pad)
        ax.set_ylim(pts[:, 1].min() - pad, pts[:, 1].max() + pad)
    ax.set_aspect("equal")
    top = np.allclose(normal, [0.0, 0.0, 1.0], atol=1e-3)
    ax.set_xlabel("x [mm]" if top else "along the surface [mm]")
    ax.set_ylabel("y [mm]" if top else "across [mm]")
    view = "seen from above" if top else "seen along the surface's mean normal"
    ax.set_title(title or f"t = {picture.time:.3f} s, {view}")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def _plot_perspective(path, picture: RunPicture, normal: np.ndarray, title: str) -> Path:
    x = np.asarray(picture.positions, dtype=np.float64) * _MM
    tri = np.asarray(picture.triangles, dtype=np.int64).reshape(-1, 3)
    fig = new_figure(7.0, 5.6)
    ax = fig.add_subplot(1, 1, 1, projection="3d")
    ax.set_proj_type("persp")
    if len(tri):
        ax.add_collection3d(Poly3DCollection(x[tri], facecolors=[NODE_CLASS_COLORS[NodeClass.NORMAL]],
                                             edgecolors=[(0.45, 0.3, 0.25)], linewidths=0.2, alpha=0.9))
    for cls, sel in _class_points(picture):
        ax.scatter(x[sel, 0], x[sel, 1], x[sel, 2], s=8, color=NODE_CLASS_COLORS[cls], depthshade=False,
                   label=f"{cls.name.lower()} ({int(sel.sum())})")
    curve = _curve(picture)
    if curve is not None:
        ax.plot(curve[:, 0], curve[:, 1], curve[:, 2], color=(0.45, 0.02, 0.02), lw=1.5, label="incision")
    active = np.asarray(picture.active, dtype=bool)
    pts = x[active] if active.any() else x
    if len(pts):
        centre, half = 0.5 * (pts.min(axis=0) + pts.max(axis=0)), 0.5 * np.ptp(pts, axis=0).max()
        for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
            setter(c - half, c + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    elev = float(np.degrees(np.arcsin(np.clip(normal[2], -1.0, 1.0))))
    azim = float(np.degrees(np.arctan2(normal[1], normal[0])))
    ax.view_init(elev=max(elev, 25.0), azim=azim - 30.0)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    ax.set_title(title or f"t = {picture.time:.3f} s, perspective")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_series(path, t, series: dict, ylabel: str, title: str = "", marks: dict | None = None) -> Path:
    """Line plot of time series.

    Args:
        path: The PNG file.
        t: Times [s], shape (k,).
        series: Label -> values, each shape (k,).
        ylabel: Y axis label (with its unit).
        title: Figure title.
        marks: Label -> (t [s], y) points drawn as markers.

    Returns:
        The path written.
    """
    fig = new_figure()
    ax = fig.add_subplot(1, 1, 1)
    t = np.asarray(t, dtype=np.float64)
    for label, y in series.items():
        ax.plot(t, np.asarray(y, dtype=np.float64), label=label, lw=1.2)
    for label, (mt, my) in (marks or {}).items():
        ax.plot([mt], [my], "o", label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    if len(series) + len(marks or {}) > 1:
        ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def write_run_plots(out_dir, columns: dict, picture: RunPicture | None, name: str = "") -> list[Path]:
    """Write the pictures of a run.

    Args:
        out_dir: Output directory.
        columns: Time-series columns (``t`` [s], ``tool_fx/fy/fz`` [N], ``incision_width_m`` [m]).
        picture: The final state for ``preview.png``, or None for no preview.
        name: Run name for the titles.

    Returns:
        The paths written: ``preview.png`` (with a picture), ``tool_force.png`` and
        ``width.png`` (when the width column exists).
    """
    out = Path(out_dir)
    written = []
    if picture is not None:
        written.append(plot_preview(out / "preview.png", picture,
                                    f"{name}: final mesh at t = {picture.time:.3f} s".lstrip(": ")))
    t = columns.get("t")
    if t is not None and all(c in columns for c in ("tool_fx", "tool_fy", "tool_fz")):
        f = np.column_stack([columns["tool_fx"], columns["tool_fy"], columns["tool_fz"]])
        written.append(plot_series(out / "tool_force.png", t,
                                   {"|F|": np.linalg.norm(f, axis=1), "Fx": f[:, 0], "Fy": f[:, 1],
                                    "Fz": f[:, 2]}, "tool force [N]", f"{name} tool force".strip()))
    if t is not None and WIDTH_COLUMN in columns:
        w = np.asarray(columns[WIDTH_COLUMN], dtype=np.float64)
        marks = {}
        try:
            a = analyse_width(t, w)
        except ValueError:
            a = None
        if a is not None:
            marks["peak"] = (a.peak_time, a.peak_width * _MM)
            if a.settling_time is not None:
                marks["settled"] = (a.settling_time, float(np.interp(a.settling_time, t, w)) * _MM)
        written.append(plot_series(out / "width.png", t, {"width": w * _MM}, "incision width [mm]",
                                   f"{name} incision width".strip(), marks))
    return written
