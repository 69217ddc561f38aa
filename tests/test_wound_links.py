"""warp_cut/cut/wound_links.py: where the residual links of a cut go, and that they do not
depend on how often the cut runs."""

import numpy as np
import pytest
from conftest import DEVICE

from warp_cut import Material, Simulator, TissueModel
from warp_cut.cut.incision import Incision
from warp_cut.cut.settings import CutSettings
from warp_cut.cut.topology import TopologyEditor
from warp_cut.cut.wound_links import align_links, carry_links, open_links

SPACING = 0.002
MATERIAL = Material(density=1000.0, thickness=1e-3, youngs_modulus=2e4, residual_strain=0.1)


def straight_incision(model, y: float, lip_offset: float = 0.0015) -> tuple[Incision, list[int], list[int]]:
    """An incision along x at height y [m] from x = -5 to +5 mm, ended, with three stations at
    u = 3, 5, 7 mm whose lips are the patch nodes nearest the lip points ``lip_offset`` [m]
    above and below; returns (incision, left lips, right lips)."""
    inc = Incision([-0.005, y, 0.0], [0, 0, 1], spacing=SPACING, lip_offset=0.0005, tolerance=1e-5)
    inc.extend([0.005, y, 0.0], 1e-6)
    inc.open_end = False
    inc.station_u = [0.003, 0.005, 0.007]
    x = model.points
    def nearest(p):
        return int(np.argmin(np.linalg.norm(x - p, axis=1)))
    inc.left = [nearest([u - 0.005, y + lip_offset, 0.0]) for u in inc.station_u]
    inc.right = [nearest([u - 0.005, y - lip_offset, 0.0]) for u in inc.station_u]
    assert len(set(inc.left + inc.right)) == 6
    return inc, inc.left, inc.right


def patch():
    model = TissueModel.from_patch((0.016, 0.012), SPACING, material=MATERIAL)
    return model, TopologyEditor(model)


def test_a_link_between_lips_of_two_stations_moves_to_one_stations_pair():
    """A link from the left lip of the first station to the right lip of the third is moved to
    the middle station's pair (force and smoothing kept); a link within one station's pair, and
    one joining two lips of one side, stay."""
    model, editor = patch()
    inc, left, right = straight_incision(model, 0.0)
    editor.begin()
    editor.make_links([(left[0], right[2]), (left[2], right[2]), (left[0], left[1])], [SPACING] * 3)
    force, smoothing = model.link_force.copy(), model.link_smoothing.copy()
    report = editor.finish()
    moved = align_links(editor, inc, report.residual_links)
    assert moved == 1 and report.moved_links == [report.residual_links[0]]
    assert model.links.tolist() == [[left[1], right[1]], [left[2], right[2]], [left[0], left[1]]]
    assert np.array_equal(model.link_force, force) and np.array_equal(model.link_smoothing, smoothing)
    assert editor.node_links[left[0]] == {report.residual_links[2]}
    assert editor.node_links[right[1]] == {report.residual_links[0]}


def test_a_moved_link_goes_to_the_least_loaded_pair_between_its_stations():
    """The middle pair already carries two links: a link across three stations goes to the
    first or last pair (one link each is fewer than two), never to a dead lip's station."""
    model, editor = patch()
    inc, left, right = straight_incision(model, 0.0)
    editor.begin()
    editor.make_links([(left[1], right[1])], [SPACING])
    editor.make_links([(left[1], right[1])], [SPACING], once_per_pair=False)
    editor.make_links([(right[0], left[2])], [SPACING], once_per_pair=False)
    report = editor.finish()
    assert align_links(editor, inc, report.residual_links) == 1
    assert model.links.tolist()[2] in ([left[0], right[0]], [left[2], right[2]])
    # with the first station's left lip dead, the only least-loaded pair left is the last
    editor.begin()
    editor.delete_nodes([left[0]])
    editor.make_links([(right[0], left[2])], [SPACING], once_per_pair=False)
    report = editor.finish()
    align_links(editor, inc, report.residual_links)
    assert model.link_table.column("pairs")[report.residual_links[0]].tolist() == [left[2], right[2]]


