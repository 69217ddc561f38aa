"""warp_cut/mesh/triangulate.py: border edges and border loops, against a direct count."""

from __future__ import annotations

from collections import Counter

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from warp_cut.mesh.patch import skin_patch_mesh
from warp_cut.mesh.triangulate import border_loop_count, boundary_edges

POINTS, TRIANGLES = skin_patch_mesh((0.02, 0.016), 0.002)


@given(seed=st.integers(0, 2**32 - 1), keep=st.floats(0.05, 1.0))
def test_boundary_edges_are_the_edges_of_one_triangle_in_its_winding(seed, keep):
    """Any subset of a patch's triangles: the directed edges used by exactly one of them, each
    in its triangle's winding and in the triangles' order - a Counter over sorted pairs."""
    rng = np.random.default_rng(seed)
    tri = TRIANGLES[rng.random(len(TRIANGLES)) < keep]
    count = Counter(tuple(sorted(e)) for t in tri.tolist() for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])))
    expected = [list(e) for t in tri.tolist() for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))
                if count[tuple(sorted(e))] == 1]
    assert boundary_edges(tri).tolist() == expected


def test_border_loops_of_a_patch_with_holes():
    """The whole patch has one border loop; each hole made by taking out the triangles round an
    inner node, apart from the others, adds one."""
    assert border_loop_count(TRIANGLES) == 1
    inner = [v for v in range(len(POINTS))
             if abs(POINTS[v, 0]) < 0.006 and abs(POINTS[v, 1]) < 0.005]
    holes = []
    for v in inner:  # nodes at least three spacings apart: their fans share no node
        if all(np.abs(POINTS[v] - POINTS[w]).max() > 0.005 for w in holes):
            holes.append(v)
    assert len(holes) >= 2
    for k in range(1, len(holes) + 1):
        keep = ~np.isin(TRIANGLES, holes[:k]).any(axis=1)
        assert border_loop_count(TRIANGLES[keep]) == 1 + k
    assert border_loop_count(np.zeros((0, 3), dtype=np.int64)) == 0
