"""warp_cut/cut/wound/islands.py: the pieces of skin a cut frees, and the scraps an edit trims off.

Compared against: the connected pieces of hand-built meshes (a sheet with separate small
pieces beside it, a piece held by a single node, a pinned piece, two pieces of equal size),
found here with a union-find over triangles sharing a node; and the flaps a cut leaves hanging
by one edge (triangles hung on the border of a sheet, checked against the nodes they share with it).
"""

import numpy as np
import pytest

from warp_cut import TissueModel
from warp_cut.cut.classes import NodeClass
from warp_cut.cut.topology import TopologyEditor
from warp_cut.cut.wound.islands import Freed, FreedPieces, flaps_from, islands_from, scraps_from


def grid(n: int, origin=(0.0, 0.0), cell: float = 1e-3):
    """An n x n node grid of ``cell`` squares at ``origin`` [m], split on one diagonal:
    (points (n^2, 3), triangles (2 (n-1)^2, 3)), counter-clockwise from +z."""
    g = np.stack(np.meshgrid(np.arange(n), np.arange(n)), axis=-1).reshape(-1, 2) * cell + origin
    tri = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            tri += [[a, b, e], [a, e, d]]
    return np.column_stack([g, np.zeros(len(g))]), np.array(tri)


def sheet_with_pieces(pieces, n: int = 8, pinned=None, **kwargs):
    """A sheet of n x n nodes and, to its right, separate square pieces of ``pieces`` nodes a
    side: (model, triangle rows of each part, sheet first)."""
    points, tri = grid(n)
    parts = [list(range(len(tri)))]
    for k, side in enumerate(pieces):
        p, t = grid(side, origin=(n * 1e-3 + k * 5e-3, 0.0))
        parts.append(list(range(len(tri), len(tri) + len(t))))
        tri = np.concatenate([tri, t + len(points)])
        points = np.concatenate([points, p])
    model = TissueModel.from_triangles(points, tri, pinned=pinned or "none", **kwargs)
    return model, parts


def pieces_by_shared_nodes(model) -> list[set[int]]:
    """The mesh's pieces (triangles joined through a shared node), by union-find."""
    corners = model.triangle_table.column("corners")
    live = [t for t in range(len(corners)) if model.triangle_table.alive[t]]
    parent = {t: t for t in live}

    def root(t):
        while parent[t] != t:
            parent[t] = parent[parent[t]]
            t = parent[t]
        return t

    first_at: dict[int, int] = {}
    for t in live:
        for v in corners[t].tolist():
            if v in first_at:
                parent[root(t)] = root(first_at[v])
            else:
                first_at[v] = t
    out: dict[int, set] = {}
    for t in live:
        out.setdefault(root(t), set()).add(t)
    return list(out.values())


def test_a_piece_cut_free_is_found_and_the_sheet_is_not():
    """Seeds in the sheet and in a separate 2-triangle piece: the piece is the one island,
    exactly the union-find's piece, and the sheet is left."""
    model, parts = sheet_with_pieces([2])
    found = islands_from(model, [parts[0][5], parts[1][0]])
    assert found == [set(parts[1])]
    assert set(parts[1]) in pieces_by_shared_nodes(model)


def test_several_free_pieces_are_each_found():
    model, parts = sheet_with_pieces([2, 3])
    found = islands_from(model, [parts[0][0], parts[1][1], parts[2][0]])
    assert sorted(map(sorted, found)) == sorted([sorted(parts[1]), sorted(parts[2])])


def test_seeds_all_in_one_piece_free_nothing():
    model, parts = sheet_with_pieces([2])
    assert islands_from(model, parts[0][:4]) == []
    assert islands_from(model, parts[0][:1]) == []


def test_no_live_seed_frees_nothing():
    model, _ = sheet_with_pieces([2])
    assert islands_from(model, []) == []


def test_a_pinned_piece_is_held_in_place():
    """The small piece holds a pinned node: it has come apart but is not free."""
    points, _ = grid(8)
    model, parts = sheet_with_pieces([2], pinned=[len(points)])
    assert model.pinned[len(points)]
    assert islands_from(model, [parts[0][0], parts[1][0]]) == []


