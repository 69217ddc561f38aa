"""A finished run read back frame by frame from its USD export (``warp-cut view``).

The export (``usd_export``) holds per time code the tissue's points, its topology (when it
changed), the node classes as the indices of ``displayColor``, the incision's Bezier control
points and the tool's placement; value clips are resolved by USD. The tool force of each frame
comes from ``timeseries.csv`` beside it when that has one row per frame.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
from pxr import Gf, Usd, UsdGeom

from ..errors import InputError
from ..io.usd_export import INCISION, TISSUE, TOOL, USD_SUFFIXES
from .frames import ViewFrame

__all__ = ["RunPlayback", "find_usd"]


def find_usd(path) -> Path:
    """The USD export of a run: ``path`` itself (a USD file) or the one in the directory
    ``path`` (named by metrics.json, else the only one). InputError if there is none."""
    path = Path(path)
    if path.is_file():
        if path.suffix not in USD_SUFFIXES:
            raise InputError(f"{path}: not a USD file (expected one of {', '.join(USD_SUFFIXES)})")
        return path
    if not path.is_dir():
        raise InputError(f"{path}: no such run directory or USD file")
    metrics = path / "metrics.json"
    if metrics.is_file():
        try:
            name = json.loads(metrics.read_text(encoding="utf-8")).get("name")
        except (json.JSONDecodeError, UnicodeDecodeError, AttributeError):
            name = None
        if name and (path / f"{name}.usdc").is_file():
            return path / f"{name}.usdc"
    found = sorted(p for s in USD_SUFFIXES for p in path.glob(f"*{s}") if not p.name.startswith("."))
    if len(found) != 1:
        what = "no USD file" if not found else f"{len(found)} USD files ({', '.join(p.name for p in found)})"
        raise InputError(f"{path}: {what}; give the run's directory (written by warp-cut run without "
                         "--no-usd) or the USD file itself")
    return found[0]


def _read_forces(path: Path, frames: int) -> np.ndarray | None:
    """Tool force [N] per frame, (frames, 3), from timeseries.csv, or None if it does not fit."""
    if not path.is_file():
        return None
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    if len(rows) != frames or not rows or not {"tool_fx", "tool_fy", "tool_fz"} <= set(rows[0]):
        return None
    return np.array([[float(r[c] or 0.0) for c in ("tool_fx", "tool_fy", "tool_fz")] for r in rows])


class RunPlayback:
    """The frames of a finished run (a run directory or its USD file).

    ``frame_count`` frames at ``fps`` per second; ``frame(k)`` is frame k as a ViewFrame.
    Raises InputError for a missing or unreadable export.
    """

    def __init__(self, path):
        self.path = find_usd(path)
        stage = Usd.Stage.Open(str(self.path))
        if stage is None:
            raise InputError(f"{self.path}: not a readable USD stage")
        self.mesh = UsdGeom.Mesh(stage.GetPrimAtPath(TISSUE))
        if not self.mesh:
            raise InputError(f"{self.path}: no tissue mesh at {TISSUE} (not a warp-cut export)")
        self.stage = stage
        self.curves = UsdGeom.BasisCurves(stage.GetPrimAtPath(INCISION))
        self.tool = UsdGeom.Cylinder(stage.GetPrimAtPath(TOOL))
        self.classes = UsdGeom.PrimvarsAPI(self.mesh).GetPrimvar("displayColor")
        self.start = int(stage.GetStartTimeCode())
        self.frame_count = int(stage.GetEndTimeCode()) - self.start + 1
        self.fps = float(stage.GetTimeCodesPerSecond())
        self.name = self.path.stem
        self.forces = _read_forces(self.path.parent / "timeseries.csv", self.frame_count)

    def _faces(self, t: float) -> np.ndarray:
        counts = np.asarray(self.mesh.GetFaceVertexCountsAttr().Get(t) or [], dtype=np.int64)
        indices = np.asarray(self.mesh.GetFaceVertexIndicesAttr().Get(t) or [], dtype=np.int32)
        if np.any(counts != 3) or len(indices) != 3 * len(counts):
            raise InputError(f"{self.path}: the tissue at time {t:g} is not a triangle mesh")
        return indices.reshape(-1, 3)

    def _tool(self, t: float):
        if not self.tool or self.tool.GetVisibilityAttr().Get(t) == UsdGeom.Tokens.invisible:
            return None
        height = self.tool.GetHeightAttr().Get(t)
        if height is None:
            return None
        m = UsdGeom.Xformable(self.tool).ComputeLocalToWorldTransform(t)
        p0 = np.array(m.Transform(Gf.Vec3d(0.0, 0.0, -0.5 * height)))
        p1 = np.array(m.Transform(Gf.Vec3d(0.0, 0.0, 0.5 * height)))
        return p0, p1, float(self.tool.GetRadiusAttr().Get(t))

    def frame(self, k: int) -> ViewFrame:
        """Frame k (0 <= k < frame_count)."""
        if not 0 <= k < self.frame_count:
            raise InputError(f"frame must be in [0, {self.frame_count - 1}], got {k}")
        t = float(self.start + k)
        points = np.asarray(self.mesh.GetPointsAttr().Get(t) or [], dtype=np.float32).reshape(-1, 3)
        faces = self._faces(t)
        indices = self.classes.GetIndices(t) if self.classes else None
        classes = (np.asarray(indices, dtype=np.int8) if indices is not None and len(indices) == len(points)
                   else np.zeros(len(points), np.int8))
        curve = np.asarray(self.curves.GetPointsAttr().Get(t) or [], dtype=np.float64) if self.curves else []
        force = self.forces[k] if self.forces is not None else np.zeros(3)
        return ViewFrame(time=t / self.fps, points=points, faces=faces, node_class=classes,
                         topology=(len(points), hash(faces.tobytes())),
                         incision=curve.reshape(-1, 3) if len(curve) >= 4 else None,
                         tool=self._tool(t), force=np.asarray(force, dtype=np.float64))
