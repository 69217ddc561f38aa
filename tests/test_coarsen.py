"""warp_cut/cut/remesh/coarsen.py (through ``fill_region(coarsen_below=...)``): the refinement's needless
small points are taken out, and the fill keeps its region, its outline, its input points and
its smallest angle. Checked on a thin slit whose sides the refinement splits against each other,
and as properties of random star-shaped regions with points inside; areas and angles are
computed here from the triangles."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.cut.remesh.coarsen import coarsen
from warp_cut.cut.remesh.fill import fill_region

ANGLE = 22.0


def smallest_angles(points, triangles) -> np.ndarray:
    """Smallest angle [deg] of each triangle, by the law of cosines."""
    c = np.asarray(points)[np.asarray(triangles)]
    sides = [np.linalg.norm(c[:, (k + 1) % 3] - c[:, (k + 2) % 3], axis=1) for k in range(3)]  # opposite corner k
    out = []
    for k in range(3):
        a, b, o = sides[(k + 1) % 3], sides[(k + 2) % 3], sides[k]
        out.append(np.degrees(np.arccos(np.clip((a * a + b * b - o * o) / (2 * a * b), -1, 1))))
    return np.min(out, axis=0)


def signed_areas(points, triangles) -> np.ndarray:
    c = np.asarray(points)[np.asarray(triangles)]
    u, v = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
    return 0.5 * (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])


def edge_lengths(points, triangles) -> np.ndarray:
    c = np.asarray(points)[np.asarray(triangles)]
    return np.linalg.norm(c - c[:, [1, 2, 0]], axis=2)


def boundary_length(points, triangles) -> float:
    """Length of the edges of exactly one triangle: the filled region's outline."""
    e = np.sort(np.asarray(triangles)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, counts = np.unique(e, axis=0, return_counts=True)
    once = edges[counts == 1]
    return float(np.linalg.norm(points[once[:, 0]] - points[once[:, 1]], axis=1).sum())


def ring(n: int) -> list[tuple[int, int]]:
    return [(k, (k + 1) % n) for k in range(n)]


def thin_slit(width: float) -> np.ndarray:
    """A 4 x 4 square with a slit from its right side: a channel ``width`` wide running in to
    x = 2.3-2.6 (its two sides ending apart), then a thin wedge to its tip at (1.5, 2.1)."""
    return np.array([[0, 0], [4, 0], [4, 2 - width / 2], [2.3, 2 - width / 2], [1.5, 2.1], [2.6, 2 + width / 2],
                     [4, 2 + width / 2], [4, 4], [0, 4]], dtype=float)


def assert_same_region(outline, inputs, plain, coarse):
    """The coarsened fill covers the region the plain one does: the area of ``outline`` (k, 2),
    the same outline length, every triangle counter-clockwise, the ``inputs`` first and unmoved."""
    area = pytest.approx(shapely.Polygon(outline).area, rel=1e-9)
    assert signed_areas(coarse.points, coarse.triangles).sum() == area
    assert signed_areas(plain.points, plain.triangles).sum() == area
    assert np.all(signed_areas(coarse.points, coarse.triangles) > 0.0)
    assert boundary_length(coarse.points, coarse.triangles) == pytest.approx(
        boundary_length(plain.points, plain.triangles), rel=1e-9)
    np.testing.assert_array_equal(coarse.points[:len(inputs)], inputs)


def test_the_splits_a_thin_slits_sides_cascade_into_are_taken_out():
    """The slit's wedge, 0.15 wide where it leaves the channel, its two sides ending apart: the
    refinement splits each side against the points split on the other, down to the slit's
    width (56 points inserted, edges of 0.15). Coarsened below 0.25 the fill has fewer points
    and no edge under 0.2, every angle still at least the target, the same region and outline."""
    points = thin_slit(0.15)
    plain = fill_region(points, ring(len(points)), min_angle_deg=ANGLE, min_edge=1e-3)
    coarse = fill_region(points, ring(len(points)), min_angle_deg=ANGLE, min_edge=1e-3, coarsen_below=0.25)
    assert edge_lengths(plain.points, plain.triangles).min() < 0.16
    assert len(coarse.points) < len(plain.points) - 10
    assert edge_lengths(coarse.points, coarse.triangles).min() > 0.2
    assert smallest_angles(coarse.points, coarse.triangles).min() >= ANGLE
    assert coarse.unrefined == 0 and coarse.input_count == len(points)
    assert_same_region(points, points, plain, coarse)


def test_a_split_point_goes_only_where_it_lies_in_line_on_the_outline():
    """A square's corner points are inputs; the refinement's points on its sides split them in
    line. A point at an outline corner (here an inserted point bent out of line) stays."""
    points = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.0]], dtype=float)
    triangles = np.array([[0, 4, 3], [4, 1, 2], [4, 2, 3]])
    kept, tris = coarsen(points, triangles, 4, 10.0, 20.0)
    assert len(kept) == 4 and len(tris) == 2  # the side's midpoint went: two triangles of 45 degrees
    bent = points.copy()
    bent[4] = [0.5, 0.05]  # no longer on the side 0-1: a corner of the outline
    kept, tris = coarsen(bent, triangles, 4, 10.0, 0.0)
    assert len(kept) == 5 and len(tris) == 3


