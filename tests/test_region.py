"""warp_cut/cut/sweep/region.py: the swept band's nodes and the region of triangles re-meshed round it,
decided on the rest positions.

Compared against: distances to segments from Shapely (2D) and by hand (3D), the mesh's border
found here from edges used once, the region's outline checked by Green's theorem (its signed
area is the triangles' area exactly when every edge has the region on its left), corner angles
computed here with numpy, and hand-made regions (one triangle, a region at the patch's edge).
"""

import numpy as np
import pytest
import shapely
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from warp_cut import TissueModel
from warp_cut.cut.chart import RegionChart
from warp_cut.cut.sweep.region import Region, distance_to_segments, tissue_segments
from warp_cut.cut.tolerances import ROUND_ANGLE_DEG

SPACING = 0.002


def patch():
    """A flat 12 x 10 mm patch of 2 mm spacing (rows at y = 0, +-1.67, +-3.33, +-5 mm)."""
    return TissueModel.from_patch((0.012, 0.01), SPACING, pinned="none")


def border_of(model) -> set[int]:
    """Nodes on an edge that one live triangle uses (counted here)."""
    count = {}
    for t in model.triangles:
        for k in range(3):
            key = tuple(sorted((int(t[k]), int(t[(k + 1) % 3]))))
            count[key] = count.get(key, 0) + 1
    return {v for e, c in count.items() if c == 1 for v in e}


def triangles_at(model, nodes) -> set[int]:
    corners = model.triangle_table.column("corners")
    return {t for t in range(len(corners)) if model.triangle_table.alive[t] and set(corners[t].tolist()) & set(nodes)}


def corner_angle_sums(model, triangles) -> dict[int, float]:
    """Node -> sum of the angles [deg] of ``triangles`` at it, by the law of cosines."""
    corners, x = model.triangle_table.column("corners"), model.points
    out: dict[int, float] = {}
    for t in triangles:
        c = corners[t]
        for k in range(3):
            u, v = x[c[(k + 1) % 3]] - x[c[k]], x[c[(k + 2) % 3]] - x[c[k]]
            angle = np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1)))
            out[int(c[k])] = out.get(int(c[k]), 0.0) + angle
    return out


# ----------------------------------------------------------------------------- distances

def test_distance_to_segments_by_hand():
    """A segment from (0,0,0) to (2,0,0): (1, 1, 1) is sqrt 2 away (its foot inside),
    (3, 0, 0) is 1 past the end, (1, 0, 0) on it; a zero-length segment is its point; the
    least over two segments is taken; with no segment every distance is infinite."""
    a, b = np.array([[0.0, 0, 0]]), np.array([[2.0, 0, 0]])
    p = np.array([[1.0, 1, 1], [3, 0, 0], [1, 0, 0]])
    assert distance_to_segments(p, a, b) == pytest.approx([np.sqrt(2), 1.0, 0.0])
    assert distance_to_segments(np.array([[1.0, 2, 2]]), np.array([[1.0, 0, 0]]), np.array([[1.0, 0, 0]])) \
        == pytest.approx([np.sqrt(8)])
    two_a, two_b = np.array([[0.0, 0, 0], [0, 5, 0]]), np.array([[2.0, 0, 0], [2, 5, 0]])
    assert distance_to_segments(np.array([[1.0, 4, 0]]), two_a, two_b) == pytest.approx([1.0])
    assert np.all(np.isinf(distance_to_segments(p, np.zeros((0, 3)), np.zeros((0, 3)))))


coordinate = st.integers(-200, 200).map(lambda k: k / 100)  # no subnormal lengths: Shapely calls those empty
xy = st.tuples(coordinate, coordinate)


@settings(max_examples=60, deadline=None)
@given(st.lists(xy, min_size=2, max_size=6), st.lists(xy, min_size=1, max_size=5))
def test_distance_to_a_polyline_matches_shapely(polyline, queries):
    line = np.array([[x, y, 0.0] for x, y in polyline])
    points = np.array([[x, y, 0.0] for x, y in queries])
    got = distance_to_segments(points, line[:-1], line[1:])
    geometry = shapely.LineString(line[:, :2]) if len({tuple(p) for p in polyline}) > 1 \
        else shapely.Point(line[0, :2])
    expected = [geometry.distance(shapely.Point(q)) for q in queries]
    assert got == pytest.approx(expected, abs=1e-12)


def test_tissue_segments_are_those_with_an_end_on_the_tissue():
    """Samples on, off: a segment with at least one end on the tissue is kept (the blade cut
    tissue along it), one between two samples over an opening is not."""
    curve = np.arange(7.0)[:, None] * [1.0, 0.0, 0.0]
    on = np.array([False, False, True, False, False, True, True])
    a, b = tissue_segments(curve, on)
    assert a[:, 0].tolist() == [1, 2, 4, 5] and b[:, 0].tolist() == [2, 3, 5, 6]
    a, b = tissue_segments(curve, np.zeros(7, bool))
    assert a.shape == (0, 3) and b.shape == (0, 3)


