"""warp_cut/cut/remesh/cut_piece.py: node matching of the band's lips (the paper's Alg. 2), on a hand-built
band beside hand-placed slit nodes."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from warp_cut.cut.remesh.cut_piece import _match_bend_lips, _match_lips
from warp_cut.cut.sweep.slit_band import CUT_BEFORE, TIP, BandPoint, SlitBand
from warp_cut.cut.tolerances import LIP_MATCH

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
