"""USD playback export: a run as an animated stage for usdview, Omniverse or Blender (usd-core).

Files written for ``DIR/NAME.usdc`` (``.usda`` writes text files, for small debug runs):

* ``DIR/NAME.usdc`` - the stage: metadata (defaultPrim /World, upAxis Z, metersPerUnit 1,
  timeCodesPerSecond = framesPerSecond = the scene's fps, start and end time codes), the prims
  and their static attributes, and value-clip metadata on /World naming the chunk files;
* ``DIR/NAME_clips/manifest.usdc`` - the attributes the chunks animate;
* ``DIR/NAME_clips/NAME.0000.usdc``, ... - the time samples of ``chunk_frames`` frames each.

Time code k is output frame k (frame 0 is the initial state). The tissue is ``/World/Tissue``
(Mesh, no subdivision): active nodes only, ``points`` and ``extent`` every frame, topology and
``primvars:nodeIndex`` (the model's node index of each point) when ``topology_version`` changes,
node classes as the indexed vertex primvar ``displayColor`` (five class colours; indices when the
classes change). The incision is ``/World/Incision`` (BasisCurves, cubic bezier) with the
control points of its chain each frame it exists (no curve before). The tool is
``/World/Tool``, a Cylinder (axis Z, the tool's radius, height = its length) placed by
``xformOp:translate`` (axis midpoint) and ``xformOp:orient`` (+Z onto p0 -> p1).

Long runs: memory holds one chunk. Each chunk is written to a temporary name and renamed when
complete, then the top-level file is rewritten the same way to list it and extend endTimeCode,
so a run killed part-way leaves a stage that plays every frame of its completed chunks. Every
chunk re-authors the held values (topology, classes, incision, tool height) at its first frame,
so each chunk file stands alone. ``flush()`` closes the chunk in progress early (an interactive
run saving what it has so far) and recording goes on; the clip metadata names each chunk's
first frame.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import time
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from ..cut.classes import NODE_CLASS_COLORS, NodeClass
from ..errors import InputError, SimulationUnstable
from ..mesh.geometry import compact_surface
from .files import atomic_path

__all__ = ["UsdRecorder", "axis_quaternion", "flatten_usd", "DEFAULT_CHUNK_FRAMES", "USD_SUFFIXES"]

DEFAULT_CHUNK_FRAMES = 100
"""Frames per chunk file: the memory held and the most a killed run can lose."""

USD_SUFFIXES = (".usdc", ".usda", ".usd")
"""File names the exporter writes (``.usd`` is binary crate, like ``.usdc``)."""

TISSUE, INCISION, TOOL = "/World/Tissue", "/World/Incision", "/World/Tool"

_INCISION_COLOR = (0.45, 0.02, 0.02)
_TOOL_COLOR = (0.75, 0.78, 0.82)


def axis_quaternion(direction) -> tuple[float, float, float, float]:
    """The shortest rotation taking +Z onto a direction.

    Args:
        direction: Any non-zero vector, shape (3,).

    Returns:
        Unit quaternion (w, x, y, z).
    """
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    # half-angle form: accurate for every direction, including near -Z
    c = np.sqrt(max(0.0, 0.5 * (1.0 + d[2])))
    s = np.sqrt(max(0.0, 0.5 * (1.0 - d[2])))
    n = np.array([-d[1], d[0], 0.0])  # z x d
    norm = np.linalg.norm(n)
    n = n / norm if norm > 0 else np.array([1.0, 0.0, 0.0])  # d = +-Z: any axis in the XY plane
    return (float(c), float(s * n[0]), float(s * n[1]), 0.0)


def _clip_attributes(has_tool: bool):
    """(prim path, attribute name, Sdf type name) of every attribute the chunks animate."""
    t = Sdf.ValueTypeNames
    attrs = [(TISSUE, "points", t.Point3fArray), (TISSUE, "extent", t.Float3Array),
             (TISSUE, "faceVertexCounts", t.IntArray), (TISSUE, "faceVertexIndices", t.IntArray),
             (TISSUE, "primvars:displayColor:indices", t.IntArray),
             (TISSUE, "primvars:nodeIndex", t.IntArray),
             (INCISION, "points", t.Point3fArray), (INCISION, "curveVertexCounts", t.IntArray),
             (INCISION, "extent", t.Float3Array)]
    if has_tool:
        attrs += [(TOOL, "xformOp:translate", t.Double3), (TOOL, "xformOp:orient", t.Quatf),
                  (TOOL, "height", t.Double), (TOOL, "extent", t.Float3Array),
                  (TOOL, "visibility", t.Token)]
    return attrs


def _extent(points: np.ndarray, pad: float = 0.0):
    """Bounds [min, max] [m] of points (n, 3) [m] grown by ``pad`` [m] (zeros for no points)."""
    if len(points) == 0:
        return Vt.Vec3fArray([Gf.Vec3f(0.0), Gf.Vec3f(0.0)])
    lo, hi = points.min(axis=0) - pad, points.max(axis=0) + pad
    return Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))])


class UsdRecorder:
    """Run observer writing the USD playback of a run (see the module docstring).

    Nothing is written before the first frame; a previous export at ``path`` is replaced then.
    ``abort()`` removes what this recorder wrote.

    Args:
        path: The top-level file, ending in ``.usdc``, ``.usda`` or ``.usd``.
        scene: A Scene giving the fps and tool path (or pass them one by one).
        fps: Output frames per second [1/s] (time codes per second).
        tool_path: The ToolPath placing the tool at each frame's time; without one the
            Simulator's last tool pose is used (``tool_radius`` then declares the tool).
        tool_radius: Tool radius [m] when there is no tool path (None: no tool prim).
        chunk_frames: Frames per chunk file (>= 1).

    Raises:
        InputError: A bad file name, chunk size or fps.
    """

    def __init__(self, path, scene=None, *, fps: float | None = None, tool_path=None,
                 tool_radius: float | None = None, chunk_frames: int = DEFAULT_CHUNK_FRAMES):
        self.path = Path(path)
        if self.path.suffix not in USD_SUFFIXES:
            raise InputError(f"--usd {path}: the file name must end in one of {', '.join(USD_SUFFIXES)}")
        if self.path.exists() and not self.path.is_file():
            raise InputError(f"--usd {path}: exists and is not a file")
        if isinstance(chunk_frames, bool) or not isinstance(chunk_frames, int) or chunk_frames < 1:
            raise InputError(f"--usd-chunk must be an integer >= 1 (frames per file), got {chunk_frames!r}")
        if scene is not None:
            fps = scene.fps if fps is None else fps
            tool_path = scene.tool_path() if tool_path is None else tool_path
        if fps is None or not (np.isfinite(fps) and fps > 0):
            raise InputError(f"fps must be a positive number of frames per second, got {fps!r}")
        self.fps = float(fps)
        self.tool_path = tool_path
        radius = tool_path.radius if tool_path is not None else tool_radius
        self.tool_radius = None if radius is None else float(radius)
        self.chunk_frames = chunk_frames
        self._curve_width = float(self.tool_radius or 5e-4)
        self.clip_dir = self.path.with_name(f"{self.path.stem}_clips")
        self.frames_written = 0
        """Frames in completed chunks (what the top-level file plays)."""
        self.write_time = 0.0
        """Wall time spent writing USD [s]."""
        self._stage = None
        self._chunk = None
        self._chunk_start = 0
        self._chunk_paths: list[str] = []
        self._chunk_starts: list[int] = []
        """First frame of each written chunk (a flush can end a chunk early)."""
        self._held: dict = {}
        self._topology = None
        self._last_frame = -1
        self._created_dir = False

    # ------------------------------------------------------------------ files
    def _file(self, name: str) -> Path:
        """A file of the clip directory, with the top-level file's suffix."""
        return self.clip_dir / f"{name}{self.path.suffix}"

    def _remove_outputs(self) -> None:
        """Delete the top-level file and the chunk files of this path (ours by name)."""
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()
        if self.clip_dir.is_dir():
            shutil.rmtree(self.clip_dir)

    def _export(self, layer, target: Path) -> None:
        """Write ``layer`` to ``target`` atomically."""
        with atomic_path(target, suffix=target.suffix) as tmp:
            if not layer.Export(str(tmp)):
                raise OSError(f"could not write {target}")

    def _start(self) -> None:
        """Write the manifest and build the stage: metadata, prims, static attributes, clips."""
        self._created_dir = not self.path.parent.exists()
        self._remove_outputs()
        self.clip_dir.mkdir(parents=True)
        has_tool = self.tool_radius is not None
        self._attrs = _clip_attributes(has_tool)
        manifest = Sdf.Layer.CreateAnonymous(self.path.suffix)
        for prim, name, type_name in self._attrs:
            spec = manifest.GetPrimAtPath(prim) or Sdf.CreatePrimInLayer(manifest, prim)
            Sdf.AttributeSpec(spec, name, type_name)
        self._export(manifest, self._file("manifest"))

        stage = Usd.Stage.CreateInMemory()
        world = UsdGeom.Xform.Define(stage, "/World")
        stage.SetDefaultPrim(world.GetPrim())
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        stage.SetTimeCodesPerSecond(self.fps)
        stage.SetFramesPerSecond(self.fps)
        stage.SetStartTimeCode(0)
        stage.SetEndTimeCode(0)
        mesh = UsdGeom.Mesh.Define(stage, TISSUE)
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateDoubleSidedAttr(True)
        colors = [NODE_CLASS_COLORS[c] for c in NodeClass]
        pv = UsdGeom.PrimvarsAPI(mesh)
        color = pv.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                 UsdGeom.Tokens.vertex)
        color.Set(Vt.Vec3fArray(colors))
        color.CreateIndicesAttr()  # declared here, valued by the chunks
        pv.CreatePrimvar("nodeIndex", Sdf.ValueTypeNames.IntArray, UsdGeom.Tokens.vertex)
        curves = UsdGeom.BasisCurves.Define(stage, INCISION)
        curves.CreateTypeAttr(UsdGeom.Tokens.cubic)
        curves.CreateBasisAttr(UsdGeom.Tokens.bezier)
        curves.CreateWrapAttr(UsdGeom.Tokens.nonperiodic)
        curves.CreateWidthsAttr([self._curve_width])
        curves.SetWidthsInterpolation(UsdGeom.Tokens.constant)
        curves.CreateDisplayColorAttr([_INCISION_COLOR])
        if has_tool:
            tool = UsdGeom.Cylinder.Define(stage, TOOL)
            tool.CreateAxisAttr(UsdGeom.Tokens.z)
            tool.CreateRadiusAttr(self.tool_radius)
            tool.CreateDisplayColorAttr([_TOOL_COLOR])
            tool.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble)
            tool.AddOrientOp(UsdGeom.XformOp.PrecisionFloat)
        clips = Usd.ClipsAPI(world.GetPrim())
        clips.SetClipPrimPath("/World")
        clips.SetClipManifestAssetPath(Sdf.AssetPath(f"./{self.clip_dir.name}/manifest{self.path.suffix}"))
        self._stage = stage

    def _new_chunk(self, frame: int) -> None:
        """Start an in-memory chunk layer at ``frame`` (held values are authored again)."""
        layer = Sdf.Layer.CreateAnonymous(self.path.suffix)
        for prim, name, type_name in self._attrs:
            spec = layer.GetPrimAtPath(prim) or Sdf.CreatePrimInLayer(layer, prim)
            Sdf.AttributeSpec(spec, name, type_name)
        self._chunk = layer
        self._chunk_start = frame
        self._held = {}

    def _close_chunk(self) -> None:
        """Write the chunk file, then the top-level file listing it (each atomically)."""
        if self._chunk is None:
            return
        index = len(self._chunk_paths)
        name = f"{self.path.stem}.{index:04d}"
        self._export(self._chunk, self._file(name))
        self._chunk = None
        self._chunk_paths.append(f"./{self.clip_dir.name}/{name}{self.path.suffix}")
        self._chunk_starts.append(self._chunk_start)
        end = self._last_frame
        clips = Usd.ClipsAPI(self._stage.GetPrimAtPath("/World"))
        clips.SetClipAssetPaths([Sdf.AssetPath(p) for p in self._chunk_paths])
        clips.SetClipActive([(float(start), float(k)) for k, start in enumerate(self._chunk_starts)])
        clips.SetClipTimes([(0.0, 0.0), (float(end), float(end))])
        self._stage.SetEndTimeCode(end)
        self._export(self._stage.GetRootLayer(), self.path)
        self.frames_written = end + 1

    # ------------------------------------------------------------------ authoring
    def _set(self, prim: str, name: str, frame: int, value) -> None:
        """Author a time sample of ``prim.name`` at ``frame`` in the current chunk."""
        self._chunk.SetTimeSample(f"{prim}.{name}", float(frame), value)

    def _set_held(self, prim: str, name: str, frame: int, key, make_value) -> None:
        """Author ``make_value()`` when ``key`` differs from the chunk's last authored key."""
        slot = (prim, name)
        old = self._held.get(slot, _UNSET)
        if old is not _UNSET and _same(old, key):
            return
        self._held[slot] = key
        self._set(prim, name, frame, make_value())

    def _tissue(self, sim, frame: int) -> None:
        """Author the tissue mesh: points and extent every frame, topology and classes when changed.

        Raises:
            ValueError: A triangle uses a deleted node, or a node class is out of range.
            SimulationUnstable: A live node has a non-finite position.
        """
        model = sim.model
        if self._topology is None or self._topology[0] != model.topology_version:
            try:
                keep, faces = compact_surface(model.active, model.triangles)
            except ValueError as err:
                raise ValueError(f"{err} (topology_version {model.topology_version})") from None
            self._topology = (model.topology_version, keep, faces.astype(np.int32).ravel())
        version, keep, faces = self._topology
        self._set_held(TISSUE, "faceVertexCounts", frame, version,
                       lambda: Vt.IntArray.FromNumpy(np.full(len(faces) // 3, 3, np.int32)))
        self._set_held(TISSUE, "faceVertexIndices", frame, version, lambda: Vt.IntArray.FromNumpy(faces))
        self._set_held(TISSUE, "primvars:nodeIndex", frame, version,
                       lambda: Vt.IntArray.FromNumpy(keep.astype(np.int32)))
        classes = np.asarray(model.node_class)[keep].astype(np.int32)
        if len(classes) and (classes.min() < 0 or classes.max() >= len(NodeClass)):
            raise ValueError(f"node_class holds {int(classes.max())}, outside the classes 0..{len(NodeClass) - 1}")
        self._set_held(TISSUE, "primvars:displayColor:indices", frame, classes,
                       lambda: Vt.IntArray.FromNumpy(classes))
        points = sim.state.positions.numpy()[keep]
        finite = np.all(np.isfinite(points), axis=1)
        if not finite.all():
            node = int(keep[np.flatnonzero(~finite)[0]])
            raise SimulationUnstable(node, sim.time, sim.substep, sim.step_limit.step,
                                     "has a non-finite position (USD export)")
        points = np.ascontiguousarray(points, dtype=np.float32)
        self._set(TISSUE, "points", frame, Vt.Vec3fArray.FromNumpy(points))
        self._set(TISSUE, "extent", frame, _extent(points))

    def _incision(self, sim, frame: int) -> None:
        """Author the incision's Bezier control points (3 s + 1, 3) [m] (no curve before the cut)."""
        controls = sim.incision_controls
        if controls is None:
            pts = np.zeros((0, 3), np.float32)
        else:
            pts = np.asarray(controls, dtype=np.float32)
            if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < 4 or (len(pts) - 1) % 3:
                raise ValueError(f"incision_controls must have shape (3 s + 1, 3), s >= 1, got {pts.shape}")
            if not np.all(np.isfinite(pts)):
                raise ValueError("incision_controls holds a non-finite point")
        counts = [] if len(pts) == 0 else [len(pts)]
        # points every frame the curve exists: a reader interpolates float samples linearly,
        # so a value held over frames with no sample would show a blend of its neighbours
        if len(pts):
            self._held.pop((INCISION, "points"), None)
            self._held.pop((INCISION, "extent"), None)
        self._set_held(INCISION, "points", frame, pts, lambda: Vt.Vec3fArray.FromNumpy(pts))
        self._set_held(INCISION, "curveVertexCounts", frame, len(pts), lambda: Vt.IntArray(counts))
        self._set_held(INCISION, "extent", frame, pts, lambda: _extent(pts, 0.5 * self._curve_width))

    def _tool(self, sim, frame: int) -> None:
        """Author the tool cylinder's placement, height [m] and visibility."""
        if self.tool_radius is None:
            return
        pose = self.tool_path.pose_at(sim.time) if self.tool_path is not None else sim.tool_pose
        visible = pose is not None and pose.length > 0
        self._set_held(TOOL, "visibility", frame, visible,
                       lambda: UsdGeom.Tokens.inherited if visible else UsdGeom.Tokens.invisible)
        if not visible:
            return
        length, r = pose.length, self.tool_radius
        mid = 0.5 * (pose.p0 + pose.p1)
        w, x, y, z = axis_quaternion(pose.p1 - pose.p0)
        self._set(TOOL, "xformOp:translate", frame, Gf.Vec3d(*map(float, mid)))
        self._set(TOOL, "xformOp:orient", frame, Gf.Quatf(w, x, y, z))
        self._set_held(TOOL, "height", frame, length, lambda: float(length))
        self._set_held(TOOL, "extent", frame, length, lambda: Vt.Vec3fArray(
            [Gf.Vec3f(-r, -r, -0.5 * length), Gf.Vec3f(r, r, 0.5 * length)]))

    # ------------------------------------------------------------------ observer protocol
    def on_frame(self, sim, frame: int) -> None:
        """Record the Simulator's state as time code ``frame``.

        Args:
            sim: The Simulator.
            frame: Output frame index; frames must increase from call to call.

        Raises:
            ValueError: ``frame`` does not increase.
        """
        start = time.perf_counter()
        if frame <= self._last_frame:
            raise ValueError(f"frames must increase: got {frame} after {self._last_frame}")
        if self._stage is None:
            self._start()
        if self._chunk is not None and frame >= self._chunk_start + self.chunk_frames:
            self._close_chunk()
        if self._chunk is None:
            self._new_chunk(frame)
        self._last_frame = frame
        self._tissue(sim, frame)
        self._incision(sim, frame)
        self._tool(sim, frame)
        self.write_time += time.perf_counter() - start

    def flush(self) -> None:
        """Write the frames recorded so far: the chunk in progress is closed early and the
        top-level file lists it. Recording may go on (the next frame starts a new chunk)."""
        start = time.perf_counter()
        self._close_chunk()
        self.write_time += time.perf_counter() - start

    def finish(self, metrics: dict | None = None) -> None:
        """Write the last chunk and the final top-level file.

        Args:
            metrics: If given, gains ``usd_file``, ``usd_frames`` and ``usd_write_time_s`` [s].
        """
        self.flush()
        if metrics is not None and self._stage is not None:
            metrics["usd_file"] = str(self.path)
            metrics["usd_frames"] = self.frames_written
            metrics["usd_write_time_s"] = self.write_time

    def abort(self) -> None:
        """Remove everything this recorder wrote (a run that failed leaves no output)."""
        if self._stage is None:
            return
        self._chunk = None
        self._remove_outputs()
        if self._created_dir:
            with contextlib.suppress(OSError):
                os.rmdir(self.path.parent)
        self._stage = None


def flatten_usd(source, target) -> Path:
    """Write a stage with its chunks resolved into one self-contained file, atomically.

    For tools without value-clip support. The whole animation is held in memory while
    flattening.

    Args:
        source: The top-level file of an export.
        target: The flat file (.usdc, .usda or .usd).

    Returns:
        ``target``.

    Raises:
        InputError: ``source`` is missing or unreadable, or ``target`` has another suffix.
    """
    source, target = Path(source), Path(target)
    if not source.is_file():
        raise InputError(f"{source}: file not found")
    if target.suffix not in USD_SUFFIXES:
        raise InputError(f"{target}: the file name must end in one of {', '.join(USD_SUFFIXES)}")
    stage = Usd.Stage.Open(str(source))
    if stage is None:
        raise InputError(f"{source}: not a readable USD stage")
    layer = stage.Flatten()
    with atomic_path(target, suffix=target.suffix) as tmp:
        if not layer.Export(str(tmp)):
            raise OSError(f"could not write {target}")
    return target


_UNSET = object()


def _same(a, b) -> bool:
    """Equality of held keys (arrays compared element-wise)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and np.array_equal(a, b)
    return a == b