def test_a_piece_held_by_a_single_node_is_not_an_island():
    """A square touching the sheet at one corner node only (a bow-tie) is held by it."""
    points, tri = grid(4)
    extra = np.array([[4e-3, 3e-3, 0.0], [4e-3, 4e-3, 0.0], [3e-3, 4e-3, 0.0]])  # beyond node 15 (3, 3) mm
    corner = 15
    assert points[corner] == pytest.approx([3e-3, 3e-3, 0.0])
    n = len(points)
    tri = np.concatenate([tri, [[corner, n, n + 1], [corner, n + 1, n + 2]]])
    model = TissueModel.from_triangles(np.concatenate([points, extra]), tri, pinned="none")
    assert islands_from(model, [0, len(tri) - 1]) == []
    assert len(pieces_by_shared_nodes(model)) == 1


def test_dead_seeds_are_ignored():
    """A seed triangle the edit deleted starts no piece."""
    model, parts = sheet_with_pieces([2])
    editor = TopologyEditor(model)
    editor.begin()
    editor.delete_triangles([parts[1][0]])
    editor.finish()
    live_piece = {t for t in parts[1] if model.triangle_table.alive[t]}
    assert islands_from(model, [parts[0][0], parts[1][0]]) == []  # only the sheet's seed is alive
    assert islands_from(model, [parts[0][0], *parts[1]]) == [live_piece]


def test_of_two_equal_pieces_one_is_the_tissue():
    """Two separate 3 x 3 pieces and nothing else: one of them (the one still growing when the
    other is done) is the tissue, the other the one island. With the default limit (half the
    live triangles) the search stops before either is done: no island."""
    a, ta = grid(3)
    b, tb = grid(3, origin=(5e-3, 0.0))
    model = TissueModel.from_triangles(np.concatenate([a, b]), np.concatenate([ta, tb + len(a)]), pinned="none")
    first, second = set(range(len(ta))), set(range(len(ta), 2 * len(ta)))
    assert sorted(map(sorted, pieces_by_shared_nodes(model))) == [sorted(first), sorted(second)]
    found = islands_from(model, [0, len(ta)], limit=100)
    assert found in ([first], [second])
    assert islands_from(model, [0, len(ta)]) == []


def test_the_search_stops_at_the_limit_and_costs_the_small_pieces_not_the_sheet():
    """A 30 x 30 node sheet (1682 triangles) with a 2-triangle piece: with a limit of 100
    triangles searched the piece is still found (the sheet is only grown while the piece is);
    with a limit of 1 nothing is (the search stopped)."""
    model, parts = sheet_with_pieces([2], n=30)
    assert len(parts[0]) == 1682
    assert islands_from(model, [parts[0][800], parts[1][0]], limit=100) == [set(parts[1])]
    assert islands_from(model, [parts[0][800], parts[1][0]], limit=1) == []


def test_a_piece_found_whole_before_the_limit_is_an_island_though_the_tissue_is_not_found():
    """Seeds at two far corners of a 30 x 30 node sheet, as on the two sides of a long wound,
    and in a 2-triangle piece: the piece is done at once, but the sheet's two seeds grow past
    the default limit (half the live triangles) before they meet. The piece is found all the
    same (before, the search stopped with no island, and an arc across a zigzag wound left a
    piece of 9 triangles floating in it: ``test_cutting``'s arc across a zigzag wound)."""
    model, parts = sheet_with_pieces([2], n=30)
    seeds = [parts[0][0], parts[0][-1], parts[1][0]]
    assert islands_from(model, seeds) == [set(parts[1])]
    assert islands_from(model, seeds[:2]) == []


MM2 = 1e-6  # one square of the grids here [m^2]


