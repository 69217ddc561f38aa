"""warp_cut/stiffness.py: van Gelder's k = E t sum|T| / |e|^2 gives the sheet of E and t at
every mesh resolution."""

import math

import numpy as np
import pytest

from warp_cut import Material, TissueModel
from warp_cut.scene import parse_scene
from warp_cut.sim.stiffness import material_stiffness


def test_equilateral_pair_by_hand():
    a = 0.01
    pts = np.array([[0, 0, 0], [a, 0, 0], [a / 2, a * math.sqrt(3) / 2, 0],
                    [a / 2, -a * math.sqrt(3) / 2, 0]])
    tri = np.array([[0, 1, 2], [1, 0, 3]])
    springs = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]])
    E, t = 20e3, 2e-3
    k = material_stiffness(pts, tri, springs, E, t, fallback=7.0)
    area = math.sqrt(3) / 4 * a * a
    # the shared edge has two triangles, the border edges one, the spring 2-3 none (fallback)
    np.testing.assert_allclose(k, [E * t * 2 * area / a**2] + [E * t * area / a**2] * 4 + [7.0])
    assert k[0] == pytest.approx(math.sqrt(3) / 2 * E * t)


def lattice(size, spacing):
    """(nx, ny, dx, dy) of the patch generator's lattice: ny rows of pitch dy = H / ny, and
    columns of pitch dx = W / nx fitted to it (warp_cut/mesh/patch.py's rule); even rows hold
    nx + 1 nodes, odd rows are staggered by dx / 2 with a node added at each side."""
    width, height = size
    ny = max(1, round(height / (spacing * math.sqrt(3) / 2)))
    nx = max(1, round(width * math.sqrt(3) / (2 * height / ny)))
    return nx, ny, width / nx, height / ny


def lattice_stiffness(points, springs, size, spacing, E, t):
    """Van Gelder's k for every spring of the patch, by hand from the lattice (no triangle
    search): full triangles have area dx dy / 2, the right triangles at the side borders
    (legs dx / 2 and dy) dx dy / 4; so a horizontal edge dx has k = E t dy / dx (half on the
    top and bottom border), a half edge dx / 2 (odd rows' ends) k = 2 E t dy / dx, a side edge
    dy k = E t dx / (4 dy), a slanted edge l = |(dx / 2, dy)| k = E t dx dy / l^2, and 3/4 of
    that when it starts at a side border (one full and one right triangle)."""
    _, _, dx, dy = lattice(size, spacing)
    width, height = size
    d = np.abs(points[springs[:, 1]] - points[springs[:, 0]])
    at_side = np.any(np.isclose(np.abs(points[springs, 0]), width / 2, rtol=0, atol=1e-12), axis=1)
    on_top = np.all(np.isclose(np.abs(points[springs, 1]), height / 2, rtol=0, atol=1e-12), axis=1)
    flat, upright = np.isclose(d[:, 1], 0, atol=1e-12), np.isclose(d[:, 0], 0, atol=1e-12)
    full = flat & np.isclose(d[:, 0], dx, rtol=1e-9)
    half = flat & np.isclose(d[:, 0], dx / 2, rtol=1e-9)
    slanted = np.isclose(d[:, 0], dx / 2, rtol=1e-9) & np.isclose(d[:, 1], dy, rtol=1e-9)
    side = upright & np.isclose(d[:, 1], dy, rtol=1e-9) & at_side
    assert np.all(full | half | slanted | side)  # the lattice has no other edges
    ell2 = dx * dx / 4 + dy * dy
    return E * t * np.select(
        [full & on_top, full, half, side, slanted & at_side, slanted],
        [dy / (2 * dx), dy / dx, 2 * dy / dx, dx / (4 * dy), 0.75 * dx * dy / ell2, dx * dy / ell2])


