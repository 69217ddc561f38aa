"""Scene files: TOML in SI units, validated key by key before anything runs.

Every error names the file, the key and the allowed range (see README, "Scene files").
"""

from __future__ import annotations

import copy
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .cut.cutter import CutSettings
from .errors import InputError, SceneError
from .sim.control import ToolPath
from .sim.material import Material
from .sim.model import TissueModel, boundary_nodes
from .sim.stiffness import STIFFNESS_MODELS, material_stiffness
from .solvers import INTEGRATORS

__all__ = ["Scene", "load_scene", "parse_scene", "apply_overrides", "bundled_scene_path",
           "DEFAULT_SCENE"]

DEFAULT_SCENE = "straight_incision"
"""Bundled scene run by ``warp-cut run`` without a scene argument."""

_SCHEMA: dict[str, set[str]] = {
    "": {"name", "duration", "fps", "device", "tissue", "material", "physics", "solver", "tool",
         "cutting"},
    "tissue": {"kind", "size", "spacing", "path", "scale", "thickness", "density", "pinned",
               "uniform_mass"},
    "material": {"stiffness", "stiffness_model", "damping", "youngs_modulus", "residual_strain"},
    "physics": {"gravity", "residual_stress", "collision", "cutting"},
    "solver": {"integrator", "dt", "substeps", "safety"},
    "tool": {"radius", "length", "keyframes"},
    "cutting": {"sweep_radius", "interval", "force_threshold", "spacing", "tolerance", "lip_offset"},
}
_EXTENSIONS: dict[str, set[str]] = {}
"""Extra top-level tables other modules register (name -> allowed keys)."""


def register_section(name: str, keys: set[str]) -> None:
    """Allow an extra top-level table ``[name]`` with ``keys`` (validated by its owner)."""
    _EXTENSIONS[name] = set(keys)


def bundled_scene_path(name: str) -> Path:
    """Path of a scene shipped with the package (``scenes/NAME.toml``)."""
    base = resources.files("warp_cut.scenes")
    candidate = base / (name if name.endswith(".toml") else f"{name}.toml")
    return Path(str(candidate))


def bundled_scene_names() -> list[str]:
    base = resources.files("warp_cut.scenes")
    return sorted(p.name[:-5] for p in base.iterdir() if p.name.endswith(".toml"))


class _Reader:
    """Typed access to a nested dict with errors that name the file and key."""

    def __init__(self, data: dict, path):
        self.data = data
        self.path = path

    def error(self, key: str, message: str) -> SceneError:
        return SceneError(self.path, key, message)

    def table(self, name: str) -> dict:
        value = self.data.get(name, {})
        if not isinstance(value, dict):
            raise self.error(name, f"must be a table, got {type(value).__name__}")
        return value

    def number(self, table: dict, section: str, key: str, default=None, *, low=None,
               high=None, low_open=False, integer=False):
        full = f"{section}.{key}" if section else key
        value = table.get(key, default)
        if value is None:
            raise self.error(full, "is required")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(full, f"must be a number, got {value!r}")
        if integer and float(value) != int(value):
            raise self.error(full, f"must be an integer, got {value!r}")
        value = int(value) if integer else float(value)
        rng = f"{'(' if low_open else '['}{low if low is not None else '-inf'}, {high if high is not None else 'inf'}]"
        if not math.isfinite(value):
            raise self.error(full, f"must be finite, allowed range {rng}, got {value}")
        if low is not None and (value <= low if low_open else value < low):
            raise self.error(full, f"must be in {rng}, got {value}")
        if high is not None and value > high:
            raise self.error(full, f"must be in {rng}, got {value}")
        return value

    def boolean(self, table: dict, section: str, key: str, default: bool) -> bool:
        value = table.get(key, default)
        if not isinstance(value, bool):
            raise self.error(f"{section}.{key}", f"must be true or false, got {value!r}")
        return value

    def vector(self, value, full: str, length: int = 3) -> np.ndarray:
        if (not isinstance(value, (list, tuple)) or len(value) != length
                or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value)):
            raise self.error(full, f"must be a list of {length} numbers, got {value!r}")
        arr = np.asarray(value, dtype=np.float64)
        if not np.all(np.isfinite(arr)):
            raise self.error(full, f"must be finite, got {value!r}")
        return arr

    def choice(self, table: dict, section: str, key: str, default, allowed) -> str:
        value = table.get(key, default)
        if value not in allowed:
            raise self.error(f"{section}.{key}", f"must be one of {sorted(allowed)}, got {value!r}")
        return value


