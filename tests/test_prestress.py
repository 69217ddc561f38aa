"""warp_cut/sim/prestress.py: the prestressed sheet (material.residual_stress_model = "prestress").

Compared against: zero net force at every interior node of a flat irregular mesh (the cotangent
edge tensions are a constant stress), the finite-difference gradient of the mesh area on a
curved mesh (f_i = -T grad_i area), the closed form T L / sqrt(3) of an equilateral lattice
edge, a simulator that keeps the pinned prestressed sheet at rest, and what a cut leaves behind:
no links, and a sheet still under the one tension in its rest shape (-T grad(area) at every
free node, the wound's edge included).
"""

import math

import numpy as np
import pytest
import trimesh
from conftest import DEVICE

from warp_cut import InputError, Material, SceneError, Simulator, TissueModel
from warp_cut.cut.classes import NodeClass
from warp_cut.cut.settings import CutSettings
from warp_cut.mesh.geometry import edges_of
from warp_cut.mesh.patch import skin_patch_mesh
from warp_cut.mesh.surfaces import flat_grid, jittered_delaunay
from warp_cut.scene import load_scene, parse_scene
from warp_cut.sim import strokes
from warp_cut.sim.material_policy import MAX_PRESTRAIN
from warp_cut.sim.model import boundary_nodes
from warp_cut.sim.prestress import membrane_edge_tensions
from warp_cut.sim.statics import spring_network_forces
from warp_cut.sim.stiffness import material_stiffness
from warp_cut.verify.stroke_check import run_stroke

PRESTRESS = Material(residual_stress_model="prestress")


def net_forces(model, x=None):
    x = model.points if x is None else x
    return spring_network_forces(x, model.springs, model.rest_lengths, model.stiffness)


def irregular_patch(rng, stiffness_model):
    pts, tri = skin_patch_mesh((0.03, 0.02), 0.002)
    border = boundary_nodes(len(pts), tri)
    pts[~border, :2] += rng.uniform(-0.45e-3, 0.45e-3, size=(int((~border).sum()), 2))
    model = TissueModel.from_triangles(pts, tri, material=PRESTRESS, pinned="border")
    if stiffness_model == "material":
        model.stiffness = material_stiffness(model.points, model.triangles, model.springs,
                                             PRESTRESS.youngs_modulus, PRESTRESS.thickness)
        model.apply_prestress()
    return model, border


@pytest.mark.parametrize("stiffness_model", ["constant", "material"])
def test_flat_irregular_mesh_is_in_equilibrium(rng, stiffness_model):
    model, border = irregular_patch(rng, stiffness_model)
    tension = model.stiffness * (np.linalg.norm(np.diff(model.points[model.springs], axis=1)[:, 0],
                                                axis=1) - model.rest_lengths)
    # the springs really are tensioned (a few across obtuse angles are compressed)
    assert np.median(tension) > 1e-3 and (tension > 0).mean() > 0.9
    forces = net_forces(model)
    assert np.abs(forces[~border]).max() < 1e-12 * tension.max()
    assert np.abs(forces[border]).max() > 0.1 * tension.max()  # the pinned border holds the sheet


def area_gradients(points, triangles, nodes, h=1e-7):
    """d(total area)/dx_i [m] (k, 3) of ``nodes`` by central differences over their triangles."""
    out = np.zeros((len(nodes), 3))

    def area(x, tri):
        c = x[tri]
        return 0.5 * np.linalg.norm(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]), axis=1).sum()

    for k, v in enumerate(nodes):
        tri = triangles[(triangles == v).any(axis=1)]
        for c in range(3):
            up, down = points.copy(), points.copy()
            up[v, c] += h
            down[v, c] -= h
            out[k, c] = (area(up, tri) - area(down, tri)) / (2 * h)
    return out


def test_curved_mesh_force_is_minus_tension_times_area_gradient():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    pts, tri = np.asarray(sphere.vertices), np.asarray(sphere.faces)
    model = TissueModel.from_triangles(pts, tri, material=PRESTRESS, pinned="none")
    forces = net_forces(model)
    sample = np.arange(0, len(pts), 41)
    for i, grad in zip(sample, area_gradients(pts, tri, sample)):
        np.testing.assert_allclose(forces[i], -PRESTRESS.membrane_tension * grad,
                                   atol=1e-6 * np.linalg.norm(forces[i]))
        # on a sphere that is the mean-curvature normal: 2 T / R x area, pointing inward
        assert forces[i] @ pts[i] < 0