def test_a_small_separate_piece_is_a_scrap_and_the_sheet_is_not():
    """A 2-triangle piece of 1 mm^2 beside an 8 x 8 sheet: a scrap below 1.5 mm^2 (the union-find's
    piece), none below 0.9 mm^2; the sheet never, however large the area allowed."""
    model, parts = sheet_with_pieces([2])
    seeds = [parts[0][3], parts[1][0]]
    assert scraps_from(model, seeds, 1.5 * MM2, 6) == [set(parts[1])]
    assert set(parts[1]) in pieces_by_shared_nodes(model)
    assert scraps_from(model, seeds, 0.9 * MM2, 6) == []
    assert scraps_from(model, parts[0], 1.0, 6) == []


def test_a_scrap_is_searched_up_to_the_triangle_count():
    """A 3 x 3 node piece (8 triangles, 4 mm^2): no scrap when at most 6 triangles are searched,
    a scrap when 8 are."""
    model, parts = sheet_with_pieces([3])
    assert scraps_from(model, parts[1][:1], 10 * MM2, 6) == []
    assert scraps_from(model, parts[1][:1], 10 * MM2, 8) == [set(parts[1])]


def test_a_small_piece_held_by_one_node_or_dead_is_no_scrap():
    """A triangle touching the sheet at one corner is held; a deleted seed starts nothing."""
    points, tri = grid(4)
    extra = np.array([[4e-3, 3e-3, 0.0], [4e-3, 4e-3, 0.0]])
    n = len(points)
    tri = np.concatenate([tri, [[15, n, n + 1]]])
    model = TissueModel.from_triangles(np.concatenate([points, extra]), tri, pinned="none")
    assert scraps_from(model, [len(tri) - 1], 10 * MM2, 6) == []
    model, parts = sheet_with_pieces([2])
    editor = TopologyEditor(model)
    editor.begin()
    editor.delete_triangles(parts[1])
    editor.finish()
    assert scraps_from(model, parts[1], 10 * MM2, 6) == []


def test_freed_pieces_remove_a_scrap_unless_it_holds_a_kept_node_and_then_later():
    """A 2-triangle scrap (1 mm^2) beside the sheet: while it holds a node of ``keep`` it waits
    (nothing removed), and the next call removes it from the waiting ones even with no seed;
    its four nodes go, the sheet stays whole."""
    model, parts = sheet_with_pieces([2])
    editor = TopologyEditor(model)
    freed = FreedPieces(editor, 1.5 * MM2, 6, keep_islands=False)
    scrap_nodes = set(model.triangle_table.column("corners")[parts[1]].ravel().tolist())
    editor.begin()
    assert freed.remove_scraps({parts[1][0]}, keep={min(scrap_nodes)}) == 0
    assert freed.waiting == set(parts[1])
    assert freed.remove_scraps(set(), keep=set()) == 1
    editor.finish()
    assert not model.active[sorted(scrap_nodes)].any()
    assert model.active.sum() == 64 and model.triangle_count == len(parts[0])


@pytest.mark.parametrize("keep_islands, removed", [(False, 1), (True, 0)])
def test_freed_pieces_remove_the_islands_an_edit_cut_free(keep_islands, removed):
    """A 3 x 3 node piece (8 triangles, 4 mm^2: no scrap below 1.5 mm^2) apart from the sheet,
    one triangle of each made again in the edit (a slit's two sides): the piece is an island,
    removed unless the settings keep islands, whether or not the slit met the opening by a new
    point (a slit whose lips were matched to an earlier wound's border nodes frees it too)."""
    model, parts = sheet_with_pieces([3])
    editor = TopologyEditor(model)
    freed = FreedPieces(editor, 1.5 * MM2, 6, keep_islands=keep_islands)
    remade = [parts[0][0], parts[1][0]]
    corners = model.triangle_table.column("corners")[remade].copy()
    editor.begin()
    editor.delete_triangles(remade)
    editor.add_triangles(corners, model.points)
    assert freed.after_edit(keep=set()) == Freed(0, 0, removed)
    editor.finish()
    assert model.triangle_count == len(parts[0]) + (0 if removed else 8)


N = 6  # the flap tests' sheet: N x N nodes, 1 mm cells
RIGHT = [r * N + N - 1 for r in range(N)]  # the sheet's right border nodes, bottom to top