@dataclass
class Scene:
    """A validated scene. ``data`` is the resolved TOML (overrides applied); ``path`` its file."""

    name: str
    duration: float
    fps: float
    device: str
    material: Material
    tissue: dict
    physics: dict
    solver: dict
    tool: dict | None
    cutting: dict
    data: dict = field(repr=False)
    path: Path | None = None
    stiffness_model: str = "constant"
    """``"constant"`` (every spring K) or ``"material"`` (from E and thickness, see stiffness.py)."""

    @property
    def frame_count(self) -> int:
        """Output frames after t = 0."""
        return max(1, round(self.duration * self.fps))

    def build_model(self) -> TissueModel:
        """The TissueModel this scene describes."""
        t = self.tissue
        try:
            if t["kind"] == "patch":
                model = TissueModel.from_patch(t["size"], t["spacing"], material=self.material,
                                               pinned="none")
            else:
                model = TissueModel.from_mesh_file(t["path"], material=self.material,
                                                   pinned="none", scale=t["scale"])
        except InputError as exc:
            raise SceneError(self.path, "tissue", str(exc)) from exc
        if t["uniform_mass"] is not None:
            model.masses[:] = t["uniform_mass"]
        pinned = t["pinned"]
        if pinned == "border":
            model.pinned |= boundary_nodes(model.node_count, model.triangles)
        elif isinstance(pinned, dict) and "box" in pinned:
            model.pin_box(*pinned["box"])
        elif isinstance(pinned, dict) and "indices" in pinned:
            idx = np.asarray(pinned["indices"], dtype=np.int64)
            if len(idx) and (idx.min() < 0 or idx.max() >= model.node_count):
                raise SceneError(self.path, "tissue.pinned.indices",
                                 f"must be node indices in [0, {model.node_count - 1}]")
            model.pinned[idx] = True
        if self.stiffness_model == "material":
            model.stiffness = material_stiffness(
                model.points, model.triangles, model.springs, self.material.youngs_modulus,
                self.material.thickness, fallback=self.material.stiffness)
        return model

    def tool_path(self) -> ToolPath | None:
        """The keyframed tool, or None if the scene has no tool."""
        if self.tool is None:
            return None
        k = self.tool["keyframes"]
        return ToolPath([f["t"] for f in k], [f["p0"] for f in k], [f["p1"] for f in k],
                        self.tool["radius"])

    def simulator_options(self) -> dict:
        """Keyword arguments for ``Simulator`` (without dt, which the run loop fits to frames)."""
        p = self.physics
        return dict(integrator=self.solver["integrator"],
                    gravity=p["gravity"] if p["gravity"] is not None else None,
                    device=self.device, substeps=self.solver["substeps"],
                    residual_stress=p["residual_stress"], collision=p["collision"],
                    safety=self.solver["safety"], cutting=self.cut_settings())

    def cut_settings(self):
        """The CutSettings of ``[cutting]`` if ``physics.cutting`` is on, else None."""
        if not self.physics["cutting"]:
            return None

        return CutSettings(**self.cutting)


def _check_keys(reader: _Reader, table: dict, section: str) -> None:
    allowed = _SCHEMA.get(section) or _EXTENSIONS.get(section, set())
    if section == "":
        allowed = allowed | set(_EXTENSIONS)
    for key in table:
        if key not in allowed:
            where = f"{section}.{key}" if section else key
            raise reader.error(where, f"unknown key; allowed keys here: {sorted(allowed)}")


