"""warp_cut/cut/sweep/event_band.py: the band one event takes out of the tissue, before the fill.

Compared against: a straight incision along x with an old slit end (a wedge from its newest lip
pair to an old tip cut along a curve 0.15 mm to one side), where the lips of the next station
are known (y = +-lip offset) and the wedge's edges are straight lines.
"""

import numpy as np
import pytest
import shapely

from warp_cut.cut.chart import RegionChart
from warp_cut.cut.curve.incision import Incision
from warp_cut.cut.sweep.event_band import clear_of_old_tip
from warp_cut.cut.sweep.slit_band import CUT_BEFORE, TIP, BandPoint, SlitBand

MM = 1e-3
W = 0.25 * MM  # lip offset


def incision() -> Incision:
    inc = Incision([0, 0, 0], [0, 0, 1], spacing=2 * MM, lip_offset=W, tolerance=1e-6)
    inc.extend([10 * MM, 0, 0], 1e-9)
    return inc


def point(x, y, station, side=0, u=0.0, node=-1) -> BandPoint:
    return BandPoint(np.array([x, y, 0.0]) * MM, side, station, u * MM, node)


def old_end() -> list:
    """The slit cut before, past its pair (nodes 1, 2 at x = 4 mm): round an old tip at
    (7, -0.15) mm."""
    return [point(4, 0.25, CUT_BEFORE, node=1), point(7, -0.15, CUT_BEFORE, node=3),
            point(4, -0.25, CUT_BEFORE, node=2)]


def band_with_station_at_6mm() -> tuple[SlitBand, list]:
    run = [point(4, 0.25, CUT_BEFORE, 1, 4, node=1), point(6, 0.25, 0, 1, 6), point(9, 0, TIP, 0, 9),
           point(6, -0.25, 0, -1, 6), point(4, -0.25, CUT_BEFORE, -1, 4, node=2)]
    old = old_end()
    return SlitBand(runs=[run, old], stations=[6 * MM]), old


CHART = RegionChart([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])


def test_a_lip_beside_the_old_slit_end_moves_out_across_the_curve():
    """The right lip at (6, -0.25) mm lies 0.07 mm from the old end's lower edge (y = -0.183 mm
    there): with a 0.2 mm margin it moves along -y, by whole tenths of a lip offset, to the
    first place 0.2 mm clear of the old end; the left lip, 0.27 mm clear, and every other point
    stay where they were."""
    band, old = band_with_station_at_6mm()
    before = [p.rest.copy() for p in band.runs[0]]
    clear_of_old_tip(band, old, incision(), CHART, 0.2 * MM)
    run = band.runs[0]
    opening = shapely.Polygon([p.rest[:2] for p in old]).buffer(0.2 * MM)
    right = run[3]
    assert (right.station, right.side) == (0, -1)
    moved = before[3] - right.rest
    assert moved[0] == pytest.approx(0.0) and moved[2] == pytest.approx(0.0)
    assert 0.0 < moved[1] <= W + 1e-12
    assert round(moved[1] / (0.1 * W), 6) == pytest.approx(round(moved[1] / (0.1 * W)))
    assert not opening.contains(shapely.Point(right.rest[:2]))
    assert opening.contains(shapely.Point((right.rest + [0, 0.1 * W, 0])[:2]))  # the first clear place
    for k in (0, 1, 2, 4):
        assert run[k].rest == pytest.approx(before[k])
    assert band.runs[1] is old and len(run) == 5


def test_a_lip_that_cannot_clear_the_old_end_within_a_lip_offset_stays():
    """With a 1 mm margin no place within a lip offset is clear: the lips stay (the fill then
    refuses the slit, and a later event tries again)."""
    band, old = band_with_station_at_6mm()
    before = [p.rest.copy() for p in band.runs[0]]
    clear_of_old_tip(band, old, incision(), CHART, 1.0 * MM)
    assert all(np.array_equal(p.rest, b) for p, b in zip(band.runs[0], before))