def test_equilateral_edge_tension_is_t_l_over_sqrt3():
    s = 0.002
    pts = np.array([[0, 0, 0], [s, 0, 0], [s / 2, s * np.sqrt(3) / 2, 0], [s / 2, -s * np.sqrt(3) / 2, 0]])
    tri = np.array([[0, 1, 2], [1, 0, 3]])
    springs = np.array([[0, 1], [0, 2], [1, 2]])
    f = membrane_edge_tensions(pts, tri, springs, 4.0)
    # the shared edge has two 60 degree opposite angles, the others one
    np.testing.assert_allclose(f, [4.0 * s / np.sqrt(3), 2.0 * s / np.sqrt(3), 2.0 * s / np.sqrt(3)],
                               rtol=1e-12)


def test_tension_too_large_for_the_springs_is_refused_naming_the_parameters():
    mat = Material(residual_strain=0.9, youngs_modulus=1e6, residual_stress_model="prestress")
    with pytest.raises(InputError, match="youngs_modulus .* residual_strain .* thickness"):
        TissueModel.from_patch((0.01, 0.01), 0.002, material=mat)
    data = {"material": {"residual_stress_model": "prestress", "youngs_modulus": 1e6,
                         "residual_strain": 0.9}}
    with pytest.raises(SceneError, match=r"\[material.residual_strain\].*too large"):
        parse_scene(data, "x.toml").build_model()


def test_scene_validates_the_model_name():
    with pytest.raises(SceneError, match=r"material.residual_stress_model.*\['links', 'prestress'\]"):
        parse_scene({"material": {"residual_stress_model": "springs"}}, "x.toml")
    with pytest.raises(InputError, match="links"):
        Material(residual_stress_model="bogus")


def test_scene_prestress_uses_the_final_stiffness_and_physics_switch():
    scene = load_scene("paper_width_curve", ['material.residual_stress_model="prestress"',
                                             'material.stiffness_model="material"'])
    model = scene.build_model()
    interior = ~model.pinned
    assert np.abs(net_forces(model)[interior]).max() < 1e-12
    assert model.material.residual_stress_model == "prestress"
    off = load_scene("paper_width_curve", ['material.residual_stress_model="prestress"',
                                           "physics.residual_stress=false"]).build_model()
    lengths = np.linalg.norm(np.diff(off.points[off.springs], axis=1)[:, 0], axis=1)
    np.testing.assert_allclose(off.rest_lengths, lengths, rtol=1e-12)


# XPBD's one constraint iteration is a spring softened by k h^2 (n_i w_i + n_j w_j) (kernels/xpbd.py),
# which differs between nodes of different valence and mass: its rest state is not exactly the
# springs' one, and the prestressed sheet settles by about 0.7 % of the spacing at 1 ms
@pytest.mark.parametrize("integrator, tolerance", [("semi_implicit", 1e-7), ("implicit_euler", 1e-7),
                                                   ("xpbd", 0.01 * 0.002)])
def test_pinned_prestressed_sheet_stays_at_rest(integrator, tolerance):
    model = TissueModel.from_patch((0.02, 0.016), 0.002, material=PRESTRESS, pinned="border")
    sim = Simulator(model, dt=1e-3, gravity=None, integrator=integrator, device=DEVICE)
    sim.step(100)
    assert np.abs(sim.positions - model.points).max() < tolerance  # float32 of a 2 cm patch: ~1e-9
    unpinned = TissueModel.from_patch((0.02, 0.016), 0.002, material=PRESTRESS, pinned="none")
    free = Simulator(unpinned, dt=1e-3, gravity=None, integrator=integrator, device=DEVICE)
    free.step(100)
    assert np.abs(free.positions - unpinned.points).max() > 1e-5  # without the pins it shrinks


def quasi_static_cut(material, stiffness_model="constant"):
    model = TissueModel.from_patch((0.03, 0.02), 0.002, material=material, pinned="border")
    if stiffness_model == "material":
        model.stiffness_model = "material"
        model.stiffness = material_stiffness(model.points, model.triangles, model.springs,
                                             material.youngs_modulus, material.thickness)
        if material.residual_stress_model == "prestress":
            model.apply_prestress()
    sim = Simulator(model, dt=1e-3, gravity=None, device=DEVICE, cutting=CutSettings())
    cutter = sim.cutter
    y = 0.5 * 0.002 * np.sqrt(3) / 2  # between two node rows
    cutter.start_incision(sim, np.array([-0.008, y, 0.0]), [0, 0, 1], 0.0006)
    made = []
    for x in np.linspace(-0.008, 0.008, 40)[1:]:
        before = model.spring_table.count
        cutter.extend_incision(sim, np.array([x, y, 0.0]))
        slots = np.arange(before, model.spring_table.count)
        slots = slots[model.spring_table.alive[slots]]
        pairs = model.spring_table.column("pairs")[slots]
        now = np.linalg.norm(sim.positions[pairs[:, 1]] - sim.positions[pairs[:, 0]], axis=1)
        made.append((model.spring_table.column("rest_length")[slots], now))
    return model, sim, made