# ----------------------------------------------------------------------------- Region.around

def test_the_band_deletes_the_tissue_nodes_within_the_clearance_of_the_cut_part_of_the_curve():
    """A curve along y = 0.3 mm from x = -3 to +5 mm, over tissue from x = -3 to 1 only (its
    samples past x = 1 mm lie over an opening). The nodes deleted are those within 1 mm of the
    cut part's segments (Shapely) that are on no border of the mesh; the region holds every
    triangle at a node within clearance + margin of it."""
    model = patch()
    curve = np.array([[x, 3e-4, 0.0] for x in (-3e-3, -1e-3, 1e-3, 3e-3, 5e-3)])
    on = np.array([True, True, False, False, False])  # the segment 1-2 has an end on the tissue
    clearance, margin = 1e-3, 1e-3
    region = Region.around(model, curve, on, np.arange(model.node_count), clearance, margin)
    cut = shapely.LineString(curve[:3, :2])
    dist = np.array([cut.distance(shapely.Point(p[:2])) for p in model.points])
    border = border_of(model)
    expected = {v for v in np.flatnonzero(dist <= clearance).tolist() if v not in border}
    assert region.deleted == expected and expected
    assert triangles_at(model, np.flatnonzero(dist <= clearance + margin)) <= region.triangles


def test_protected_nodes_stay_and_provisional_nodes_go_however_far():
    """The incision's own lips (protected) are kept even in the band; its provisional nodes
    (an old tip) are deleted even far from the piece, and their triangles join the region."""
    model = patch()
    curve = np.array([[-2e-3, 0.0, 0.0], [2e-3, 0.0, 0.0]])
    near = np.arange(model.node_count)
    swept = Region.around(model, curve, np.ones(2, bool), near, 1e-3, 5e-4).deleted
    keep = min(swept)
    far = int(np.argmin(np.linalg.norm(model.points - [3.9e-3, 3.3e-3, 0.0], axis=1)))
    region = Region.around(model, curve, np.ones(2, bool), near, 1e-3, 5e-4, protected=[keep], provisional=[far])
    assert region.deleted == (swept - {keep}) | {far}
    assert triangles_at(model, [far]) <= region.triangles


def test_a_curve_along_the_patch_edge_deletes_no_border_node():
    """A curve 0.2 mm inside the patch's lower edge with a 2 mm clearance: the row above
    (1.47 mm away) goes, the border nodes 0.2 mm away are left to the slit's band."""
    model = patch()
    curve = np.array([[-4e-3, -5e-3 + 2e-4, 0.0], [4e-3, -5e-3 + 2e-4, 0.0]])
    region = Region.around(model, curve, np.ones(2, bool), np.arange(model.node_count), 2e-3, 5e-4)
    line = shapely.LineString(curve[:, :2])
    dist = np.array([line.distance(shapely.Point(p[:2])) for p in model.points])
    border = border_of(model)
    within = set(np.flatnonzero(dist <= 2e-3).tolist())
    assert within & border and within - border  # both kinds were in the clearance
    assert region.deleted == within - border


def test_a_curve_all_over_an_opening_deletes_nothing():
    model = patch()
    curve = np.array([[-2e-3, 0.0, 0.0], [2e-3, 0.0, 0.0]])
    region = Region.around(model, curve, np.zeros(2, bool), np.arange(model.node_count), 1e-3, 5e-4)
    assert region.deleted == set() and region.triangles == set()


# ----------------------------------------------------------------------------- outline, round, grow, sweep

def outline_signed_area(model, edges) -> float:
    """Green's theorem: half the sum of x_a y_b - x_b y_a over the directed outline edges."""
    x = model.points
    return 0.5 * sum(x[a, 0] * x[b, 1] - x[b, 0] * x[a, 1] for a, b in edges)


def test_the_outline_has_the_region_on_its_left():
    """For a region round a curve: each outline edge is used by one region triangle, in that
    triangle's winding; the outline's loops close (one edge in and one out at each node); and
    the area Green's theorem gives from the directed outline is the triangles' area (it would
    be its negative with the region on the right)."""
    model = patch()
    curve = np.array([[-2e-3, 3e-4, 0.0], [2e-3, 3e-4, 0.0]])
    region = Region.around(model, curve, np.ones(2, bool), np.arange(model.node_count), 1e-3, 5e-4)
    edges = region.outline()
    corners = model.triangle_table.column("corners")
    directed = [(int(c[k]), int(c[(k + 1) % 3])) for t in region.triangles for c in [corners[t]] for k in range(3)]
    for a, b in edges:
        assert directed.count((a, b)) == 1 and (b, a) not in directed
    starts, ends = sorted(a for a, _ in edges), sorted(b for _, b in edges)
    assert starts == ends
    area = sum(model.triangle_areas[np.isin(model.triangle_table.live_slots(), list(region.triangles))])
    assert outline_signed_area(model, edges) == pytest.approx(area, rel=1e-12)


