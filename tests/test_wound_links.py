"""warp_cut/cut/wound/links.py: the residual links a cut leaves across its wound, and where they
go when an edit takes one of their nodes.

Compared against: the springs of the uncut patch that cross a line, counted here from their
end points (a node on either side, the crossing between the cut's ends), the link force
sigma_r t L0 of each (E eps_r x thickness x rest length), the station nearest where each spring
crossed (from the crossing's x on a straight incision), nodes nearest a deleted one found with
numpy, and the side of a straight incision each node lies on (the sign of y).
"""

import numpy as np
import pytest
from conftest import DEVICE
from hypothesis import given
from hypothesis import strategies as st

from warp_cut import Material, Simulator, TissueModel
from warp_cut.cut.curve.incision import Incision
from warp_cut.cut.settings import CutSettings
from warp_cut.cut.tolerances import LINK_REACH, LINK_TAKER_MASS
from warp_cut.cut.topology import TopologyEditor
from warp_cut.cut.wound.links import OriginalSprings, carry_links, link_crossed_springs, settle_pending_links

SPACING = 0.002
MATERIAL = Material(density=1000.0, thickness=1e-3, youngs_modulus=2e4, residual_strain=0.1)
SIGMA_T = 2e4 * 0.1 * 1e-3
"""sigma_r x thickness [N/m]: a link's force per metre of its spring's rest length."""


def patch():
    model = TissueModel.from_patch((0.016, 0.012), SPACING, material=MATERIAL)
    return model, TopologyEditor(model)


def between_rows(model) -> float:
    """A height between the two rows of nodes nearest y = 0 (no node on the line)."""
    rows = np.unique(model.points[:, 1].round(9))
    k = np.searchsorted(rows, 0.0, side="right")
    return float(0.5 * (rows[k - 1] + rows[k]))


def node_at(model, x_mm: float, y: float) -> int:
    """The patch node at (x_mm [mm], y [m]) (asserted to be there)."""
    v = int(np.argmin(np.linalg.norm(model.points - [x_mm * 1e-3, y, 0.0], axis=1)))
    assert np.linalg.norm(model.points[v] - [x_mm * 1e-3, y, 0.0]) < 1e-9
    return v


ROWS = (6e-3 / 7, 3 * 6e-3 / 7)
"""Heights [m] of the patch's rows nearest the line y = 0 (0.857 and 2.571 mm; x even at
+0.857 and -2.571 mm, odd at -0.857 and +2.571 mm)."""


def straight_incision(model) -> Incision:
    """An incision along +x on y = 0 (between two rows) from x = -5 to +5 mm, with stations at
    u = 4.2, 6.2, 8.2 mm (no spring crosses halfway between two, nor 1.5 mm from one): left
    lips the nodes at (x, +2.571 mm), x = -1, 1, 3 mm, right lips those at (x - 1 mm, -2.571 mm)."""
    inc = Incision([-0.005, 0.0, 0.0], [0, 0, 1], spacing=SPACING, lip_offset=0.0005, tolerance=1e-6)
    inc.extend([0.005, 0.0, 0.0], 1e-9)
    for x in (-1, 1, 3):
        inc.add_station((x + 5.2) * 1e-3, node_at(model, x, ROWS[1]), node_at(model, x - 1, -ROWS[1]))
    return inc


def crossing_springs(model, y: float, x_from: float, x_to: float):
    """Springs of ``model`` with a node on either side of the line at height y, crossing it at
    x in [x_from, x_to]: (spring rows, crossing x)."""
    p = model.points[model.springs]
    below = (p[:, 0, 1] - y) * (p[:, 1, 1] - y) < 0
    t = (y - p[:, 0, 1]) / np.where(below, p[:, 1, 1] - p[:, 0, 1], 1.0)
    at = p[:, 0, 0] + t * (p[:, 1, 0] - p[:, 0, 0])
    rows = np.flatnonzero(below & (at >= x_from) & (at <= x_to))
    return rows, at[rows]


def pairs_of(model) -> list[tuple[int, int]]:
    return sorted(tuple(sorted(map(int, pair))) for pair in model.links)


# ----------------------------------------------------------------------------- OriginalSprings

