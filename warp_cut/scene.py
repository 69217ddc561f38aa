"""Scene files: TOML in SI units, validated key by key before anything runs.

Every error names the file, the key and the allowed range (see docs/scenes.md). A scene is
parsed section by section into frozen dataclasses: ``TissueSection``, ``PhysicsSection``,
``SolverSection``, ``ToolSection``, the ``Material`` and the ``CutSettings``.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from .cut.settings import MAX_TRAVEL, ONE_EVENT_RULE, CutSettings
from .errors import InputError, SceneError
from .mesh.checks import cuttable_problems
from .sim.bending import flexural_rigidity
from .sim.control import ToolPath
from .sim.material import RESIDUAL_STRESS_MODELS, Material
from .sim.model import TissueModel, boundary_nodes
from .sim.stiffness import STIFFNESS_MODELS, material_stiffness
from .solvers import INTEGRATORS

__all__ = ["Scene", "TissueSection", "PhysicsSection", "SolverSection", "ToolSection", "Keyframe",
           "load_scene", "parse_scene", "apply_overrides", "bundled_scene_path", "DEFAULT_SCENE"]

DEFAULT_SCENE = "straight_incision"
"""Bundled scene run by ``warp-cut run`` without a scene argument."""

DEFAULT_FOUNDATION_STIFFNESS = 1.0e6
"""``material.foundation_stiffness`` k_f [N/m^3] when ``physics.foundation`` is on and none is given:
a subcutaneous layer of Young's modulus ~5-10 kPa and 5-10 mm thickness (k_f ~ E / depth); the
Table 1 skin patch then settles by rho t g / k_f = 22 um under gravity."""

_SCHEMA: dict[str, set[str]] = {
    "": {"name", "duration", "fps", "device", "tissue", "material", "physics", "solver", "tool",
         "cutting"},
    "tissue": {"kind", "size", "spacing", "path", "scale", "thickness", "density", "pinned",
               "uniform_mass"},
    "material": {"stiffness", "stiffness_model", "damping", "youngs_modulus", "residual_strain",
                 "residual_stress_model", "foundation_stiffness", "bending_rigidity"},
    "physics": {"gravity", "residual_stress", "collision", "cutting", "foundation", "bending"},
    "solver": {"integrator", "dt", "substeps", "safety"},
    "tool": {"radius", "length", "keyframes"},
    "cutting": {"sweep_radius", "interval", "travel",
                "force_threshold", "spacing", "tolerance", "lip_offset", "keep_islands"},
}
"""Allowed keys of each table ("" is the top level)."""


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


@dataclass(frozen=True)
class TissueSection:
    """``[tissue]``: where the mesh comes from and which nodes are pinned.

    Attributes:
        kind: ``"patch"`` (the skin patch generator) or ``"mesh"`` (a mesh file).
        size: Patch width (x) and height (y) [m] (kind = "patch").
        spacing: Patch node spacing [m] (kind = "patch").
        path: Mesh file, resolved against the scene file (kind = "mesh").
        scale: Factor from mesh-file units to metres.
        uniform_mass: Every node's mass [kg], or None for lumped masses.
        pinned: ``"border"``, ``"none"``, ``("box", lower (3,), upper (3,))`` [m] or
            ``("indices", node indices)``.
    """

    kind: str = "patch"
    size: tuple[float, float] = (0.10, 0.06)
    spacing: float = 2e-3
    path: Path | None = None
    scale: float = 1.0
    uniform_mass: float | None = None
    pinned: str | tuple = "border"


@dataclass(frozen=True)
class PhysicsSection:
    """``[physics]``: which physics the scene asks for (what it leaves out is not compiled).

    Attributes:
        gravity: Gravity [m/s^2], shape (3,), or None for none.
        residual_stress: The residual stress (links where the cut deletes springs, or the
            prestress, as ``material.residual_stress_model`` says).
        collision: The tool test and response.
        cutting: Cut the tissue where the tool goes.
        foundation: A support holding each node to its rest position
            (``material.foundation_stiffness``).
        bending: The sheet resists bending (a hinge on every interior edge,
            ``material.bending_rigidity``; ``warp_cut.sim.bending``).
    """

    gravity: np.ndarray | None
    residual_stress: bool = True
    collision: bool = True
    cutting: bool = False
    foundation: bool = False
    bending: bool = False


@dataclass(frozen=True)
class SolverSection:
    """``[solver]``: the integrator and its step.

    Attributes:
        integrator: A name of ``warp_cut.solvers.INTEGRATORS``.
        dt: Step [s] (the tool pose is updated once per step) or ``"auto"``.
        substeps: Integration substeps per step, or ``"auto"``.
        safety: Fraction of the stable step the automatic choices use.
    """

    integrator: str = "semi_implicit"
    dt: float | str = 1e-3
    substeps: int | str = "auto"
    safety: float = 0.5


@dataclass(frozen=True)
class Keyframe:
    """One tool pose: time t [s], tip p0 [m] and other end p1 [m] of the axis, shape (3,)."""

    t: float
    p0: np.ndarray
    p1: np.ndarray


@dataclass(frozen=True)
class ToolSection:
    """``[tool]``: a rigid cylinder moved through keyframes.

    Attributes:
        radius: Cylinder radius [m].
        length: Axis length [m].
        keyframes: Poses in increasing time, linear in between, held outside.
    """

    radius: float
    length: float
    keyframes: tuple[Keyframe, ...]


@dataclass(frozen=True)
class Scene:
    """A validated scene.

    Attributes:
        name: Run name (output directory).
        duration: Simulated time [s].
        fps: Output frames per second.
        device: Warp device.
        material: Material constants (stiffness, damping, E, residual strain, thickness, density,
            residual-stress model, foundation stiffness: 0 unless ``physics.foundation``).
        stiffness_model: ``"constant"`` (every spring K) or ``"material"`` (from E and thickness).
        tissue, physics, solver: The sections of the same names.
        tool: The ``[tool]`` section, or None.
        cutting: Cutting parameters (used when ``physics.cutting`` is on).
        data: The resolved TOML (overrides applied).
        path: The scene file, or None.
    """

    name: str
    duration: float
    fps: float
    device: str
    material: Material
    stiffness_model: str
    tissue: TissueSection
    physics: PhysicsSection
    solver: SolverSection
    tool: ToolSection | None
    cutting: CutSettings
    data: dict = field(repr=False)
    path: Path | None = None

    @property
    def frame_count(self) -> int:
        """Output frames after t = 0."""
        return max(1, round(self.duration * self.fps))

    def build_model(self) -> TissueModel:
        """The TissueModel this scene describes."""
        t = self.tissue
        # the prestress is applied below, once the stiffness is final
        plain = dataclasses.replace(self.material, residual_stress_model="links")
        try:
            if t.kind == "patch":
                model = TissueModel.from_patch(t.size, t.spacing, material=plain, pinned="none")
            else:
                model = TissueModel.from_mesh_file(t.path, material=plain, pinned="none",
                                                   scale=t.scale)
        except InputError as exc:
            raise SceneError(self.path, "tissue", str(exc)) from exc
        model.material = self.material
        if t.kind == "mesh" and self.physics.cutting:
            problems = cuttable_problems(model.points, model.triangles)
            if problems:
                raise SceneError(self.path, "tissue.path",
                                 f"{t.path}: this mesh cannot be cut (physics.cutting = true needs a manifold, "
                                 f"consistently wound mesh without duplicate or degenerate triangles): "
                                 + "; ".join(problems))
        if t.uniform_mass is not None:
            model.masses[:] = t.uniform_mass
        self._pin(model)
        if self.stiffness_model == "material":
            model.stiffness_model = "material"
            model.stiffness = material_stiffness(
                model.points, model.triangles, model.springs, self.material.youngs_modulus,
                self.material.thickness, fallback=self.material.stiffness)
        if self.material.residual_stress_model == "prestress":
            try:
                model.apply_prestress(None if self.physics.residual_stress else 0.0)
            except InputError as exc:
                raise SceneError(self.path, "material.residual_strain", str(exc)) from exc
        return model

    def _pin(self, model: TissueModel) -> None:
        pinned = self.tissue.pinned
        if pinned == "border":
            model.pinned |= boundary_nodes(model.node_count, model.triangles)
        elif pinned[0] == "box":
            model.pin_box(pinned[1], pinned[2])
        elif pinned[0] == "indices":
            idx = np.asarray(pinned[1], dtype=np.int64)
            if len(idx) and (idx.min() < 0 or idx.max() >= model.node_count):
                raise SceneError(self.path, "tissue.pinned.indices",
                                 f"must be node indices in [0, {model.node_count - 1}]")
            model.pinned[idx] = True

    def tool_path(self) -> ToolPath | None:
        """The keyframed tool, or None if the scene has no tool."""
        if self.tool is None:
            return None
        k = self.tool.keyframes
        return ToolPath([f.t for f in k], [f.p0 for f in k], [f.p1 for f in k], self.tool.radius)

    def simulator_options(self) -> dict:
        """Keyword arguments for ``Simulator`` (without dt, which the run loop fits to frames)."""
        p, s = self.physics, self.solver
        return dict(integrator=s.integrator, gravity=p.gravity, device=self.device,
                    substeps=s.substeps, residual_stress=p.residual_stress, collision=p.collision,
                    safety=s.safety, cutting=self.cut_settings())

    def cut_settings(self) -> CutSettings | None:
        """The CutSettings of ``[cutting]`` if ``physics.cutting`` is on, else None."""
        return self.cutting if self.physics.cutting else None


def _check_keys(reader: _Reader, table: dict, section: str) -> None:
    allowed = _SCHEMA[section]
    for key in table:
        if key not in allowed:
            where = f"{section}.{key}" if section else key
            raise reader.error(where, f"unknown key; allowed keys here: {sorted(allowed)}")


def _section(reader: _Reader, name: str) -> dict:
    """The table ``[name]`` (empty if absent), its keys checked."""
    table = reader.table(name)
    _check_keys(reader, table, name)
    return table


def _parse_material(r: _Reader) -> tuple[Material, str]:
    mat_t, tis_t = _section(r, "material"), _section(r, "tissue")
    d = Material()
    material = Material(
        stiffness=r.number(mat_t, "material", "stiffness", d.stiffness, low=0, high=1e9),
        damping=r.number(mat_t, "material", "damping", d.damping, low=0, high=1e9),
        youngs_modulus=r.number(mat_t, "material", "youngs_modulus", d.youngs_modulus, low=0, high=1e12),
        residual_strain=r.number(mat_t, "material", "residual_strain", d.residual_strain, low=0, high=0.99),
        thickness=r.number(tis_t, "tissue", "thickness", d.thickness, low=0, high=1.0, low_open=True),
        density=r.number(tis_t, "tissue", "density", d.density, low=0, high=1e5, low_open=True),
    )
    model = r.choice(mat_t, "material", "stiffness_model", "constant", set(STIFFNESS_MODELS))
    stress_model = r.choice(mat_t, "material", "residual_stress_model", "links", set(RESIDUAL_STRESS_MODELS))
    k_f = r.number(mat_t, "material", "foundation_stiffness", DEFAULT_FOUNDATION_STIFFNESS,
                   low=0, high=1e10, low_open=True)
    rigidity = r.number(mat_t, "material", "bending_rigidity",
                        flexural_rigidity(material.youngs_modulus, material.thickness), low=0, high=1e6)
    material = dataclasses.replace(material, residual_stress_model=stress_model, foundation_stiffness=k_f,
                                   bending_rigidity=rigidity)
    return material, model


def _parse_patch(r: _Reader, tis_t: dict) -> dict:
    size = r.vector(tis_t.get("size", [0.10, 0.06]), "tissue.size", 2)
    if np.any(size <= 0) or np.any(size > 100):
        raise r.error("tissue.size", f"must be two lengths in (0, 100] m, got {size.tolist()}")
    spacing = r.number(tis_t, "tissue", "spacing", 2e-3, low=0, low_open=True, high=float(min(size)))
    if np.prod(size / spacing) > 5e6:
        raise r.error("tissue.spacing", f"gives more than 5e6 nodes for size {size.tolist()}; "
                                        "allowed: size[0]*size[1]/spacing^2 <= 5e6")
    return {"size": (float(size[0]), float(size[1])), "spacing": spacing}


def _parse_mesh_file(r: _Reader, tis_t: dict) -> dict:
    raw = tis_t.get("path")
    if not isinstance(raw, str) or not raw:
        raise r.error("tissue.path", "is required for kind = 'mesh' (an OBJ, STL or PLY file)")
    mesh_path = Path(raw)
    if not mesh_path.is_absolute() and r.path is not None:
        mesh_path = Path(r.path).parent / mesh_path
    if not mesh_path.is_file():
        raise r.error("tissue.path", f"file not found: {mesh_path}")
    if mesh_path.suffix.lower() not in (".obj", ".stl", ".ply"):
        raise r.error("tissue.path", f"must be an .obj, .stl or .ply file, got {mesh_path.name}")
    return {"path": mesh_path, "scale": r.number(tis_t, "tissue", "scale", 1.0, low=0, low_open=True)}


def _parse_pinned(r: _Reader, pinned) -> str | tuple:
    if isinstance(pinned, dict):
        if set(pinned) == {"box"}:
            box = pinned["box"]
            if not isinstance(box, list) or len(box) != 2:
                raise r.error("tissue.pinned.box", "must be [[x0, y0, z0], [x1, y1, z1]] in m")
            lo = r.vector(box[0], "tissue.pinned.box[0]")
            hi = r.vector(box[1], "tissue.pinned.box[1]")
            if np.any(lo > hi):
                raise r.error("tissue.pinned.box", "needs lower corner <= upper corner")
            return ("box", lo, hi)
        if set(pinned) == {"indices"}:
            idx = pinned["indices"]
            if not isinstance(idx, list) or any(isinstance(i, bool) or not isinstance(i, int) for i in idx):
                raise r.error("tissue.pinned.indices", "must be a list of node indices")
            return ("indices", tuple(idx))
        raise r.error("tissue.pinned", "a table must be {box = [[..], [..]]} or {indices = [..]}")
    if pinned not in ("border", "none"):
        raise r.error("tissue.pinned",
                      f"must be 'border', 'none', {{box = [[x0,y0,z0],[x1,y1,z1]]}} or "
                      f"{{indices = [...]}}, got {pinned!r}")
    return pinned


def _parse_tissue(r: _Reader) -> TissueSection:
    tis_t = _section(r, "tissue")
    kind = r.choice(tis_t, "tissue", "kind", "patch", {"patch", "mesh"})
    where = _parse_patch(r, tis_t) if kind == "patch" else _parse_mesh_file(r, tis_t)
    uniform_mass = None
    if "uniform_mass" in tis_t:
        uniform_mass = r.number(tis_t, "tissue", "uniform_mass", low=0, low_open=True)
    return TissueSection(kind=kind, uniform_mass=uniform_mass,
                         pinned=_parse_pinned(r, tis_t.get("pinned", "border")), **where)


def _parse_physics(r: _Reader) -> PhysicsSection:
    phys_t = _section(r, "physics")
    gravity_on = phys_t.get("gravity", [0.0, 0.0, -9.81])
    gravity = None
    if gravity_on is not False:
        gravity = r.vector(gravity_on, "physics.gravity")
        if np.linalg.norm(gravity) > 1e4:
            raise r.error("physics.gravity", "magnitude must be <= 1e4 m/s^2")
    return PhysicsSection(
        gravity=gravity,
        residual_stress=r.boolean(phys_t, "physics", "residual_stress", True),
        collision=r.boolean(phys_t, "physics", "collision", True),
        cutting=r.boolean(phys_t, "physics", "cutting", False),
        foundation=r.boolean(phys_t, "physics", "foundation", False),
        bending=r.boolean(phys_t, "physics", "bending", False),
    )


def _parse_solver(r: _Reader, fps: float) -> SolverSection:
    sol_t = _section(r, "solver")
    integrator = r.choice(sol_t, "solver", "integrator", "semi_implicit", set(INTEGRATORS))
    dt = sol_t.get("dt", 1e-3)
    if dt != "auto":
        dt = r.number(sol_t, "solver", "dt", 1e-3, low=0, high=1.0 / fps, low_open=True)
    substeps = sol_t.get("substeps", "auto")
    if substeps != "auto":
        substeps = r.number(sol_t, "solver", "substeps", low=1, high=1e6, integer=True)
    safety = r.number(sol_t, "solver", "safety", 0.5, low=0, high=1.0, low_open=True)
    return SolverSection(integrator=integrator, dt=dt, substeps=substeps, safety=safety)


def _parse_cutting(r: _Reader, duration: float) -> CutSettings:
    cut_t = _section(r, "cutting")
    given = {}
    for key in ("sweep_radius", "spacing", "tolerance", "lip_offset"):
        if key in cut_t:
            given[key] = r.number(cut_t, "cutting", key, low=0, high=1.0, low_open=True)
    if "interval" in cut_t:
        given["interval"] = r.number(cut_t, "cutting", "interval", low=0, high=duration)
    if "travel" in cut_t:
        if "interval" in cut_t:
            raise r.error("cutting.travel", ONE_EVENT_RULE)
        given["travel"] = r.number(cut_t, "cutting", "travel", low=0, high=MAX_TRAVEL, low_open=True)
    if "force_threshold" in cut_t:
        given["force_threshold"] = r.number(cut_t, "cutting", "force_threshold", low=0, high=1e6)
    given["keep_islands"] = r.boolean(cut_t, "cutting", "keep_islands", False)
    return CutSettings(**given)


def _parse_keyframes(r: _Reader, keys) -> list[Keyframe]:
    if not isinstance(keys, list) or not keys:
        raise r.error("tool.keyframes", "needs at least one [[tool.keyframes]] with t, p0, p1")
    frames = []
    for n, kf in enumerate(keys):
        where = f"tool.keyframes[{n}]"
        if not isinstance(kf, dict) or set(kf) != {"t", "p0", "p1"}:
            raise r.error(where, "must have exactly the keys t [s], p0 [m] (tip), p1 [m]")
        t = r.number(kf, where, "t", low=0, high=1e6)
        if frames and t <= frames[-1].t:
            raise r.error(f"{where}.t", "keyframe times must be strictly increasing")
        frames.append(Keyframe(t, r.vector(kf["p0"], f"{where}.p0"), r.vector(kf["p1"], f"{where}.p1")))
    return frames


def _parse_tool(r: _Reader) -> ToolSection | None:
    if "tool" not in r.data:
        return None
    tool_t = _section(r, "tool")
    radius = r.number(tool_t, "tool", "radius", low=0, high=1.0)
    frames = _parse_keyframes(r, tool_t.get("keyframes"))
    lengths = [float(np.linalg.norm(f.p1 - f.p0)) for f in frames]
    length = tool_t.get("length")
    if length is None:
        return ToolSection(radius, max(lengths), tuple(frames))
    length = r.number(tool_t, "tool", "length", low=0, low_open=True, high=10.0)
    for n, L in enumerate(lengths):
        if abs(L - length) > 1e-6 * max(1.0, length):
            raise r.error(f"tool.keyframes[{n}]",
                          f"|p1 - p0| = {L:.6g} m differs from tool.length = {length} m (the tool is rigid)")
    return ToolSection(radius, length, tuple(frames))


def parse_scene(data: dict, path=None) -> Scene:
    """Validate a scene dictionary (as loaded from TOML) into a Scene.

    Args:
        data: The TOML content.
        path: The scene file (names it in errors; mesh paths are relative to it).

    Raises:
        SceneError: naming the file, the key and the allowed range.
    """
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
    material, stiffness_model = _parse_material(r)
    tissue = _parse_tissue(r)
    physics = _parse_physics(r)
    if not physics.foundation:  # the support's stiffness counts only when the scene asks for it
        material = dataclasses.replace(material, foundation_stiffness=0.0)
    if not physics.bending:  # so does the bending rigidity
        material = dataclasses.replace(material, bending_rigidity=0.0)
    solver = _parse_solver(r, fps)
    cutting = _parse_cutting(r, duration)
    if physics.cutting and "tool" not in data:
        raise r.error("physics.cutting", "needs a [tool] to cut with")
    return Scene(name=name, duration=duration, fps=fps, device=device, material=material,
                 stiffness_model=stiffness_model, tissue=tissue, physics=physics, solver=solver,
                 tool=_parse_tool(r), cutting=cutting, data=data, path=Path(path) if path else None)


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
