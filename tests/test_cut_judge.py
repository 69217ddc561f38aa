"""warp_cut/verify/cut_judge.py on small hand-built meshes with known answers: a triangle of
5 deg, triangles wound against the surface or folded over, pieces joined through a node or not,
an annulus (two border loops, a known open area), and islands free, attached or removed."""

import math

import numpy as np
import pytest

from warp_cut import TissueModel
from warp_cut.mesh import surfaces
from warp_cut.verify import cut_judge as J

FLAT = surfaces.flat_grid(0.01, 0.002)
"""A flat Surface in the XY plane (normal +Z), used as the reference surface."""


def sliver_points(angle_deg: float) -> np.ndarray:
    """An isosceles triangle (counter-clockwise from +Z) with apex angle ``angle_deg`` at node 0."""
    a = math.radians(angle_deg)
    return np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 0.0], [1e-3 * math.cos(a), 1e-3 * math.sin(a), 0.0]])


def equilateral(scale=1e-3) -> np.ndarray:
    return scale * np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, math.sqrt(3) / 2, 0.0]])


def square_grid(n: int, size: float) -> tuple[np.ndarray, np.ndarray]:
    """An n x n-cell square grid of ``size`` [m] centred on the origin, two CCW triangles per cell."""
    s = np.linspace(-size / 2, size / 2, n + 1)
    x, y = np.meshgrid(s, s, indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    idx = lambda i, j: i * (n + 1) + j  # noqa: E731
    tri = []
    for i in range(n):
        for j in range(n):
            tri += [[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)], [idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]]
    return pts, np.array(tri)


def cells(tri: np.ndarray, n: int, keep) -> np.ndarray:
    """The triangles of the grid cells (i, j) for which keep(i, j) is true."""
    rows = [2 * (i * n + j) + k for i in range(n) for j in range(n) if keep(i, j) for k in (0, 1)]
    return tri[rows]


def test_smallest_angles_rest_and_current():
    rest, now = sliver_points(5.0), equilateral()
    out = J.judge_arrays(rest, now, [[0, 1, 2]], [True], FLAT, base_loops=1, wounds=0)
    assert out.cut_triangles == 1
    assert out.min_rest_angle_deg == pytest.approx(5.0, abs=1e-9)
    assert out.min_current_angle_deg == pytest.approx(60.0, abs=1e-9)
    assert (out.rest_slivers, out.current_slivers) == (1, 0)


def test_no_cut_triangles_gives_nan_angles_and_zero_counts():
    out = J.judge_arrays(equilateral(), equilateral(), [[0, 1, 2]], [False], FLAT, base_loops=1, wounds=0)
    assert out.cut_triangles == 0 and math.isnan(out.min_rest_angle_deg) and math.isnan(out.min_current_angle_deg)
    assert (out.wound_against, out.folded, out.folded_tissue) == (0, 0, 0)


def test_wound_against_counts_cut_triangles_turned_against_the_surface_at_rest():
    pts = np.vstack([equilateral(), equilateral() + [2e-3, 0.0, 0.0]])
    tri = np.array([[0, 1, 2], [3, 5, 4], [0, 2, 1]])  # normal +Z, -Z (made), -Z (original)
    out = J.judge_arrays(pts, pts, tri, [True, True, False], FLAT, base_loops=0, wounds=0)
    assert out.wound_against == 1  # only the cut's own count
    assert (out.folded, out.folded_tissue) == (1, 1)  # at rest = now: the same two face down


def test_folded_counts_triangles_turned_over_as_the_skin_lies():
    rest = np.vstack([equilateral(), equilateral() + [2e-3, 0.0, 0.0]])
    now = rest.copy()
    now[[2, 5], 1] *= -1.0  # the third corner swung across the first edge in both: both face -Z
    tri = np.array([[0, 1, 2], [3, 4, 5]])
    out = J.judge_arrays(rest, now, tri, [True, False], FLAT, base_loops=0, wounds=0)
    assert out.wound_against == 0
    assert (out.folded, out.folded_tissue) == (1, 1)


