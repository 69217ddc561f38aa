"""warp_cut/sweep.py: sweep files, their expansion into scenarios, ids, and errors."""

import math
import tomllib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.batch.sweep import load_sweep, parse_sweep, toml_value
from warp_cut.errors import SceneError
from warp_cut.scene import apply_overrides, load_scene, parse_scene


def _sweep(tmp_path, text: str, name="s.toml"):
    path = tmp_path / name
    path.write_text(text)
    return load_sweep(path)


def test_grid_is_a_cartesian_product_then_cases(tmp_path):
    sweep = _sweep(tmp_path, """
base = "skin_press"
[grid]
"material.stiffness" = [80.0, 160.0, 320.0]
"tool.radius" = [0.0005, 0.001]
[[cases]]
"material.damping" = 1.0
""")
    ids = [s.id for s in sweep.scenarios]
    assert len(ids) == 7 and len(set(ids)) == 7
    assert ids[0] == "material.stiffness=80.0__tool.radius=0.0005"
    assert ids[1] == "material.stiffness=80.0__tool.radius=0.001"
    assert ids[-1] == "material.damping=1.0"
    assert sweep.parameters == ["material.stiffness", "tool.radius", "material.damping"]
    assert sweep.scenarios[-1].overrides == ("material.damping=1.0",)


def test_repeat_set_and_tags(tmp_path):
    sweep = _sweep(tmp_path, """
base = "skin_press"
repeat = 3
[set]
duration = 0.25
[grid]
"tag.label" = ["a b"]
"fps" = [30]
""")
    assert [s.id for s in sweep.scenarios] == [f"tag.label=a-b__fps=30__rep{k}" for k in range(3)]
    assert [s.rep for s in sweep.scenarios] == [0, 1, 2]
    scenario = sweep.scenarios[0]
    assert scenario.params == {"tag.label": "a b", "fps": 30}
    assert sweep.overrides(scenario) == ["duration=0.25", "fps=30"]  # tags never reach the scene
    assert len({sweep.fingerprint(s) for s in sweep.scenarios}) == 3


def test_scenario_scene_is_what_warp_cut_run_set_gives(tmp_path):
    sweep = _sweep(tmp_path, """
base = "skin_press"
[set]
"tissue.size" = [0.02, 0.03]
[[cases]]
"physics.gravity" = [0.0, 0.0, -1.62]
"solver.dt" = "auto"
""")
    scenario = sweep.scenarios[0]
    ours = parse_scene(apply_overrides(sweep.base_data, sweep.overrides(scenario), sweep.base_path),
                       sweep.base_path)
    theirs = load_scene("skin_press", sweep.overrides(scenario))
    assert ours.data == theirs.data
    assert ours.tissue.size == (0.02, 0.03) and ours.solver.dt == "auto"
    np.testing.assert_array_equal(ours.physics.gravity, [0, 0, -1.62])
    assert "--set 'tissue.size=[0.02, 0.03]'" in sweep.command(scenario)


def test_base_relative_to_sweep_file_and_inline(tmp_path):
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "tiny.toml").write_text("name = 'tiny'\nduration = 0.1\n")
    sweep = _sweep(tmp_path / "scenes", 'base = "tiny.toml"\n[grid]\nfps = [10, 20]\n')
    assert sweep.base_data["name"] == "tiny" and not sweep.base_inline
    inline = _sweep(tmp_path, '[base]\nname = "inl"\nduration = 0.1\n[grid]\nfps = [10]\n')
    assert inline.base_inline and inline.base_data["name"] == "inl"
    assert inline.base_path == tmp_path / "s.toml" and inline.command(inline.scenarios[0]) is None


def test_inline_base_text_is_the_scene_with_mesh_path_made_absolute(tmp_path):
    sweep = _sweep(tmp_path, '[base]\nname = "m"\n[base.tissue]\nkind = "mesh"\n'
                             'path = "meshes/skin.obj"\n')
    assert tomllib.loads(sweep.base_text) == sweep.base_data
    assert sweep.base_data["tissue"]["path"] == str(tmp_path.resolve() / "meshes" / "skin.obj")


def test_no_parameters_gives_one_base_scenario(tmp_path):
    sweep = _sweep(tmp_path, 'base = "skin_press"\n')
    assert [s.id for s in sweep.scenarios] == ["base"] and sweep.parameters == []


def test_long_and_structured_values_get_short_stable_ids(tmp_path):
    frames = [{"t": 0.0, "p0": [0, 0, 0.01], "p1": [0, 0, 0.05]}]
    data = {"base": "skin_press", "cases": [{"tool.keyframes": frames},
                                             {f"tag.k{i}": "x" * 30 for i in range(6)}]}
    first = parse_sweep(data, tmp_path / "s.toml")
    again = parse_sweep(data, tmp_path / "s.toml")
    ids = [s.id for s in first.scenarios]
    assert ids == [s.id for s in again.scenarios]
    assert ids[0].startswith("tool.keyframes=~") and len(ids[0]) < 30
    assert len(ids[1]) <= 100 and "~" in ids[1]


def test_ids_that_collide_after_sanitising_are_told_apart(tmp_path):
    sweep = parse_sweep({"base": "skin_press", "cases": [{"tag.x": "a/b"}, {"tag.x": "a:b"}]},
                        tmp_path / "s.toml")
    a, b = (s.id for s in sweep.scenarios)
    assert a != b and a.startswith("tag.x=a-b~") and b.startswith("tag.x=a-b~")


