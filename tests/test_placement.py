"""warp_cut/cut/remesh/placement.py: where a node the re-mesh makes starts.

Checked against maps built here: the tissue's map reproduces an affine map exactly; in tissue
that is an affine image of its chart (no fold, whatever the stretch, shear or turn) every new
point stays where its rest triangle puts it (nothing jumps); a new point placed through crushed
tissue, so that a new triangle is born folded over, goes where the tissue round it carries it,
and no new triangle is left folded; the tool's nodes are left out of the map and a moved point
is kept out of the tool's cylinder.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.cut.contact.material_point import held_by
from warp_cut.cut.remesh.placement import folded_against, start_positions, tissue_map
from warp_cut.mesh.triangulate import delaunay
from warp_cut.sim.control import Tool

H = 1e-3  # spacing [m]


def affine(seed: int, turn: float = 0.0):
    """(origin (3,), rows (2, 3)): a chart-to-3D affine map with positive orientation (its
    normal d/dx x d/dy has +z), stretched, sheared and turned by ``turn`` [rad] about x."""
    rng = np.random.default_rng(seed)
    jac2 = np.eye(2) + rng.uniform(-0.3, 0.3, (2, 2))
    jac2[0, 0], jac2[1, 1] = abs(jac2[0, 0]) + 0.5, abs(jac2[1, 1]) + 0.5
    if np.linalg.det(jac2) <= 0:
        jac2[0, 1] = jac2[1, 0] = 0.0
    rows = np.column_stack([jac2.T, np.zeros(2)])  # (2, 3): d/dx, d/dy
    c, s = np.cos(turn), np.sin(turn)
    rows = rows @ np.array([[1, 0, 0], [0, c, s], [0, -s, c]])
    return rng.uniform(-1e-3, 1e-3, 3), rows


def grid_patch(n: int = 7, jitter: float = 0.0, seed: int = 0):
    """Chart points (n^2, 2) [m] of a jittered grid of spacing H round the origin and their
    Delaunay triangles (counter-clockwise)."""
    g = (np.arange(n) - (n - 1) / 2) * H
    pts = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    pts += np.random.default_rng(seed).uniform(-jitter, jitter, pts.shape) * H
    return pts, delaunay(pts)


def centre_new(points: np.ndarray, count: int) -> np.ndarray:
    """(n,) bool: the ``count`` points nearest the chart's origin."""
    new = np.zeros(len(points), dtype=bool)
    new[np.argsort(np.linalg.norm(points, axis=1))[:count]] = True
    return new


def test_the_tissue_map_is_an_affine_map_exactly():
    points, _ = grid_patch(jitter=0.3, seed=1)
    origin, rows = affine(2, turn=0.4)
    x = origin + points @ rows
    at = np.array([[0.0, 0.0], [1.3e-3, -0.7e-3], [4e-3, 4e-3]])  # the last outside the nodes
    maps = tissue_map(points, x, at, scale=2 * H)
    np.testing.assert_allclose(maps[:, 0], origin + at @ rows, atol=1e-12)
    np.testing.assert_allclose(maps[:, 1:], np.broadcast_to(rows, (3, 2, 3)), atol=1e-9)


def test_no_tissue_map_from_nodes_on_a_line_or_too_few():
    line = np.column_stack([np.linspace(0, 4e-3, 5), np.zeros(5)])
    assert tissue_map(line, np.column_stack([line, np.zeros(5)]), np.zeros((1, 2)), H) is None
    assert tissue_map(line[:2], np.zeros((2, 3)), np.zeros((1, 2)), H) is None


def test_a_mirrored_triangle_is_folded_against_the_tissue():
    x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]) * H
    maps = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]])  # normal +z
    assert not folded_against(x, np.array([[0, 1, 2]]), maps)[0]
    assert folded_against(x, np.array([[0, 2, 1]]), maps)[0]


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), turn=st.floats(-1.2, 1.2), count=st.integers(1, 12),
       jitter=st.floats(0.0, 0.35))