def test_original_springs_keep_the_tissue_as_built_and_find_every_spring_in_a_box():
    """The springs' pairs, rest lengths and rest end points are copies (an edit does not change
    them); a box query returns every spring whose midpoint lies in the box, and nothing farther
    than two grid cells beyond it."""
    model, editor = patch()
    springs = OriginalSprings(model)
    pairs, lengths = model.springs.copy(), model.rest_lengths.copy()
    editor.begin()
    editor.delete_nodes([int(np.argmin(np.linalg.norm(model.points, axis=1)))])
    editor.finish()
    assert np.array_equal(springs.pairs, pairs) and np.array_equal(springs.rest_lengths, lengths)
    mid = 0.5 * (springs.a + springs.b)
    lo, hi = np.array([-0.003, -0.001, -1.0]), np.array([0.001, 0.002, 1.0])
    found = set(springs.near(lo, hi).tolist())
    inside = set(np.flatnonzero(np.all((mid >= lo) & (mid <= hi), axis=1)).tolist())
    assert inside and inside <= found
    reach = 2 * springs.cell
    assert np.all(np.all((mid[list(found)] >= lo - reach) & (mid[list(found)] <= hi + reach), axis=1))


# ----------------------------------------------------------------------------- link_crossed_springs

def test_every_spring_the_piece_crosses_with_both_nodes_alive_is_linked_between_them():
    """A piece of curve between two rows, from x = -5 to 5 mm, nothing deleted: each spring
    crossing it between its ends (counted here) gets one link between its own two nodes, of
    sigma_r t L0; linking the piece again with the same record makes none."""
    model, editor = patch()
    springs = OriginalSprings(model)
    y = between_rows(model)
    inc = straight_incision(model)
    rows, _ = crossing_springs(model, y, -0.005, 0.005)
    seen: set = set()
    editor.begin()
    link_crossed_springs(editor, inc, springs, inc.point_at(np.linspace(0, inc.length, 21)), seen)
    editor.finish()
    assert len(rows) > 0 and pairs_of(model) == sorted(tuple(sorted(model.springs[r])) for r in rows)
    assert model.link_force.sum() == pytest.approx(SIGMA_T * model.rest_lengths[rows].sum())
    assert inc.pending_links == [] and len(seen) == len(rows)
    editor.begin()
    link_crossed_springs(editor, inc, springs, inc.point_at(np.linspace(0, inc.length, 21)), seen)
    editor.finish()
    assert model.link_count == len(rows)


def test_a_crossed_spring_whose_node_is_gone_links_the_lip_pair_of_the_station_nearest_its_crossing():
    """The two rows beside the line deleted (as the band does): each crossed spring's link goes
    to the lip pair of the station nearest where it crossed, if within half a spacing along the
    curve (``LINK_REACH``); the others wait, each with its crossing's arc length and rest length, and go to the
    nearest pair once settled without a reach (the incision's end)."""
    model, editor = patch()
    springs = OriginalSprings(model)
    y = between_rows(model)
    inc = straight_incision(model)
    rows, at = crossing_springs(model, y, -0.005, 0.005)
    ends = np.unique(model.springs[rows])
    editor.begin()
    editor.delete_nodes(ends.tolist())
    link_crossed_springs(editor, inc, springs, inc.point_at(np.linspace(0, inc.length, 21)), set())
    u_cross = at + 0.005
    station_u = np.array(inc.station_u)
    nearest = np.argmin(np.abs(u_cross[:, None] - station_u[None]), axis=1)
    near_enough = np.abs(u_cross - station_u[nearest]) <= LINK_REACH * SPACING
    expected = sorted(tuple(sorted((inc.left[k], inc.right[k]))) for k in nearest[near_enough])
    assert near_enough.any() and not near_enough.all()
    assert pairs_of(model) == expected
    waiting = sorted(zip(u_cross[~near_enough], springs.rest_lengths[rows[~near_enough]]))
    assert np.array(sorted(inc.pending_links)) == pytest.approx(np.array(waiting))
    settle_pending_links(editor, inc, reach=np.inf)
    editor.finish()
    assert inc.pending_links == []
    assert pairs_of(model) == sorted(tuple(sorted((inc.left[k], inc.right[k]))) for k in nearest)
    assert model.link_force.sum() == pytest.approx(SIGMA_T * springs.rest_lengths[rows].sum())


