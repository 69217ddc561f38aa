"""warp_cut/cut/remesh/cut_piece.py: node matching of the band's lips (the paper's Alg. 2), on a hand-built
band beside hand-placed slit nodes; the fill's refusals (``_fill``), on hand-made layouts."""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest

import warp_cut.cut.remesh.cut_piece as cut_piece
from warp_cut.cut.remesh.cut_piece import _fill, _match_bend_lips, _match_lips
from warp_cut.cut.remesh.fill import Fill
from warp_cut.cut.remesh.layout import Layout, NewPoint, Refusal, SlitDoesNotFit
from warp_cut.cut.sweep.slit_band import CUT_BEFORE, TIP, BandPoint, SlitBand
from warp_cut.cut.tolerances import LIP_MATCH, MAX_GROWTH, MIN_ANGLE_DEG

S = 2e-3


def model_with(points, active=None) -> SimpleNamespace:
    """The two arrays ``_match_lips`` reads: rest positions (n, 3) [m] and which nodes live."""
    points = np.asarray(points, dtype=float)
    return SimpleNamespace(points=points, active=np.ones(len(points), bool) if active is None else np.asarray(active))


def lip(x, y, side, station) -> BandPoint:
    return BandPoint(np.array([x, y, 0.0]), side, station, x)


def band() -> SlitBand:
    """A run from a pair (nodes 0, 1) with lips at x = 2 mm (station 0) to the tip at 3 mm."""
    pair_left = BandPoint(np.array([0.0, 2.5e-4, 0.0]), 1, CUT_BEFORE, 0.0, 0)
    pair_right = BandPoint(np.array([0.0, -2.5e-4, 0.0]), -1, CUT_BEFORE, 0.0, 1)
    tip = BandPoint(np.array([0.003, 0.0, 0.0]), 0, TIP, 0.003)
    return SlitBand(runs=[[pair_left, lip(0.002, 2.5e-4, 1, 0), tip, lip(0.002, -2.5e-4, -1, 0), pair_right]],
                    stations=[0.002])


def test_a_lip_next_to_a_slit_node_is_that_node_and_the_others_stay_new():
    """Node 2 lies 0.05 s from the left lip: the lip becomes node 2, at its position; node 3, 0.2 s
    from the right lip (beyond the 0.1 s reach), leaves it a new point; the tip and the pair's
    nodes (no lip stations) are never matched."""
    points = [[0.0, 2.5e-4, 0], [0.0, -2.5e-4, 0], [0.002 + 0.05 * S, 2.5e-4, 0], [0.002, -2.5e-4 - 0.2 * S, 0],
              [0.003, 1e-5, 0]]
    b = band()
    _match_lips(b, model_with(points), {2, 3, 4}, 0.1 * S)
    run = b.runs[0]
    assert run[1].node == 2 and run[1].station == 0 and run[1].side == 1
    np.testing.assert_allclose(run[1].rest, points[2])
    assert run[3].node == -1 and run[2].node == -1  # the right lip too far; the tip is no lip
    assert [p.node for p in (run[0], run[4])] == [0, 1]


def test_one_node_stands_in_for_one_lip_and_a_dead_node_for_none():
    """A node within reach of both lips stands in for the first of them met along the run only
    (two lips on one node would be no slit); a deleted node within reach is never matched."""
    points = [[0.0, 2.5e-4, 0], [0.0, -2.5e-4, 0], [0.002, 0.0, 0], [0.002, -2.4e-4, 0]]
    b = band()
    _match_lips(b, model_with(points, active=[True, True, True, False]), {2, 3}, 0.15 * S)
    nodes = [p.node for p in b.runs[0] if p.station == 0]
    assert nodes.count(2) == 1 and 3 not in nodes


def bend_incision(left, right) -> SimpleNamespace:
    """The two lists ``_match_bend_lips`` reads: each station's left and right lip nodes."""
    return SimpleNamespace(left=list(left), right=list(right))


