"""warp_cut/cut/sweep/beside.py: the strip of tissue between a cut and an opening beside it.

Compared against: a hand-built flat grid of 1 mm squares (5 x 5 cells) with an opening from
(2, 1) to (3, 4) mm (three cells taken out) and a straight incision up the line x = 1.7 mm,
0.3 mm left of the opening: which samples lie beside it, how far across the curve its borders
are, and where the strip's sides lie are known by construction.
"""

import numpy as np
import pytest
from conftest import grid_without

from warp_cut.cut.curve.incision import Incision
from warp_cut.cut.sweep import beside as beside_module
from warp_cut.cut.sweep.beside import Beside, beside_opening, strip_polygons
from warp_cut.cut.sweep.tissue_at_rest import on_tissue_at_rest

MM = 1e-3
EDGE = 0.5 * MM
LIP = 0.1 * MM


def grid_with_a_slot():
    """6 x 6 nodes 1 mm apart, the cells of column 2 in rows 1-3 left out: an opening 1 x 3 mm."""
    return grid_without({(1, 2), (2, 2), (3, 2)})


def incision_up(x_mm: float) -> Incision:
    """A straight incision from (x, 0.2) to (x, 4.8) mm: its left is -x, the opening on its right."""
    inc = Incision(np.array([x_mm * MM, 0.2 * MM, 0.0]), [0, 0, 1], spacing=MM, lip_offset=LIP, tolerance=1e-6)
    for y in np.linspace(1.0, 4.8, 8):
        inc.extend(np.array([x_mm * MM, y * MM, 0.0]), 0.0)
    return inc


def samples(inc: Incision):
    u = np.linspace(0.0, inc.length, 47)  # every 0.1 mm
    model = grid_with_a_slot()
    nodes = np.arange(model.node_count)
    on_tissue = on_tissue_at_rest(model, inc.point_at(u), nodes, EDGE)
    return model, nodes, u, on_tissue


def test_samples_beside_the_opening_and_the_borders_across_them():
    """Along 1 <= y <= 4 mm the opening's edge x = 2 mm is 0.3 mm to the right and its far edge
    x = 3 mm 1.3 mm (within the reach of edge + spacing = 1.5 mm); the tissue's outer edge x = 0
    lies 1.7 mm to the left, out of reach. Below y = 1 mm the opening's corner is nearer than
    the clearance but not across the curve: not beside."""
    inc = incision_up(1.7)
    model, nodes, u, on_tissue = samples(inc)
    beside = beside_opening(model, inc, u, on_tissue, nodes, EDGE)
    y = inc.point_at(u)[:, 1] / MM
    along = (y > 1.0 + 1e-6) & (y < 4.0 - 1e-6)
    ends = (np.abs(y - 1.0) < 1e-6) | (np.abs(y - 4.0) < 1e-6)  # rays through the opening's corners
    assert beside.mask[~ends].tolist() == along[~ends].tolist()
    assert not (beside.mask & on_tissue).any()
    np.testing.assert_allclose(beside.first[1, along], 0.3 * MM, atol=1e-12)
    np.testing.assert_allclose(beside.second[1, along], 1.3 * MM, atol=1e-12)
    assert np.isinf(beside.first[0]).all()
    assert (~on_tissue[(y > 0.5) & (y < 1.0)]).any() and not beside.mask[(y > 0.5) & (y < 1.0)].any()


def test_far_from_every_opening_no_sample_is_beside_one():
    inc = incision_up(0.9)  # 1.1 mm from the opening, 0.9 from the outer edge: clear with 0.5 mm
    model, nodes, u, on_tissue = samples(inc)
    assert on_tissue[5:-5].all()
    assert not beside_opening(model, inc, u, on_tissue, nodes, EDGE).mask.any()


