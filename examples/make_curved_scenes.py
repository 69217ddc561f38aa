"""Make the bundled curved-skin scenes from the library's own surfaces and strokes.

``scenes/forearm_incision.toml`` cuts round a forearm-like cylinder (radius 3 cm);
``scenes/dome_incision.toml`` cuts across a dome (radius of curvature 4 cm). Each scene loads a
mesh file (``scenes/meshes/*.obj``, written here with trimesh) through ``tissue.kind = "mesh"``,
as a user's own mesh would be, and moves the scalpel through keyframes that follow the skin:
the tool comes in along its own axis, keeps 60 degrees to the skin's tangent plane while it
travels, and is lifted out (``warp_cut.sim.strokes.Stroke``).

Run it to regenerate the files (they are committed; the output is deterministic)::

    .venv/bin/python examples/make_curved_scenes.py
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import trimesh

from warp_cut.mesh import surfaces
from warp_cut.sim import strokes

SCENES = Path(__file__).resolve().parent.parent / "scenes"
KEYFRAME_STEP = 0.02
"""Time between keyframes [s] (the tool moves linearly in between: 0.4 mm chords at 2 cm/s)."""


def _keyframes(stroke: strokes.Stroke) -> str:
    """The stroke's poses, and one 0.1 s later with the tool 1 cm further out along its axis:
    the stroke ends with the tip just clear of the nodes, and a tool held there would keep
    the incision open."""
    path = stroke.tool_path(KEYFRAME_STEP)
    axis = (path.p1[-1] - path.p0[-1]) / np.linalg.norm(path.p1[-1] - path.p0[-1])
    times = np.append(path.times, path.times[-1] + 0.1)
    p0s = np.vstack([path.p0, path.p0[-1] + 0.01 * axis])
    p1s = np.vstack([path.p1, path.p1[-1] + 0.01 * axis])
    rows = []
    for t, p0, p1 in zip(times, p0s, p1s):
        rows.append("[[tool.keyframes]]\n"
                    f"t = {t:.6f}\n"
                    f"p0 = [{p0[0]:.9f}, {p0[1]:.9f}, {p0[2]:.9f}]\n"
                    f"p1 = [{p1[0]:.9f}, {p1[1]:.9f}, {p1[2]:.9f}]\n")
    return "\n".join(rows)


def _write(name: str, description: str, surface, stroke: strokes.Stroke, settle: float) -> None:
    mesh_file = SCENES / "meshes" / f"{name}.obj"
    mesh_file.parent.mkdir(exist_ok=True)
    trimesh.Trimesh(surface.points, surface.triangles, process=False).export(mesh_file)
    duration = math.ceil((stroke.duration + settle) * 10) / 10
    text = f'''# {description}
# Made by examples/make_curved_scenes.py (the mesh in meshes/{name}.obj, the keyframes from a
# stroke that keeps the scalpel at 60 degrees to the skin). Table 1 material, border pinned,
# the skin on its support (physics.foundation: subcutaneous tissue, see docs/wound.md).
name = "{name}_incision"
duration = {duration}
fps = 60

[tissue]
kind = "mesh"
path = "meshes/{name}.obj"
pinned = "border"

[physics]
cutting = true
foundation = true

[tool]
radius = {stroke.radius}
length = {stroke.tool_length}

{_keyframes(stroke)}'''
    (SCENES / f"{name}_incision.toml").write_text(text)
    print(f"wrote {mesh_file} ({len(surface.points)} nodes) and scenes/{name}_incision.toml "
          f"({stroke.length * 1e3:.1f} mm stroke, {duration} s)")


def main() -> None:
    arm = surfaces.cylinder(radius=0.03, length=0.08, arc_angle=2.6, spacing=0.002)
    around = strokes.line([0.0, -0.0235], math.pi / 2, 0.047)  # round the arm, across its crest
    _write("forearm", "A cut round a forearm-like cylinder of radius 3 cm: 47 mm at 2 cm/s.", arm,
           strokes.Stroke(arm, around, tilt=math.radians(60), radius=0.001, depth=0.002, speed=0.02), 0.6)
    dome = surfaces.dome(radius_of_curvature=0.04, base_radius=0.03, spacing=0.002)
    across = strokes.line([-0.02, 0.0], 0.0, 0.04)
    _write("dome", "A cut across a dome (radius of curvature 4 cm): 40 mm at 2 cm/s over its apex.", dome,
           strokes.Stroke(dome, across, tilt=math.radians(60), radius=0.001, depth=0.002, speed=0.02), 0.6)


if __name__ == "__main__":
    np.set_printoptions(precision=9)
    main()