# ----------------------------------------------------------------------------- settle_pending_links

def pair(inc, k: int) -> tuple[int, int]:
    return tuple(sorted((inc.left[k], inc.right[k])))


def test_pending_links_go_to_the_nearest_live_pair_within_reach_and_wait_otherwise():
    """Stations at u = 4.2, 6.2, 8.2 mm. Within a 1.5 mm reach a link crossing at 5.9 mm goes to
    the middle pair, one at 9.8 mm (1.6 mm past the last) waits; with the middle pair's left lip
    dead, a link at 5.0 mm goes to the first pair (0.8 mm) rather than the last (3.2 mm); with
    no reach the waiting one goes to the last pair. Forces sigma_r t L0 of each rest length."""
    model, editor = patch()
    inc = straight_incision(model)
    editor.begin()
    inc.pending_links = [(0.0059, 0.002), (0.0098, 0.0017)]
    settle_pending_links(editor, inc, reach=0.0015)
    assert pairs_of(model) == [pair(inc, 1)]
    assert inc.pending_links == [(0.0098, 0.0017)]
    editor.delete_nodes([inc.left[1]])
    inc.pending_links.append((0.0050, 0.0019))
    settle_pending_links(editor, inc, reach=0.0015)
    assert pairs_of(model) == [pair(inc, 0)]  # the first link went with the dead lip
    assert inc.pending_links == [(0.0098, 0.0017)]
    settle_pending_links(editor, inc, reach=np.inf)
    editor.finish()
    assert inc.pending_links == []
    assert pairs_of(model) == sorted([pair(inc, 0), pair(inc, 2)])
    assert sorted(model.link_force) == pytest.approx(sorted([SIGMA_T * 0.0019, SIGMA_T * 0.0017]))


def test_pending_links_wait_while_the_incision_has_no_live_pair():
    model, editor = patch()
    inc = straight_incision(model)
    editor.begin()
    editor.delete_nodes(inc.right)
    inc.pending_links = [(0.005, 0.002)]
    settle_pending_links(editor, inc, reach=np.inf)
    editor.finish()
    assert inc.pending_links == [(0.005, 0.002)] and model.link_count == 0


# ----------------------------------------------------------------------------- carry_links

def linked_then_cut(model, editor, links, deleted):
    """Make ``links`` (node pairs), then delete nodes ``deleted`` in a second edit: its report."""
    editor.begin()
    editor.make_links(links, [SPACING] * len(links))
    editor.finish()
    editor.begin()
    editor.delete_nodes(deleted)
    return editor.finish()


def test_an_orphaned_link_is_carried_to_the_nearest_candidate_on_the_deleted_nodes_side():
    """A link from (0, 4.29) mm above the incision to (-1, -0.86) mm below it; the lower node
    deleted. Of the candidates (0, 0.86) mm above (1.98 mm from it), (-3, -0.86) below (2 mm)
    and (-4, -2.57) below (3.46 mm) the link goes to (-3, -0.86): the nearest on the deleted
    node's side, not the nearest of all. Force and smoothing kept."""
    model, editor = patch()
    inc = straight_incision(model)
    keep, gone = node_at(model, 0, 2 * ROWS[1] - ROWS[0]), node_at(model, -1, -ROWS[0])
    editor.begin()
    editor.make_links([(keep, gone)], [SPACING])
    editor.finish()
    force, smoothing = model.link_force[0], model.link_smoothing[0]
    editor.begin()
    editor.delete_nodes([gone])
    report = editor.finish()
    assert [e[:2] for e in report.orphaned_links] == [(keep, gone)]
    above, below, far_below = node_at(model, 0, ROWS[0]), node_at(model, -3, -ROWS[0]), node_at(model, -4, -ROWS[1])
    x = model.points
    d = np.linalg.norm(x[[above, below, far_below]] - x[gone], axis=1)
    assert d[0] < d[1] < d[2]
    lost = carry_links(editor, inc, report, [above, below, far_below], reach=0.004)
    assert lost == 0 and pairs_of(model) == [tuple(sorted((keep, below)))]
    assert model.link_force[0] == pytest.approx(force) and model.link_smoothing[0] == pytest.approx(smoothing)


