"""warp_cut/cut/sweep/slit_band.py: the band one event's slit takes out of the tissue, as rings of
points of the rest surface.

Compared against: a straight incision along x and an arc, where the lip lines are known
(y = +-lip offset; radius +- lip offset), the band's area from the trapezoids it is made of,
Shapely's validity and orientation of each ring, and hand-placed borders of an earlier wound the
band runs into (where the lip lines meet them, which border nodes the band's end runs through,
and when a meeting snaps onto a node).
"""

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.cut.curve.incision import Incision
from warp_cut.cut.sweep.slit_band import EXTENSION, JUNCTION, START, TIP, plan_band
from warp_cut.cut.tolerances import FIRST_STATION, SNAP

S = 2e-3          # station spacing [m]
W = 1e-3          # lip offset [m]
LENGTH = 0.01     # incision length [m]


def straight(length: float = LENGTH) -> Incision:
    """A straight incision along +x from the origin, normal +z: left (+1) is +y."""
    inc = Incision([0, 0, 0], [0, 0, 1], spacing=S, lip_offset=W, tolerance=1e-6)
    inc.extend([length, 0, 0], 1e-9)
    assert inc.length == pytest.approx(length)
    return inc


def samples(count: int = 101, length: float = LENGTH) -> np.ndarray:
    return np.linspace(0.0, length, count)


def band_of(inc, u, on, *, stations=(0.002, 0.004, 0.006, 0.008), pair=None, pair_u=0.0, start=None,
            start_possible=True, extension=1.5e-3, margin=1e-3, points=None, borders=()):
    return plan_band(inc, u, on, stations=list(stations), pair=pair, pair_u=pair_u, start=start,
                     start_possible=start_possible, extension=extension, margin=margin,
                     points=np.zeros((0, 3)) if points is None else points, borders=borders)


def ring_xy(run) -> np.ndarray:
    return np.array([p.rest[:2] for p in run])


def signed_area(xy: np.ndarray) -> float:
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


# ----------------------------------------------------------------------------- a whole slit

def test_a_slit_from_its_start_to_its_tip_is_one_clockwise_ring_of_lips():
    """All on tissue, the incision's first event: start point, left lips up, tip, right lips
    down; the lips at (u, +-lip offset) exactly; the ring a valid polygon with the band on its
    right (clockwise), of the area of its trapezoids and end triangles."""
    inc = straight()
    u = samples()
    band = band_of(inc, u, np.ones(len(u), bool))
    assert len(band.runs) == 1
    run = band.runs[0]
    assert [(p.station, p.side) for p in run] == [(START, 0), (0, 1), (1, 1), (2, 1), (3, 1), (TIP, 0),
                                                   (3, -1), (2, -1), (1, -1), (0, -1)]
    xy = ring_xy(run)
    expected = [[0, 0]] + [[s, W] for s in band.stations] + [[LENGTH, 0]] + [[s, -W] for s in band.stations[::-1]]
    assert xy == pytest.approx(np.array(expected), abs=1e-9)
    assert all(p.node == -1 for p in run)  # all new points
    polygon = shapely.Polygon(xy)
    assert polygon.is_valid and signed_area(xy) < 0
    s0, sk = band.stations[0], band.stations[-1]
    area = 2 * W * (sk - s0) + W * s0 + W * (LENGTH - sk)  # the middle strip, the start and tip triangles
    assert polygon.area == pytest.approx(area, rel=1e-6)


def test_an_existing_start_node_is_kept_at_the_start():
    inc = straight()
    u = samples()
    run = band_of(inc, u, np.ones(len(u), bool), start=17).runs[0]
    assert run[0].station == START and run[0].node == 17