@pytest.mark.parametrize("text, key", [
    ('base = "skin_press"\nbogus = 1\n', "bogus"),
    ('base = "skin_press"\nrepeat = 0\n', "repeat"),
    ('base = "skin_press"\nrepeat = 1.5\n', "repeat"),
    ('base = "skin_press"\n[grid]\n"material.stiffness" = 80.0\n', 'grid."material.stiffness"'),
    ('base = "skin_press"\n[grid]\n"material.stiffness" = []\n', 'grid."material.stiffness"'),
    ('base = "skin_press"\n[grid]\n"material stiffness" = [1.0]\n', "grid"),
    ('base = "skin_press"\n[grid]\n"material..x" = [1.0]\n', "grid"),
    ('base = "skin_press"\ncases = 3\n', "cases"),
    ('base = "skin_press"\n[[cases]]\nduration = 1979-05-27\n', 'cases[0]."duration"'),
    ('base = "skin_press"\n[[cases]]\nfps = 10\n[[cases]]\nfps = 10\n', "cases"),
    ('base = "skin_press"\n[set]\n"tag.x" = 1\n', 'set."tag.x"'),
    ('base = "skin_press"\n[set]\n"duration.x" = 1\n', "duration.x"),
    ('base = "nowhere.toml"\n', "base"),
    ('[grid]\nfps = [1]\n', "base"),
    ('base = "skin_press"\n[grid]\na = [1, 2]\nb = [1, 2]\nc = [1, 2]\nd = [1, 2]\n'
     'e = [1, 2]\nf = [1, 2]\ng = [1, 2]\nh = [1, 2]\n[grid.x]\n', 'grid."x"'),
    ('this is = = not toml', "file"),
])
def test_bad_sweep_names_file_and_key(tmp_path, text, key):
    with pytest.raises(SceneError) as info:
        _sweep(tmp_path, text)
    assert info.value.key == key and info.value.path.endswith("s.toml")
    assert str(info.value).startswith(f"{info.value.path}: [{key}]")


def test_too_many_scenarios_is_refused(tmp_path):
    grid = "\n".join(f'"tag.k{i}" = [{", ".join(map(str, range(10)))}]' for i in range(6))
    with pytest.raises(SceneError, match="allowed up to"):
        _sweep(tmp_path, f'base = "skin_press"\n[grid]\n{grid}\n')


def test_missing_sweep_file(tmp_path):
    with pytest.raises(SceneError, match="sweep file not found"):
        load_sweep(tmp_path / "nope.toml")


_scalars = (st.booleans() | st.integers(-2**62, 2**62)
            | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=12))
_values = st.recursive(_scalars, lambda inner: st.lists(inner, max_size=4)
                       | st.dictionaries(st.text(min_size=1, max_size=6), inner, max_size=3),
                       max_leaves=10)


@settings(max_examples=200, deadline=None)
@given(_values)
def test_toml_value_round_trips_through_set(value):
    assert tomllib.loads(f"v = {toml_value(value)}")["v"] == value
    assert apply_overrides({}, [f"a.b={toml_value(value)}"])["a"]["b"] == value


def test_toml_value_non_finite():
    assert toml_value(math.inf) == "inf" and toml_value(-math.inf) == "-inf"
    assert math.isnan(tomllib.loads(f"v = {toml_value(math.nan)}")["v"])


def test_bundled_angle_sweep_meets_the_skin_at_2_s_at_every_angle():
    sweep = load_sweep("paper_angle_sweep")
    assert [s.params["tag.angle_deg"] for s in sweep.scenarios] == [30, 40, 50, 60, 70]
    for scenario in sweep.scenarios:
        scene = parse_scene(apply_overrides(sweep.base_data, sweep.overrides(scenario),
                                            sweep.base_path), sweep.base_path)
        assert scene.physics.gravity is None
        path = scene.tool_path()
        angle = math.radians(scenario.params["tag.angle_deg"])
        for t in (0.0, 2.0, 2.5):
            p0, p1 = (np.asarray(p) for p in path.endpoints_at(t))
            axis = (p1 - p0) / np.linalg.norm(p1 - p0)
            assert math.degrees(math.asin(axis[2])) == pytest.approx(scenario.params["tag.angle_deg"])
            # lowest point of the tip's rim: p0 + r (sin a, 0, -cos a)
            lowest = p0 + scene.tool.radius * np.array([math.sin(angle), 0.0, -math.cos(angle)])
            assert lowest[2] == pytest.approx(0.005 * (2.0 - t), abs=1e-9)
            assert lowest[0] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("name, model", [("residual_strain_sweep", "links"),
                                         ("residual_strain_sweep_prestress", "prestress")])
def test_bundled_residual_strain_sweep_scenes_are_valid(name, model):
    sweep = load_sweep(name)
    grid = tomllib.loads(sweep.path.read_text())["grid"]  # the file, read without the parser
    assert sweep.parameters == list(grid) == ["material.residual_strain"]
    assert [s.params["material.residual_strain"] for s in sweep.scenarios] == grid["material.residual_strain"]
    for scenario in sweep.scenarios:
        scene = parse_scene(apply_overrides(sweep.base_data, sweep.overrides(scenario),
                                            sweep.base_path), sweep.base_path)
        assert scene.material.residual_strain == scenario.params["material.residual_strain"]
        assert scene.material.residual_stress_model == model
    if model == "prestress":
        scene.build_model()  # the largest strain still leaves every rest length positive
