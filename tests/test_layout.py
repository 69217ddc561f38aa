"""warp_cut/cut/remesh/layout.py on hand-built cases: the sharp corners of the new outline
(``sharp_corners``), the cut across one (``corner_cut``) and the outline loops read back from
GEOS (``_loops``)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.cut.chart import RegionChart
from warp_cut.cut.remesh.layout import (
    NewPoint,
    Turn,
    _corners,
    _inside,
    _loops,
    _merge_crossings,
    corner_cut,
    sharp_corners,
)
from warp_cut.cut.sweep.slit_band import TIP, BandPoint
from warp_cut.cut.tolerances import CORNER_CUT, REFINE_ANGLE_DEG

S = 2e-3


def corner_layout(angle_deg: float, before_len: float, after_len: float, turn: float = 0.3):
    """A layout holding one outline corner, vertex 7 at the origin, its neighbours at the given
    distances [m], the corner ``angle_deg`` wide (the whole figure turned by ``turn`` rad)."""
    a, b = turn, turn + math.radians(angle_deg)
    points = np.array([[0.0, 0.0], [before_len * math.cos(b), before_len * math.sin(b)],
                       [after_len * math.cos(a), after_len * math.sin(a)]])
    return SimpleNamespace(turns=[(7, 0, 1, 2)], fill=SimpleNamespace(points=points))


def interior_angle(at, p, q) -> float:
    """Angle [deg] at ``at`` between the rays to p and q."""
    u, v = np.asarray(p) - at, np.asarray(q) - at
    return math.degrees(math.acos(np.clip(u @ v / (np.linalg.norm(u) * np.linalg.norm(v)), -1.0, 1.0)))


@settings(max_examples=60, deadline=None)
@given(angle=st.floats(3.0, 21.9), before=st.floats(0.2, 6.0), after=st.floats(0.2, 6.0), turn=st.floats(-3.1, 3.1))
def test_a_sharp_corner_is_cut_across_on_its_own_two_edges(angle, before, after, turn):
    layout = corner_layout(angle, before * S, after * S, turn)
    corner, near_before, near_after = layout.fill.points
    end_before, tip, end_after = corner_cut(layout, layout.turns[0], S)
    assert np.array_equal(tip, corner)
    reach = 0.5 * CORNER_CUT * S / math.sin(math.radians(angle) / 2)
    for end, far in ((end_before, near_before), (end_after, near_after)):  # on the edge, as far as it reaches
        edge, along = far - corner, end - corner
        assert abs(edge[0] * along[1] - edge[1] * along[0]) <= 1e-12 * S * S and edge @ along > 0
        assert math.isclose(np.linalg.norm(along), min(reach, np.linalg.norm(edge)), rel_tol=1e-9)
    if min(before, after) * S >= reach:  # room on both edges: a cut CORNER_CUT wide, square to the bisector
        assert math.isclose(np.linalg.norm(end_after - end_before), CORNER_CUT * S, rel_tol=1e-9)
        for end, far, other in ((end_before, near_before, end_after), (end_after, near_after, end_before)):
            assert math.isclose(interior_angle(end, far, other), 90.0 + angle / 2, abs_tol=1e-6)


def test_a_corner_is_cut_where_its_shorter_edge_ends():
    layout = corner_layout(10.0, 0.3 * S, 4.0 * S)
    corner, near_before, _ = layout.fill.points
    end_before, _, end_after = corner_cut(layout, layout.turns[0], S)
    assert np.allclose(end_before, near_before)
    reach = 0.5 * CORNER_CUT * S / math.sin(math.radians(5.0))
    assert math.isclose(np.linalg.norm(end_after - corner), reach, rel_tol=1e-9)


class OneBandPointTable:
    """A vertex table holding nodes 0-2 at three corners of a square and one band point (the tip)
    at its fourth, found within ``tolerance`` [m]."""

    def __init__(self, tolerance: float):
        self.tip = BandPoint(np.array([S, S, 0.0]), 0, TIP, 0.0)
        self.items = [0, 1, 2, self.tip]
        self.xy = np.array([[0.0, 0.0], [S, 0.0], [0.0, S], [S, S]])
        self.tolerance = tolerance

    def get(self, points):
        d = np.linalg.norm(self.xy[None] - np.asarray(points)[:, None], axis=2)
        k = np.argmin(d, axis=1)
        return [self.items[j] if d[i, j] <= self.tolerance else None for i, j in enumerate(k.tolist())]


def test_one_band_point_given_twice_apart_by_rounding_is_one_vertex():
    """GEOS can return a band point twice, a rounding apart (where the band's corner touches the
    tissue's outline). Both copies are that one point: two vertices at one place would make a
    triangle of no area in the fill (a refused event, every event after it again)."""
    tiny = 1e-9 * S
    ring = [(0.0, 0.0), (S, 0.0), (S, S - tiny), (S - tiny, S), (0.0, S)]
    loops, points, matched = _loops([shapely.Polygon(ring)], OneBandPointTable(1e-4 * S), 0.1 * S)
    assert len(points) == 1 and points[0].band.station == TIP
    assert loops == [[0, 1, -1, 2]]
    assert matched == {}


def test_where_a_slit_touches_a_border_at_a_node_the_corners_are_the_tissue_between_edges():
    """A slit's band ending at node 0 on a straight border (the wound along y = 0, tissue above)
    touches it there: the outline passes node 0 twice, along the border (2 -> 0 -> 1) and round
    the band's end (3 -> 0 -> 4). Paired that way, neither corner is sharp; the tissue there is
    two wedges between the border and the band's sides, of 15 and 25 degrees, and those are the
    corners (``sharp_corners`` must see them to mend them)."""
    deg = math.radians
    points = np.array([[0.0, 0.0], [S, 0.0], [-S, 0.0],
                       [S * math.cos(deg(15)), S * math.sin(deg(15))],
                       [S * math.cos(deg(155)), S * math.sin(deg(155))]])
    raw = [Turn(0, 0, 2, 1), Turn(0, 0, 3, 4)]  # border 2 -> 0 -> 1, band 3 -> 0 -> 4
    corners = _corners(raw, points)
    assert sorted((t.before, t.after) for t in corners) == [(2, 4), (3, 1)]
    for _, row, before, after in corners:
        a, b = points[after] - points[row], points[before] - points[row]
        angle = math.degrees(math.atan2(a[0] * b[1] - a[1] * b[0], a @ b)) % 360.0
        assert math.isclose(angle, 15.0 if after == 1 else 25.0, abs_tol=1e-9)
    assert _corners([Turn(5, 0, 1, 2)], points) == [Turn(5, 0, 1, 2)]


def test_corners_under_the_refinement_angle_are_the_sharp_ones_to_mend():
    """Four corners of an outline: 10 and 21 degrees at new points (the fill cannot mend them:
    each comes back with its triangle, to go with the band), 10 degrees at a node of the
    region's outline between two nodes (None: the region takes its fan in), 10 degrees at a
    protected node (a lip of the slit: left alone), and 23 and 90 degrees (the refinement's
    own business)."""
    rows, ids, turns = [], [], []

    def corner(vertex: int, angle_deg: float, at, neighbours: tuple[int, int]):
        k = len(rows)
        a, b = 0.0, math.radians(angle_deg)
        rows.extend([at, (at[0] + S * math.cos(b), at[1] + S * math.sin(b)),
                     (at[0] + S * math.cos(a), at[1] + S * math.sin(a))])
        ids.extend([vertex, *neighbours])
        turns.append(Turn(vertex, k, k + 1, k + 2))

    corner(-1, 10.0, (0.0, 0.0), (-2, -3))
    corner(-4, REFINE_ANGLE_DEG - 1.0, (0.1, 0.0), (5, 6))
    corner(7, 10.0, (0.2, 0.0), (8, 9))
    corner(10, 10.0, (0.3, 0.0), (11, 12))
    corner(-5, REFINE_ANGLE_DEG + 1.0, (0.4, 0.0), (13, 14))
    corner(15, 90.0, (0.5, 0.0), (16, 17))
    layout = SimpleNamespace(turns=turns, ids=ids, fill=SimpleNamespace(points=np.array(rows)))
    found = sharp_corners(layout, protected={10})
    assert [turn.vertex for turn, _ in found] == [-1, -4, 7]
    for turn, wedge in found[:2]:
        assert np.array_equal(wedge, layout.fill.points[[turn.before, turn.row, turn.after]])
    assert found[2][1] is None


def crossing(x: float, y: float) -> NewPoint:
    """A new point where a lip line crosses a border (no band point), at chart (x, y) [m]."""
    return NewPoint(None, np.array([x, y]))


def test_two_crossings_nearer_than_merge_are_one_and_band_points_and_nodes_stay():
    """A loop of nodes 0, 1 and new points -1..-4: two crossings 0.05 S apart (-1, -2), a crossing
    0.05 S from a lip of the band (-3 next to -4), and the lip. Within a merge of 0.1 S the loop
    keeps one of the two crossings and the lip (a band point is never dropped, nor a node); with
    a merge of 0.01 S nothing goes; a loop never drops under three vertices."""
    lip = NewPoint(BandPoint(np.array([S, 2 * S, 0.0]), 1, 0, 0.0), np.array([S, 2 * S]))
    points = [crossing(S, 0.0), crossing(1.05 * S, 0.0), crossing(S, 1.95 * S), lip]
    loop = [0, -1, -2, 1, -3, -4]
    assert _merge_crossings(loop, points, 0.1 * S) == [0, -2, 1, -4]
    assert _merge_crossings(loop, points, 0.01 * S) == loop
    assert _merge_crossings([-1, -2, 0], points, 0.1 * S) == [-1, -2, 0]


def test_the_fill_keeps_inner_nodes_clear_of_every_pieces_outline():
    """Two square pieces of tissue, 4 S and 2 S a side, apart; nodes inside each, one well in and
    one nearer its outline than ``clear``, and one between them: the fill keeps as inner points
    only the nodes inside a piece and farther than ``clear`` from every piece's outline (a node a
    hair from the outline would make a thin triangle with it)."""
    chart = RegionChart(np.zeros(3), [0.0, 0.0, 1.0])
    squares = [[(0, 0), (4, 0), (4, 4), (0, 4)], [(6, 0), (8, 0), (8, 2), (6, 2)]]
    pieces = [shapely.Polygon(chart.to2d([(S * x, S * y, 0.0) for x, y in square])) for square in squares]
    xy = [(2 * S, 2 * S), (3.95 * S, 2 * S), (7 * S, 1 * S), (6.05 * S, 1 * S), (5 * S, 1 * S)]
    model = SimpleNamespace(points=np.array([(x, y, 0.0) for x, y in xy]))
    assert _inside(pieces, [0, 1, 2, 3, 4], model, chart, 0.1 * S) == [0, 2]
    assert _inside(pieces, [0, 1, 2, 3, 4], model, chart, 0.01 * S) == [0, 1, 2, 3]