def sheet_with_hung(points, triangles, touched=True, **kwargs):
    """The N x N sheet with ``points`` (k, 3) [mm] added (numbered from N^2) and ``triangles``
    (rows of node numbers, the sheet's or the added ones) hung on it; the added nodes are of the
    cut's classes (``touched``) or NORMAL. Returns (model, the hung triangles' slots)."""
    sheet_points, tri = grid(N)
    model = TissueModel.from_triangles(np.concatenate([sheet_points, 1e-3 * np.asarray(points, float)]),
                                       np.concatenate([tri, triangles]), **{"pinned": "none", **kwargs})
    if touched:
        model.node_class[N * N:] = NodeClass.LIP
    return model, list(range(len(tri), len(tri) + len(triangles)))


def only_in(model, piece: set[int], nodes) -> bool:
    """True if every node of ``nodes`` lies in triangles of ``piece`` only (what holds a flap)."""
    corners = model.triangle_table.column("corners")
    outside = [t for t in range(model.triangle_table.count) if model.triangle_table.alive[t] and t not in piece]
    return not set(nodes) & set(corners[outside].ravel().tolist())


FLAP = ([[N, 2.5, 0.0]], [[RIGHT[2], N * N, RIGHT[3]]])  # a triangle on the border edge RIGHT[2]-RIGHT[3]
SQUARE = ([[N, 2.0, 0.0], [N, 3.0, 0.0]], [[RIGHT[2], N * N, N * N + 1], [RIGHT[2], N * N + 1, RIGHT[3]]])


def test_a_triangle_hung_on_one_border_edge_is_a_flap_from_either_side():
    """A triangle hung on the sheet's border edge: a flap held by that edge, seeded from itself or
    from the sheet's triangle on the edge; its third node lies in it only."""
    model, mine = sheet_with_hung(*FLAP)
    sheet_side = (model.index.triangles_with_edge(RIGHT[2], RIGHT[3]) - set(mine)).pop()
    for seeds in (mine, [sheet_side]):
        assert flaps_from(model, seeds, 1.5 * MM2, 8) == [(set(mine), (RIGHT[2], RIGHT[3]))]
    assert only_in(model, set(mine), [N * N])


def test_a_square_hung_on_one_edge_is_one_flap_and_its_outer_triangle_another():
    """A 1 mm^2 square of two triangles hung on the sheet's border edge: seen from the sheet, one
    flap of both; seen from its outer triangle alone, that triangle hangs on the square's diagonal
    (a flap on its own, its outer node in it only)."""
    model, mine = sheet_with_hung(*SQUARE)
    sheet_side = (model.index.triangles_with_edge(RIGHT[2], RIGHT[3]) - set(mine)).pop()
    assert flaps_from(model, [sheet_side], 1.5 * MM2, 8) == [(set(mine), (RIGHT[2], RIGHT[3]))]
    assert flaps_from(model, mine[:1], 1.5 * MM2, 8) == [({mine[0]}, (RIGHT[2], N * N + 1))]
    assert only_in(model, set(mine), [N * N, N * N + 1]) and only_in(model, {mine[0]}, [N * N])


def test_a_piece_over_the_area_or_the_triangle_count_is_no_flap():
    """The hung triangle (0.5 mm^2) is no flap below 0.4 mm^2; the square seen from the sheet is
    none when one triangle is searched."""
    model, mine = sheet_with_hung(*FLAP)
    assert flaps_from(model, mine, 0.4 * MM2, 8) == []
    model, mine = sheet_with_hung(*SQUARE)
    sheet_side = (model.index.triangles_with_edge(RIGHT[2], RIGHT[3]) - set(mine)).pop()
    assert flaps_from(model, [sheet_side], 1.5 * MM2, 1) == []