def parse_scene(data: dict, path=None) -> Scene:
    """Validate a scene dictionary (as loaded from TOML) into a Scene."""
    r = _Reader(data, path)
    _check_keys(r, data, "")
    name = data.get("name", Path(path).stem if path else "scene")
    if not isinstance(name, str) or not name or any(c in name for c in "/\\\0"):
        raise r.error("name", f"must be a non-empty string without slashes, got {name!r}")
    duration = r.number(data, "", "duration", 1.0, low=0, high=1e6, low_open=True)
    fps = r.number(data, "", "fps", 60.0, low=0, high=1e5, low_open=True)
    device = data.get("device", "cpu")
    if not isinstance(device, str) or not (device == "cpu" or device.startswith("cuda")):
        raise r.error("device", f"must be 'cpu', 'cuda' or 'cuda:N', got {device!r}")

    mat_t = r.table("material")
    _check_keys(r, mat_t, "material")
    tis_t = r.table("tissue")
    _check_keys(r, tis_t, "tissue")
    defaults = Material()
    material = Material(
        stiffness=r.number(mat_t, "material", "stiffness", defaults.stiffness, low=0, high=1e9),
        damping=r.number(mat_t, "material", "damping", defaults.damping, low=0, high=1e9),
        youngs_modulus=r.number(mat_t, "material", "youngs_modulus", defaults.youngs_modulus,
                                low=0, high=1e12),
        residual_strain=r.number(mat_t, "material", "residual_strain", defaults.residual_strain,
                                 low=0, high=0.99),
        thickness=r.number(tis_t, "tissue", "thickness", defaults.thickness, low=0, high=1.0,
                           low_open=True),
        density=r.number(tis_t, "tissue", "density", defaults.density, low=0, high=1e5,
                         low_open=True),
    )

    stiffness_model = r.choice(mat_t, "material", "stiffness_model", "constant",
                               set(STIFFNESS_MODELS))
    kind = r.choice(tis_t, "tissue", "kind", "patch", {"patch", "mesh"})
    tissue: dict[str, Any] = {"kind": kind, "scale": 1.0, "uniform_mass": None}
    if kind == "patch":
        size = r.vector(tis_t.get("size", [0.10, 0.06]), "tissue.size", 2)
        if np.any(size <= 0) or np.any(size > 100):
            raise r.error("tissue.size", f"must be two lengths in (0, 100] m, got {size.tolist()}")
        tissue["size"] = tuple(size)
        tissue["spacing"] = r.number(tis_t, "tissue", "spacing", 2e-3, low=0, low_open=True,
                                     high=float(min(size)))
        if np.prod(size / tissue["spacing"]) > 5e6:
            raise r.error("tissue.spacing", f"gives more than 5e6 nodes for size {size.tolist()}; "
                                            "allowed: size[0]*size[1]/spacing^2 <= 5e6")
    else:
        raw = tis_t.get("path")
        if not isinstance(raw, str) or not raw:
            raise r.error("tissue.path", "is required for kind = 'mesh' (an OBJ, STL or PLY file)")
        mesh_path = Path(raw)
        if not mesh_path.is_absolute() and path is not None:
            mesh_path = Path(path).parent / mesh_path
        if not mesh_path.is_file():
            raise r.error("tissue.path", f"file not found: {mesh_path}")
        if mesh_path.suffix.lower() not in (".obj", ".stl", ".ply"):
            raise r.error("tissue.path", f"must be an .obj, .stl or .ply file, got {mesh_path.name}")
        tissue["path"] = mesh_path
        tissue["scale"] = r.number(tis_t, "tissue", "scale", 1.0, low=0, low_open=True)
    if "uniform_mass" in tis_t:
        tissue["uniform_mass"] = r.number(tis_t, "tissue", "uniform_mass", low=0, low_open=True)
    pinned = tis_t.get("pinned", "border")
    if isinstance(pinned, dict):
        if set(pinned) == {"box"}:
            box = pinned["box"]
            if not isinstance(box, list) or len(box) != 2:
                raise r.error("tissue.pinned.box", "must be [[x0, y0, z0], [x1, y1, z1]] in m")
            lo = r.vector(box[0], "tissue.pinned.box[0]")
            hi = r.vector(box[1], "tissue.pinned.box[1]")
            if np.any(lo > hi):
                raise r.error("tissue.pinned.box", "needs lower corner <= upper corner")
            pinned = {"box": (lo, hi)}
        elif set(pinned) == {"indices"}:
            idx = pinned["indices"]
            if not isinstance(idx, list) or any(isinstance(i, bool) or not isinstance(i, int) for i in idx):
                raise r.error("tissue.pinned.indices", "must be a list of node indices")
        else:
            raise r.error("tissue.pinned", "a table must be {box = [[..], [..]]} or {indices = [..]}")
    elif pinned not in ("border", "none"):
        raise r.error("tissue.pinned",
                      f"must be 'border', 'none', {{box = [[x0,y0,z0],[x1,y1,z1]]}} or "
                      f"{{indices = [...]}}, got {pinned!r}")
    tissue["pinned"] = pinned

    phys_t = r.table("physics")
    _check_keys(r, phys_t, "physics")
    gravity_on = phys_t.get("gravity", [0.0, 0.0, -9.81])
    if gravity_on is False:
        gravity = None
    else:
        gravity = r.vector(gravity_on, "physics.gravity")
        if np.linalg.norm(gravity) > 1e4:
            raise r.error("physics.gravity", "magnitude must be <= 1e4 m/s^2")
    physics = {
        "gravity": gravity,
        "residual_stress": r.boolean(phys_t, "physics", "residual_stress", True),
        "collision": r.boolean(phys_t, "physics", "collision", True),
        "cutting": r.boolean(phys_t, "physics", "cutting", False),
    }

    sol_t = r.table("solver")
    _check_keys(r, sol_t, "solver")
    solver = {"integrator": r.choice(sol_t, "solver", "integrator", "semi_implicit",
                                     set(INTEGRATORS))}
    dt = sol_t.get("dt", 1e-3)
    solver["dt"] = "auto" if dt == "auto" else r.number(sol_t, "solver", "dt", 1e-3, low=0,
                                                        high=1.0 / fps, low_open=True)
    sub = sol_t.get("substeps", "auto")
    solver["substeps"] = "auto" if sub == "auto" else r.number(
        sol_t, "solver", "substeps", low=1, high=1e6, integer=True)
    solver["safety"] = r.number(sol_t, "solver", "safety", 0.5, low=0, high=1.0, low_open=True)

    cut_t = r.table("cutting")
    _check_keys(r, cut_t, "cutting")
    cutting = {}
    for key in ("sweep_radius", "spacing", "tolerance", "lip_offset"):
        if key in cut_t:
            cutting[key] = r.number(cut_t, "cutting", key, low=0, high=1.0, low_open=True)
    if "interval" in cut_t:
        cutting["interval"] = r.number(cut_t, "cutting", "interval", low=0, high=duration)
    if "force_threshold" in cut_t:
        cutting["force_threshold"] = r.number(cut_t, "cutting", "force_threshold", low=0, high=1e6)
    if physics["cutting"] and "tool" not in data:
        raise r.error("physics.cutting", "needs a [tool] to cut with")

    tool = None
    if "tool" in data:
        tool_t = r.table("tool")
        _check_keys(r, tool_t, "tool")
        radius = r.number(tool_t, "tool", "radius", low=0, high=1.0)
        keys = tool_t.get("keyframes")
        if not isinstance(keys, list) or not keys:
            raise r.error("tool.keyframes", "needs at least one [[tool.keyframes]] with t, p0, p1")
        frames = []
        for n, kf in enumerate(keys):
            where = f"tool.keyframes[{n}]"
            if not isinstance(kf, dict) or set(kf) != {"t", "p0", "p1"}:
                raise r.error(where, "must have exactly the keys t [s], p0 [m] (tip), p1 [m]")
            t = r.number(kf, where, "t", low=0, high=1e6)
            frames.append({"t": t, "p0": r.vector(kf["p0"], f"{where}.p0"),
                           "p1": r.vector(kf["p1"], f"{where}.p1")})
            if len(frames) > 1 and t <= frames[-2]["t"]:
                raise r.error(f"{where}.t", "keyframe times must be strictly increasing")
        lengths = [float(np.linalg.norm(f["p1"] - f["p0"])) for f in frames]
        length = tool_t.get("length")
        if length is not None:
            length = r.number(tool_t, "tool", "length", low=0, low_open=True, high=10.0)
            for n, L in enumerate(lengths):
                if abs(L - length) > 1e-6 * max(1.0, length):
                    raise r.error(f"tool.keyframes[{n}]",
                                  f"|p1 - p0| = {L:.6g} m differs from tool.length = {length} m "
                                  "(the tool is rigid)")
        tool = {"radius": radius, "length": length if length is not None else max(lengths),
                "keyframes": frames}
    return Scene(name=name, duration=duration, fps=fps, device=device, material=material,
                 tissue=tissue, physics=physics, solver=solver, tool=tool, cutting=cutting,
                 data=data, path=Path(path) if path else None, stiffness_model=stiffness_model)


