"""warp_cut/scene.py: validation names file, key and allowed range; overrides; bundled scenes."""

import numpy as np
import pytest
import trimesh

from warp_cut import SceneError, ToolStartsInside
from warp_cut.runner import prepare_simulation
from warp_cut.scene import apply_overrides, bundled_scene_path, load_scene, parse_scene


def base():
    return {
        "name": "t", "duration": 0.05, "fps": 20,
        "tissue": {"kind": "patch", "size": [0.02, 0.02], "spacing": 0.004},
        "tool": {"radius": 0.001, "keyframes": [
            {"t": 0.0, "p0": [0, 0, 0.005], "p1": [0, 0, 0.02]},
            {"t": 0.05, "p0": [0, 0, -0.002], "p1": [0, 0, 0.013]}]},
    }


@pytest.mark.parametrize("key, value, words", [
    ("duration", -1.0, ["duration", "(0"]),
    ("fps", "fast", ["fps", "number"]),
    ("tissue.spacing", 0.0, ["tissue.spacing", "(0"]),
    ("tissue.kind", "cube", ["tissue.kind", "patch"]),
    ("tissue.pinned", "left", ["tissue.pinned", "border"]),
    ("material.stiffness", -5.0, ["material.stiffness", "[0"]),
    ("material.residual_strain", 1.5, ["material.residual_strain", "0.99"]),
    ("physics.gravity", [0, 0], ["physics.gravity", "3 numbers"]),
    ("physics.collision", "yes", ["physics.collision", "true or false"]),
    ("solver.integrator", "rk4", ["solver.integrator", "semi_implicit"]),
    ("solver.dt", 1.0, ["solver.dt", "0.05"]),
    ("solver.substeps", 0, ["solver.substeps", "[1"]),
    ("tool.radius", float("nan"), ["tool.radius", "finite"]),
    ("tissue.colour", 1, ["tissue.colour", "unknown key"]),
    ("cutting.travel", 0.0, ["cutting.travel", "(0", "4"]),
    ("cutting.travel", 5.0, ["cutting.travel", "(0", "4"]),
    ("cutting.interval", -0.01, ["cutting.interval", "[0"]),
])
def test_bad_values_name_file_key_and_range(key, value, words):
    data = apply_overrides(base(), [])
    node = data
    parts = key.split(".")
    for p in parts[:-1]:
        node = node.setdefault(p, {})
    node[parts[-1]] = value
    with pytest.raises(SceneError) as info:
        parse_scene(data, "my_scene.toml")
    message = str(info.value)
    assert message.startswith("my_scene.toml: ")
    for word in words:
        assert word in message


def test_keyframes_must_increase_and_tool_is_rigid():
    data = base()
    data["tool"]["keyframes"][1]["t"] = 0.0
    with pytest.raises(SceneError, match="increasing"):
        parse_scene(data, "s.toml")
    data = base()
    data["tool"]["length"] = 0.02
    with pytest.raises(SceneError, match="rigid"):
        parse_scene(data, "s.toml")


def test_overrides_parse_toml_values():
    data = apply_overrides(base(), ["material.stiffness=80", "physics.gravity=[0,0,-1.62]",
                                    "name=moon", "solver.dt=\"auto\""])
    scene = parse_scene(data)
    assert scene.material.stiffness == 80.0 and scene.name == "moon"
    np.testing.assert_allclose(scene.physics.gravity, [0, 0, -1.62])
    assert scene.solver.dt == "auto"
    with pytest.raises(SceneError, match="section.key=value"):
        apply_overrides(base(), ["stiffness"])


def test_cut_events_by_travel_or_on_a_clock_not_both():
    """``cutting.travel`` [lip spacings] or ``cutting.interval`` [s]; neither: by travel, the
    default; both: refused, naming the key."""
    data = base()
    data["cutting"] = {"travel": 0.75}
    assert parse_scene(data, "s.toml").cutting.event_rule(2e-3) == (None, pytest.approx(1.5e-3))
    data["cutting"] = {"interval": 0.02}
    assert parse_scene(data, "s.toml").cutting.event_rule(2e-3) == (0.02, None)
    data["cutting"] = {"interval": 0.02, "travel": 0.75}
    with pytest.raises(SceneError, match=r"s.toml: \[cutting.travel\] .*not both"):
        parse_scene(data, "s.toml")


def test_gravity_false_disables_it():
    data = base()
    data["physics"] = {"gravity": False}
    assert parse_scene(data).simulator_options()["gravity"] is None


def test_pinned_box_and_indices():
    data = base()
    data["tissue"]["pinned"] = {"box": [[-1, -1, -1], [0, 1, 1]]}
    model = parse_scene(data).build_model()
    np.testing.assert_array_equal(model.pinned, model.points[:, 0] <= 0)
    data["tissue"]["pinned"] = {"indices": [0, 3]}
    assert parse_scene(data).build_model().pinned.sum() == 2
    data["tissue"]["pinned"] = {"indices": [10**6]}
    with pytest.raises(SceneError, match="indices"):
        parse_scene(data).build_model()


def test_mesh_path_is_relative_to_scene_file(tmp_path):
    trimesh.creation.box().export(tmp_path / "box.stl")
    data = base()
    data["tissue"] = {"kind": "mesh", "path": "box.stl", "pinned": "none"}
    scene = parse_scene(data, tmp_path / "s.toml")
    assert scene.build_model().node_count == 8
    data["tissue"]["path"] = "nothere.obj"
    with pytest.raises(SceneError, match="tissue.path"):
        parse_scene(data, tmp_path / "s.toml")


def test_bundled_default_scene_loads():
    scene = load_scene(None)
    assert scene.name == "straight_incision" and bundled_scene_path("skin_press").is_file()
    assert scene.physics.cutting and scene.cut_settings() is not None
    assert scene.material.stiffness == 160.0 and scene.material.damping == 3.0
    assert scene.material.youngs_modulus == 20e3 and scene.material.residual_strain == 0.1
    with pytest.raises(SceneError, match="not found"):
        load_scene("no_such_scene")


def test_tool_inside_at_start_is_rejected():
    data = base()
    data["tool"]["keyframes"][0]["p0"] = [0, 0, -0.002]
    with pytest.raises(ToolStartsInside):
        prepare_simulation(parse_scene(data))