def test_a_piece_held_by_two_edges_or_at_a_node_is_no_flap():
    """A triangle hung on one border edge whose third node a second triangle joins to the sheet
    further up (a bow-tie) is held by more than the edge, and so is a ribbon hung at both ends."""
    bow = ([[N, 3.0, 0.0]], [[RIGHT[1], N * N, RIGHT[2]], [RIGHT[4], RIGHT[5], N * N]])
    ribbon = ([[N, 1.5, 0.0], [N, 3.5, 0.0]],
              [[RIGHT[1], N * N, RIGHT[2]], [RIGHT[2], N * N, N * N + 1], [N * N + 1, RIGHT[4], RIGHT[3]],
               [RIGHT[2], N * N + 1, RIGHT[3]]])
    for points, tri in (bow, ribbon):
        model, mine = sheet_with_hung(points, tri)
        assert not only_in(model, {mine[0]}, range(N * N, model.node_count))
        assert flaps_from(model, mine, 10 * MM2, 8) == []


def test_a_pinned_or_kept_or_untouched_piece_is_no_flap():
    """The hung triangle is held when its node is pinned, waits while it is a node the next event
    closes onto (``keep``), and is the mesh as it was given when the cut touched none of its nodes."""
    pinned = np.zeros(N * N + 1, dtype=bool)
    pinned[N * N] = True
    model, mine = sheet_with_hung(*FLAP, pinned=pinned)
    assert flaps_from(model, mine, 1.5 * MM2, 8) == []
    model, mine = sheet_with_hung(*FLAP)
    assert flaps_from(model, mine, 1.5 * MM2, 8, keep={N * N}) == []
    model, mine = sheet_with_hung(*FLAP, touched=False)
    assert flaps_from(model, mine, 1.5 * MM2, 8) == []


def test_freed_pieces_remove_a_flap_and_the_flaps_it_leaves():
    """A triangle hung on the outer edge of the hung square, seeded alone: a flap on that edge;
    once it is gone the square's outer triangle hangs on the diagonal, then the inner one on the
    sheet's edge: all three go, with their three nodes, and the sheet stays whole."""
    points = SQUARE[0] + [[N + 1, 2.5, 0.0]]
    tri = SQUARE[1] + [[N * N, N * N + 2, N * N + 1]]
    model, mine = sheet_with_hung(points, tri)
    editor = TopologyEditor(model)
    freed = FreedPieces(editor, 0.0, 0, keep_islands=False, flap_area=2.0 * MM2, flap_triangles=8)
    editor.begin()
    assert freed.remove_flaps({mine[2]}, keep=set()) == 3
    editor.finish()
    assert not model.active[N * N:].any()
    assert model.active.sum() == N * N and model.triangle_count == 2 * (N - 1) ** 2


def flap_made_again():
    """The sheet with the hung triangle, in an edit begun that made the triangle again (as a
    cut's fill makes it): (model, editor, its ``FreedPieces`` with flaps under 1.5 mm^2)."""
    model, mine = sheet_with_hung(*FLAP)
    editor = TopologyEditor(model)
    freed = FreedPieces(editor, 0.0, 0, keep_islands=False, flap_area=1.5 * MM2, flap_triangles=8)
    corners = model.triangle_table.column("corners")[mine].copy()
    editor.begin()
    editor.delete_triangles(mine)
    editor.add_triangles(corners, model.points)
    return model, editor, freed


def test_an_edit_that_leaves_a_flap_removes_it():
    """The hung triangle made again in an edit (as a cut's fill makes it): ``after_edit`` removes
    it as a flap, one triangle, and nothing else; with ``keep`` holding its node it stays."""
    for keep, flaps in ((set(), 1), ({N * N}, 0)):
        model, editor, freed = flap_made_again()
        assert freed.after_edit(keep=keep) == Freed(0, flaps, 0)
        editor.finish()
        assert model.triangle_count == 2 * (N - 1) ** 2 + 1 - flaps


def test_a_flap_holding_a_node_of_the_slit_being_cut_waits_for_the_incisions_end():
    """The hung triangle made again in an edit while its node is a node of the incision's slit:
    it stays (the next events re-mesh round that slit); at the incision's end it goes."""
    model, editor, freed = flap_made_again()
    assert freed.after_edit(keep=set(), slit={N * N}) == Freed(0, 0, 0)
    assert freed.at_incision_end() == Freed(0, 1, 0)
    editor.finish()
    assert not model.active[N * N] and model.triangle_count == 2 * (N - 1) ** 2
