"""warp_cut/cut/sweep/piece.py: which piece of an incision's rest curve one event cuts, and when it
waits.

Compared against: a hand-built flat grid of 1 mm squares (12 x 12 nodes) with an opening
(columns 6-7 of row 2: x 6-8 mm, y 2-3 mm), an incision along y = 2.6 mm from x = 1 mm, and
the nodes near a segment found here by brute force, where which samples lie on the tissue and
where the opening begins are known by construction.
"""

import numpy as np
import pytest
from conftest import grid_without

from warp_cut.cut.curve.incision import Incision
from warp_cut.cut.sweep.piece import piece_to_cut
from warp_cut.cut.tolerances import MIN_ADVANCE
from warp_cut.sim.control import Tool

MM = 1e-3
Y = 2.6 * MM


def grid():
    """12 x 12 nodes 1 mm apart, the cells at row 2, columns 6-7 left out (an opening)."""
    return grid_without({(2, 6), (2, 7)}, n=12)


def nodes_near(model):
    """Live nodes whose rest position lies within ``radius`` of the segment a-b (brute force)."""
    def near(a, b, radius):
        ab = b - a
        t = np.clip((model.points - a) @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)
        d = np.linalg.norm(a + t[:, None] * ab - model.points, axis=1)
        return np.flatnonzero((d <= radius) & model.active)
    return near


def incision(to_x_mm: float, lip_offset_mm: float = 0.1) -> Incision:
    """A straight incision along y = 2.6 mm from x = 1 mm to ``to_x_mm``."""
    inc = Incision([1 * MM, Y, 0], [0, 0, 1], spacing=1 * MM, lip_offset=lip_offset_mm * MM, tolerance=1e-6)
    inc.extend([to_x_mm * MM, Y, 0], 1e-9)
    inc.starts_on_tissue = True
    return inc


TOOL = Tool([0.0, 0.0, 1.0e-3], [0.0, 0.0, 2.0e-3], 0.2e-3)


def test_a_piece_on_the_tissue_is_sampled_every_tenth_of_a_spacing():
    """From the start to 4 mm along (x 1-5 mm, all on the tissue, clear of the opening by more
    than the edge clearance): samples a tenth of a spacing apart from 0 to 4 mm, every one on
    the tissue, none beside an opening, the live nodes near among those found."""
    model = grid()
    inc = incision(5.0)
    piece = piece_to_cut(model, nodes_near(model), inc, TOOL, 4.0 * MM, final=False)
    assert piece is not None
    assert piece.u[0] == 0.0 and piece.u[-1] == pytest.approx(4.0 * MM)
    assert np.diff(piece.u).max() <= 0.1 * MM + 1e-12
    assert piece.points[:, 1] == pytest.approx(np.full(len(piece.u), Y))
    assert piece.on_tissue.all() and not piece.beside.mask.any()
    assert set(piece.near.tolist()) <= set(np.flatnonzero(model.active).tolist())


def test_a_piece_shorter_than_the_least_advance_waits():
    model = grid()
    inc = incision(5.0)
    assert piece_to_cut(model, nodes_near(model), inc, TOOL, 0.9 * MIN_ADVANCE * MM, final=True) is None


def test_a_tip_in_an_opening_waits_for_the_blade_unless_the_incision_ends():
    """To 6 mm along (x 7 mm, inside the opening): while the blade is in the skin the event
    waits; the incision's last cut (the blade gone) takes the piece, its samples from x = 6 mm
    less the edge clearance over the opening."""
    model = grid()
    inc = incision(9.0)
    assert piece_to_cut(model, nodes_near(model), inc, TOOL, 6.0 * MM, final=False) is None
    piece = piece_to_cut(model, nodes_near(model), inc, None, 6.0 * MM, final=True)
    assert piece is not None and piece.on_tissue[0] and not piece.on_tissue[-1]
    x = piece.points[:, 0]
    assert not piece.on_tissue[x > 6.0 * MM].any()


def test_a_piece_all_over_an_opening_cuts_nothing_and_the_cut_point_moves_past_it():
    """A slit cut to x = 6.2 mm (inside the opening, cut point there); the next piece, to
    x = 7.8 mm, lies all in the opening: nothing to cut, and the cut point moves to its end."""
    model = grid()
    inc = incision(9.0)
    inc.cut_point = np.array([6.2 * MM, Y, 0.0])
    inc.station_u, inc.left, inc.right = [1.0 * MM], [0], [1]  # a standing lip pair (live nodes)
    assert piece_to_cut(model, nodes_near(model), inc, None, 6.8 * MM, final=True) is None
    assert inc.cut_point == pytest.approx([7.8 * MM, Y, 0.0])


def two_openings():
    """12 x 12 nodes 1 mm apart, cells at row 2, columns 5 and 7 left out: two openings (x 5-6
    and 7-8 mm, y 2-3 mm) with a neck of tissue 1 mm wide between them (x 6-7 mm)."""
    return grid_without({(2, 5), (2, 7)}, n=12)


def test_a_neck_between_two_openings_narrower_than_twice_the_edge_clearance_is_cut():
    """Lip offset 0.25 mm: edge clearance 0.55 mm (+ 0.3 spacing), more than half the neck's
    1 mm, so no sample of the neck lies clear of its borders. A piece from x = 4.5 to 9.5 mm
    (tip clear of the second opening) takes the neck's samples (x 6-7 mm) as on the tissue,
    marked ``necks``; those over the openings stay off it."""
    model = two_openings()
    inc = incision(11.0, lip_offset_mm=0.25)
    inc.cut_point = np.array([4.5 * MM, Y, 0.0])
    inc.station_u, inc.left, inc.right = [1.0 * MM], [0], [1]  # a standing lip pair (live nodes)
    piece = piece_to_cut(model, nodes_near(model), inc, TOOL, 8.5 * MM, final=False)
    assert piece is not None
    x = piece.points[:, 0]
    in_neck = (x >= 6.0 * MM - 1e-9) & (x <= 7.0 * MM + 1e-9)
    assert piece.necks.tolist() == in_neck.tolist()
    assert piece.on_tissue[in_neck].all()
    assert not piece.on_tissue[((x > 5.0 * MM) & (x < 6.0 * MM)) | ((x > 7.0 * MM) & (x < 8.0 * MM))].any()


def test_a_piece_with_nothing_to_cut_moves_the_cut_point_only_to_the_tissue_it_ends_on():
    """The slit ends in the first opening (cut point x 5.5 mm); a piece to x = 6.5 mm (into the
    neck, no sample of which lies clear of its borders) cuts nothing. The cut point moves to
    the last sample over the opening, before x = 6 mm, not into the neck: the next piece holds
    the whole neck and sees it between the two openings."""
    model = two_openings()
    inc = incision(11.0, lip_offset_mm=0.25)
    inc.cut_point = np.array([5.5 * MM, Y, 0.0])
    inc.station_u, inc.left, inc.right = [1.0 * MM], [0], [1]
    assert piece_to_cut(model, nodes_near(model), inc, None, 5.5 * MM, final=False) is None
    assert 5.5 * MM < inc.cut_point[0] < 6.0 * MM