@pytest.mark.parametrize("stiffness_model", ["constant", "material"])
def test_a_cut_sheet_carries_the_same_tension_in_its_rest_shape(stiffness_model):
    """The springs a cut makes or leaves on fewer triangles get the rest lengths that
    ``apply_prestress`` gives the original ones, from the rest shape (the lips at their rest
    positions): the whole cut sheet is then under the one tension T, every free node pulled with
    -T grad(area) (finite differences; the wound's edge nodes by the traction the cut released,
    the others by nothing), but at a spring whose prestrain the guard ``MAX_PRESTRAIN`` clips."""
    material = Material(residual_stress_model="prestress")
    model, sim, made = quasi_static_cut(material, stiffness_model)
    assert sim.cutter.totals["deleted_springs"] > 0 and sim.cutter.totals["new_springs"] > 0
    assert model.link_count == 0 and sim.cutter.totals["residual_links"] == 0
    # a spring of a triangle nearly flat in the rest shape would need |f / (k L)| above the
    # guard (softer material springs only): its nodes are left out, and they are few
    f = membrane_edge_tensions(model.points, model.triangles, model.springs, material.membrane_tension)
    length = np.linalg.norm(np.diff(model.points[model.springs], axis=1)[:, 0], axis=1)
    clipped = np.abs(f / (model.stiffness * length)) > MAX_PRESTRAIN
    assert clipped.sum() <= 0.01 * len(f)
    free = np.setdiff1d(np.flatnonzero(model.active & ~model.pinned), model.springs[clipped])
    triangles = model.triangles
    expected = -material.membrane_tension * area_gradients(model.points, triangles, free)
    forces = net_forces(model)[free]
    scale = np.abs(expected).max()
    np.testing.assert_allclose(forces, expected, atol=1e-9 * scale)
    lips = free[model.node_class[free] == NodeClass.LIP]
    assert len(lips) > 10 and np.abs(expected[np.isin(free, lips)]).max() > 0.1 * scale  # released
    rest = np.concatenate([r for r, _ in made])
    length = np.concatenate([n for _, n in made])
    # what the cut makes is stretched like the sheet around (an edge across obtuse angles is
    # compressed, as in the original sheet)
    assert (rest < length).mean() > 0.8
    links_model, _, _ = quasi_static_cut(Material(), stiffness_model)
    assert links_model.link_count > 0  # the same cut in the links model leaves links
    assert links_model.prestress_tension == 0.0


def test_a_finished_cut_leaves_no_compressed_spring_between_the_triangles_it_made():
    """An edge's cotangent tension (T/2)(cot a + cot b)|e| is negative where its opposite angles
    sum above 180 deg: the cut's own triangles are Delaunay in the rest shape (each event's fill
    is a constrained Delaunay refinement of its region there, and once the incision ends the
    edges where two events' regions meet are flipped to Delaunay too), so every spring between
    two of them carries tension (computed here from the rest shape's angles). How many flips
    that takes depends on where the regions fell (none on this straight cut), so it is not
    counted."""
    model, sim, _ = quasi_static_cut(PRESTRESS)
    sim.cutter.end_incision(sim)
    table = model.triangle_table
    made = np.array(sorted(t for t in sim.cutter.new_triangles if table.alive[t]))
    corners = table.column("corners")[made]
    edges, counts = edges_of(corners, return_counts=True)
    inner = edges[counts == 2]
    assert len(inner) > 20
    tension = membrane_edge_tensions(model.points, model.triangles, inner, PRESTRESS.membrane_tension)
    assert tension.min() >= -1e-12
    for i, j in inner:  # and the springs carry it: stretched in the rest shape
        slot = sim.cutter.editor.spring_between(int(i), int(j))
        assert model.spring_table.column("rest_length")[slot] <= np.linalg.norm(model.points[i] - model.points[j])