def test_against_uses_the_reference_normal_given():
    pts, tri = equilateral(), np.array([[0, 1, 2]])
    assert J.against(pts, tri, lambda c: np.tile([0.0, 0.0, 1.0], (len(c), 1))).tolist() == [False]
    assert J.against(pts, tri, lambda c: np.tile([0.0, 0.3, -1.0], (len(c), 1))).tolist() == [True]


def test_component_count_joins_through_shared_nodes_only():
    assert J.component_count([[0, 1, 2], [3, 4, 5]]) == 2
    assert J.component_count([[0, 1, 2], [2, 3, 4]]) == 1  # one shared node: not free
    assert J.component_count([[0, 1, 2], [1, 3, 2], [5, 6, 7]]) == 2
    assert J.component_count(np.zeros((0, 3), int)) == 0


def test_annulus_has_two_loops_and_its_hole_as_open_area():
    n, size = 4, 8e-3
    pts, tri = square_grid(n, size)
    ring = cells(tri, n, lambda i, j: not (1 <= i <= 2 and 1 <= j <= 2))
    assert J.loop_count(tri) == 1 and J.loop_count(ring) == 2
    base_area = J.parameter_area(pts, tri, FLAT)
    assert base_area == pytest.approx(size * size, rel=1e-12)
    out = J.judge_arrays(pts, pts, ring, np.zeros(len(ring), bool), FLAT, base_loops=1, wounds=1, base_area=base_area)
    assert (out.border_loops, out.expected_loops, out.holes, out.components) == (2, 2, 0, 1)
    assert out.open_area_mm2 == pytest.approx(1e6 * (size / 2) ** 2, rel=1e-9)  # the 2 x 2 cells
    out = J.judge_arrays(pts, pts, ring, np.zeros(len(ring), bool), FLAT, base_loops=1, wounds=0)
    assert out.holes == 1 and math.isnan(out.open_area_mm2)


def test_island_free_attached_removed():
    n, size = 6, 12e-3
    pts, tri = square_grid(n, size)
    h = size / n
    outline = np.array([[-1.5, -1.5], [1.5, -1.5], [1.5, 1.5], [-1.5, 1.5]]) * h  # around the 3 x 3 middle
    inner = lambda i, j: 2 <= i <= 3 and 2 <= j <= 3  # noqa: E731 - the 2 x 2 middle cells
    moat = lambda i, j: (1 <= i <= 4 and 1 <= j <= 4) and not inner(i, j)  # noqa: E731
    free = cells(tri, n, lambda i, j: not moat(i, j))
    removed = cells(tri, n, lambda i, j: not (moat(i, j) or inner(i, j)))
    assert J.island_state(pts, free, FLAT, outline, h) == "free"
    assert J.island_state(pts, tri, FLAT, outline, h) == "attached"
    assert J.island_state(pts, removed, FLAT, outline, h) == "removed"
    out = J.judge_arrays(pts, pts, free, np.zeros(len(free), bool), FLAT, base_loops=1, wounds=1, outline=outline)
    # the moat's outer rim and the island's own border: expected = 1 + 1 wound + 1 free island
    assert (out.components, out.island, out.border_loops, out.expected_loops, out.holes) == (2, "free", 3, 3, 0)


def test_judge_reads_the_model_and_counts_slots_from_the_baseline():
    pts, tri = square_grid(2, 4e-3)
    model = TissueModel.from_triangles(pts, tri)
    base = J.baseline(model, FLAT)
    assert (base.triangle_slots, base.border_loops) == (8, 1)
    assert base.area == pytest.approx(16e-6, rel=1e-12)
    out = J.judge(model, model.points, FLAT, base, wounds=0)
    assert (out.cut_triangles, out.holes, out.components) == (0, 0, 1)
    assert out.open_area_mm2 == pytest.approx(0.0, abs=1e-9)