def test_without_an_incision_a_link_goes_to_the_nearest_candidate_on_any_side():
    model, editor = patch()
    keep, gone = node_at(model, 0, 2 * ROWS[1] - ROWS[0]), node_at(model, -1, -ROWS[0])
    report = linked_then_cut(model, editor, [(keep, gone)], [gone])
    above, below = node_at(model, 0, ROWS[0]), node_at(model, -3, -ROWS[0])
    assert carry_links(editor, None, report, [above, below], reach=0.004) == 0
    assert pairs_of(model) == [tuple(sorted((keep, above)))]


def test_a_link_is_never_carried_to_a_node_a_spring_joins_to_its_other_end():
    """The link of the test above, without an incision: of the candidates (-1, 2.57) mm (3.4 mm
    from the deleted node) and (4, 0.86) mm (5.3 mm), the nearer one is the kept node's lattice
    neighbour. A link along that spring would pull the two together and crush the triangles on
    it (fuzz case 4087729486, stroke 3: a triangle of 32.7 deg at rest flattened to 0.2 deg), so
    the link goes to the farther one; with only the neighbour it is lost."""
    model, editor = patch()
    keep, gone = node_at(model, 0, 2 * ROWS[1] - ROWS[0]), node_at(model, -1, -ROWS[0])
    report = linked_then_cut(model, editor, [(keep, gone)], [gone])
    neighbour, farther = node_at(model, -1, ROWS[1]), node_at(model, 4, ROWS[0])
    assert editor.spring_between(keep, neighbour) is not None and editor.spring_between(keep, farther) is None
    x = model.points
    assert np.linalg.norm(x[neighbour] - x[gone]) < np.linalg.norm(x[farther] - x[gone]) < 0.006
    assert carry_links(editor, None, report, [neighbour, farther], reach=0.006) == 0
    assert pairs_of(model) == [tuple(sorted((keep, farther)))]
    model, editor = patch()
    report = linked_then_cut(model, editor, [(keep, gone)], [gone])
    assert carry_links(editor, None, report, [neighbour], reach=0.006) == 1 and model.link_count == 0


def test_a_link_is_not_carried_to_a_near_massless_node():
    """A node the re-mesh made tiny (here: its mass set to 1 % of the others') takes no carried
    link even when it is as near as any: a bundle of links on it crushed its triangles and shortened
    the stable step (fuzz case 538663700: 1e-9-3e-7 kg nodes against a median near 1e-5 kg,
    triangles flattened to 1.4 deg). The link goes to the nearest candidate of normal mass."""
    model, editor = patch()
    keep, gone = node_at(model, 0, 2 * ROWS[1] - ROWS[0]), node_at(model, -1, -ROWS[0])
    report = linked_then_cut(model, editor, [(keep, gone)], [gone])
    light, normal, far = node_at(model, -3, -ROWS[0]), node_at(model, 1, -ROWS[0]), node_at(model, 4, ROWS[0])
    x = model.points
    assert np.linalg.norm(x[light] - x[gone]) <= np.linalg.norm(x[normal] - x[gone])
    model.node_table.set("masses", [light], [0.01 * model.masses[normal]])
    assert carry_links(editor, None, report, [light, normal, far], reach=0.006) == 0
    assert pairs_of(model) == [tuple(sorted((keep, normal)))]
    assert LINK_TAKER_MASS * np.median(model.masses[[light, normal, far]]) > model.masses[light]


def test_a_severed_link_is_carried_to_a_lip_on_each_side():
    """A link across the incision whose two nodes one edit deletes, (4, 0.86) and (3, -0.86) mm,
    goes to the lips nearest them on their own sides, (3, 2.57) and (2, -2.57) mm; a link between
    (-4, 0.86) and (-2, 0.86) mm, both above, whose nodes both map to the lip (-1, 2.57) mm, is
    lost (counted)."""
    model, editor = patch()
    inc = straight_incision(model)
    across = (node_at(model, 4, ROWS[0]), node_at(model, 3, -ROWS[0]))
    one_side = (node_at(model, -4, ROWS[0]), node_at(model, -2, ROWS[0]))
    report = linked_then_cut(model, editor, [across, one_side], list(across + one_side))
    assert len(report.severed_links) == 2
    lost = carry_links(editor, inc, report, inc.left + inc.right, reach=0.004)
    assert lost == 1
    assert pairs_of(model) == [tuple(sorted((node_at(model, 3, ROWS[1]), node_at(model, 2, -ROWS[1]))))]