def stretch_force(spacing, stiffness_model):
    """Force [N] needed to hold a 2 x 1 cm sheet stretched by 1 % along x, from the spring
    forces on the right border nodes (left border fixed, every node displaced affinely)."""
    mat = Material(youngs_modulus=20e3, thickness=2e-3)
    model = TissueModel.from_patch((0.02, 0.01), spacing, material=mat, pinned="none")
    if stiffness_model == "material":
        model.stiffness = material_stiffness(model.points, model.triangles, model.springs,
                                             mat.youngs_modulus, mat.thickness)
    x = model.points * np.array([1.01, 1.0, 1.0])
    i, j = model.springs.T
    d = x[j] - x[i]
    L = np.linalg.norm(d, axis=1)
    f = (model.stiffness * (L - model.rest_lengths) / L)[:, None] * d
    forces = np.zeros_like(x)
    np.add.at(forces, i, f)
    np.add.at(forces, j, -f)
    right = model.points[:, 0] > 0.01 - 1e-9
    return -forces[right, 0].sum()


def border_force_by_hand(spacing, stiffness_model, E=20e3, t=2e-3, K=160.0, eps=0.01,
                         size=(0.02, 0.01)):
    """``stretch_force`` in closed form: only springs from the right border inward pull on it.
    Each even row has a horizontal edge dx (stretched by eps dx) and each odd row a half edge
    dx / 2 (eps dx / 2); each odd row also has a slanted edge from the even row below and
    above, whose x-pull is k (L - l) (1 + eps) (dx / 2) / L, L = |((1 + eps) dx / 2, dy)|."""
    _, ny, dx, dy = lattice(size, spacing)
    even, odd = ny // 2 + 1, (ny + 1) // 2
    ell = math.hypot(dx / 2, dy)
    stretched = math.hypot((1 + eps) * dx / 2, dy)
    slant_pull = (stretched - ell) * (1 + eps) * (dx / 2) / stretched
    if stiffness_model == "constant":
        k_full = [K] * even
        k_half, k_slant = K, K
    else:  # lattice_stiffness: the top and bottom rows' edges have one triangle
        k_full = [E * t * dy / (2 * dx)] * 2 + [E * t * dy / dx] * (even - 2)
        k_half, k_slant = 2 * E * t * dy / dx, 0.75 * E * t * dx * dy / ell**2
    return sum(k_full) * eps * dx + odd * k_half * eps * dx / 2 + 2 * odd * k_slant * slant_pull


def test_material_model_converges_with_the_mesh_to_the_membrane_of_e_and_t():
    spacings = (2e-3, 1e-3, 2.5e-4)
    mat = [stretch_force(h, "material") for h in spacings]
    const = [stretch_force(h, "constant") for h in spacings]
    for h, m, c in zip(spacings, mat, const):
        assert m == pytest.approx(border_force_by_hand(h, "material"), rel=1e-9)
        assert c == pytest.approx(border_force_by_hand(h, "constant"), rel=1e-9)
    # the material model: the horizontal edges give E t eps dy per row, E t eps H in all,
    # whatever the spacing; the slanted ones add a share fixed by the triangles' shape, which
    # the fitted pitches only change through rounding (0.2 % here)
    assert mat[2] == pytest.approx(mat[1], rel=0.01)
    # the paper's constant K drifts: K eps dx (3 ny / 4 + 1) from the horizontal edges, the
    # "+ 1" (one more even row than odd ones) a share ~ dy / H that shrinks with the mesh
    assert const[0] > const[1] > const[2]
    # a lattice of equilateral triangles is an isotropic sheet (plane stress, Poisson 1/3);
    # held uniaxially, the border force lies between E t W eps (free lateral contraction)
    # and E t W eps / (1 - nu^2) (none)
    E, t, W, eps, nu = 20e3, 2e-3, 0.01, 0.01, 1 / 3
    assert E * t * W * eps <= mat[2] <= E * t * W * eps / (1 - nu**2)


def test_scene_selects_the_stiffness_model():
    data = {"tissue": {"kind": "patch", "size": [0.02, 0.02], "spacing": 0.004},
            "material": {"stiffness_model": "material", "youngs_modulus": 1e4}}
    model = parse_scene(data).build_model()
    assert model.material.thickness == 2e-3
    expected = lattice_stiffness(model.points, model.springs, (0.02, 0.02), 0.004, 1e4, 2e-3)
    np.testing.assert_allclose(model.stiffness, expected, rtol=1e-12)
    data["material"]["stiffness_model"] = "constant"
    assert np.all(parse_scene(data).build_model().stiffness == 160.0)
    data["material"]["stiffness_model"] = "springy"
    with pytest.raises(Exception, match="stiffness_model"):
        parse_scene(data)