def apply_overrides(data: dict, overrides: list[str], path=None) -> dict:
    """Apply ``section.key=value`` strings (values in TOML syntax; bare words are strings)."""
    data = copy.deepcopy(data)
    for item in overrides or []:
        if "=" not in item:
            raise SceneError(path, item, "an override must look like section.key=value")
        key, raw = item.split("=", 1)
        key = key.strip()
        try:
            value = tomllib.loads(f"v = {raw}")["v"]
        except tomllib.TOMLDecodeError:
            value = raw.strip()
        parts = key.split(".")
        if not all(parts):
            raise SceneError(path, key, "an override key must be dotted names like tool.radius")
        node = data
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise SceneError(path, key, f"'{part}' is not a table")
        node[parts[-1]] = value
    return data


def load_scene(source, overrides: list[str] | None = None) -> Scene:
    """Load and validate a scene from a path or a bundled scene name."""
    if source is None:
        source = DEFAULT_SCENE
    path = Path(source)
    if not path.is_file():
        bundled = bundled_scene_path(str(source))
        if not bundled.is_file():
            raise SceneError(path, "file", f"scene not found (bundled scenes: {', '.join(bundled_scene_names())})")
        path = bundled
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SceneError(path, "file", f"is not valid TOML: {exc}") from exc
    return parse_scene(apply_overrides(data, overrides or [], path), path)