def test_a_node_the_cut_deleted_is_replaced_by_the_lip_at_the_station_where_the_spring_crossed():
    """A pending link whose two nodes the cut deleted is made between the two lips of the
    station nearest where the spring crossed the incision, whatever the deleted nodes' distance
    to other lips; one with a live node keeps it. Without a lip within reach it waits while the
    tool cuts and is lost once it has gone."""
    model, editor = patch()
    inc, left, right = straight_incision(model, 0.0, lip_offset=0.0026)  # lips on the rows at +-2.6 mm
    x = model.points
    # a spring crossing near x = 0 (u = 5 mm, the middle station) between the rows at
    # +-0.87 mm, both nodes gone; the deleted nodes lie nearer the first station's lips
    above = int(np.argmin(np.linalg.norm(x - [0.0005, 0.0009, 0.0], axis=1)))
    below = int(np.argmin(np.linalg.norm(x - [-0.0005, -0.0009, 0.0], axis=1)))
    assert x[above, 1] > 0.0 > x[below, 1] and {above, below}.isdisjoint(left + right)
    assert abs(0.5 * (x[above, 0] + x[below, 0])) < 0.0006
    keep = int(np.argmin(np.linalg.norm(x - [0.0025, 0.0009, 0.0], axis=1)))  # live, left side
    editor.begin()
    editor.delete_nodes([above, below])
    inc.pending_links = [(above, below, SPACING, 0.0), (keep, below, SPACING, 0.0)]
    lost = open_links(editor, inc, x, reach=0.0015)
    editor.finish()
    assert lost == 0 and inc.pending_links == []
    assert model.links.tolist() == [[left[1], right[1]], [keep, right[1]]]
    # no station within 1 mm of u = 8.5 mm (the last at 7 mm): kept pending while the tool
    # cuts, then lost
    far_above = int(np.argmin(np.linalg.norm(x - [0.0045, 0.0009, 0.0], axis=1)))
    far_below = int(np.argmin(np.linalg.norm(x - [0.0035, -0.0009, 0.0], axis=1)))
    editor.begin()
    editor.delete_nodes([far_above, far_below])
    inc.pending_links = [(far_above, far_below, SPACING, 0.0)]
    inc.open_end = True
    assert open_links(editor, inc, x, reach=0.001) == 0 and len(inc.pending_links) == 1
    inc.open_end = False
    assert open_links(editor, inc, x, reach=0.001) == 1 and inc.pending_links == []
    editor.finish()


def test_the_slit_tip_pair_takes_no_carried_link_while_the_tool_cuts():
    """While the tool cuts, a link whose nodes the cut deleted and whose spring crossed at the
    slit's tip station (its newest pair, next to the tool) waits; one crossing at the station
    behind is made there, and so is a link whose two nodes survived, at the tip too. Once the
    tool has gone the waiting one goes to the tip pair."""
    model, editor = patch()
    inc, left, right = straight_incision(model, 0.0, lip_offset=0.0026)
    inc.open_end = True
    x = model.points
    def node(p):
        return int(np.argmin(np.linalg.norm(x - p, axis=1)))
    at_tip = (node([0.0025, 0.0009, 0.0]), node([0.0015, -0.0009, 0.0]))  # crosses at u = 7 mm
    behind = (node([0.0005, 0.0009, 0.0]), node([-0.0005, -0.0009, 0.0]))  # u = 5 mm
    alive = (node([0.0045, 0.0009, 0.0]), node([0.0035, -0.0009, 0.0]))  # u = 9 mm, both live
    editor.begin()
    editor.delete_nodes(list(at_tip + behind))
    inc.pending_links = [(*at_tip, SPACING, 0.0), (*behind, SPACING, 0.0), (*alive, SPACING, 0.0)]
    assert open_links(editor, inc, x, reach=0.0015) == 0
    assert inc.pending_links == [(*at_tip, SPACING, 0.0)]
    assert sorted(model.links.tolist()) == sorted([[left[1], right[1]], list(alive)])
    inc.open_end = False
    assert open_links(editor, inc, x, reach=0.0015) == 0 and inc.pending_links == []
    assert model.links.tolist()[-1] == [left[2], right[2]]
    editor.finish()