def test_a_link_orphaned_and_then_severed_in_one_edit_is_carried_as_severed():
    """The link across the incision of the test above, its lower node deleted first and its
    upper one later in the same edit (a scrap or an island removed after the event's own
    deletions): orphaned at the first deletion, with the upper node as the one kept, it has
    lost both nodes by the end of the edit and the report holds it severed. It goes to the lips
    nearest its two nodes on their sides, never to a deleted node (fuzz case 1896506760,
    stroke 4: link_dead_node, when it was carried as orphaned to its dead kept node)."""
    model, editor = patch()
    inc = straight_incision(model)
    keep, gone = node_at(model, 4, ROWS[0]), node_at(model, 3, -ROWS[0])
    editor.begin()
    editor.make_links([(keep, gone)], [SPACING])
    editor.finish()
    editor.begin()
    editor.delete_nodes([gone])
    editor.delete_nodes([keep])
    report = editor.finish()
    assert [e[:2] for e in report.severed_links] == [(keep, gone)] and not report.orphaned_links
    assert carry_links(editor, inc, report, inc.left + inc.right, reach=0.004) == 0
    assert pairs_of(model) == [tuple(sorted((node_at(model, 3, ROWS[1]), node_at(model, 2, -ROWS[1]))))]
    ends = model.link_table.live("pairs").ravel()
    assert model.active[ends].all()


def test_a_link_is_lost_when_nothing_is_left_within_reach():
    model, editor = patch()
    inc = straight_incision(model)
    keep, gone = node_at(model, 0, 2 * ROWS[1] - ROWS[0]), node_at(model, -1, -ROWS[0])
    report = linked_then_cut(model, editor, [(keep, gone)], [gone])
    far = node_at(model, 0, -0.006)
    assert carry_links(editor, inc, report, [far], reach=0.002) == 1
    assert carry_links(editor, inc, report, [], reach=1.0) == 1
    assert carry_links(editor, inc, report, [keep], reach=1.0) == 1  # the surviving node is no taker
    assert model.link_count == 0


# ----------------------------------------------------------------------------- a whole cut

def cut_between_rows(step: float, radius: float):
    """A 12 mm cut between two rows of a 20 mm patch (the rows 0.83 mm either side of the line:
    a tool of 1 mm radius deletes them, one of 0.6 mm does not), extended every ``step`` [m];
    returns (model, sim, y)."""
    model = TissueModel.from_patch((0.02, 0.02), SPACING, pinned="border", material=MATERIAL)
    sim = Simulator(model, dt=1e-3, gravity=None, device=DEVICE, cutting=CutSettings())
    y = between_rows(model)
    cutter = sim.cutter
    cutter.start_incision(sim, [-0.006, y, 0.0], [0, 0, 1], radius)
    for xk in np.linspace(-0.006, 0.006, int(round(0.012 / step)) + 1)[1:]:
        cutter.extend_incision(sim, [xk, y, 0.0])
    cutter.end_incision(sim)
    return model, sim, y


@pytest.mark.parametrize("radius", [0.0006, 0.001])
@pytest.mark.parametrize("step", [0.0003, 0.003])
def test_every_spring_the_cut_separates_leaves_its_link_whatever_the_event_interval(step, radius):
    """SPEC section 1: each spring of the uncut patch that crosses the cut line between the
    cut's ends (counted here) leaves one link of sigma_r t L0, with events 0.3 mm or 3 mm apart;
    none is lost and every link spans the line. With the 0.6 mm tool both rows beside the line
    survive and each link joins its spring's own nodes; with the 1 mm tool they are swept and
    each link joins the lip pair of the station nearest where its spring crossed."""
    model, sim, y = cut_between_rows(step, radius)
    uncut = TissueModel.from_patch((0.02, 0.02), SPACING, pinned="border", material=MATERIAL)
    rows, at = crossing_springs(uncut, y, -0.006, 0.006)
    assert model.link_force.sum() == pytest.approx(SIGMA_T * uncut.rest_lengths[rows].sum(), rel=1e-9)
    assert sim.cutter.totals["lost_links"] == 0 and model.link_count == len(rows)
    x = sim.positions
    assert np.all((x[model.links[:, 0], 1] - y) * (x[model.links[:, 1], 1] - y) < 0)
    inc = sim.cutter.incisions[0]
    if radius < 0.0008:
        assert pairs_of(model) == sorted(tuple(sorted(uncut.springs[r])) for r in rows)
    else:
        u_cross = at + 0.006
        nearest = np.argmin(np.abs(u_cross[:, None] - np.array(inc.station_u)[None]), axis=1)
        assert pairs_of(model) == sorted(tuple(sorted((inc.left[k], inc.right[k]))) for k in nearest)