def test_a_lip_at_the_inside_of_a_bend_is_the_earlier_lip_of_its_side():
    """The slit bends right after its pair (nodes 0, 1): the new right lip lies 0.1 s from the
    pair's right node 1, which it becomes, though the band closes onto that node (the inside
    of the bend collapses onto one node); the left lip, on the outside, stays new."""
    points = [[0.0, 2.5e-4, 0], [0.002 - 0.1 * S, -2.5e-4, 0]]
    b = band()
    assert _match_bend_lips(b, bend_incision([0], [1]), model_with(points), LIP_MATCH * S) == 1
    run = b.runs[0]
    assert (run[3].node, run[3].station, run[3].side) == (1, 0, -1)
    np.testing.assert_allclose(run[3].rest, points[1])
    assert run[1].node == -1


def test_bend_matching_keeps_to_its_side_and_its_reach():
    """An earlier lip of the other side next to a new lip is never that lip (it would close the
    slit: lips across a thin tool's slit lie nearer than ``LIP_MATCH``), one just beyond reach
    leaves the lip new, and a station with no lip on a side (-1) matches nothing."""
    points = [[0.002, 2.5e-4 + 0.1 * S, 0], [0.002 + 1.01 * LIP_MATCH * S, 2.5e-4, 0]]
    b = band()
    assert _match_bend_lips(b, bend_incision([-1, 1], [0, -1]), model_with(points), LIP_MATCH * S) == 0
    assert [p.node for p in b.runs[0] if p.station == 0] == [-1, -1]


# ----------------------------------------------------------------------------- the fill's refusals
SLIVER = Fill(np.array([[0.0, 0.0], [S, 0.0], [0.0, 0.05 * S]]), np.array([[0, 1, 2]]), unrefined=1, input_count=3)
"""One triangle whose smallest angle is 2.9 degrees, which the refinement left (a sharp corner)."""
GOOD = Fill(np.array([[0.0, 0.0], [S, 0.0], [0.5 * S, 0.8 * S]]), np.array([[0, 1, 2]]), input_count=3)


def layout_of(fill: Fill, *, ids=(0, 1, 2), points=(), split=(), fixed=(), band_lips=None) -> Layout:
    """A layout of ``fill`` on node ids ``ids`` (new points < 0: ``points[-1 - v]``), its split and
    fixed outline edges as given, no turns (so no sharp corner to mend)."""
    fill.split_edges = set(split)
    return Layout(list(ids), list(points), fill, None, set(fixed), [], set(), [], None, dict(band_lips or {}), {})


class GrowingRegion:
    """A region that records what it was asked to grow across."""

    def __init__(self):
        self.grown = []

    def grow(self, edges) -> None:
        self.grown.append(set(edges))


def fill_with(monkeypatch, layouts, band=None):
    """``_fill`` with ``lay_out`` giving ``layouts`` in turn (the last one from then on)."""
    made = itertools.chain(layouts, itertools.repeat(layouts[-1]))
    monkeypatch.setattr(cut_piece, "lay_out", lambda *_: next(made))
    region = GrowingRegion()
    inc = SimpleNamespace(spacing=S)
    return region, lambda: _fill(None, inc, region, band or SlitBand(), None, set())


def test_a_fill_left_under_the_smallest_angle_is_refused_not_written(monkeypatch):
    """The refinement left a 2.9 degree triangle (it reports one unrefined) and nothing is left
    to mend: the event is refused (``Refusal.UNDER_ANGLE``); a good fill is taken as it is."""
    assert np.degrees(np.arctan(0.05)) < MIN_ANGLE_DEG
    _, fill = fill_with(monkeypatch, [layout_of(SLIVER)])
    with pytest.raises(SlitDoesNotFit) as refused:
        fill()
    assert refused.value.reason is Refusal.UNDER_ANGLE
    _, fill = fill_with(monkeypatch, [layout_of(GOOD)])
    layout, growth = fill()
    assert layout.fill is GOOD and growth == 0