def test_a_slit_continued_from_its_newest_lip_pair_closes_onto_that_pair():
    """An event continuing the slit from the pair (nodes 3 and 4) at u = 4 mm: the ring begins
    with the pair's two nodes at their own positions, and only stations beyond 4 mm follow."""
    inc = straight()
    points = np.zeros((5, 3))
    points[3], points[4] = [0.004, W * 1.02, 0.0], [0.004, -W * 0.97, 0.0]  # where the pair's nodes really are
    u = samples(61)[24:]  # from u = 4 mm on
    run = band_of(inc, u, np.ones(len(u), bool), stations=(0.006, 0.008), pair=(3, 4), pair_u=0.004,
                  points=points).runs[0]
    assert (run[0].node, run[-1].node) == (3, 4)
    assert run[0].rest == pytest.approx(points[3]) and run[-1].rest == pytest.approx(points[4])
    assert [p.station for p in run[1:-1]] == [0, 1, TIP, 1, 0]
    assert shapely.Polygon(ring_xy(run)).is_valid and signed_area(ring_xy(run)) < 0


def test_a_slit_whose_blade_entered_in_an_opening_reaches_back_into_it():
    """No pair and no start allowed (the blade entered in an earlier wound; its first samples,
    to 2 mm, over the opening, no border near): the ring's back end is two extension points
    ``extension`` behind the first sample on the tissue, at +-lip offset; the run's stations are
    its own, as an incision's first run has: from FIRST_STATION spacings past that sample, one
    a spacing, up to ``margin`` short of the tip (the stations given are for a run going on from
    the slit cut before)."""
    inc = straight()
    u = samples()
    on = u > 2e-3 + 1e-12
    ua = u[on][0]
    band = band_of(inc, u, on, start_possible=False)
    run = band.runs[0]
    assert (run[0].station, run[-1].station) == (EXTENSION, EXTENSION)
    assert ring_xy(run)[[0, -1]] == pytest.approx(np.array([[ua - 1.5e-3, W], [ua - 1.5e-3, -W]]))
    expected = ua + FIRST_STATION * S + S * np.arange(4)
    expected = expected[expected <= LENGTH - 1e-3 + 1e-12]
    assert band.stations == pytest.approx(expected)
    lips = [p for p in run if p.station >= 0]
    assert [p.station for p in lips] == list(range(len(expected))) + list(range(len(expected)))[::-1]
    assert all(p.u > ua + 1e-3 for p in lips)


def test_a_run_from_an_opening_to_the_tip_too_short_for_its_stations_gets_one_lip_pair():
    """From an opening (samples to 8 mm over it) to the tip at 10 mm: its own first station
    would fall FIRST_STATION spacings (1.3 mm) past its first sample, beyond the tip less
    nothing; it gets one halfway between the margin (1 mm) past the opening and the tip, at
    9.6 mm, so the band has width there. (Where both lip lines met an earlier wound's border
    at one node, it had none, and the fill never laid the tip: a stroke crossing a wound at 12
    degrees had its last event refused three times.)"""
    inc = straight()
    u = samples(51)
    on = u > 8e-3 + 1e-12
    ua = u[on][0]
    band = band_of(inc, u, on, start_possible=False)
    run = band.runs[0]
    assert band.stations == pytest.approx([0.5 * (ua + 1e-3 + LENGTH)])
    assert [p.station for p in run] == [EXTENSION, 0, TIP, 0, EXTENSION]
    assert shapely.Polygon(ring_xy(run)).is_valid and signed_area(ring_xy(run)) < 0


# ----------------------------------------------------------------------------- openings