def test_a_link_whose_two_nodes_an_edit_deletes_is_carried_to_a_lip_on_each_side():
    """A link across the incision whose two nodes one edit deletes (the tip re-opened, a
    capsule over re-closed tissue) goes to the nearest lip on each side, force and smoothing
    kept; one whose two nodes lay on one side of the incision is lost (counted)."""
    model, editor = patch()
    inc, left, right = straight_incision(model, 0.0, lip_offset=0.0026)
    x = model.points
    def node(p):
        return int(np.argmin(np.linalg.norm(x - p, axis=1)))
    across = (node([0.0005, 0.0009, 0.0]), node([-0.0005, -0.0009, 0.0]))
    one_side = (node([0.0025, 0.0009, 0.0]), node([0.0045, 0.0009, 0.0]))
    editor.begin()
    editor.make_links([across, one_side], [SPACING, SPACING])
    force = model.link_force.copy()
    report = editor.finish()
    editor.begin()
    editor.delete_nodes(list(across + one_side))
    report = editor.finish()
    assert sorted(report.severed_links)[0][:2] in (across, across[::-1]) and len(report.severed_links) == 2
    lost = carry_links(editor, inc, report, x, reach=0.004)
    assert lost == 1 and model.link_count == 1
    for end, lips in zip(sorted(model.links[0], key=lambda v: v not in left), (left, right)):
        assert end in lips  # a lip on each side, one nearest where the deleted node was
        gone = across[0] if lips is left else across[1]
        d = np.linalg.norm(x[lips] - x[gone], axis=1)
        assert np.linalg.norm(x[end] - x[gone]) == pytest.approx(d.min())
    assert model.link_force[0] == pytest.approx(force[0])


def cut_between_rows(step: float, radius: float):
    """A 12 mm cut between two rows of a 20 mm patch (the rows 0.87 mm either side of the line:
    a tool of ``radius`` [m] over that deletes them), extended every ``step`` [m]; returns
    (model, sim, y)."""
    model = TissueModel.from_patch((0.02, 0.02), SPACING, pinned="border", material=MATERIAL)
    sim = Simulator(model, dt=1e-3, gravity=None, device=DEVICE, cutting=CutSettings())
    rows = np.unique(model.points[:, 1].round(9))
    k = np.searchsorted(rows, 0.0, side="right")
    y = 0.5 * (rows[k - 1] + rows[k])
    cutter = sim.cutter
    cutter.start_incision(sim, [-0.006, y, 0.0], [0, 0, 1], radius)
    for xk in np.linspace(-0.006, 0.006, int(round(0.012 / step)) + 1)[1:]:
        cutter.extend_incision(sim, [xk, y, 0.0])
    cutter.end_incision(sim)
    return model, sim, y


@pytest.mark.parametrize("radius", [0.0006, 0.001])
@pytest.mark.parametrize("step", [0.0003, 0.003])
def test_every_spring_the_cut_separates_leaves_its_link_whatever_the_event_interval(step, radius):
    """SPEC section 1, with links kept alive: each spring of the uncut patch that crosses the
    cut line inside the swept band leaves a link of sigma_r t L0, carried to the lips if the
    capsule took its nodes (the 1 mm tool deletes both rows beside the line: every link is
    carried). Counted independently on the uncut patch (springs with a node on either side of
    the line, crossing it between the cut's ends or within a tool radius beyond them), the
    total link force is theirs, with events 0.3 mm or 3 mm apart; every link spans the line."""
    model, sim, y = cut_between_rows(step, radius)
    uncut = TissueModel.from_patch((0.02, 0.02), SPACING, pinned="border", material=MATERIAL)
    p = uncut.points[uncut.springs]
    lateral = (p[:, 0, 1] - y) * (p[:, 1, 1] - y)
    at = p[:, 0, 0] + (y - p[:, 0, 1]) / np.where(lateral < 0, p[:, 1, 1] - p[:, 0, 1], 1.0) * (p[:, 1, 0] - p[:, 0, 0])
    crossing = (lateral < 0) & (np.abs(at) <= 0.006 + radius)
    expected = 2e4 * 0.1 * 1e-3 * uncut.rest_lengths[crossing].sum()
    assert model.link_force.sum() == pytest.approx(expected, rel=1e-9)
    assert sim.cutter.totals["lost_links"] == 0 and model.link_count == crossing.sum()
    x = sim.positions
    assert np.all((x[model.links[:, 0], 1] - y) * (x[model.links[:, 1], 1] - y) < 0)
