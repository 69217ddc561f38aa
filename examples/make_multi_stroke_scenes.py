"""Make the bundled multi-stroke scenes: several strokes cut one after the other into one skin.

``scenes/elliptical_excision.toml`` excises a 30 x 10 mm ellipse of skin from the paper's patch:
an upper arc, then a lower arc from the same end to the other (``warp_cut.verify.incision_sets``,
``excision_set``); the island they enclose comes free and is removed (``cut.removed_islands``).
``scenes/forearm_t_incision.toml`` makes a T round a forearm-like cylinder: a 24 mm cut across
the arm, then a 14 mm stem from its middle along the arm. Between strokes the scalpel is lifted
1 cm out along its axis and carried over the skin to the next start. Run it to regenerate the
files (they are committed; the output is deterministic)::

    .venv/bin/python examples/make_multi_stroke_scenes.py
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import trimesh

from warp_cut.mesh import surfaces
from warp_cut.verify.incision_sets import ToolSpec, excision_set, t_set

SCENES = Path(__file__).resolve().parent.parent / "scenes"
KEYFRAME_STEP = 0.02
"""Time between keyframes [s] (the tool moves linearly in between: 0.4 mm chords at 2 cm/s)."""
LIFT = 0.01
"""How far the scalpel is drawn out along its axis after a stroke and before the next [m]."""
TRANSIT = 0.1
"""Time to lift the tool out, and again to carry it to the next stroke's start [s]."""


def _poses(strokes) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """(t [s], tip (3,), top (3,)) keyframes of the strokes one after the other: each stroke's
    own poses, the tool drawn out LIFT along its axis, then carried to LIFT above the next
    stroke's first pose."""
    out, t0 = [], 0.0
    for k, stroke in enumerate(strokes):
        path = stroke.tool_path(KEYFRAME_STEP)
        if k:
            first_axis = (path.p1[0] - path.p0[0]) / np.linalg.norm(path.p1[0] - path.p0[0])
            out.append((t0, path.p0[0] + LIFT * first_axis, path.p1[0] + LIFT * first_axis))
            t0 += TRANSIT
        out += [(t0 + t, p0, p1) for t, p0, p1 in zip(path.times, path.p0, path.p1)]
        axis = (path.p1[-1] - path.p0[-1]) / np.linalg.norm(path.p1[-1] - path.p0[-1])
        t0 += float(path.times[-1]) + TRANSIT
        out.append((t0, path.p0[-1] + LIFT * axis, path.p1[-1] + LIFT * axis))
        t0 += TRANSIT
    return out


def _keyframes(strokes) -> str:
    return "\n".join("[[tool.keyframes]]\n"
                     f"t = {t:.6f}\n"
                     f"p0 = [{p0[0]:.9f}, {p0[1]:.9f}, {p0[2]:.9f}]\n"
                     f"p1 = [{p1[0]:.9f}, {p1[1]:.9f}, {p1[2]:.9f}]\n" for t, p0, p1 in _poses(strokes))


def _duration(strokes, settle: float) -> float:
    return math.ceil((_poses(strokes)[-1][0] + settle) * 10) / 10


def _save(name: str, head: str, tool: ToolSpec, strokes) -> None:
    """Write scenes/``name``.toml: ``head`` (the scene up to its tool), the tool and its keyframes."""
    text = f"{head}\n[tool]\nradius = {tool.radius}\nlength = {tool.tool_length}\n\n{_keyframes(strokes)}"
    (SCENES / f"{name}.toml").write_text(text)
    print(f"wrote scenes/{name}.toml ({len(strokes)} strokes)")


def write_excision() -> None:
    patch = surfaces.flat_grid(0.06, 0.002)
    tool = ToolSpec(radius=0.001, depth=0.003)
    strokes = excision_set(patch, tool, heading=0.0).strokes
    text = f'''# An elliptical excision from the paper's skin patch: two arcs, 30 x 10 mm, cut one after the
# other from the same end to the other; the island they enclose comes free and is removed.
# Made by examples/make_multi_stroke_scenes.py (keyframes from warp_cut.verify.incision_sets).
name = "elliptical_excision"
duration = {_duration(strokes, 0.5)}
fps = 60

[tissue]
kind = "patch"
size = [0.06, 0.04]
spacing = 0.002
thickness = 0.002
density = 1100.0
pinned = "border"

[material]
stiffness = 160.0
damping = 3.0
youngs_modulus = 20000.0
residual_strain = 0.1

[physics]
gravity = [0.0, 0.0, -9.81]
residual_stress = true
collision = true
cutting = true

[cutting]
# cut events by the blade's travel: cutting.travel, default 1 lip spacing (benchmarks/results/event_travel.md)
keep_islands = false     # the excised skin is removed (cut.removed_islands)
'''
    _save("elliptical_excision", text, tool, strokes)


def write_forearm_t() -> None:
    arm = surfaces.cylinder(radius=0.03, length=0.08, arc_angle=2.6, spacing=0.002)
    mesh_file = SCENES / "meshes" / "forearm.obj"
    if not mesh_file.exists():
        trimesh.Trimesh(arm.points, arm.triangles, process=False).export(mesh_file)
    tool = ToolSpec(radius=0.001, depth=0.002)
    strokes = t_set(arm, tool, heading=math.pi / 2, length=0.024, stem=0.014).strokes
    text = f'''# A T round a forearm-like cylinder of radius 3 cm: a 24 mm cut across the arm, then a 14 mm
# stem from its middle along the arm, which starts in the first wound and joins it.
# Made by examples/make_multi_stroke_scenes.py (the mesh is meshes/forearm.obj). Table 1
# material, border pinned, the skin on its support (physics.foundation, see docs/wound.md) and
# resisting bending (physics.bending): a membrane keeps two of the cut's triangles folded over
# once the tool has gone, the bending skin none.
name = "forearm_t_incision"
duration = {_duration(strokes, 0.5)}
fps = 60

[tissue]
kind = "mesh"
path = "meshes/forearm.obj"
pinned = "border"

[physics]
cutting = true
foundation = true
bending = true
'''
    _save("forearm_t_incision", text, tool, strokes)


if __name__ == "__main__":
    write_excision()
    write_forearm_t()
