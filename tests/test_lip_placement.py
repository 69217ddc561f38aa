"""warp_cut/cut/lip_placement.py: where a new lip node goes.

Compared against the displacement fields put on the tissue by hand: each side of a straight cut
moved rigidly (apart by 2d, and together by a common c), where the lip must follow its side's
part of the gape and its rest position must not carry the common motion.
"""

import numpy as np
import pytest

from warp_cut import Material, TissueModel
from warp_cut.cut.incision import Incision
from warp_cut.cut.lip_placement import lip_placement
from warp_cut.cut.topology import NodePositions, TopologyEditor

SPACING = 0.002
Y0 = 0.5 * SPACING * np.sqrt(3) / 2  # between two node rows


def straight_incision() -> Incision:
    inc = Incision([-0.006, Y0, 0.0], [0.0, 0.0, 1.0], spacing=SPACING, lip_offset=0.25e-3, tolerance=1e-4)
    for x in np.linspace(-0.005, 0.006, 12):
        inc.extend([x, Y0, 0.0], min_step=1e-4)
    return inc


def moved_apart(model, gape: float, common) -> np.ndarray:
    """Rest positions with the tissue above the cut line moved by +gape in y and the tissue below
    by -gape, both by ``common`` [m]."""
    x = model.points.copy()
    side = np.where(x[:, 1] > Y0, 1.0, -1.0)
    x[:, 1] += side * gape
    return x + np.asarray(common)


@pytest.mark.parametrize("side", [1, -1])
def test_a_lip_of_a_prestressed_sheet_follows_its_side_of_the_gape(side):
    model = TissueModel.from_patch((0.03, 0.02), SPACING, material=Material(residual_stress_model="prestress"))
    inc = straight_incision()
    gape, common = 0.4e-3, np.array([0.1e-3, -0.05e-3, -0.3e-3])
    x = moved_apart(model, gape, common)
    u = 0.5 * inc.length
    current, rest = lip_placement(model, x, inc, u, side)
    point = inc.lip_position(u, side)
    np.testing.assert_allclose(current, point + [0.0, side * gape, 0.0], atol=1e-12)
    np.testing.assert_allclose(rest, point - common, atol=1e-12)
    # the slit's end stays on the curve, where the two sides meet; its rest position as theirs
    end, end_rest = lip_placement(model, x, inc, inc.length, 0)
    np.testing.assert_allclose(end, inc.lip_position(inc.length, 0), atol=1e-12)
    np.testing.assert_allclose(end_rest, end - common, atol=1e-12)


def test_without_prestress_a_lip_goes_on_the_curve():
    model = TissueModel.from_patch((0.03, 0.02), SPACING, material=Material())
    inc = straight_incision()
    x = moved_apart(model, 0.4e-3, [0.0, 0.0, -0.3e-3])
    u = 0.5 * inc.length
    for side in (1, -1, 0):
        current, rest = lip_placement(model, x, inc, u, side)
        np.testing.assert_array_equal(current, inc.lip_position(u, side))
        np.testing.assert_array_equal(rest, current)


def test_a_side_with_no_tissue_near_leaves_the_lip_on_the_curve():
    model = TissueModel.from_patch((0.03, 0.02), SPACING, material=Material(residual_stress_model="prestress"))
    inc = straight_incision()
    model.node_table.kill(np.flatnonzero(model.points[:, 1] > Y0))  # nothing left above the cut
    x = moved_apart(model, 0.4e-3, [0.0, 0.0, 0.0])
    u = 0.5 * inc.length
    current, rest = lip_placement(model, x, inc, u, -1)
    np.testing.assert_array_equal(current, inc.lip_position(u, -1))
    np.testing.assert_array_equal(rest, current)


def test_nodes_an_edit_has_just_made_count_with_their_side():
    """During an edit a lip already made has its position among the edit's own (a
    ``NodePositions`` whose base array is shorter than the model): it counts with its side."""
    model = TissueModel.from_patch((0.03, 0.02), SPACING, material=Material(residual_stress_model="prestress"))
    inc = straight_incision()
    gape = 0.4e-3
    x = moved_apart(model, gape, [0.0, 0.0, 0.0])
    u = 0.5 * inc.length
    alone, _ = lip_placement(model, x, inc, u, 1)  # before the edit made a node
    editor = TopologyEditor(model)
    editor.begin()
    made = int(editor.add_nodes(inc.lip_position(u, 1)[None])[0])
    positions = NodePositions(x)
    positions[made] = inc.lip_position(u, 1) + [0.0, 3 * gape, 0.0]  # moved further than its side
    current, _ = lip_placement(model, positions, inc, u, 1)
    assert current[1] > alone[1] > inc.lip_position(u, 1)[1]
