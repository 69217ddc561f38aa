"""warp_cut/cut/remesh.py: the edge flips that reshape a fill before it joins the mesh.

A fill's triangles (the zipped strip or the ears) may hold a sliver beside a well-shaped
neighbour; ``_flipped_better`` flips their shared edge when the pair's smallest angle grows.
Checked against what a flip must keep: the same region covered (signed areas), every triangle
turning the same way, no smaller smallest angle, and no flip across a non-convex quad.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.cut.remesh import _UP, _flip, _flipped_better, _min_angle, _shape, _valid
from warp_cut.mesh.checks import triangle_min_angles


def signed_areas(tris, x) -> np.ndarray:
    p = x[np.asarray(tris)]
    return 0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2]


def always(_tris) -> bool:
    return True


def test_a_flip_keeps_the_turn_of_both_triangles():
    x = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 0.1, 0], [0.5, -0.1, 0]])
    t1, t2 = (0, 1, 2), (1, 0, 3)  # a long shared edge 0-1: two slivers
    new = _flip(t1, t2, frozenset((0, 1)))
    assert set(map(frozenset, new)) == {frozenset((0, 3, 2)), frozenset((3, 1, 2))}
    assert all(_valid(t, x, _UP) for t in new)
    assert signed_areas(new, x).sum() == signed_areas([t1, t2], x).sum()
    assert _flip(t1, (0, 1, 3), frozenset((0, 1))) is None  # the edge run the same way twice


def test_the_slivers_of_a_long_diagonal_are_flipped_and_a_concave_quad_is_not():
    x = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 0.1, 0], [0.5, -0.1, 0]])
    better = _flipped_better([(0, 1, 2), (1, 0, 3)], x, x, always)
    assert _min_angle(better, x) > 20.0 > 12.0 > _min_angle([(0, 1, 2), (1, 0, 3)], x)  # 22.6 against 11.3 deg
    concave = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 0.1, 0], [-0.5, -0.02, 0]])  # reflex at node 0
    tris = [(0, 1, 2), (1, 0, 3)]
    assert _flipped_better(tris, concave, concave, always) == tris  # (0, 3, 2) would turn over


def test_a_flipped_set_the_mesh_refuses_is_not_used():
    x = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 0.1, 0], [0.5, -0.1, 0]])
    tris = [(0, 1, 2), (1, 0, 3)]
    assert _flipped_better(tris, x, x, lambda t: t == tris) == tris


@settings(max_examples=60, deadline=None)
@given(st.integers(5, 12), st.integers(0, 2**31 - 1))
def test_flips_of_a_fan_never_lose_area_turn_or_angle(corners, seed):
    """A fan over a random convex polygon (points on a circle at random angles): the flipped
    set covers the same area, every triangle turns the way of the fan, and its smallest
    angle is at least the fan's."""
    rng = np.random.default_rng(seed)
    angles = np.sort(rng.uniform(0, 2 * np.pi, corners))
    x = np.stack([np.cos(angles), np.sin(angles), np.zeros(corners)], axis=1)
    fan = [(0, k, k + 1) for k in range(1, corners - 1)]
    fan = [t for t in fan if _valid(t, x, _UP)]
    flipped = _flipped_better(fan, x, x, always)
    assert len(flipped) == len(fan)
    assert np.isclose(signed_areas(flipped, x).sum(), signed_areas(fan, x).sum())
    assert all(_valid(t, x, _UP) for t in flipped)
    assert _min_angle(flipped, x) >= _min_angle(fan, x) - 1e-9


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=9, max_size=9))
def test_a_triangle_shape_is_its_angles_and_normal(coords):
    """``_shape`` (plain floats) against numpy: the smallest angle as ``triangle_min_angles``
    gives it, the unit normal of (b - a) x (c - a)."""
    x = np.array(coords).reshape(3, 3)
    n = np.cross(x[1] - x[0], x[2] - x[0])
    if np.linalg.norm(n) < 1e-3:  # nearly degenerate: no normal to compare
        return
    angle, normal = _shape((0, 1, 2), x)
    assert angle == pytest.approx(triangle_min_angles(x, np.array([[0, 1, 2]]))[0], abs=1e-6)
    np.testing.assert_allclose(normal, n / np.linalg.norm(n), atol=1e-9)