def test_a_slit_over_an_opening_in_the_middle_is_two_runs_that_reach_into_it():
    """Samples from 3.8 to 6 mm over an opening (no border to meet): the first run ends with
    two extension points 1.5 mm past its last sample, the second starts with two 1.5 mm before
    its first; no station within the 1 mm margin of the opening, none inside it."""
    inc = straight()
    u = samples(51)
    on = np.ones(len(u), bool)
    on[20:30] = False  # u = 4.0 .. 5.8 mm
    band = band_of(inc, u, on)
    first, second = band.runs
    ub, ua = u[19], u[30]
    assert [p.station for p in first] == [START, 0, EXTENSION, EXTENSION, 0]
    assert ring_xy(first)[2:4] == pytest.approx(np.array([[ub + 1.5e-3, W], [ub + 1.5e-3, -W]]))
    assert band.stations[:1] == pytest.approx([0.002])  # the given station the first run holds
    assert band.stations[1:] == pytest.approx([ua + FIRST_STATION * S])  # the second run's own
    assert [p.station for p in second] == [EXTENSION, 1, TIP, 1, EXTENSION]
    assert ring_xy(second)[[0, -1]] == pytest.approx(np.array([[ua - 1.5e-3, W], [ua - 1.5e-3, -W]]))
    for run in band.runs:
        assert shapely.Polygon(ring_xy(run)).is_valid and signed_area(ring_xy(run)) < 0
        for p in run:
            if p.station >= 0:
                assert not (ub - 1e-3 < p.u < ua + 1e-3)


def earlier_wound():
    """Two borders of an earlier wound across the incision: nodes 0-2 on x = 4.5 mm at
    y = 2.5, 0, -2.5 mm, nodes 3-6 on x = 5.5 mm at y = 3, 1.2, -1.2, -3 mm; (points, border
    edges)."""
    points = np.array([[4.5e-3, 2.5e-3, 0], [4.5e-3, 0, 0], [4.5e-3, -2.5e-3, 0],
                       [5.5e-3, 3e-3, 0], [5.5e-3, 1.2e-3, 0], [5.5e-3, -1.2e-3, 0], [5.5e-3, -3e-3, 0]])
    return points, [(0, 1), (1, 2), (3, 4), (4, 5), (5, 6)]


def test_a_slit_crossing_an_earlier_wound_meets_its_borders_without_a_sliver():
    """The slit crosses an earlier wound between x = 4.5 and 5.5 mm (its samples from 3.2 to
    6.8 mm are not in the tissue). The first run's lip lines meet the near border at
    (4.5, +-1) mm, away from its nodes (more than SNAP spacings), and the band's end runs
    along the border through node 1 between them; the second run's meet the far border at
    (5.5, +-1) mm, within SNAP spacings of nodes 4 and 5: the band starts and ends on those
    nodes, so no tiny edge is left beside them."""
    points, borders = earlier_wound()
    inc = straight()
    u = samples(51)
    on = (u < 3.3e-3) | (u > 6.7e-3)
    band = band_of(inc, u, on, points=points, borders=borders)
    first, second = band.runs
    assert [p.station for p in first] == [START, 0, JUNCTION, JUNCTION, JUNCTION, 0]  # the end along the border
    meets = [p for p in first if p.station == JUNCTION]
    assert [(p.side, p.node) for p in meets] == [(1, -1), (0, 1), (-1, -1)]
    assert ring_xy(meets) == pytest.approx(np.array([[4.5e-3, W], [4.5e-3, 0.0], [4.5e-3, -W]]), abs=1e-12)
    for meet in ([4.5e-3, W, 0], [4.5e-3, -W, 0]):  # too far from the near border's nodes to snap
        assert np.linalg.norm(points[:3] - meet, axis=1).min() > SNAP * S
    start = [p for p in second if p.station == JUNCTION]
    assert [(p.side, p.node) for p in start] == [(1, 4), (-1, 5)]
    assert abs(points[4, 1] - W) <= SNAP * S
    assert (second[0].node, second[-1].node) == (4, 5)
    for run in band.runs:
        xy = ring_xy(run)
        assert shapely.Polygon(xy).is_valid and signed_area(xy) < 0
    # the band and the wound between the borders leave no tissue between them on the slit's line
    wound = shapely.box(4.5e-3, -3e-3, 5.5e-3, 3e-3)
    slit = shapely.union_all([shapely.Polygon(ring_xy(r)) for r in band.runs] + [wound])
    assert slit.contains(shapely.LineString([[0.1e-3, 0], [LENGTH - 0.1e-3, 0]]))