def test_points_no_triangle_uses_keep_their_place():
    """An input point that lies in no triangle (left in an opening) is kept, so the input points
    keep their indices when an inserted point goes."""
    points = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [5.0, 5.0], [0.5, 0.0]], dtype=float)
    triangles = np.array([[0, 5, 3], [5, 1, 2], [5, 2, 3]])
    kept, tris = coarsen(points, triangles, 5, 10.0, 20.0)
    np.testing.assert_array_equal(kept, points[:5])
    assert sorted(map(sorted, tris.tolist())) in ([[0, 1, 2], [0, 2, 3]], [[0, 1, 3], [1, 2, 3]])


@st.composite
def star_regions(draw):
    """A star-shaped polygon of 5-12 corners (radii 1-3, angles jittered) with up to 4 points
    inside (within half the smallest radius)."""
    n = draw(st.integers(5, 12))
    radii = draw(st.lists(st.floats(1.0, 3.0), min_size=n, max_size=n))
    jitter = draw(st.lists(st.floats(-0.3, 0.3), min_size=n, max_size=n))
    angles = [2 * math.pi * (k + j) / n for k, j in enumerate(jitter)]
    outline = [[r * math.cos(a), r * math.sin(a)] for r, a in zip(radii, angles)]
    inner = draw(st.lists(st.tuples(st.floats(0, 2 * math.pi), st.floats(0.05, 0.45)), max_size=4))
    points = outline + [[r * math.cos(a), r * math.sin(a)] for a, r in inner]
    return np.array(points), n


@settings(max_examples=40, deadline=None)
@given(star_regions(), st.floats(0.1, 1.0))
def test_coarsening_keeps_the_region_its_inputs_and_its_smallest_angle(region, short):
    """On random star-shaped regions: the coarsened fill covers the same area with the same
    outline, keeps the input points, has no more points than the plain fill, and its smallest
    angle is at least the target or the plain fill's smallest, whichever is less."""
    points, n = region
    if len(np.unique(np.round(points, 9), axis=0)) < len(points):
        return  # two equal points: not a region
    plain = fill_region(points, ring(n), min_angle_deg=ANGLE, min_edge=1e-3)
    coarse = fill_region(points, ring(n), min_angle_deg=ANGLE, min_edge=1e-3, coarsen_below=short)
    assert_same_region(points[:n], points, plain, coarse)
    assert len(coarse.points) <= len(plain.points)
    floor = min(ANGLE, smallest_angles(plain.points, plain.triangles).min())
    assert smallest_angles(coarse.points, coarse.triangles).min() >= floor - 1e-9