def test_the_outline_of_the_whole_patch_is_its_border():
    model = patch()
    region = Region(model, [], range(model.triangle_count))
    edges = region.outline()
    assert {v for e in edges for v in e} == border_of(model)
    assert outline_signed_area(model, edges) == pytest.approx(0.012 * 0.01)
    assert all(region.on_mesh_border(a, b) for a, b in edges)
    assert region.nodes() == set(range(model.node_count))


def test_a_single_interior_triangle_is_rounded_into_the_fans_of_its_corners():
    """One interior triangle: each corner is a 60-ish deg corner of the region, under
    ROUND_ANGLE_DEG, so round() takes in the three fans; afterwards no outline node off the
    mesh's border is a corner sharper than ROUND_ANGLE_DEG (angles summed here)."""
    model = patch()
    border = border_of(model)
    corners = model.triangle_table.column("corners")
    t = next(t for t in range(model.triangle_count) if not set(corners[t].tolist()) & border
             and not any(set(corners[u].tolist()) & border for u in triangles_at(model, corners[t].tolist())))
    region = Region(model, [], [t])
    assert max(corner_angle_sums(model, [t]).values()) < ROUND_ANGLE_DEG
    region.round()
    assert triangles_at(model, corners[t].tolist()) <= region.triangles
    sums = corner_angle_sums(model, region.triangles)
    touching = {v for u in range(model.triangle_count) for v in corners[u].tolist()
                if set(corners[u].tolist()) & border}
    for a, _ in region.outline():
        if a not in touching:
            assert sums[a] >= ROUND_ANGLE_DEG


def test_regions_round_the_curve_have_no_sharp_corner_off_the_border():
    model = patch()
    curve = np.array([[-1e-3, 1e-3, 0.0], [2e-3, -1e-3, 0.0]])
    region = Region.around(model, curve, np.ones(2, bool), np.arange(model.node_count), 6e-4, 3e-4)
    border = border_of(model)
    corners = model.triangle_table.column("corners")
    near_border = {v for u in range(model.triangle_count) if set(corners[u].tolist()) & border
                   for v in corners[u].tolist()}
    sums = corner_angle_sums(model, region.triangles)
    assert all(sums[a] >= ROUND_ANGLE_DEG for a, _ in region.outline() if a not in near_border)


def test_grow_takes_in_the_triangles_across_the_edges_given():
    model = patch()
    region = Region(model, [], [0])
    a, b = next((a, b) for a, b in region.outline() if not region.on_mesh_border(a, b))
    across = set(model.index.triangles_with_edge(a, b)) - {0}
    region.grow([(a, b)])
    assert region.triangles == {0} | across and len(across) == 1


def test_sweep_takes_fans_and_deletes_only_the_nodes_at_the_border():
    """sweep() adds the fans of the nodes given; a node touching the tissue's border is
    deleted with it (a sharp corner of tissue between the slit and a border), an inner one
    is not."""
    model = patch()
    border = border_of(model)
    inner = int(np.argmin(np.linalg.norm(model.points, axis=1)))
    edge = next(iter(sorted(border)))
    region = Region(model, [], [])
    region.sweep([inner, edge])
    assert region.triangles == triangles_at(model, [inner, edge])
    assert region.deleted == {edge}


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0.2, 1.0), st.floats(0.0, 1.0)), min_size=3, max_size=7))
def test_healed_triangles_cover_the_healed_ring_with_its_own_nodes(radii_and_turns):
    """A ring of patch nodes taken back into the tissue (``Region.healed``; here a star-shaped
    ring round the centre node, convex or not) is covered by triangles of its own nodes: they
    tile it exactly (their union is the ring's polygon and their areas sum to its area), so a
    new node the fill puts inside it gets its rest position from nodes of the ring."""
    model = patch()
    centre = model.points[int(np.argmin(np.linalg.norm(model.points, axis=1)))]
    turns = np.cumsum([t for _, t in radii_and_turns])
    angles = 2.0 * np.pi * turns / (turns[-1] + 1.0)  # increasing, less than a full turn
    ring = []
    for (r, _), a in zip(radii_and_turns, angles):
        target = centre + 5e-3 * r * np.array([np.cos(a), np.sin(a), 0.0])
        v = int(np.argmin(np.linalg.norm(model.points - target, axis=1)))
        if v not in ring:
            ring.append(v)
    assume(len(ring) >= 3)  # else the nodes were too close to make a ring
    polygon = shapely.Polygon(model.points[ring][:, :2])
    assume(polygon.is_valid and polygon.area > 1e-9)  # not collinear, not crossing itself
    region = Region(model, [], [])
    region.healed.append(ring)
    chart = RegionChart.of_triangles(model.points[model.triangles])
    triangles = region.healed_triangles(chart)
    assert set(triangles.ravel().tolist()) <= set(ring)
    pieces = [shapely.Polygon(model.points[t][:, :2]) for t in triangles]
    assert sum(p.area for p in pieces) == pytest.approx(polygon.area, rel=1e-9)
    assert shapely.union_all(pieces).symmetric_difference(polygon).area <= 1e-9 * polygon.area
