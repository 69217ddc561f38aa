"""warp_cut/cut/sweep/tissue_at_rest.py: rest points in the tissue or in an opening, and where a new
incision starts beside an earlier wound.

Compared against: a hand-built flat grid of 1 mm squares (5 x 5 cells) with its middle cell's
two triangles taken out (a square opening from (2, 2) to (3, 3) mm), where which points lie on
a triangle and how far each lies from a border are known by construction.
"""

import numpy as np
import pytest
from conftest import grid_without

from warp_cut import TissueModel
from warp_cut.cut.curve.incision import Incision
from warp_cut.cut.sweep.tissue_at_rest import (
    joined_start,
    necks,
    on_tissue_at_rest,
    rest_point_on_tissue,
    tissue_and_edge,
)

MM = 1e-3


def grid_with_a_hole() -> TissueModel:
    """6 x 6 nodes 1 mm apart (node id = 6 row + column), every cell split on one diagonal,
    the middle cell (columns 2-3, rows 2-3) left out."""
    return grid_without({(2, 2)})


def at(x_mm, y_mm):
    return np.array([[x_mm * MM, y_mm * MM, 0.0]])


def test_points_on_triangles_clear_of_every_border_are_in_the_tissue():
    """On a triangle 0.5 mm from the hole's edge (1.5 mm from the outer border): in the tissue
    with a 0.4 mm clearance, not with 0.6 mm; in the hole, or beyond the outer edge: never."""
    model = grid_with_a_hole()
    nodes = np.arange(model.node_count)
    assert on_tissue_at_rest(model, at(1.5, 2.5), nodes, 0.4 * MM)[0]
    assert not on_tissue_at_rest(model, at(1.5, 2.5), nodes, 0.6 * MM)[0]
    assert not on_tissue_at_rest(model, at(2.5, 2.5), nodes, 0.0)[0]   # in the hole
    assert not on_tissue_at_rest(model, at(-0.5, 1.5), nodes, 0.0)[0]  # beyond the edge
    mask = on_tissue_at_rest(model, np.vstack([at(1.5, 1.5), at(2.5, 2.5)]), nodes, 0.1 * MM)
    assert mask.tolist() == [True, False]


def test_the_border_of_an_incisions_own_slit_is_no_border_to_it():
    """A point 0.2 mm from the hole's edge is too near it with a 0.3 mm clearance, unless the
    hole's border is the incision's own slit (its nodes ``own``)."""
    model = grid_with_a_hole()
    nodes = np.arange(model.node_count)
    point = at(3.2, 2.5)
    assert not on_tissue_at_rest(model, point, nodes, 0.3 * MM)[0]
    hole = {14, 15, 20, 21}  # the hole's corners: (2, 2), (3, 2), (2, 3), (3, 3) mm
    assert on_tissue_at_rest(model, point, nodes, 0.3 * MM, own=hole)[0]


def test_rest_point_on_tissue_looks_only_at_the_nodes_near_it():
    model = grid_with_a_hole()
    assert rest_point_on_tissue(model, at(1.5, 0.5)[0], 1 * MM)
    assert not rest_point_on_tissue(model, at(2.5, 2.5)[0], 1 * MM)
    assert not rest_point_on_tissue(model, at(8.0, 8.0)[0], 1 * MM)  # no node near


def test_a_start_within_the_radius_of_an_earlier_slit_node_moves_onto_it():
    """An earlier incision whose slit holds node 15 (at (3, 2) mm): a start 0.4 mm from it with a
    0.5 mm radius starts on it; with a 0.3 mm radius, or once the node is gone, where asked."""
    model = grid_with_a_hole()
    earlier = Incision(at(0, 0)[0], [0, 0, 1], spacing=MM, lip_offset=0.1 * MM, tolerance=1e-6)
    earlier.slit_nodes = {15}
    start = at(3.4, 2.0)[0]
    np.testing.assert_allclose(joined_start(model, [earlier], start, 0.5 * MM), model.points[15])
    np.testing.assert_allclose(joined_start(model, [earlier], start, 0.3 * MM), start)
    model.active[15] = False
    np.testing.assert_allclose(joined_start(model, [earlier], start, 0.5 * MM), start)
    assert joined_start(model, [], start, 1.0) is start


@pytest.mark.parametrize("point", [(0.0, 0.0), (5.0, 5.0)])
def test_a_corner_of_the_tissue_is_on_it_only_with_no_clearance(point):
    model = grid_with_a_hole()
    nodes = np.arange(model.node_count)
    assert not on_tissue_at_rest(model, at(*point), nodes, 0.01 * MM)[0]


def test_tissue_and_edge_split_on_tissue_into_over_a_triangle_and_clear_of_a_border():
    """On the tissue 0.2 mm from the hole (x 1.8 mm): over a triangle, not clear of 0.4 mm; in
    the hole's middle: over none, yet 0.5 mm from every border; far from it: both. Their and
    is ``on_tissue_at_rest``."""
    model = grid_with_a_hole()
    points = np.concatenate([at(1.8, 2.5), at(2.5, 2.5), at(0.9, 0.9)])
    nodes = np.flatnonzero(model.active)
    over, clear = tissue_and_edge(model, points, nodes, 0.4 * MM)
    assert over.tolist() == [True, False, True]
    assert clear.tolist() == [False, True, True]
    assert (over & clear).tolist() == on_tissue_at_rest(model, points, nodes, 0.4 * MM).tolist()


@pytest.mark.parametrize("over, clear, expected", [
    ("0110", "0000", "0110"),            # over the tissue between two openings, nowhere clear: a neck
    ("0110", "0010", "0000"),            # a sample clear of the borders: an ordinary run
    ("1100", "0000", "0000"),            # from the piece's start: not between two openings
    ("0011", "0000", "0000"),            # to its end (the tip): not between two openings
    ("011011100", "000000000", "011011100"),  # two necks
    ("010111010", "000010000", "010000010"),  # a neck, a run with a clear sample, a neck
])
def test_a_neck_is_a_run_over_the_tissue_between_openings_nowhere_clear_of_a_border(over, clear, expected):
    """Samples 0.1 mm apart; no run longer than 1 mm here."""
    def mask(text):
        return np.array([c == "1" for c in text])
    u = 1e-4 * np.arange(len(over))
    assert necks(u, mask(over), mask(clear), 1e-3).tolist() == mask(expected).tolist()


@pytest.mark.parametrize("length_mm, is_neck", [(0.8, True), (1.0, True), (1.2, False)])
def test_a_run_longer_than_a_neck_runs_beside_a_border_and_is_no_neck(length_mm, is_neck):
    """A run over the tissue nowhere clear of a border, between two openings, is a neck up to
    ``longest`` (1 mm) along the curve; longer, it runs beside a border (a recut wandering off
    its wound), and is none."""
    u = np.linspace(0.0, length_mm * MM + 2e-4, 25)
    over = (u > 1e-4 - 1e-12) & (u < length_mm * MM + 1e-4 + 1e-12)
    found = necks(u, over, np.zeros(len(u), dtype=bool), 1.0 * MM)
    assert found.tolist() == (over if is_neck else np.zeros(len(u), dtype=bool)).tolist()