@pytest.mark.parametrize("angle_deg", [15.0, 25.0])
def test_a_spring_two_incisions_cross_keeps_one_link(angle_deg):
    """A 12 mm cut between two rows, then a second one through its middle at a shallow angle:
    near their crossing both lines cut the same springs (3-7 of them here). Each spring of the
    uncut patch either line crosses keeps one link of sigma_r t L0: the wound's links sum to
    sigma_r t over the distinct springs. The tension a spring held is released once; when each
    incision linked the springs it crossed, the second linked those again (8-31 % more force
    here; fuzz case 1491093012: 7 springs linked twice, a triangle crushed to 1.7 deg). The
    flaps the two cuts leave in the thin wedge between them stay (``freed.flap_area`` 0): a flap
    removed takes its nodes' links with it, tension no tissue is left to hold (at 25 deg, 8 %
    of the sum)."""
    model, sim, y = cut_between_rows(0.0003, 0.0006)
    cutter = sim.cutter
    cutter.freed.flap_area = 0.0
    a = np.radians(angle_deg)
    d = np.array([np.cos(a), np.sin(a), 0.0])
    p0 = np.array([0.0, y, 0.0]) - 0.006 * d
    cutter.start_incision(sim, p0, [0, 0, 1], 0.0006)
    for t in np.linspace(0.0, 0.012, 41)[1:]:
        cutter.extend_incision(sim, p0 + t * d)
    cutter.end_incision(sim)
    uncut = TissueModel.from_patch((0.02, 0.02), SPACING, pinned="border", material=MATERIAL)
    along, _ = crossing_springs(uncut, y, -0.006, 0.006)
    ends = uncut.points[uncut.springs]
    rel = [ends[:, k] - p0 for k in (0, 1)]
    side = [d[0] * r[:, 1] - d[1] * r[:, 0] for r in rel]  # of the second line
    crosses = side[0] * side[1] < 0
    hit = ends[:, 0] + (side[0] / np.where(crosses, side[0] - side[1], 1.0))[:, None] * (ends[:, 1] - ends[:, 0])
    u = (hit - p0) @ d
    across = np.flatnonzero(crosses & (u >= 0.0) & (u <= 0.012))
    assert len(np.intersect1d(along, across)) >= 3 and sim.cutter.totals["lost_links"] == 0
    distinct = np.union1d(along, across)
    assert model.link_force.sum() == pytest.approx(SIGMA_T * uncut.rest_lengths[distinct].sum(), rel=1e-9)


_GRID_SPRINGS = OriginalSprings(TissueModel.from_patch((0.05, 0.04), 0.002))


@given(lo=st.tuples(*[st.floats(-0.03, 0.03)] * 3), size=st.tuples(*[st.floats(0.0, 0.012)] * 3))
def test_springs_near_a_box_are_those_of_its_grid_cells(lo, size):
    """``OriginalSprings.near``: the springs whose midpoint's grid cell lies in the box's cells
    grown by one, in the grid's sorted order - the same as testing every spring."""
    springs = _GRID_SPRINGS
    lo = np.array(lo)
    hi = lo + np.array(size)
    mid = 0.5 * (springs.a + springs.b)
    cells = np.floor(mid / springs.cell).astype(np.int64)
    k_lo, k_hi = np.floor(lo / springs.cell).astype(np.int64) - 1, np.floor(hi / springs.cell).astype(np.int64) + 1
    inside = np.all((cells >= k_lo) & (cells <= k_hi), axis=1)
    got = springs.near(lo, hi)
    assert set(got.tolist()) == set(np.flatnonzero(inside).tolist())
    assert np.array_equal(got, springs.order[np.isin(springs.order, got)])  # in the grid's order