def test_a_finished_cut_takes_the_sheets_modulus_and_not_before():
    """With the paper's constant K, the springs a cut makes are K while it cuts (its strip's
    triangles are not final); once the incision ends, every spring of its triangles gets van
    Gelder's stiffness for the lattice's modulus 2K/sqrt(3): (2K/sqrt(3)) x (its triangles'
    area) / L^2 in the rest shape, computed here from the triangles."""
    K = PRESTRESS.stiffness
    model, sim, _ = quasi_static_cut(PRESTRESS)
    cutter = sim.cutter
    live = model.spring_table.alive.copy()
    assert np.all(model.spring_table.column("stiffness")[live] == K)
    cutter.end_incision(sim)
    table = model.triangle_table
    made = [t for t in cutter.new_triangles if table.alive[t]]
    corners = table.column("corners")[made]
    edges = np.unique(np.sort(np.concatenate([corners[:, [0, 1]], corners[:, [1, 2]], corners[:, [2, 0]]]), axis=1),
                      axis=0)
    tri, x = model.triangles, model.points
    area = 0.5 * np.linalg.norm(np.cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]]), axis=1)
    for i, j in edges:
        on_edge = np.isin(tri, [i, j]).sum(axis=1) == 2
        expected = 2 * K / np.sqrt(3) * area[on_edge].sum() / np.sum((x[i] - x[j]) ** 2)
        slot = cutter.editor.spring_between(int(i), int(j))
        assert model.spring_table.column("stiffness")[slot] == pytest.approx(expected, rel=1e-6)  # float32 areas
    assert len(edges) > 30


def test_a_moving_tool_cut_leaves_one_tension_and_lips_that_follow_the_gape():
    """A tilted scalpel drawn across a prestressed jittered Delaunay disk (the lips made while
    the wound gapes): the rest shape is still under the one tension (every free node pulled
    with -T grad(area), lips at their rest positions, not where they were placed), and the
    lips stand apart by more than the slit's initial width where the wound has opened."""
    surface = jittered_delaunay(radius=0.02, spacing=0.002, jitter=0.2, seed=7)
    model = TissueModel.from_surface(surface, material=PRESTRESS)
    sim = Simulator(model, dt=1e-3, device=DEVICE, gravity=None, cutting=CutSettings(interval=1 / 60))
    stroke = strokes.Stroke(surface, strokes.line([-0.008, 0.001], 0.2, 0.016), tilt=math.radians(60),
                            radius=0.001, depth=0.002, speed=0.02, tool_length=0.04, margin=3e-3)
    result = run_stroke(sim, stroke, surface, settle=0.3)
    assert result.exception is None and result.incisions == 1 and result.unfilled_holes == 0
    f = membrane_edge_tensions(model.points, model.triangles, model.springs, PRESTRESS.membrane_tension)
    length = np.linalg.norm(np.diff(model.points[model.springs], axis=1)[:, 0], axis=1)
    clipped = np.abs(f / (model.stiffness * length)) > MAX_PRESTRAIN
    free = np.setdiff1d(np.flatnonzero(model.active & ~model.pinned), model.springs[clipped])
    expected = -PRESTRESS.membrane_tension * area_gradients(model.points, model.triangles, free)
    np.testing.assert_allclose(net_forces(model)[free], expected, atol=1e-9 * np.abs(expected).max())
    inc = sim.cutter.incisions[0]
    pairs = inc.pairs()
    gap = np.linalg.norm(sim.positions[pairs[:, 0]] - sim.positions[pairs[:, 1]], axis=1)
    assert len(pairs) >= 5 and np.median(gap) > 2.0 * inc.lip_offset + 0.1e-3  # opened


def test_a_fill_is_judged_in_the_rest_shape_too():
    """A thick tool (r 2.0 mm on a 1.7 mm grid, tilted 64 degrees, gravity and the foundation
    on) across a prestressed patch: the fill at the slit's start made a triangle that looked
    fair where the nodes were but was 1.9 degrees in the rest shape the springs take their
    lengths from, and 0.04 degrees once the sheet had settled. A prestressed sheet's fill
    counts the smaller of its two smallest angles: none below 10 degrees now."""
    surface = flat_grid(0.0413111842029696, 0.00171044765737931)
    material = Material(foundation_stiffness=1e6, residual_stress_model="prestress")
    sim = Simulator(TissueModel.from_surface(surface, material=material), dt=1e-3, device=DEVICE,
                    cutting=CutSettings(interval=0.03310187971208809))
    path = strokes.line([-0.0111884457216376, 0.0014753994358203404], 5.602684401619392, 0.016273897858153114)
    stroke = strokes.Stroke(surface, path, tilt=math.radians(63.78196440257604), radius=0.0020073533581260626,
                            depth=0.002160665425005849, speed=0.008160930801347761,
                            tool_length=0.048489289974786604, margin=3e-3)
    result = run_stroke(sim, stroke, surface)
    assert result.exception is None and result.incisions == 1 and result.unfilled_holes == 0
    assert result.slivers == 0 and result.min_new_angle_deg >= 10.0


def test_new_springs_in_the_links_model_take_their_length_of_the_moment():
    _, _, made = quasi_static_cut(Material(), "constant")
    rest = np.concatenate([r for r, _ in made])
    length = np.concatenate([n for _, n in made])
    np.testing.assert_allclose(rest, length, rtol=1e-6, atol=2e-9)  # float32 positions