def test_a_lip_line_meets_the_nearer_of_two_borders_close_together():
    """Two borders 0.03 mm apart (x = 4.52 and 4.55 mm, within one step of the lip lines'
    search): the band's end meets the first one the lip lines reach, x = 4.52 mm."""
    points = np.array([[4.52, 2.5, 0], [4.52, 0, 0], [4.52, -2.5, 0],
                       [4.55, 2.5, 0], [4.55, 0, 0], [4.55, -2.5, 0]]) * 1e-3
    inc = straight()
    u = samples(51)
    first = band_of(inc, u, u < 3.3e-3, points=points, borders=[(0, 1), (1, 2), (3, 4), (4, 5)]).runs[0]
    meets = [p for p in first if p.station == JUNCTION]
    assert ring_xy(meets) == pytest.approx(np.array([[4.52e-3, W], [4.52e-3, 0.0], [4.52e-3, -W]]), abs=1e-12)
    assert meets[1].node == 1


@pytest.mark.parametrize("lip_offset", [1e-4, 1e-3])
def test_a_slit_from_its_start_into_an_opening_too_short_for_its_stations_gets_one_lip_pair(lip_offset):
    """A slit from its start into an opening 3 mm on (border x = 3 mm; the last sample on the
    tissue at 2.8 mm) where no station falls due (the next one is further on): one station
    halfway, at 1.4 mm (no nearer the opening than the 1 mm margin), its lips at +-lip offset,
    then the lip lines meet the border. Without it the band was a wedge from the start
    to the border (with a 0.1 mm lip offset both lip lines met the border at one node, a band
    with no area, and a later stroke starting 3 mm from an earlier wound opened none of it)."""
    points = np.array([[3.0, 3.0, 0], [3.0, 0.5, 0], [3.0, -3.0, 0]]) * 1e-3
    inc = Incision([0, 0, 0], [0, 0, 1], spacing=S, lip_offset=lip_offset, tolerance=1e-6)
    inc.extend([LENGTH, 0, 0], 1e-9)
    u = samples(51)
    band = band_of(inc, u, u < 2.9e-3, stations=(0.004,), points=points, borders=[(0, 1), (1, 2)])
    assert len(band.runs) == 1
    run = band.runs[0]
    assert band.stations == pytest.approx([1.4e-3])
    assert run[0].station == START and [p.station for p in run[1:]].count(0) == 2
    lips = {p.side: p.rest for p in run if p.station == 0}
    assert lips[1] == pytest.approx([1.4e-3, lip_offset, 0.0]) and lips[-1] == pytest.approx([1.4e-3, -lip_offset, 0.0])
    assert {p.station for p in run[1:] if p.station != 0} == {JUNCTION}
    assert shapely.Polygon(ring_xy(run)).area > 0.0


@pytest.mark.parametrize("lip_offset, kept", [(1e-4, False), (1e-3, True)])
def test_a_pairless_wedge_from_the_start_sharper_than_the_smallest_angle_is_left(lip_offset, kept):
    """A slit from its start into an opening 1.5 mm on (border x = 1.5 mm), shorter than the
    margin (1 mm) and the first station together: no lip pair fits, and the band is a wedge
    from the start to the border. With a 0.1 mm lip offset its angle at the start is under
    MIN_ANGLE_DEG: no fill has a good triangle there, and the run is left (no band); with
    1 mm it is the wedge."""
    points = np.array([[1.5, 3.0, 0], [1.5, 1.5, 0], [1.5, -3.0, 0]]) * 1e-3
    inc = Incision([0, 0, 0], [0, 0, 1], spacing=S, lip_offset=lip_offset, tolerance=1e-6)
    inc.extend([LENGTH, 0, 0], 1e-9)
    u = samples(101)
    band = band_of(inc, u, u < 0.95e-3, stations=(), points=points, borders=[(0, 1), (1, 2)])
    assert len(band.runs) == (1 if kept else 0)
    if kept:
        stations = [p.station for p in band.runs[0]]
        assert stations[0] == START and len(stations) >= 3 and set(stations[1:]) == {JUNCTION}