def test_in_unfolded_tissue_new_points_stay_where_their_rest_triangle_puts_them(seed, turn, count, jitter):
    points, triangles = grid_patch(jitter=jitter, seed=seed)
    origin, rows = affine(seed, turn)
    x = origin + points @ rows  # the tissue (old and new points) an affine image of its chart
    new = centre_new(points, count)
    placed = start_positions(points, triangles, x, new, tool=None, spacing=H)
    np.testing.assert_array_equal(placed, x)


def crushed(seed: int):
    """A patch whose new points were placed through crushed tissue: four new points at the
    centre carried across the origin (mirrored), so triangles round them are born folded."""
    points, triangles = grid_patch(jitter=0.2, seed=seed)
    origin, rows = affine(seed, turn=0.3)
    x = origin + points @ rows
    new = centre_new(points, 4)
    x[new] = origin + (-points[new]) @ rows + np.array([0.0, 0.0, 0.3 * H])
    return points, triangles, x, new, (origin, rows)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_new_points_of_triangles_born_folded_go_where_the_tissue_carries_them(seed):
    points, triangles, x, new, (origin, rows) = crushed(seed)
    touching = triangles[new[triangles].any(axis=1)]
    truth = tissue_map(points[~new], x[~new], points[touching].mean(axis=1), 1.5 * H)
    assert folded_against(x, touching, truth).any()  # the case is what it says
    placed = start_positions(points, triangles, x, new, tool=None, spacing=H)
    assert not folded_against(placed, touching, truth).any()
    np.testing.assert_allclose(placed[new], origin + points[new] @ rows, atol=1e-9)  # the tissue is affine
    np.testing.assert_array_equal(placed[~new], x[~new])  # old nodes never move


def test_the_tools_nodes_are_left_out_of_the_map_and_a_moved_point_is_kept_out_of_it():
    points, triangles, x, new, (origin, rows) = crushed(5)
    centre = origin.copy()
    tool = Tool(p0=centre - np.array([0, 0, 5 * H]), p1=centre + np.array([0, 0, 5 * H]), radius=1.0 * H)
    held = held_by(x, tool) & ~new
    assert held.any()
    x[held] += np.array([0.0, 0.0, -2 * H])  # the tool pushed them; they say nothing of the tissue
    placed = start_positions(points, triangles, x, new, tool=tool, spacing=H)
    moved = new & (np.linalg.norm(placed - x, axis=1) > 0)
    assert moved.any()
    axis_gap = np.linalg.norm(placed[moved][:, :2] - centre[:2], axis=1)
    assert (axis_gap >= tool.radius * (1 - 1e-9)).all()
    # in the plane of the tissue a moved point lies where the map of the unheld nodes carries it,
    # pushed radially out of the vertical cylinder
    target = origin + points[moved] @ rows
    direction = (target - centre)[:, :2]
    np.testing.assert_allclose(placed[moved][:, :2] - centre[:2],
                               np.maximum(np.linalg.norm(direction, axis=1), tool.radius)[:, None]
                               * direction / np.linalg.norm(direction, axis=1)[:, None], atol=1e-9)
    np.testing.assert_allclose(placed[moved][:, 2], target[:, 2], atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), count=st.integers(1, 12), push=st.floats(0.1, 2.0))
def test_after_any_crush_no_new_triangle_is_left_folded(seed, count, push):
    """New points thrown about in affine tissue (as a crushed dent would place them): afterwards
    no triangle with a new corner is folded against the tissue, and the points moved are where
    the tissue carries them."""
    points, triangles = grid_patch(jitter=0.25, seed=seed)
    origin, rows = affine(seed, turn=0.5)
    tissue = origin + points @ rows
    new = centre_new(points, count)
    x = tissue.copy()
    x[new] += np.random.default_rng(seed).normal(scale=push * H, size=(int(new.sum()), 3))
    placed = start_positions(points, triangles, x, new, tool=None, spacing=H)
    touching = triangles[new[triangles].any(axis=1)]
    maps = tissue_map(points[~new], tissue[~new], points[touching].mean(axis=1), 1.5 * H)
    assert not folded_against(placed, touching, maps).any()
    moved = np.linalg.norm(placed - x, axis=1) > 0
    np.testing.assert_allclose(placed[moved], tissue[moved], atol=1e-9)
