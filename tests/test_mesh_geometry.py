"""warp_cut.mesh.geometry edge routines (half_edges, edges_of with counts, edge_keys,
boundary_nodes) against plain Python loops over random triangle lists, boundary_nodes
against the border of a known patch, and cross3 against the cross product written out."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.mesh.geometry import boundary_nodes, cross3, edge_keys, edges_of, half_edges
from warp_cut.mesh.patch import skin_patch_mesh

triangle_lists = st.lists(st.tuples(*[st.integers(0, 9)] * 3), min_size=0, max_size=20)


def edge_counts(triangles):
    """Undirected edge -> number of triangles using it, self pairs left out (plain Python)."""
    counts = {}
    for a, b, c in triangles:
        for u, v in ((a, b), (b, c), (c, a)):
            if u != v:
                counts[(min(u, v), max(u, v))] = counts.get((min(u, v), max(u, v)), 0) + 1
    return counts


@settings(max_examples=100, deadline=None)
@given(triangle_lists)
def test_half_edges_follow_the_winding(triangles):
    tri = np.array(triangles, dtype=np.int32).reshape(-1, 3)
    he = half_edges(tri)
    expected = [pair for a, b, c in triangles for pair in ((a, b), (b, c), (c, a))]
    assert he.dtype == np.int32
    assert he.reshape(-1, 2).tolist() == [list(p) for p in expected]


@settings(max_examples=100, deadline=None)
@given(triangle_lists)
def test_edges_of_with_counts_match_a_python_count(triangles):
    counts = edge_counts(triangles)
    edges, used = edges_of(np.array(triangles, dtype=np.int64).reshape(-1, 3), return_counts=True)
    assert [tuple(e) for e in edges.tolist()] == sorted(counts)
    assert used.tolist() == [counts[k] for k in sorted(counts)]


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 49), st.integers(0, 49)), max_size=30))
def test_edge_keys_are_equal_exactly_for_equal_pairs(pairs):
    sorted_pairs = np.sort(np.array(pairs, dtype=np.int64).reshape(-1, 2), axis=1)
    keys = edge_keys(sorted_pairs, 50)
    for i in range(len(pairs)):
        for j in range(len(pairs)):
            assert (keys[i] == keys[j]) == (tuple(sorted_pairs[i]) == tuple(sorted_pairs[j]))


@settings(max_examples=100, deadline=None)
@given(triangle_lists)
def test_boundary_nodes_are_the_ends_of_single_use_edges(triangles):
    expected = {v for edge, k in edge_counts(triangles).items() if k == 1 for v in edge}
    mask = boundary_nodes(10, np.array(triangles, dtype=np.int64).reshape(-1, 3))
    assert set(np.flatnonzero(mask).tolist()) == expected


def test_boundary_nodes_of_a_patch_are_its_rectangle_border():
    points, triangles = skin_patch_mesh((0.02, 0.012), 0.002)
    on_border = (np.isclose(np.abs(points[:, 0]), 0.01) | np.isclose(np.abs(points[:, 1]), 0.006))
    np.testing.assert_array_equal(boundary_nodes(len(points), triangles), on_border)


vectors = st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=3, max_size=3)


@settings(max_examples=100, deadline=None)
@given(st.lists(vectors, min_size=1, max_size=6), vectors)
def test_cross3_is_the_cross_product_and_broadcasts(rows, single):
    """Row by row against the components written out, a single vector broadcast against
    the rows and lists taken as arrays; a x a is 0 and a x b = -(b x a)."""
    a, b = np.array(rows), np.array(single)

    def by_hand(u, v):
        return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]

    expected = np.array([by_hand(u, b) for u in a])
    assert cross3(a, b).shape == (len(rows), 3)
    assert np.array_equal(cross3(a, b), expected)
    assert np.array_equal(cross3(rows, single), expected)
    assert np.array_equal(cross3(b, a), -expected)
    assert not cross3(a, a).any()