def earlier_slit(tip_y: float):
    """An earlier slit across the incision's path from above, its tip (node 3) at (5, tip_y) mm:
    its borders run down x = 4.8 mm (nodes 0-2) and up x = 5.2 mm (nodes 4-6), the last
    border nodes 0.8 mm above the tip; (points, border edges)."""
    points = np.array([[4.8, 6, 0], [4.8, 3, 0], [4.8, tip_y + 0.8, 0], [5.0, tip_y, 0],
                       [5.2, tip_y + 0.8, 0], [5.2, 3, 0], [5.2, 6, 0]]) * 1e-3
    return points, [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (5, 6)]


def test_a_lip_line_passing_the_tip_of_an_earlier_slit_closes_the_band_on_that_tip():
    """The incision passes 0.4 mm below an earlier slit's tip: its left lip line (y = 1 mm)
    crosses the slit's borders 0.2 mm from nodes 2 and 4 (snapped onto them), its right lip
    line (y = -1 mm) crosses nothing but passes the tip 1.4 mm away (within the extension):
    each band's end runs from the snapped node to the tip node, so the new slit opens into the
    old one through its tip. With the tip 3 mm above the line the right lip line passes nothing
    within reach: the bands just reach into the opening."""
    points, borders = earlier_slit(0.4)
    inc = straight()
    u = samples(51)
    on = (u < 3.4e-3) | (u > 6.6e-3)
    first, second = band_of(inc, u, on, points=points, borders=borders).runs
    assert [(p.station, p.node) for p in first[-3:]] == [(JUNCTION, 2), (JUNCTION, 3), (0, -1)]
    assert [(p.station, p.node) for p in second[:1] + second[-1:]] == [(JUNCTION, 4), (JUNCTION, 3)]
    assert first[-2].rest == pytest.approx(points[3]) and second[-1].side == -1
    for run in (first, second):
        assert shapely.Polygon(ring_xy(run)).is_valid and signed_area(ring_xy(run)) < 0
    points, borders = earlier_slit(3.0)
    first, second = band_of(inc, u, on, points=points, borders=borders).runs
    assert [p.station for p in first[-3:]] == [EXTENSION, EXTENSION, 0]
    assert [p.station for p in second[:1] + second[-1:]] == [EXTENSION, EXTENSION]


def test_a_lip_line_that_meets_no_border_within_reach_goes_on_into_the_opening():
    """The border lies 6 mm past the run's end, beyond three extensions (4.5 mm): extension
    points, as with no border at all."""
    points = np.array([[9.5e-3, 3e-3, 0], [9.5e-3, -3e-3, 0]])
    inc = straight(0.016)
    u = samples(81, 0.016)
    on = u < 3.5e-3
    first = band_of(inc, u, on, points=points, borders=[(0, 1)]).runs[0]
    assert [p.station for p in first[-3:]] == [EXTENSION, EXTENSION, 0]


# ----------------------------------------------------------------------------- a curved slit

def test_the_lips_of_an_arc_lie_at_its_radius_plus_and_minus_the_lip_offset():
    """A quarter circle of radius 10 mm turning left: left lips at 9 mm from its centre, right
    lips at 11 mm, every station's lips on the radius through its curve point."""
    radius = 0.01
    angles = np.linspace(0, np.pi / 2, 40)
    path = np.column_stack([radius * np.sin(angles), radius * (1 - np.cos(angles)), np.zeros_like(angles)])
    inc = Incision(path[0], [0, 0, 1], spacing=S, lip_offset=W, tolerance=1e-7)
    for p in path[1:]:
        inc.extend(p, 1e-9)
    u = np.linspace(0, inc.length, 200)
    stations = list(np.arange(1, int(inc.length / S)) * S)
    run = band_of(inc, u, np.ones(len(u), bool), stations=stations).runs[0]
    centre = np.array([0.0, radius])
    for p in run:
        if p.station >= 0:
            r = np.linalg.norm(p.rest[:2] - centre)
            assert r == pytest.approx(radius - p.side * W, abs=2e-6)
            radial = inc.point_at(p.u)[0] - [*centre, 0.0]
            to_lip = p.rest - [*centre, 0.0]
            sine = np.linalg.norm(np.cross(radial, to_lip)) / np.linalg.norm(radial) / np.linalg.norm(to_lip)
            assert sine < 2e-3  # on the radius through the curve point (to the chords' turn)
    assert shapely.Polygon(ring_xy(run)).is_valid and signed_area(ring_xy(run)) < 0