def test_a_fill_splitting_a_fixed_edge_grows_the_region_then_is_refused(monkeypatch):
    """A refinement that splits an edge the region shares with the mesh outside (a node there
    would sit on the edge of a triangle outside): the region grows across that edge, and a fill
    that still splits one after ``MAX_GROWTH`` growths is refused (``Refusal.SPLITS_OUTLINE``);
    one that stops splitting after a growth is taken, with the growths counted."""
    splitting = layout_of(GOOD, ids=(10, 11, 12), split=[(0, 1)], fixed=[(10, 11)])
    region, fill = fill_with(monkeypatch, [splitting])
    with pytest.raises(SlitDoesNotFit) as refused:
        fill()
    assert refused.value.reason is Refusal.SPLITS_OUTLINE
    assert region.grown == [{(10, 11)}] * MAX_GROWTH
    whole = layout_of(Fill(GOOD.points, GOOD.triangles, input_count=3), ids=(10, 11, 12), fixed=[(10, 11)])
    region, fill = fill_with(monkeypatch, [layout_of(Fill(GOOD.points, GOOD.triangles, input_count=3),
                                                     ids=(10, 11, 12), split=[(0, 1)], fixed=[(10, 11)]), whole])
    layout, growth = fill()
    assert layout is whole and growth == 1 and region.grown == [{(10, 11)}]


def test_a_fill_that_does_not_lay_each_lip_once_is_refused(monkeypatch):
    """The band asks for a lip pair (station 0) and the tip: a fill whose outline holds the tip
    and only the left lip, or the left lip twice, is refused (``Refusal.SLIT_NOT_LAID``); one
    that holds all three once is taken, as is one whose right lip was matched to a node."""
    left, right, tip = lip(0.002, 2.5e-4, 1, 0), lip(0.002, -2.5e-4, -1, 0), BandPoint(np.zeros(3), 0, TIP, 0.003)
    band_ = SlitBand(runs=[[left, tip, right]], stations=[0.002])
    points = [NewPoint(left, np.zeros(2)), NewPoint(tip, np.zeros(2)), NewPoint(right, np.zeros(2)),
              NewPoint(left, np.zeros(2))]
    for ids in ((-1, -2, 0), (-1, -2, -4, -3)):
        _, fill = fill_with(monkeypatch, [layout_of(Fill(GOOD.points, GOOD.triangles, input_count=len(ids)),
                                                    ids=ids, points=points)], band_)
        with pytest.raises(SlitDoesNotFit) as refused:
            fill()
        assert refused.value.reason is Refusal.SLIT_NOT_LAID
    _, fill = fill_with(monkeypatch, [layout_of(GOOD, ids=(-1, -2, -3), points=points)], band_)
    assert fill()[1] == 0
    _, fill = fill_with(monkeypatch, [layout_of(GOOD, ids=(-1, -2, 7), points=points, band_lips={(0, -1): 7})], band_)
    assert fill()[1] == 0


def rest_layout(ids, count: int) -> SimpleNamespace:
    """What ``_check_rest_angles`` reads of a layout: its vertex ids (nodes >= 0) and a fill of
    ``count`` chart points (their chart positions do not matter: the check is at rest) with one
    triangle (0, 1, 2)."""
    return SimpleNamespace(ids=list(ids), fill=SimpleNamespace(points=np.zeros((count, 2)), triangles=[[0, 1, 2]]))


@pytest.mark.parametrize("apex_deg, refused", [(MIN_ANGLE_DEG + 1.0, False), (MIN_ANGLE_DEG - 1.0, True)])
def test_a_fill_under_the_smallest_angle_at_rest_is_refused_whatever_its_chart(apex_deg, refused):
    """An isosceles rest triangle (two nodes and a new point lifted onto the rest surface) with
    its apex 1 deg either side of ``MIN_ANGLE_DEG`` (the base angles, (180 - apex) / 2, are
    about 80 deg: the apex is the smallest): refused (``Refusal.UNDER_ANGLE_AT_REST``) exactly
    when it is under, whatever the chart says."""
    half = np.radians(apex_deg / 2.0)
    model = model_with([[-S * np.sin(half), 0.0, 0.0], [S * np.sin(half), 0.0, 0.0]])
    apex = np.array([[0.0, S * np.cos(half), 0.0]])
    layout = rest_layout([0, 1], 3)
    if refused:
        with pytest.raises(SlitDoesNotFit) as why:
            cut_piece._check_rest_angles(model, layout, [2], apex)
        assert why.value.reason is Refusal.UNDER_ANGLE_AT_REST
    else:
        cut_piece._check_rest_angles(model, layout, [2], apex)