def test_the_strip_reaches_into_the_opening_on_its_side_and_to_the_lip_line_on_the_other():
    """One strip: its right side a quarter spacing into the opening (x = 2.25 mm; half the
    opening's width would be 2.5 mm), its left side on the lip line (x = 1.6 mm) with a vertex
    every spacing or so, from y = 1 to 4 mm."""
    inc = incision_up(1.7)
    model, nodes, u, on_tissue = samples(inc)
    beside = beside_opening(model, inc, u, on_tissue, nodes, EDGE)
    strips = strip_polygons(inc, u, beside, EDGE)
    assert len(strips) == 1
    strip = strips[0] / MM
    right, left = strip[strip[:, 0] > 1.7], strip[strip[:, 0] < 1.7]
    np.testing.assert_allclose(right[:, 0], 2.25, atol=1e-9)
    np.testing.assert_allclose(left[:, 0], 1.6, atol=1e-9)
    assert right[:, 1].min() == pytest.approx(1.0, abs=0.11) and right[:, 1].max() == pytest.approx(4.0, abs=0.11)
    gaps = np.diff(np.sort(left[:, 1]))
    assert len(left) == 2 or gaps.max() <= 1.0 + 1e-9
    assert len(left) < len(right)  # the lip line's vertices become nodes: not one per sample


def test_a_side_with_an_opening_within_the_clearance_on_both_sides_opens_to_both():
    """Between two openings (the first and second borders within the clearance on both sides)
    the strip reaches into both: no lip line is left."""
    count = 5
    first = np.vstack([np.full(count, 0.2 * MM), np.full(count, 0.3 * MM)])
    second = np.vstack([np.full(count, 0.6 * MM), np.full(count, np.inf)])
    inc = incision_up(1.7)
    u = np.linspace(1.0 * MM, 1.4 * MM, count)
    strip = strip_polygons(inc, u, Beside(np.ones(count, bool), first, second), EDGE)[0] / MM
    np.testing.assert_allclose(sorted(set(np.round(strip[:, 0], 9))), [1.7 - 0.2 - 0.2, 1.7 + 0.3 + 0.25])


def test_no_sample_beside_an_opening_no_strip():
    inc = incision_up(1.7)
    assert strip_polygons(inc, np.linspace(0, MM, 5), Beside.none(5), EDGE) == []


def test_a_short_run_beside_an_opening_is_where_a_stroke_meets_it_and_cuts_no_strip(monkeypatch):
    """With a station spacing of 2 mm the 3 mm run beside the opening is shorter than
    ``BESIDE_RUN`` spacings (set to 2 here): the band's ends join the opening as before, no
    strip."""
    monkeypatch.setattr(beside_module, "BESIDE_RUN", 2.0)
    inc = Incision(np.array([1.7 * MM, 0.2 * MM, 0.0]), [0, 0, 1], spacing=2 * MM, lip_offset=LIP, tolerance=1e-6)
    for y in np.linspace(1.0, 4.8, 8):
        inc.extend(np.array([1.7 * MM, y * MM, 0.0]), 0.0)
    model, nodes, u, on_tissue = samples(inc)
    assert not beside_opening(model, inc, u, on_tissue, nodes, EDGE).mask.any()


def test_runs_kept_are_long_and_not_a_moment_out_of_an_opening():
    """Samples 0.1 mm apart, runs of at least 0.5 mm kept: a 0.2 mm run goes; a 0.8 mm run
    between two samples in an opening (a recut wandering off its wound) goes; one with tissue
    on a side, or at the piece's end, stays."""
    from warp_cut.cut.sweep.beside import _strip_runs

    u = np.arange(40) * 0.1 * MM
    mask = np.zeros(40, bool)
    inside = np.ones(40, bool)
    mask[2:5] = True                       # 0.2 mm long: too short
    mask[8:17] = True                      # 0.8 mm, openings on both sides
    inside[7] = inside[17] = False
    mask[20:29] = True                     # 0.8 mm, an opening before, tissue after
    inside[19] = False
    mask[32:] = True                       # 0.7 mm to the piece's end
    inside[31] = False
    kept = _strip_runs(mask, inside, u, 0.5 * MM)
    assert np.flatnonzero(kept).tolist() == list(range(20, 29)) + list(range(32, 40))