# ----------------------------------------------------------------------------- properties

@settings(max_examples=50, deadline=None)
@given(st.lists(st.booleans(), min_size=41, max_size=41), st.floats(0.5e-3, 1.5e-3), st.floats(0.2e-3, 1e-3))
def test_every_run_is_a_clockwise_ring_of_paired_lips_away_from_the_openings(on, margin, extension):
    """Any pattern of samples on and off the tissue (no border near): one ring per run of
    samples on it (but a lone sample with an opening on either side, or at the start where no
    slit may start: no length of tissue to open), each valid and clockwise when it has an
    area; every lip at +-lip offset on its side, each station in a run with both lips, left
    lips going up and right lips coming back down; no station within the margin of an opening
    nor outside its run."""
    on = np.array(on)
    inc = straight()
    u = samples(41)
    stations = [0.002, 0.004, 0.006, 0.008]
    band = band_of(inc, u, on, stations=stations, margin=margin, extension=extension, start_possible=False)
    runs = []
    for first in np.flatnonzero(on & ~np.concatenate([[False], on[:-1]])):
        last = first + np.argmin(np.concatenate([on[first:], [False]])) - 1
        if not (first == last and first < len(u) - 1):
            runs.append((first, last))
    assert len(band.runs) == len(runs)
    for run, (first, last) in zip(band.runs, runs):
        lips = [p for p in run if p.station >= 0]
        for p in lips:
            assert p.rest[1] == pytest.approx(p.side * W, abs=1e-9) and p.rest[0] == pytest.approx(p.u, abs=1e-9)
            assert u[first] + margin - 1e-12 < p.u
            if last < len(u) - 1:
                assert p.u <= u[last] - margin + 1e-12
        left = [p.station for p in lips if p.side == 1]
        right = [p.station for p in lips if p.side == -1]
        assert left == sorted(left) and right == sorted(right, reverse=True) and sorted(left) == sorted(right)
        xy = ring_xy(run)
        if abs(signed_area(xy)) > 1e-12:
            assert shapely.Polygon(xy).is_valid and signed_area(xy) < 0


# ----------------------------------------------------------------------------- waiting past an opening

def test_a_run_past_an_opening_too_short_for_a_lip_pair_waits():
    """samples_to_cut: an event cuts all its samples, except that a last run which comes from an
    opening and reaches the tip shorter than ``least`` is left for a later event (the cut stops
    at the last sample over the opening); a run that begins the piece, is long enough, or ends
    in an opening is cut."""
    from warp_cut.cut.sweep.slit_band import samples_to_cut

    u = samples(51)  # 0.2 mm apart
    on = np.ones(len(u), bool)
    assert samples_to_cut(u, on, 3e-3) == len(u)           # one run from the piece's start
    on[10:30] = False                                       # an opening from 2 to 5.8 mm
    assert samples_to_cut(u, on, 3e-3) == len(u)           # past it 4 mm of tissue: long enough
    assert samples_to_cut(u, on, 4.1e-3) == 30              # not enough: stop before the run
    on[45:] = False                                         # the tip in an opening: no tip run
    assert samples_to_cut(u, on, 4.1e-3) == len(u)
    assert samples_to_cut(u, np.zeros(len(u), bool), 1e-3) == len(u)  # nothing on the tissue
