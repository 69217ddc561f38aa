"""The three-stage cut (kernels/cutting.py, warp_cut/cut/) on a resting patch: Stage 1 kernels
against brute force, and whole cuts against the rules the cut states for itself.

The cuts here are driven directly (``Cutter.start_incision`` / ``extend_incision`` /
``end_incision``) on a patch that takes no physics step, so every node is where the cut put it
and each rule (station spacing, lip offset, deviation, open slit, stable step) can be checked
exactly. tests/test_cut_scenes.py runs the bundled scenes, with physics.
"""

import math
from dataclasses import dataclass

import numpy as np
import pytest
import warp as wp
from conftest import DEVICE, grid_without
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from warp_cut import Material, Simulator, TissueModel, Tool, stable_time_step
from warp_cut.cut.classes import NodeClass, SpringClass
from warp_cut.cut.remesh.layout import Refusal, SlitDoesNotFit
from warp_cut.cut.settings import CutSettings
from warp_cut.cut.sweep.tissue_at_rest import on_triangles, tissue_near
from warp_cut.cut.tolerances import EXIT_ADVANCE, LAST_STATION, MIN_ADVANCE
from warp_cut.cut.topology import TopologyEditor
from warp_cut.errors import InputError
from warp_cut.kernels.cutting import capsule_node_hits_among, capsule_spring_hits_among
from warp_cut.mesh.checks import check_mesh
from warp_cut.mesh.geometry import triangle_min_angles
from warp_cut.mesh.surfaces import cylinder, dome, flat_grid, jittered_delaunay, saddle
from warp_cut.mesh.triangulate import border_loop_count
from warp_cut.sim import strokes
from warp_cut.verify.stroke_check import run_stroke
from warp_cut.verify.stroke_quality import new_rest_edges, original_border
from warp_cut.verify.validity import cut_problems

SPACING = 0.002
"""Node spacing of the test patches [m]."""

MIN_ANGLE_DEG = 20.0
"""Smallest angle [deg] a triangle the cut makes may have in the rest shape (SPEC: the cut is
decided in the rest shape). A thin triangle gives its nodes little lumped mass (one third of its
small area) while its springs keep their stiffness, so it shrinks the stable step ~ sqrt(m / k)."""


# ------------------------------------------------------------------ Stage 1 kernels
def seg_dist(p, a, b):
    ab = b - a
    t = np.clip(((p - a) @ ab) / max(ab @ ab, 1e-300), 0, 1)
    return np.linalg.norm(p - (a + np.outer(t, ab)), axis=1)


def seg_seg_dist(p0, p1, q0, q1, samples=2001):
    """Brute force: minimum over a fine grid of the first segment of the point-segment distance."""
    s = np.linspace(0, 1, samples)[:, None]
    return seg_dist(p0 + s * (p1 - p0), q0, q1).min()


def run_hits(kernel, dim, inputs):
    """Launch a Stage 1 kernel over every index 0..dim-1 as its candidates."""
    hits = wp.zeros(4096, dtype=wp.int32, device=DEVICE)
    count = wp.zeros(1, dtype=wp.int32, device=DEVICE)
    candidates = wp.array(np.arange(dim, dtype=np.int32), dtype=wp.int32, device=DEVICE)
    inputs = inputs[:2] + [candidates] + inputs[2:]
    wp.launch(kernel, dim=dim, device=DEVICE, inputs=inputs + [hits, count])
    return set(hits.numpy()[: int(count.numpy()[0])].tolist())


def test_capsule_node_hits_match_oracle():
    rng = np.random.default_rng(0)
    for _ in range(20):
        pts = rng.uniform(-1, 1, (300, 3))
        a, b, r = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3), rng.uniform(0.05, 0.5)
        flags = np.ones(300, np.int32)
        flags[:10] = 0  # deleted nodes are never hit
        got = run_hits(capsule_node_hits_among, 300, [
            wp.array(pts.astype(np.float32), dtype=wp.vec3, device=DEVICE),
            wp.array(flags, dtype=wp.int32, device=DEVICE), wp.vec3(*a), wp.vec3(*b), float(r)])
        d = seg_dist(pts.astype(np.float32).astype(float), a, b)
        clear = np.abs(d - r) > 1e-5
        want = set(np.flatnonzero((d < r) & (flags == 1) & clear).tolist())
        assert got - set(np.flatnonzero(~clear)) == want


def test_capsule_spring_hits_match_brute_force():
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1, 1, (60, 3))
    springs = rng.integers(0, 60, (200, 2))
    springs = springs[springs[:, 0] != springs[:, 1]]
    springs[:5] = -1  # dead slots
    for _ in range(5):
        a, b, r = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3), rng.uniform(0.05, 0.4)
        got = run_hits(capsule_spring_hits_among, len(springs), [
            wp.array(pts.astype(np.float32), dtype=wp.vec3, device=DEVICE),
            wp.array(springs.astype(np.int32).ravel(), dtype=wp.int32, device=DEVICE),
            wp.vec3(*a), wp.vec3(*b), float(r)])
        for s, (i, j) in enumerate(springs):
            if i < 0:
                assert s not in got
                continue
            d = seg_seg_dist(pts[i], pts[j], a, b)
            if abs(d - r) > 2e-3:  # away from the boundary (brute force resolution)
                assert (s in got) == (d < r), (s, d, r)


def test_parallel_and_degenerate_segments():
    # a spring parallel to the sweep, at distance 0.5: hit for r = 0.6, not for r = 0.4
    pts = np.array([[0, 0.5, 0], [1, 0.5, 0], [2, 2, 2], [2, 2, 2]], np.float32)
    springs = np.array([[0, 1], [2, 3]], np.int32)
    for r, want in ((0.6, {0}), (0.4, set())):
        got = run_hits(capsule_spring_hits_among, 2, [
            wp.array(pts, dtype=wp.vec3, device=DEVICE),
            wp.array(springs.ravel(), dtype=wp.int32, device=DEVICE),
            wp.vec3(0.2, 0, 0), wp.vec3(0.8, 0, 0), float(r)])
        assert got == want
    # a zero-length sweep is a sphere
    got = run_hits(capsule_node_hits_among, 4, [wp.array(pts, dtype=wp.vec3, device=DEVICE),
                                          wp.array(np.ones(4, np.int32), dtype=wp.int32, device=DEVICE),
                                          wp.vec3(0, 0.4, 0), wp.vec3(0, 0.4, 0), 0.2])
    assert got == {0}


# ------------------------------------------------------------------ helpers for whole cuts
def patch_sim(size=(0.02, 0.02), pinned="border", **cut):
    """A patch of SPACING in the XY plane with a Cutter; no gravity, and no step is taken, so
    every node stays where it was made."""
    model = TissueModel.from_patch(size, SPACING, pinned=pinned)
    sim = Simulator(model, dt=1e-3, gravity=None, device=DEVICE,
                    cutting=CutSettings(**cut))
    return model, sim


def between_rows(model):
    """y [m] halfway between the two lattice rows around y = 0: a cut along it meets no node."""
    rows = np.unique(model.points[:, 1].round(9))
    k = np.searchsorted(rows, 0.0, side="right")
    return 0.5 * (rows[k - 1] + rows[k])


def assert_valid(sim, where=""):
    """Every mesh invariant of SPEC section 3, plus the mass balance and the device mirror."""
    model = sim.model
    areal = model.material.density * model.material.thickness
    rep = check_mesh(sim.positions, model.triangles, model.springs, active=model.active,
                     masses=model.masses, reference_normal=[0, 0, 1],
                     expected_total_mass=areal * model.triangle_areas.sum())
    assert rep.valid, f"{where}: {rep.problems}"
    links = model.links
    assert model.active[links.ravel()].all(), f"{where}: a link refers to a deleted node"
    dm = sim.device_model
    np.testing.assert_array_equal(dm.spring_indices.numpy()[: 2 * model.spring_table.count],
                                  model.spring_table.column("pairs").ravel().astype(np.int32))
    flags = dm.node_flags.numpy()[: model.node_count]
    np.testing.assert_array_equal(flags & 1, model.active.astype(np.int32))
    # the stable step kept up to date edit by edit equals a full recomputation
    assert sim.step_limit.step == pytest.approx(stable_time_step(model).step, rel=1e-9)
    return rep


def cut_along(sim, points, radius=0.001, step=0.0003, check=True):
    """Start at points[0], extend in steps of ``step`` [m] along the polyline, end the incision;
    with ``check``, the mesh is checked after every event and after the end. Like a tool that
    goes on cutting: when the Cutter ends an incision that ran into an opening (the tissue's
    edge, an earlier wound), the next starts where the tool was."""
    cutter = sim.cutter
    points = [np.asarray(p, dtype=np.float64) for p in points]
    cutter.start_incision(sim, points[0], [0, 0, 1], radius)
    last = points[0]
    for a, b in zip(points[:-1], points[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        for k in range(1, n + 1):
            if cutter.current is None:
                cutter.start_incision(sim, last, [0, 0, 1], radius)
            last = a + (b - a) * k / n
            cutter.extend_incision(sim, last)
            if check:
                assert_valid(sim, f"after the cut reached {last}")
    cutter.end_incision(sim)
    if check:
        assert_valid(sim, "after the end of the incision")


def arc(centre, radius, start_deg, stop_deg, step=0.0003):
    """Points (k, 3) [m] every ~``step`` along a circular arc in the XY plane."""
    n = max(2, int(np.ceil(radius * np.radians(abs(stop_deg - start_deg)) / step)) + 1)
    phi = np.radians(np.linspace(start_deg, stop_deg, n))
    return np.column_stack([centre[0] + radius * np.cos(phi), centre[1] + radius * np.sin(phi), np.zeros(n)])


def assert_station_rules(inc):
    """Stations of a finished incision that started in the tissue (``Incision.next_stations``,
    offered up to ``LAST_STATION`` spacings short of the tip at every event): consecutive ones
    exactly a spacing apart, the first at most a spacing from the start (a short first wedge:
    half a spacing at least), the last at least LAST_STATION spacings from the end but less
    than LAST_STATION + 1 (one more would have been offered at ``end_incision`` otherwise)."""
    sp, u = inc.spacing, np.asarray(inc.station_u)
    assert len(u) > 0
    np.testing.assert_allclose(np.diff(u), sp, rtol=1e-9)
    assert 0.5 * sp * (1 - 1e-9) <= u[0] <= sp * (1 + 1e-9), (u[0], sp)
    gap = inc.length - u[-1]
    assert LAST_STATION * sp * (1 - 1e-9) <= gap < (LAST_STATION + 1) * sp * (1 + 1e-9), (gap, sp)


def bridging_edges(inc, x, triangles, samples=33):
    """Edges (e, 2) of ``triangles`` that cross the incision's curve strictly between its start
    and end: tissue closing the slit. Edges at the start or end node (which lie on the curve)
    are left out. An edge with ends on either side is sampled; where the side flips, the edge
    crosses the curve itself if it passes within one sample step of it there (crossing the
    curve's extension beyond an end, it passes the end point at a distance, with u clamped)."""
    edges = np.unique(np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    ends = [v for v in (inc.start_node, inc.tip_node) if v >= 0]
    edges = edges[~np.isin(edges, ends).any(axis=1)]
    side = inc.project(x[edges.ravel()])[1].reshape(-1, 2)
    edges = edges[side[:, 0] != side[:, 1]]
    if not len(edges):
        return edges
    s = np.linspace(0.0, 1.0, samples)
    a, b = x[edges[:, 0]], x[edges[:, 1]]
    u, side, dist = (v.reshape(len(edges), samples) for v in
                     inc.project((a[:, None] + s[None, :, None] * (b - a)[:, None]).reshape(-1, 3)))
    k = np.argmax(side[:, 1:] != side[:, :-1], axis=1)
    rows = np.arange(len(edges))
    step = np.linalg.norm(b - a, axis=1) / (samples - 1)
    near = np.minimum(dist[rows, k], dist[rows, k + 1]) <= step
    inside = (u[rows, k] > 1e-12) & (u[rows, k] < inc.length - 1e-12)
    return edges[near & inside]


def border_loop(triangles, start):
    """The loop of border edges (each used by one triangle) through node ``start``: its nodes
    from ``start`` on, in the direction of the triangles' winding ([] if ``start`` is not on
    the border; the winding is consistent, so the border edges chain into directed loops)."""
    half = {(int(a), int(b)) for a, b in triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)}
    after = {a: b for a, b in half if (b, a) not in half}
    loop, v = [start], after.get(start)
    while v is not None and v != start and len(loop) <= len(after):
        loop.append(v)
        v = after.get(v)
    return loop if v == start else []


def assert_open_slit(sim, inc, geometric=False):
    """The slit of a finished incision is open along its whole length: the start node, every
    station's two lip nodes and the tip are alive, and the mesh's border runs round the slit
    through them - from the start up the left lip (the winding's way round, the tissue on the
    border's left) through its lips in station order to the tip, and back down the right lip's.
    Between them the border passes only nodes the incision put on its slit (``slit_nodes``: the
    refinement splits the slit's edges), never a node of the other lip or of the tissue: no
    triangle joins the two lips, none buries a lip inside the tissue. ``geometric`` (a patch
    that has not moved; checked in the rest shape, where the cut is decided): every station's
    lips lie on their own side of the final curve, lip_offset off it and at their station's arc
    length to within the fit ``tolerance`` (the refits after a lip was made move the curve by
    no more), and no edge between two tissue nodes crosses the curve between its ends. (The
    slit's own edges are straight chords between its nodes: on a curved path the chord from
    the start to the first lips may pass a few um across the curve, so they are not tested so.)"""
    model = sim.model
    active = model.active
    assert all(v >= 0 and active[v] for v in inc.left + inc.right), (inc.left, inc.right)
    assert inc.start_node >= 0 and active[inc.start_node]
    assert inc.tip_node >= 0 and active[inc.tip_node]
    loop = border_loop(model.triangles, inc.start_node)
    assert inc.tip_node in loop, "the start and the tip are not on one border loop: the slit is closed"
    k = loop.index(inc.tip_node)
    left_arc, right_arc = loop[1:k], loop[k + 1:][::-1]
    lips = set(inc.left + inc.right)
    for arc, own in ((left_arc, inc.left), (right_arc, inc.right)):
        assert [v for v in arc if v in lips] == own, f"border from start to tip: {arc}, its lips: {own}"
        assert set(arc) <= inc.slit_nodes, f"tissue nodes on the slit's border: {sorted(set(arc) - inc.slit_nodes)}"
    if geometric:
        x = model.points
        for own, side in ((inc.left, 1), (inc.right, -1)):
            u, sides, dist = inc.project(x[own])
            assert (sides == side).all(), sides
            np.testing.assert_allclose(dist, inc.lip_offset, atol=inc.tolerance)
            np.testing.assert_allclose(u, inc.station_u, atol=inc.tolerance)
        tissue = model.triangles[~np.isin(model.triangles, list(inc.slit_nodes)).any(axis=1)]
        bridges = bridging_edges(inc, x, tissue)
        assert not len(bridges), f"tissue edges across the slit: {bridges.tolist()}"


def assert_sound_rest_shape(model, made, outward=(0.0, 0.0, 1.0)):
    """The cut's guarantees in the rest shape (``model.points``, where it is decided): every
    triangle it made (rows ``made`` of ``model.triangles``) has a smallest angle of at least
    MIN_ANGLE_DEG, and no live triangle is degenerate or wound against the rest surface, whose
    outward unit normal is ``outward`` (3,) (a flat patch), or ``outward(centroids (t, 3))``
    (t, 3). The rest normals are computed here: twice the area along the outward normal, over
    the longest edge squared, is > 1e-6 (a 20-degree triangle has > 0.1)."""
    p, tri = model.points, model.triangles
    angles = triangle_min_angles(p, tri[made])
    assert len(angles) and angles.min() >= MIN_ANGLE_DEG, np.sort(angles)[:5]
    a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    normal = outward(p[tri].mean(axis=1)) if callable(outward) else np.broadcast_to(outward, a.shape)
    twice_area = np.einsum("ij,ij->i", np.cross(b - a, c - a), normal)
    longest = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                      np.linalg.norm(a - c, axis=1)], axis=0)
    ratio = twice_area / longest**2
    bad = np.flatnonzero(ratio <= 1e-6)
    assert not len(bad), f"rest triangles degenerate or wound against the surface: {tri[bad].tolist()}"


def surface_outward(surface):
    """The outward unit normals (t, 3) of ``surface``'s analytic shape at points (t, 3) [m]."""
    return lambda points: surface.chart.normal(surface.chart.uv_of(points))


def stroke(kind, model):
    """(polyline (k, 3) [m], tool radius [m]) of a named test stroke on a 20 mm patch."""
    y = between_rows(model)
    if kind == "between rows":
        return [np.array([-0.006, y, 0.0]), np.array([0.006, y, 0.0])], 0.0006
    if kind == "along a row":  # through nodes and along edges
        return [np.array([-0.006, 0.0, 0.0]), np.array([0.006, 0.0, 0.0])], 0.001
    if kind == "oblique":  # 30 degrees to the rows
        d = 0.005 * np.array([np.cos(np.pi / 6), np.sin(np.pi / 6), 0.0])
        return [-d, d], 0.0008
    return list(arc((0.0, -0.004), 0.006, 30.0, 150.0)), 0.0008  # "arc": 12.6 mm of a 6 mm circle


@dataclass
class PatchStroke:
    """A named stroke cut on a fresh patch by ``cut_along`` (the mesh checked after every event)."""

    model: TissueModel
    sim: Simulator
    points: list
    radius: float
    springs_before: int
    loops_before: int


@pytest.fixture(scope="module")
def patch_stroke():
    """``patch_stroke(kind)``: the ``PatchStroke`` of ``stroke(kind)``, cut once per module (the
    tests only read it)."""
    made: dict[str, PatchStroke] = {}

    def get(kind: str) -> PatchStroke:
        if kind not in made:
            model, sim = patch_sim()
            points, radius = stroke(kind, model)
            springs, loops = model.spring_count, border_loop_count(model.triangles)
            cut_along(sim, points, radius=radius)
            made[kind] = PatchStroke(model, sim, points, radius, springs, loops)
        return made[kind]

    return get


# ------------------------------------------------------------------ whole cuts on a resting patch
def test_straight_cut_structure(patch_stroke):
    """A 12 mm cut between two lattice rows (no node on its path): its length, stations and lips
    where the rules put them, residual links across the cut, every triangle it made >=
    MIN_ANGLE_DEG in the rest shape.

    The curve ends where the last crossing that extended it was: an event whose crossing has
    advanced less than ``MIN_ADVANCE`` spacings along the rest curve waits for the next, and
    ``end_incision`` cuts to the curve's end, so the curve is up to that much shorter than the
    12 mm path (the events here are 0.29 mm apart: the tool's last 0.29 mm extend nothing)."""
    case = patch_stroke("between rows")
    model, sim, radius = case.model, case.sim, case.radius
    y = case.points[0][1]
    inc = sim.cutter.incisions[0]
    assert 0.012 - MIN_ADVANCE * sim.cutter.spacing <= inc.length <= 0.012 * (1 + 1e-9)
    np.testing.assert_allclose(inc.point_at([0.0])[0], case.points[0], atol=1e-12)  # it starts where the tool did
    assert inc.lip_offset == pytest.approx(0.25 * radius)  # the documented default
    assert_station_rules(inc)
    assert inc.start_node >= 0 and inc.tip_node >= 0
    assert min(inc.left + inc.right) >= 0 and model.active[inc.left + inc.right].all()  # both lips
    # every lip at its station, on its own side (left = normal x tangent = +y), lip_offset off,
    # in the rest shape (a straight path is fitted exactly; the layout is snapped to a grid of
    # 1e-6 spacing) and, with no step taken, where it is (float32 positions: 1e-9 more)
    centre = inc.point_at(inc.station_u)
    across = np.array([0.0, inc.lip_offset, 0.0])
    grid = 1e-6 * inc.spacing
    for x, atol in ((model.points, grid), (sim.positions.astype(np.float64), grid + 1e-9)):
        np.testing.assert_allclose(x[inc.left], centre + across, atol=atol)
        np.testing.assert_allclose(x[inc.right], centre - across, atol=atol)
    # the cut springs crossing the line became residual links; each spans the incision: its
    # nodes on either side, and the line between them crosses the swept capsule (the cut's
    # ends and a sweep radius beyond them, the capsule's round caps)
    x = model.points
    assert model.link_count == sim.cutter.totals["residual_links"] > 0
    for i, j in model.links:
        assert (x[i, 1] - y) * (x[j, 1] - y) < 0
        at = x[i, 0] + (y - x[i, 1]) / (x[j, 1] - x[i, 1]) * (x[j, 0] - x[i, 0])
        assert -0.006 - radius <= at <= 0.006 + radius
    assert_sound_rest_shape(model, sim.cutter.live_new_triangles())
    assert model.spring_count != case.springs_before


def test_straight_cut_node_and_spring_classes(patch_stroke):
    """The classes of the between-rows cut as their definitions say (``cut_piece._classify``,
    recomputed here from the springs): every live node of the slit (``slit_nodes``: lips, start,
    tip, the nodes the refinement put on its edges) is LIP and no other node is; every tissue
    node joined to one by a spring is YELLOW if joined to the start or the tip, else BLUE; no
    other node is either (no stale class on a node the cut left); springs joining two slit
    nodes are LIP springs, those joining a slit node to tissue RED."""
    case = patch_stroke("between rows")
    model, inc = case.model, case.sim.cutter.incisions[0]
    cls = model.node_class
    slit = {v for v in inc.slit_nodes if model.active[v]}
    assert {inc.start_node, inc.tip_node, *inc.left, *inc.right} <= slit
    assert set(np.flatnonzero(model.active & (cls == NodeClass.LIP)).tolist()) == slit
    ends = {inc.start_node, inc.tip_node}
    joined: dict[int, set] = {}
    for (i, j), kind in zip(model.springs, model.spring_class):
        i, j = int(i), int(j)
        if i in slit and j in slit:
            assert kind == SpringClass.LIP, (i, j)
        elif i in slit or j in slit:
            assert kind == SpringClass.RED, (i, j)
            tissue, lip = (i, j) if j in slit else (j, i)
            joined.setdefault(tissue, set()).add(lip)
    for v, partners in joined.items():
        assert cls[v] == (NodeClass.YELLOW if partners & ends else NodeClass.BLUE), v
    yellow = np.flatnonzero(model.active & (cls == NodeClass.YELLOW))
    blue = np.flatnonzero(model.active & (cls == NodeClass.BLUE))
    assert set(yellow) | set(blue) == set(joined)
    assert len(yellow) >= 4 and len(blue) >= 2  # both ends have fans on both sides, and the sides rungs


@pytest.mark.parametrize("kind", ["between rows", "along a row", "oblique", "arc"])
def test_finished_stroke_leaves_an_open_slit(kind, patch_stroke):
    """After end_incision: a valid mesh (checked in cut_along), one incision, no hole - exactly
    one border loop more than before (the slit inside the patch), counted from the triangles -
    stations by their rules, the slit open from its start node to its tip, and >= 0.95 of the
    tool's path in the rest shape covered by opened stretches of the incision."""
    case = patch_stroke(kind)
    sim = case.sim
    assert len(sim.cutter.incisions) == 1
    assert border_loop_count(case.model.triangles) == case.loops_before + 1
    assert sim.cutter.unfilled_holes == 0
    inc = sim.cutter.incisions[0]
    assert_station_rules(inc)
    assert_open_slit(sim, inc, geometric=True)
    assert sim.cutter.coverage(sim.positions) >= 0.95


@pytest.mark.parametrize("kind", ["between rows", "along a row", "oblique", "arc"])
def test_finished_stroke_makes_no_sliver(kind, patch_stroke):
    """Every triangle the cut made (and left alive) has a smallest angle >= MIN_ANGLE_DEG in the
    rest shape, and no rest triangle is degenerate or wound against the patch (+z)."""
    case = patch_stroke(kind)
    assert_sound_rest_shape(case.model, case.sim.cutter.live_new_triangles())


@pytest.mark.parametrize("kind", ["between rows", "arc"])
def test_lip_deviation_on_a_resting_patch(kind, patch_stroke):
    """``max_deviation_m`` (the largest distance of a live LIP node from the contact path): the
    slit's nodes (``slit_nodes``: the station lips, made lip_offset off the curve, the start and
    the tip on it, and the points the refinement put on the straight edges between them) are
    its lips; with no step taken nothing moves them, so the measure is their largest distance
    from the path, and that is lip_offset to within the fit ``tolerance`` (plus, on the arc, the
    sagitta s^2 / 8R of the contact path's chords - the measure takes it as a polyline - and of
    the slit's edges between station lips on the inner side, a spacing long on a radius of
    R - lip_offset). Recomputed here from the slit's nodes, independently of their classes."""
    case = patch_stroke(kind)
    sim, model, points = case.sim, case.model, case.points
    inc = sim.cutter.incisions[0]
    m = sim.cutter.metrics(sim.positions)["incision"]
    slit = sorted(v for v in inc.slit_nodes if model.active[v])
    assert set(inc.left + inc.right) <= set(slit)
    x = sim.positions.astype(np.float64)[slit]
    if kind == "arc":
        own = np.abs(np.linalg.norm(x[:, :2] - [0.0, -0.004], axis=1) - 0.006)
        chord = np.linalg.norm(np.diff(np.asarray(inc.contact_path), axis=0), axis=1).max()
        slack = chord**2 / (8 * 0.006)
        lip_chords = inc.spacing**2 / (8 * (0.006 - inc.lip_offset))
    else:
        own, slack, lip_chords = np.abs(x[:, 1] - points[0][1]), 0.0, 0.0
    assert m["max_deviation_m"] == pytest.approx(own.max(), abs=slack + 1e-9)
    assert abs(m["max_deviation_m"] - inc.lip_offset) <= inc.tolerance + slack + lip_chords
    # a flat patch: the 3D distance is the in-plane one
    assert m["max_deviation_3d_m"] == pytest.approx(m["max_deviation_m"], abs=1e-9)


@pytest.mark.parametrize("kind", ["between rows", "oblique"])
def test_a_slit_inside_the_patch_does_not_reach_a_border(kind, patch_stroke):
    """``Incision.reached_border`` ("True once the slit has run into an opening or the tissue's
    edge"): a stroke that stays 4 mm inside the patch never does."""
    case = patch_stroke(kind)
    assert all(np.abs(np.asarray(p)[:2]).max() <= 0.006 for p in case.points)  # the patch spans +-10 mm
    assert not case.sim.cutter.incisions[0].reached_border


def test_latency_has_one_entry_per_event_and_stage(patch_stroke):
    """``latency_ms``: every cut event times each stage once; no bound on the times here (that
    belongs to the benchmarks), only that they are real durations."""
    sim = patch_stroke("oblique").sim
    cutter = sim.cutter
    metrics = cutter.metrics(sim.positions)
    events = metrics["cut"]["events"]
    assert events == cutter.totals["events"] > 0
    for name, values in cutter.latency_ms.items():
        v = np.asarray(values)
        assert len(v) == events and np.all(np.isfinite(v)) and np.all(v >= 0.0), name
        summary = metrics["latency_ms"][name]
        assert summary["events"] == events
        assert 0.0 <= summary["p50_ms"] <= summary["p99_ms"] <= summary["max_ms"] == pytest.approx(v.max())


def test_cut_from_border_to_border_severs_the_patch():
    """A cut across the whole (unpinned) patch, started 2 mm beside it through the direct API
    (``start_incision`` off the skin: the incision starts in the opening beyond the edge, carried
    by the tissue's map nearest it), leaves two pieces joined by no spring."""
    model, sim = patch_sim(size=(0.02, 0.012), pinned="none")
    cut_along(sim, [np.array([-0.012, 0.0, 0.0]), np.array([0.012, 0.0, 0.0])])
    # the two halves share no triangle, spring or link... except residual links across
    x = sim.positions
    for i, j in model.springs:
        assert not (x[i, 1] > 1e-4 and x[j, 1] < -1e-4) and not (x[i, 1] < -1e-4 and x[j, 1] > 1e-4)
    # connectivity through springs: two pieces
    live = np.flatnonzero(model.active)
    assert components(model.node_count, model.springs, live) == 2


def test_a_start_far_from_the_skin_is_refused_with_the_distance_it_needs():
    """start_incision 10 mm beyond the patch's edge (no tissue node within 2.5 spacings): an
    InputError that says how near the skin a start must be, and no incision begun."""
    model, sim = patch_sim()
    reach = f"{2.5 * sim.cutter.spacing:.3g}"  # the lip spacing: the median spring length, ~2 mm
    with pytest.raises(InputError, match=f"not near the skin .* within {reach} m"):
        sim.cutter.start_incision(sim, np.array([0.02, 0.0, 0.0]), [0, 0, 1], 0.001)
    assert sim.cutter.current is None and not sim.cutter.incisions


@pytest.mark.parametrize("offset, joins", [(0.6e-3, True), (1.5e-3, False)])
def test_a_start_the_swept_disc_reaches_from_an_earlier_wound_starts_in_it(offset, joins):
    """A second incision started ``offset`` beside the first's start node, cutting away from it
    with a 1 mm blade: within the blade's radius its start moves onto that node (the swept disc
    reaches the wound) and, starting in the wound, it joins it - both slits make one border
    loop; farther off it starts where it was asked to and makes a loop of its own."""
    model, sim = patch_sim()
    y = between_rows(model)
    loops = border_loop_count(model.triangles)
    cut_along(sim, [[-0.006, y, 0.0], [0.004, y, 0.0]])
    node = sim.cutter.incisions[0].start_node
    assert node >= 0 and model.active[node]
    begin = model.points[node] + np.array([0.0, -offset, 0.0])
    inc = sim.cutter.start_incision(sim, begin, [0, 0, 1], 0.001)
    expected = model.points[node] if joins else begin
    np.testing.assert_allclose(inc.path[0], expected, atol=1e-12)
    assert inc.starts_on_tissue is (not joins)
    for k in range(1, 21):
        sim.cutter.extend_incision(sim, begin + np.array([0.0, -0.0003 * k, 0.0]))
    sim.cutter.end_incision(sim)
    assert_valid(sim, "after the second incision")
    assert border_loop_count(model.triangles) == loops + (1 if joins else 2)


@pytest.mark.parametrize("heading, joins", [(-1.0, True), (1.0, False)])
def test_a_start_moved_into_a_wound_ahead_of_the_blade_moves_back(heading, joins):
    """A second incision started 1.5 mm beside the first's start node with a 2 mm blade: its
    start moves onto that node (the swept disc reaches the wound). Cutting away from the wound
    (a T's stem) keeps it there. Cutting towards it, across the wound, the start moves back to
    where the blade entered once it has travelled: starting in the wound ahead made a path from
    the wound back to the entry and on again (fuzz case 2579376181, stroke 3, a 4.2 mm blade:
    nothing cut, coverage 0)."""
    model, sim = patch_sim()
    y = between_rows(model)
    cut_along(sim, [[-0.006, y, 0.0], [0.004, y, 0.0]])
    node = sim.cutter.incisions[0].start_node
    begin = model.points[node] + np.array([0.0, -0.0015, 0.0])
    inc = sim.cutter.start_incision(sim, begin, [0, 0, 1], 0.002)
    np.testing.assert_allclose(inc.path[0], model.points[node], atol=1e-12)
    for k in range(1, 21):
        sim.cutter.extend_incision(sim, begin + np.array([0.0, heading * 0.0003 * k, 0.0]))
    np.testing.assert_allclose(inc.path[0], model.points[node] if joins else begin, atol=1e-12)
    assert inc.entry is None
    travel = np.diff(np.array(inc.path)[:, 1])
    assert (np.sign(travel) == np.sign(heading)).all()  # no turn in the path: no hairpin
    sim.cutter.end_incision(sim)
    assert_valid(sim, "after the second incision")


def components(node_count, springs, nodes):
    """Number of connected pieces among ``nodes`` through ``springs`` (union-find)."""
    parent = list(range(node_count))

    def root(v):
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    for i, j in springs:
        parent[root(int(i))] = root(int(j))
    return len({root(int(v)) for v in nodes})


def test_cut_through_a_node_and_along_an_edge():
    """A path through nodes and along edges (the degenerate cases of Stage 1) deletes them."""
    model, sim = patch_sim()
    x = model.points
    centre = int(np.argmin(np.linalg.norm(x, axis=1)))
    # along a row of the lattice: the line y = y(centre) passes exactly through nodes and edges
    y = x[centre, 1]
    cut_along(sim, [np.array([-0.005, y, 0.0]), np.array([0.005, y, 0.0])], radius=0.0006)
    assert not model.active[centre]  # a node on the path is inside the swept volume


def test_crossing_an_earlier_cut_and_restarting():
    """A cut across an earlier one, and a tool that stops and goes on, keep the mesh valid."""
    model, sim = patch_sim(size=(0.03, 0.03))
    cut_along(sim, [np.array([-0.008, 0.0, 0.0]), np.array([0.008, 0.0, 0.0])])
    cut_along(sim, [np.array([0.0, -0.008, 0.0]), np.array([0.0, 0.008, 0.0])])
    restarted = len(sim.cutter.incisions)
    # a tool that stops (zero-length moves change nothing) and goes on
    cutter = sim.cutter
    cutter.start_incision(sim, np.array([-0.01, 0.01, 0.0]), [0, 0, 1], 0.001)
    cutter.extend_incision(sim, np.array([-0.006, 0.01, 0.0]))
    version = model.topology_version
    cutter.extend_incision(sim, np.array([-0.006, 0.01, 0.0]))
    assert model.topology_version == version
    cutter.extend_incision(sim, np.array([-0.002, 0.01, 0.0]))
    assert_valid(sim, "after the restart")
    assert len(cutter.incisions) == restarted + 1  # a new start is a new incision


@pytest.mark.parametrize("exit_x", [0.0040, 0.0048, 0.0052, 0.0056])
def test_a_blade_lifted_out_between_two_events_cuts_up_to_where_it_left(exit_x):
    """Events come a lip spacing of the tip's travel apart (the default), so a blade that rises
    out of the skin as it goes may leave it up to a spacing after the last event: the incision
    still reaches where the blade last crossed the skin (the exit point, where the rising tip
    meets the surface), and so does its slit - also where that crossing lies less than the
    least advance an event cuts (``MIN_ADVANCE``) past the path (exit 5.2 mm: it stopped 0.19
    mm short while that held at the exit too). 0.05 spacing: the crossing is on the sagging
    skin, 0.03 mm before the exit point on the rest plane."""
    model, sim = patch_sim(size=(0.03, 0.02))
    tilt, speed, depth, y = math.radians(60.0), 0.02, 1e-3, 0.0007
    axis = np.array([-math.cos(tilt), 0.0, math.sin(tilt)])
    x_in, lowering = -0.006, 0.05

    def pose(t):
        if t < lowering:  # lowered along z onto the path's start
            tip = np.array([x_in, y, 0.004 - (depth + 0.004) * t / lowering])
        else:  # along +x, rising at 45 deg so that the tip comes out of the skin at exit_x
            x = x_in + speed * (t - lowering)
            tip = np.array([x, y, -depth + max(0.0, x - (exit_x - depth))])
        return Tool(tip, tip + 0.04 * axis, 5e-4)

    for _ in range(int((lowering + (exit_x + 0.004 - x_in) / speed) / 1e-3)):
        sim.step(tool=pose)
    sim.step(tool=None)
    assert len(sim.cutter.incisions) == 1
    inc = sim.cutter.incisions[0]
    reach = 0.05 * SPACING
    assert inc.path[-1][0] == pytest.approx(exit_x, abs=reach)
    assert inc.cut_point[0] == pytest.approx(exit_x, abs=reach)
    assert_valid(sim, "after the blade left")


# ------------------------------------------------------------------ stable step of a cut mesh
def stiffness_matrix(model, x):
    """Dense stiffness K = -dF/dx (3n, 3n) [N/m] of the live springs and residual links at
    positions x: a spring k (|d| - L0) d/|d| has the Jacobian block k (u u^T + (1 - L0/L)
    (I - u u^T)), a link F d / sqrt(|d|^2 + eps^2) the block F / r (I - d d^T / r^2)."""
    n = model.node_count
    K = np.zeros((3 * n, 3 * n))
    eye = np.eye(3)

    def add(i, j, block):
        for a, b, s in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            K[3 * a:3 * a + 3, 3 * b:3 * b + 3] += s * block

    for (i, j), k, rest in zip(model.springs, model.stiffness, model.rest_lengths):
        d = x[j] - x[i]
        length = np.linalg.norm(d)
        uu = np.outer(d, d) / length**2
        add(i, j, k * (uu + (1.0 - rest / length) * (eye - uu)))
    for (i, j), force, eps in zip(model.links, model.link_force, model.link_smoothing):
        d = x[j] - x[i]
        r = math.sqrt(d @ d + eps * eps)
        add(i, j, force / r * (eye - np.outer(d, d) / r**2))
    return K


def iteration_radius(K, m, D, h):
    """Spectral radius of one semi-implicit Euler step with implicit damping, linearised:
    v' = (m v - h K x) / (m + h D), x' = x + h v' (per coordinate masses m, damping D)."""
    a = 1.0 / (1.0 + h * D / m)
    B = a[:, None] * (-h * K / m[:, None])
    step = np.block([[np.eye(len(m)) + h * B, h * np.diag(a)], [B, np.diag(a)]])
    return np.abs(np.linalg.eigvals(step)).max()


def test_stable_step_of_a_cut_mesh_against_its_eigenvalues():
    """The explicit step limit kept by the cutter on a cut 12 x 12 mm patch, against the
    eigenvalues of its own stiffness (springs, lip springs and residual links) and masses.

    Undamped, the exact limit is 2 / sqrt(lambda_max(M^-1 K)); the module's Gershgorin bound
    takes lambda_max <= max_i R_i / m_i, R_i <= 2 (S_i + L_i) (S_i: the springs' stiffness sum at
    node i, L_i: the links' largest stiffnesses F / eps; each counted at both ends). It is safe.
    How safe: at the node a of that maximum, a unit in-plane displacement gives the Rayleigh
    quotient of K_aa's in-plane block, whose largest eigenvalue is at least half its trace S_a
    (springs of a flat mesh at their rest length lie in the plane, links add a positive block),
    so lambda_max >= S_a / (2 m_a): the bound is at most 4 (1 + L_a / S_a) too large, and the
    step at most X = 2 sqrt(1 + max_i L_i / S_i) too small.
    Damped (D / m ~ 1e5 / s here, h D / m >> 1), the limit is that of the overdamped motion,
    h < 2 D / lambda_max(K), linear in 1 / lambda: at most X^2 too small. Checked on the
    linearised iteration itself: stable at 0.95 x the step, unstable at X^2 x.
    """
    model, sim = patch_sim(size=(0.012, 0.012))
    y = between_rows(model)
    cut_along(sim, [np.array([-0.004, y, 0.0]), np.array([0.004, y, 0.0])], radius=0.0006, check=False)
    assert model.link_count > 0
    x = sim.positions.astype(np.float64)
    lengths = np.linalg.norm(x[model.springs[:, 1]] - x[model.springs[:, 0]], axis=1)
    np.testing.assert_allclose(lengths, model.rest_lengths, rtol=1e-6)  # at rest: the premise above
    free = model.active & ~model.pinned
    dof = np.repeat(free, 3)
    K = stiffness_matrix(model, x)[np.ix_(dof, dof)]
    m = np.repeat(model.masses, 3)[dof]
    lam = np.linalg.eigvalsh(K / np.sqrt(m)[:, None] / np.sqrt(m)[None, :]).max()
    exact = 2.0 / math.sqrt(lam)
    S = np.zeros(model.node_count)  # springs' stiffness sum at each node [N/m]
    np.add.at(S, model.springs.ravel(), np.repeat(model.stiffness, 2))
    L = np.zeros(model.node_count)  # links' largest stiffness F / eps summed at each node [N/m]
    np.add.at(L, model.links.ravel(), np.repeat(model.link_force / model.link_smoothing, 2))
    X = 2.0 * math.sqrt(1.0 + (L[free] / S[free]).max())
    limit = sim.step_limit
    assert limit.undamped_step <= exact * (1 + 1e-9)
    assert exact <= X * limit.undamped_step, (exact / limit.undamped_step, X)
    # damped: out-of-plane modes have no stiffness at rest (radius exactly 1, ~1e-7 in floats)
    D = np.repeat(model.damping, 3)[dof]
    assert limit.step >= limit.undamped_step
    assert iteration_radius(K, m, D, 0.95 * limit.step) <= 1.0 + 1e-6
    assert iteration_radius(K, m, D, X**2 * limit.step) > 1.0 + 1e-6


# ------------------------------------------------------------------ random cuts
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.integers(2, 5), st.floats(0.3, 1.2))
@example(seed=1, corners=2, radius_in_spacings=1.0)  # starts 1 mm beside the patch: always tried first
def test_random_tool_paths_keep_the_mesh_valid(seed, corners, radius_in_spacings):
    """Random polylines of 2-5 corners, crossing the border or themselves, with random tool
    radii and event steps: the mesh is valid after every event (checked in cut_along). A third
    of them start beside the patch (the start is drawn from a box 2 mm wider on each side)."""
    rng = np.random.default_rng(seed)
    model, sim = patch_sim(size=(0.02, 0.016))
    start = rng.uniform([-0.012, -0.01, 0], [0.012, 0.01, 0])
    pts = [start]
    heading = rng.uniform(0, 2 * np.pi)
    for _ in range(corners - 1):
        heading += rng.uniform(-1.2, 1.2)
        pts.append(pts[-1] + rng.uniform(0.003, 0.01) * np.array([np.cos(heading), np.sin(heading), 0]))
    cut_along(sim, pts, radius=radius_in_spacings * SPACING, step=rng.uniform(0.0002, 0.001))


def disk_point(rng, radius):
    """A point (3,) [m] uniformly distributed in the disk of ``radius`` about the origin."""
    r, phi = radius * math.sqrt(rng.uniform()), rng.uniform(0, 2 * np.pi)
    return np.array([r * math.cos(phi), r * math.sin(phi), 0.0])


def disk_cut(seed, radius_in_spacings, check=True):
    """Cut a straight stroke into a jittered Delaunay disk (radius 12 mm, jitter 0.25 spacing)
    made from ``seed``, between two random points at least 2 spacings apart, with a tool of
    ``radius_in_spacings`` spacings; returns the simulator. Both ends lie a tool radius and 2
    spacings inside the pinned border: the swept capsule plus the grey area (the triangles it
    touches, up to a spacing beyond it) stay clear of the tissue's edge, where the Cutter
    would end the incision (one that runs into an opening ends there)."""
    rng = np.random.default_rng(seed)
    surface = jittered_delaunay(radius=0.012, spacing=SPACING, jitter=0.25, seed=int(rng.integers(2**31)))
    sim = Simulator(TissueModel.from_surface(surface), dt=1e-3, gravity=None, device=DEVICE, cutting=CutSettings())
    radius = radius_in_spacings * SPACING
    inner = 0.012 - radius - 2 * SPACING
    a = disk_point(rng, inner)
    b = disk_point(rng, inner)
    while np.linalg.norm(b - a) < 2 * SPACING:
        b = disk_point(rng, inner)
    cut_along(sim, [a, b], radius=radius, step=rng.uniform(0.0002, 0.001), check=check)
    return sim


@settings(max_examples=10, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.floats(0.3, 1.2))
def test_random_strokes_on_a_jittered_delaunay_disk(seed, radius_in_spacings):
    """An irregular mesh: a straight stroke keeps the mesh valid after every event and leaves
    one incision, no hole (two border loops, counted from the triangles), the slit open and
    every triangle it made sound in the rest shape (the same 10 examples on every run: a known
    failing case is test_delaunay_disk_stroke_leaves_no_hole)."""
    sim = disk_cut(seed, radius_in_spacings)
    cut = sim.cutter.metrics(sim.positions)["cut"]
    assert cut["incisions"] == 1 and cut["unfilled_holes"] == 0
    assert border_loop_count(sim.model.triangles) == 2  # the disk's rim and the slit: no hole
    assert_open_slit(sim, sim.cutter.incisions[0], geometric=True)
    assert_sound_rest_shape(sim.model, sim.cutter.live_new_triangles())


def test_delaunay_disk_stroke_leaves_no_hole():
    """A case the property test above found: one incision and no hole after the stroke."""
    sim = disk_cut(1124, 0.6253122516287821, check=False)
    cut = sim.cutter.metrics(sim.positions)["cut"]
    assert cut["incisions"] == 1 and cut["unfilled_holes"] == 0, cut


def supported_sim(surface, interval: float, integrator: str = "semi_implicit") -> Simulator:
    """A cutting Simulator on ``surface`` with gravity and the foundation (k_f 1e6 N/m^3), as
    the fuzz cases below ran (``benchmarks/fuzz_cut.py``); events every ``interval`` [s]."""
    model = TissueModel.from_surface(surface, material=Material(foundation_stiffness=1e6))
    return Simulator(model, dt=1e-3, device=DEVICE, integrator=integrator, cutting=CutSettings(interval=interval))


def unsupported_sim(surface, interval: float, integrator: str = "semi_implicit") -> Simulator:
    """A cutting Simulator on ``surface`` without gravity or support, as the fuzz cases below
    ran; events every ``interval`` [s] (0: every step)."""
    model = TissueModel.from_surface(surface)
    return Simulator(model, dt=1e-3, device=DEVICE, integrator=integrator, gravity=None,
                     cutting=CutSettings(interval=interval))


def assert_no_hole_after(sim, surface, path, tool, min_coverage: float = 0.95) -> float:
    """Cut ``path`` with ``tool`` (tilt [deg], radius, depth [m], speed [m/s], length [m]) as one
    valid incision (``one_valid_incision``); no hole is left open after it, and it covers at
    least ``min_coverage`` of the stroke. Returns its coverage."""
    result = one_valid_incision(sim, surface, path, *tool)
    assert result.unfilled_holes == 0
    assert result.coverage >= min_coverage
    return result.coverage


def one_valid_incision(sim, surface, path, tilt_deg, radius, depth, speed, tool_length, border_keys=None):
    """Cut ``path`` with a tool of the given tilt [deg], radius, depth [m], speed [m/s] and
    length [m]; assert no exception, no edit error (folds by the motion aside) and one
    incision; return the StrokeResult (``border_keys``: the tissue's own border, whose
    openings its coverage leaves out, ``run_stroke``)."""
    stroke = strokes.Stroke(surface, path, tilt=math.radians(tilt_deg), radius=radius, depth=depth, speed=speed,
                            tool_length=tool_length, margin=3e-3)
    result = run_stroke(sim, stroke, surface, border_keys=border_keys)
    assert result.exception is None, result.traceback
    assert not {name for name in result.violations if not name.startswith("tri_flipped")}, result.violations
    assert result.incisions == 1
    return result


def border_edges(triangles) -> np.ndarray:
    """Sorted node pairs (e, 2) of the edges of exactly one of ``triangles`` (t, 3)."""
    edges, counts = np.unique(np.sort(np.asarray(triangles)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1),
                              axis=0, return_counts=True)
    return edges[counts == 1]


@dataclass
class CutStroke:
    """A stroke cut by ``cut_stroke`` and the tissue as it was when it began."""

    stroke: strokes.Stroke
    result: object
    triangles_before: np.ndarray
    loops_before: int


def cut_stroke(sim, surface, path, tool) -> CutStroke:
    """``one_valid_incision`` of ``path`` with ``tool`` (tilt [deg], radius, depth [m], speed
    [m/s], length [m]), with the tissue's triangles and border loops before it."""
    before = sim.model.triangles.copy()
    loops = border_loop_count(before)
    result = one_valid_incision(sim, surface, path, *tool)
    stroke = strokes.Stroke(surface, path, tilt=math.radians(tool[0]), radius=tool[1], depth=tool[2], speed=tool[3],
                            tool_length=tool[4], margin=3e-3)
    return CutStroke(stroke, result, before, loops)


def end_allowance(sim, stroke) -> float:
    """How much of its trace's end [m] a stroke may leave unopened: the rest curve ends at the
    blade's last crossing before it left the skin if that lies at least ``EXIT_ADVANCE``
    spacings past it, and at the material point under the blade then, which the tool has
    pushed out of its cylinder: up to its radius from where the trace lies at rest."""
    return EXIT_ADVANCE * sim.cutter.spacing + stroke.radius


def over_triangles(uv: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Mask (m,) of the parameter points ``uv`` (m, 2) inside one of the triangles with parameter
    corners ``corners`` (t, 3, 2), either winding."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]

    def turn(p, q, r):  # (m, t): z of (q - p) x (r - p) for the sample points r
        pq = (q - p)[None]
        return pq[..., 0] * (r[:, None, 1] - p[None, :, 1]) - pq[..., 1] * (r[:, None, 0] - p[None, :, 0])

    z = np.stack([turn(a, b, uv), turn(b, c, uv), turn(c, a, uv)])
    return ((z >= 0).all(axis=0) | (z <= 0).all(axis=0)).any(axis=1)


def opened_fraction(sim, surface, cut: CutStroke, upto: float) -> float:
    """Fraction of ``cut``'s trace (the tool's path on the rest surface) from its start to arc
    length ``upto`` [m] that the cut has opened, computed here from the triangles: a trace point
    is open when, on its left and on its right, edges of the wound (border edges of the live mesh
    that were not border edges when the stroke began) pass within ``tol`` = 0.5 spacing + 0.25
    tool radius (a lip pair straddles the curve at 0.25 r) of it, or the opening it lies in
    reaches past that (it and the point ``tol`` to that side are over no live triangle: the
    tissue between the slit and an earlier wound went, a flap the cut left); in the surface's
    parameter plane, at rest. Trace points over no triangle when the stroke began (an earlier
    wound) are left out."""
    stroke, model = cut.stroke, sim.model
    s = np.arange(0.0, upto, surface.spacing / 20.0) + surface.spacing / 40.0
    s = s[s < upto]
    uv = np.column_stack([np.interp(s, stroke.arclength, stroke.path.uv[:, c]) for c in range(2)])
    ahead = np.column_stack([np.interp(s + 1e-5, stroke.arclength, stroke.path.uv[:, c]) for c in range(2)]) - uv
    before = surface.uv_of(model.points[cut.triangles_before]).reshape(-1, 3, 2)
    now = surface.uv_of(model.points[model.triangles]).reshape(-1, 3, 2)
    over_skin = over_triangles(uv, before)
    old = {tuple(e) for e in border_edges(cut.triangles_before).tolist()}
    wound = np.array([e for e in border_edges(model.triangles).tolist() if tuple(e) not in old]).reshape(-1, 2)
    if not len(wound) or not over_skin.any():
        return 0.0
    tol = 0.5 * surface.spacing + 0.25 * stroke.radius
    p, q = surface.uv_of(model.points[wound[:, 0]]), surface.uv_of(model.points[wound[:, 1]])
    pq = q - p
    t = np.clip(((uv[:, None] - p[None]) * pq[None]).sum(axis=2) / (pq * pq).sum(axis=1)[None], 0.0, 1.0)
    rel = p[None] + t[..., None] * pq[None] - uv[:, None]
    near = np.linalg.norm(rel, axis=2) <= tol
    side = ahead[:, None, 0] * rel[..., 1] - ahead[:, None, 1] * rel[..., 0]
    left = tol * np.column_stack([-ahead[:, 1], ahead[:, 0]]) / np.linalg.norm(ahead, axis=1)[:, None]
    in_opening = ~over_triangles(uv, now)
    gone = [in_opening & ~over_triangles(uv + k * left, now) for k in (1.0, -1.0)]
    opened = ((near & (side > 0)).any(axis=1) | gone[0]) & ((near & (side < 0)).any(axis=1) | gone[1])
    return float(opened[over_skin].mean())


def assert_cut_guarantees(sim, surface, cut: CutStroke, *, joins: bool, min_opened: float = 0.95) -> None:
    """The new cut's guarantees after a stroke (``cut_stroke``), computed from the mesh: every
    triangle the cutter made >= MIN_ANGLE_DEG and none, nor any rest triangle, degenerate or
    wound against the surface in the rest shape; no hole: the stroke adds one border loop
    (a slit inside the tissue), none if it ``joins`` an earlier wound (crosses it, starts or
    ends in it: its slit opens into that wound's loop); and it opens at least ``min_opened``
    of its trace short of the ``end_allowance``."""
    model = sim.model
    assert_sound_rest_shape(model, sim.cutter.live_new_triangles(), surface_outward(surface))
    assert border_loop_count(model.triangles) == cut.loops_before + (0 if joins else 1)
    assert opened_fraction(sim, surface, cut, cut.stroke.length - end_allowance(sim, cut.stroke)) >= min_opened


def test_a_hole_a_thick_tool_leaves_at_the_stroke_end_is_closed_over():
    """A tool thicker than the spacing (r 2.0 mm on a 1.7 mm grid, tilted 64 degrees, gravity
    and the foundation on) pushes a lip across the curve near the stroke's end: the hole left
    there touches the slit at that one lip, so no fill can close it without joining the slit's
    sides. Once the tool has gone it is closed over (the slit stays closed there): no hole is
    left, the mesh stays valid after every event, one incision, and most of the stroke is
    still opened (coverage 0.77; 0.85 with the hole left open before)."""
    surface = flat_grid(0.0413111842029696, 0.00171044765737931)
    sim = supported_sim(surface, 0.03310187971208809)
    path = strokes.line([-0.0111884457216376, 0.0014753994358203404], 5.602684401619392, 0.016273897858153114)
    result = one_valid_incision(sim, surface, path, 63.78196440257604, 0.0020073533581260626, 0.002160665425005849,
                                0.008160930801347761, 0.048489289974786604)
    assert result.unfilled_holes == 0
    assert result.coverage >= 0.75  # 0.77: the closed-over end stays closed (0.85 with the hole open)


def test_a_thick_tool_crossing_an_earlier_opening_stays_one_incision():
    """Three strokes of thick tools (r 3.6-5.2 mm on a 2.9 mm grid, gravity and the foundation
    on): the third, a line, crosses the wide opening the first two left. While it is over the
    opening, its own hole has no lips yet, so no skin surrounds its axis and no crossing is
    found; the tip is still 1.2 mm below the skin, so the incision waits there instead of
    ending and starting again (it became two incisions)."""
    surface = flat_grid(0.0479586148771218, 0.002923193205568173)
    sim = supported_sim(surface, 0.030860677508215306)
    specs = [
        (strokes.zigzag([-0.0014987067149100572, 0.00883448168789086], 5.472114512167781, 0.01139304397733941,
                        0.00374454823395368, 0.029307810080878727),
         31.434355286440386, 0.005178034305449886, 0.00363723029017871, 0.019442849658450164, 0.0418123677495136),
        (strokes.zigzag([0.010176964066058922, 0.01004671216539704], -2.360217692093031, 0.01230117570396961,
                        0.005189360818286968, 0.027361463815118815),
         33.8320394510999, 0.003576730899440541, 0.0018040508577689845, 0.03794298327709725, 0.03521691263450564),
        (strokes.line([-0.0028115038724116598, 0.005818055531331222], 0.29953961627264175, 0.010425107465018471),
         53.97118062358926, 0.004236411856100555, 0.001165553567717782, 0.005742747775174831, 0.0422535826347943),
    ]
    for spec in specs:
        assert one_valid_incision(sim, surface, *spec).unfilled_holes == 0


def test_a_thick_tilted_zigzag_on_a_turned_grid_keeps_the_cut_guarantees():
    """A thick tilted tool (r 3.0 mm on a turned 2.5 mm grid, 68 degrees, zigzag, gravity and the
    foundation on): the stroke that pushed the left lip of its second station across the curve
    when lips were placed where the deformed tissue lay (its station then got a new lip). Lips
    are now made in the rest shape, lip_offset off the rest curve on their own side, whatever
    the tool does to the tissue; the stroke keeps the cut's guarantees (``assert_cut_guarantees``):
    one incision, one border loop more and no hole, sound rest triangles, >= 0.95 of the path
    opened short of the end allowance."""
    surface = flat_grid(0.046358519432367004, 0.0025081214055164476, angle=0.6419714300050896)
    sim = supported_sim(surface, 0.019591422619893557)
    path = strokes.zigzag([-0.007880503116256083, -0.004513425162780224], 1.1241026628893132, 0.021285099203865235,
                          0.004491403806158755, 0.028386547405885997)
    tool = (68.48897595123483, 0.003045800446927011, 0.0028847832181556786, 0.016415276483890354, 0.04411799822184638)
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, path, tool), joins=False)


def test_no_station_falls_due_where_its_lips_would_be_inside_the_tool():
    """A thick tool (r 3.1 mm on a 1.6 mm cylinder mesh, 54 degrees, zigzag, implicit Euler, an
    event every step) pressing the skin down reaches past its footprint on the flat skin, so a
    station fell due while its lips would be made inside the tool. One lip was later found 2 mm
    back along the curve from its station, and the 4-node hole left at the end had a border
    that crossed itself (coverage 0.99, one hole). Stations now fall due only where their lips
    are clear of the tool, and no hole is left."""
    surface = cylinder(0.033275678148163415, 0.04675012323118936, 2.7046781616069744, 0.0016236213288328026,
                       jitter=0.0, seed=1488651322)
    sim = supported_sim(surface, 0.0, integrator="implicit_euler")
    path = strokes.zigzag([0.0008060366074343003, -0.028124999999999997], 3.7427427960919704, 0.01476605955999952,
                          0.003830324950994517, 0.015223373129425647)
    assert_no_hole_after(sim, surface, path, (53.9895543132858, 0.0030763593871296494, 0.0010936698618277225,
                                              0.017234473619472394, 0.035057667163253474), min_coverage=0.95)


def test_lips_twisted_over_each_other_and_tissue_in_the_slit_are_cleared_once_the_tool_has_gone():
    """A tool twice the spacing thick (r 3.6 mm on a 1.8 mm saddle mesh, 33 degrees, an event
    every step) twisted the slit's last lip pair over each other (each on the other's side of
    the curve) and left a tissue node 0.25 mm from the curve: the 18 mm hole ahead could not be
    filled, and was too long to close over (one hole after the stroke; fuzz seed 1). Once the
    tool has gone, nodes standing in the slit go and their stations get new lips."""
    surface = saddle(0.04850410133548761, -18.611081449217387, 0.0018413581101183233, jitter=0.0, seed=600819021)
    sim = supported_sim(surface, 0.0)
    path = strokes.line([-0.007462169436228863, -0.004850410133548758], 6.01835789222103, 0.021744798582825627)
    assert_no_hole_after(sim, surface, path, (32.59183736215099, 0.0036101944392162603, 0.003186312283306847,
                                              0.014123057060406424, 0.04633956705363204), min_coverage=0.95)


def test_a_lip_pushed_across_the_curve_that_closes_a_hole_on_itself_is_cleared_once_the_tool_has_gone():
    """Under XPBD on a saddle (r 2.3 mm, 2 mm mesh, zigzag) a left lip was pushed 1.3 mm onto
    the right side, where it closed the hole ahead of it into a loop through itself: a closed
    border without the slit's start, which no fill offers lips to (one hole; fuzz seed
    20261202). Once the tool has gone, that lip goes and its station gets new lips."""
    surface = saddle(0.049006510705194926, 24.986658289575296, 0.002036486681735016, jitter=0.0, seed=1506422551)
    sim = supported_sim(surface, 0.0025079989036422314, integrator="xpbd")
    path = strokes.zigzag([0.015314534595373411, -0.0052506975755565975], 2.806042396499133, 0.023402563555900126,
                          0.0034542137868626473, 0.0220880207531029)
    assert_no_hole_after(sim, surface, path, (47.34991826731071, 0.0022531012167335304, 0.0028713530799079024,
                                              0.01911516138005591, 0.03986860723458417), min_coverage=0.95)


def test_a_thin_tool_crossing_a_wide_earlier_opening_deep_in_the_skin_stays_one_incision():
    """A 0.5 mm tool 3 mm deep crosses a 6 mm window cut out of a flat sheet earlier: no skin
    meets its axis while it crosses, but its tip stays below the skin around it, so the
    incision waits and goes on beyond the window (two incisions before; fuzz seed 1 split two
    strokes so)."""
    surface = flat_grid(0.04, 0.002)
    model = TissueModel.from_surface(surface, material=Material(foundation_stiffness=1e6))
    editor = TopologyEditor(model)
    editor.begin()
    window = np.flatnonzero((np.abs(model.points[:, 0]) < 0.003) & (np.abs(model.points[:, 1]) < 0.006))
    editor.delete_nodes(window)
    editor.finish()
    sim = Simulator(model, dt=1e-3, device=DEVICE, cutting=CutSettings(interval=0.0))
    path = strokes.line([-0.012, 0.0005], 0.0, 0.024)
    result = one_valid_incision(sim, surface, path, 60.0, 0.0005, 0.003, 0.02, 0.04)
    assert result.unfilled_holes == 0


def test_a_hole_no_fill_closes_once_the_tool_has_gone_is_opened_back_a_station_and_filled():
    """A thin tool (r 0.6 mm, lip offset 0.15 mm) dragged the last lips of a slit on a coarse
    jittered saddle (2.7 mm, XPBD, no support) forward past the tissue beside them: the hole
    ahead could be neither filled nor closed over (one hole; fuzz seed 20261203). Once the
    tool has gone its end lips go and their stations get new ones; the fill then passes."""
    surface = saddle(0.04582273742117599, 26.66958222595919, 0.0026863294259437806, jitter=0.4, seed=942065371)
    sim = unsupported_sim(surface, 0.023303958466318435, "xpbd")
    path = strokes.arc([0.0043878311944394845, -0.00024049369873647123], 2.2096848650338807, 0.010790208620281965,
                       0.024230242039467942)
    assert_no_hole_after(sim, surface, path, (72.24158263016193, 0.0005852419748600667, 0.0035100470154765043,
                                              0.03604300028536338, 0.04108173560605298), min_coverage=0.85)


def s_curve_tool(k: int) -> Tool:
    """Tick k of a scalpel (r 1 mm) leaning back 60 degrees along -x: 200 ticks going 8 mm in,
    then 2 cm/s along y = 8 mm sin(pi x / 2 cm) from x = -2 cm: on the rising part of the
    curve its shaft leans across the path, and it displaces the tissue beside it."""
    axis = np.array([-0.5, 0.0, 0.866])
    x = -0.02 + 2e-5 * max(k - 200, 0)
    tip = np.array([x, 0.008 * np.sin(np.pi * x / 0.02), 0.004]) - min(k, 200) / 200 * 0.008 / 0.866 * axis
    return Tool(p0=tip, p1=tip + 0.04 * axis, radius=0.001)


def test_the_wound_behind_a_tool_crossing_a_curve_is_filled_while_it_cuts():
    """Behind the tool the hole is re-meshed as the tool goes, even where a fill's triangle is
    turned on the skin far from the tool (the tool did not turn it, so waiting for the tool
    to move on would only let the hole grow with it): 1.5 s into the stroke, past the curve's
    bend, the opened incision covers >= 0.9 of the tool's path in the skin, and the lips
    reach to within a few spacings of the tool."""
    model = TissueModel.from_patch((0.10, 0.06), 0.002)
    sim = Simulator(model, dt=1e-3, device=DEVICE, cutting=CutSettings())
    for k in range(1700):
        sim.step(tool=s_curve_tool(k))
    assert cut_problems(sim) == []
    metrics = sim.cutter.metrics(sim.positions)
    assert metrics["cut"]["incisions"] == 1
    assert metrics["incision"]["coverage"] >= 0.9
    lips = np.flatnonzero(model.active & (model.node_class == NodeClass.LIP))
    tool = s_curve_tool(1699)
    crossing = tool.p0 + (0.0 - tool.p0[2]) / (tool.p1[2] - tool.p0[2]) * (tool.p1 - tool.p0)
    assert np.linalg.norm(sim.positions[lips, :2] - crossing[:2], axis=1).min() < 3 * 0.002 + 0.00115



NEARBY_RADII = (0.97, 1.0, 1.03)
"""Tool radii, as multiples of a case's own, over which a case whose outcome hangs on the
exact state of an earlier wound is tested: a small change of the code moves such a stroke's
coverage by tenths at one radius (e.g. 0.56-1.0 over 0.97-1.03 times the first tool's radius
in the two-stroke case below, under the fill that let holes wait), so a single stroke would
test the trajectory, not the rule."""


def test_a_stroke_crossing_an_earlier_cut_joins_it():
    """Two strokes (r 1.4 and 1.2 mm, tilted 68 degrees) on a jittered Delaunay disk under XPBD,
    a cut event every step, the second crossing the first: the case of a hole that ran into an
    earlier wound and was given up while the tool was near. No hole waits now: every event
    fills its region, the slit's band meeting the earlier wound's border where it crosses it.
    The first stroke adds one border loop; the second joins that wound, adding none (a hole
    left would add one); both keep the cut's guarantees (``assert_cut_guarantees``). At the
    first tool's nominal radius only: the cut is decided in the rest shape, so the outcome no
    longer hangs on the earlier wound's exact deformed state as the old fill did."""
    surface = jittered_delaunay(radius=0.018851657020718077, spacing=0.0017195898028990217,
                                jitter=0.1907679837492858, seed=325552691)
    sim = unsupported_sim(surface, 0.0, "xpbd")
    first = strokes.line([0.00802946818590338, 0.007330454779326026], 2.9784904180916874, 0.012959909967617353)
    tool = (68.78039245672159, 0.0014180189906988724, 0.0017277536993699858, 0.026482536380724755,
            0.047225139031902945)
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, first, tool), joins=False)
    second = strokes.line([0.004919762668240229, 0.011482109415071735], 3.627809137004901, 0.011880053388981135)
    tool = (67.67269074797781, 0.0011975799449719209, 0.001663015006235848, 0.030104737768195295,
            0.036669448821860275)
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, second, tool), joins=True)


def test_a_tool_drawn_out_of_its_wound_does_not_start_another_incision():
    """A shallow tool (r 1.7 mm, 34 degrees) drawn out of the skin at its stroke's end on a
    jittered saddle under XPBD (no gravity, no support) lifts the soft skin with it: once the
    incision has ended (tip 1.5 mm above the skin), the skin closed over the tip again and a
    second incision started there, of no length. A new incision does not start with the axis
    at the end of the one just finished: one incision, no hole (one border loop more), and the
    cut's other guarantees (``assert_cut_guarantees``).

    The path is opened short of its last 1.4 mm (0.88 of the whole trace): the skin dragged by
    the shallow tool puts its last crossings 1.3 mm behind the trace's end and its rest points
    0.15 mm further back, and the tool's final stretch, shorter than ``MIN_ADVANCE`` spacings,
    extends nothing - within the ``end_allowance`` (0.64 + 1.67 mm), which the opened fraction
    leaves out."""
    surface = saddle(0.046828748242237914, -37.63688037070533, 0.002576244845203869, jitter=0.4, seed=1533229460)
    sim = unsupported_sim(surface, 0.011498960362683937, "xpbd")
    path = strokes.line([0.004117361698077476, 0.005860798168576985], 4.4807667634299495, 0.0145561642047078)
    tool = (34.06093300662745, 0.0016698938272158923, 0.0035156924137645794, 0.03033737769713525, 0.03350733370293171)
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, path, tool), joins=False)


def test_a_thick_upright_tool_on_a_jittered_disk_keeps_the_cut_guarantees():
    """A thick upright tool (r 1.8 mm, 75 degrees) on a jittered Delaunay disk under XPBD: the
    stroke on which a tissue node near a station's lip point was taken as its lip out of turn
    when lips were placed by the deformed tissue (every fill then turned a triangle over).
    Lips are made in the rest shape now, new nodes all; the stroke keeps the cut's guarantees
    (``assert_cut_guarantees``): one incision, one border loop more, sound rest triangles,
    >= 0.95 opened short of the end allowance (the whole trace: 0.949, its last 0.7 mm not)."""
    surface = jittered_delaunay(radius=0.025308066932872474, spacing=0.0023498724024553705,
                                jitter=0.2163162961711657, seed=1160903577)
    path = strokes.line([0.006792538822878467, 0.004017769504807994], 3.68207020697412, 0.01590446732222027)
    tool = (74.5399617658142, 0.0018056422442688023, 0.0022504985879017846, 0.01630176602147304,
            0.04970137088697704)
    sim = unsupported_sim(surface, 0.0, "xpbd")
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, path, tool), joins=False)


@pytest.mark.parametrize("turn_deg", [90.0, 120.0])
def test_a_curve_turning_past_the_old_tip_leaves_no_finger_and_no_hole(turn_deg):
    """An incision (r 0.7 mm, lip offset 0.175 mm, an event every 0.33 mm) runs 8 mm along x,
    then turns 90 or 120 degrees and runs 8 mm on. Past its newest lip pair the slit ends in a
    wedge to the tip; round the corner each event's wedge ran straight from that pair to a new
    tip, and the old tip was kept as a finger of opening beside it (0.75 mm off the curve).
    The fingers then closed off as a hole (90 degrees: 3 border loops). The end past the pair is
    cut again at every event: the mesh is valid after every event, the wound is one border
    loop with the patch's, and no node of it lies more than 3 lip offsets off the curve (a lip
    line round the corner lies sqrt(2) lip offsets off it, a node matched to a lip a little
    more)."""
    model, sim = patch_sim((0.04, 0.04), pinned="none")
    y = between_rows(model)
    corner = np.array([0.0, y, 0.0])
    a = math.radians(180.0 - turn_deg)
    end = corner + 0.008 * np.array([math.cos(a), math.sin(a), 0.0])
    cut_along(sim, [corner - [0.008, 0.0, 0.0], corner, end], radius=0.0007, step=0.00033)
    inc = sim.cutter.incisions[-1]
    assert border_loop_count(model.triangles) == 2
    wound = np.unique(border_edges(model.triangles))
    outside = np.abs(model.points[wound]).max(axis=1) > 0.0199  # the patch's own border
    off_curve = inc.project(model.points[wound[~outside]])[2]
    assert off_curve.max() <= 3.0 * inc.lip_offset


def test_a_zigzag_turning_103_degrees_leaves_no_hole_at_its_corners():
    """A zigzag (r 0.67 mm, 44 degrees, corners turning 103 degrees) on a 2.2 mm grid, no
    gravity or support, a cut event every 0.5 ms (fuzz seed 1, case 4045558824): round each
    corner the old slit ends past the newest lip pair stayed as fingers of opening, which a
    later event closed off as 2 holes. The end past the pair is cut again at every event: one
    incision, one border loop more, sound rest triangles, >= 0.94 of the path opened. (By this
    test's measure the stroke opens 0.946 of its path, 0.987 by the cut's coverage; before the
    fill was coarsened 0.959 and 0.983. The part left closed is 0.3-0.6 mm at the corner past
    16.8 mm, where this thin tool's slit cuts the corner short, and it moves by about 0.01 with
    the details of the fill, which steer the skin's motion and so where the blade crosses it.)"""
    surface = flat_grid(0.04277129968446817, 0.002241195041240262)
    sim = unsupported_sim(surface, 0.0005038327216963659)
    path = strokes.zigzag([0.0, -0.007776599942630576], 1.972890855632651, 0.016781989574275107,
                          0.0046652740992405945, 0.014835529688710627)
    tool = (44.4817776828733, 0.0006651261687248985, 0.0027350868936785074, 0.012608881008608692,
            0.04424737974781391)
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, path, tool), joins=False, min_opened=0.94)


def test_a_stroke_starting_a_spacing_from_an_earlier_wound_opens_its_way_into_it():
    """Three strokes on a turned 3 mm grid (gravity and the foundation on, fuzz seed 1, case
    1357172982); the third (r 1.1 mm, 71 degrees, an arc) starts 3 mm from the wound the first
    two left and runs on over it. Its run from its start into that wound was too short for a
    station where they fall (0.65 spacings from the start, 0.5 before an opening), and both lip
    lines met the wound's border at one node: a band with no area, and the stroke opened none
    of its path (coverage 0). Such a run gets one lip pair halfway: one incision, no hole, and
    the stroke opens its way into the wound (coverage 0.51: the rest of its trace runs along
    the second stroke's slit)."""
    surface = flat_grid(0.039050283219759466, 0.0029823336689411596, angle=0.3517109770606838)
    sim = supported_sim(surface, 0.01636540103378328)
    specs = [
        (strokes.arc([-0.00416528513080508, 0.002631134465468663], 6.220613337255489, 0.010871429476259914,
                     -0.022744106415772996),
         72.63597483263305, 0.002418005493740651, 0.002453681488889775, 0.020982129752588976, 0.03897354256412748),
        (strokes.line([0.0039804798632566245, 0.010587295943053694], -1.7029143792965526, 0.01913320363568534),
         51.73052445598688, 0.0006652473904605798, 0.001546106173900402, 0.029587999065406965, 0.03955774854665074),
        (strokes.arc([0.006945010278207334, 0.0038076518028805706], -2.4504616856823382, 0.011272631257514574,
                     0.016611187783054034),
         70.69537799361527, 0.0010635511921305225, 0.003691779003913939, 0.016954687050706383, 0.040293576417532465),
    ]
    results = [one_valid_incision(sim, surface, *spec) for spec in specs]
    assert all(r.unfilled_holes == 0 for r in results)
    assert results[2].coverage >= 0.5


def test_a_hole_round_the_lost_start_node_is_filled_from_the_lip_it_touches():
    """A zigzag (r 0.91 mm, 71 degrees) on a 1.8 mm cylinder mesh (radius 15.5 mm), a cut event
    every step, no gravity: a later event removed the slit's start node, and the hole round the
    start then touched the slit at one lip only. Its border, a loop from that lip round to
    itself, was filled as if it began at the start: every fill failed, the hole grew to the
    whole incision and stayed open (coverage 0.15, one lip). The loop faces every other slot,
    round the slit from that lip (the start gets a new node): no hole, the stroke opened.
    Later, every event after the sixth was skipped as 'the fill does not lay the slit's points
    [(0, -1)]': the zigzag's refitted curve ran to one side of the old slit end, whose opening
    took in the next station's right lip (0.30 of the path opened); such a lip now moves out
    of it (``event_band.clear_of_old_tip``)."""
    h = 0.0018193460701189281
    surface = cylinder(0.015515766392778598, 0.026, 0.026 / 0.015515766392778598, h)
    sim = unsupported_sim(surface, 0.0)
    path = strokes.zigzag([-0.004920985520213018, -0.001455083929119989], 0.5, 0.008381704527728823, 1.5 * h, 6 * h)
    assert_no_hole_after(sim, surface, path, (71.366061510393, 0.0009096730350594641, 0.002682316691734213,
                                              0.0211849249172829, 0.04), min_coverage=0.85)


def test_a_sliver_the_settling_tissue_makes_after_the_stroke_is_flipped():
    """A thick tool (r 2.7 mm, 40 degrees) on an arc across a turned 3 mm grid, no gravity: the
    fill's triangles were fine when the incision ended, but the tissue settling afterwards
    pulled a lip almost onto the line from the other lip to a border node (a cap of 174
    degrees). Slivers are flipped at every event while the tool is away, not only when the
    incision ends: none is left after the stroke."""
    surface = flat_grid(0.04227846617263268, 0.002987891284247694, angle=0.8319276727450665)
    sim = unsupported_sim(surface, 0.005277103566928939)
    path = strokes.arc([-0.00109728007205582, -0.005128127063478125], 6.260961398504918, 0.013150921325622351,
                       0.00978092113110658)
    result = one_valid_incision(sim, surface, path, 39.649784451439864, 0.00274717946471093, 0.003354264661957709,
                                0.03474390778456375, 0.048649142632460306)
    assert result.unfilled_holes == 0
    assert result.slivers == 0, result.min_new_angle_deg


def test_a_lip_pushed_onto_the_curve_does_not_let_the_tissue_close_over_the_slit():
    """A second stroke (an arc, r 1.4 mm, 40 degrees) on a jittered 1.7 mm saddle mesh under
    gravity and the foundation, after a first stroke beside it: a lip of the slit's newest
    station was pushed onto the curve, so the triangle joining it to the other lip and the
    tissue ahead looked as if it lay on one side and was not reopened when the next station
    fell under it. The slit was then closed over event after event (coverage 0.38, a hole
    left open). A triangle joining a left lip to a right lip beyond the tip is across the
    slit wherever its lips lie: the stroke is opened along its whole path."""
    surface = saddle(0.04538366892699154, 24.223395008905776, 0.0016718022507812783, jitter=0.4, seed=571466834)
    sim = supported_sim(surface, 0.028086423723617162)
    first = strokes.line([0.015013965270377813, 0.005339971847125185], 2.77699142741516, 0.011386993042323592)
    one_valid_incision(sim, surface, first, 54.66287201128047, 0.0017997954944738944, 0.0034165456957383385,
                       0.03052109000630958, 0.04355538361749707)
    second = strokes.arc([0.01067311178671475, -0.005291624327062174], 1.5820189707557626, 0.024683978026450934,
                         0.010503226690677606)
    assert_no_hole_after(sim, surface, second, (39.67022651546075, 0.001359424371041138, 0.0031538782484876477,
                                                0.005533953312112034, 0.041035108032011436))


def test_a_closed_hole_touching_the_slit_at_one_lip_is_opened_back_once_the_tool_has_gone():
    """Four strokes on a 1.7 mm dome under XPBD with gravity and the foundation, a cut event
    every step; the last a thick tool (r 3.1 mm, 74 degrees) drawn in a zigzag across the
    earlier cuts. When it left, the tissue beyond its slit's tip was a closed hole of 20
    nodes touching the slit at one lip: no fill closes it without joining the slit's sides,
    and it spans too much of the curve to be closed over, so it stayed open (0.41 of the
    stroke opened). Once the tool has gone, such a hole is opened back by that lip's station
    (as an open one is by its end lips), and the fill gives the stations beyond it their lips.
    Over the last tool's ``NEARBY_RADII``: no hole, and on average more of the stroke opened
    than the 0.41 the hole left (0.16, 0.60 and 0.77 measured; how much of this zigzag across
    three wounds opens hangs on the radius: 0.13-0.65 over 0.97-1.03 with an earlier version
    of the links)."""
    coverage = []
    for scale in NEARBY_RADII:
        surface = dome(0.03824401342193363, 0.02369411738274433, 0.0016640125147081384, seed=1595930803)
        sim = supported_sim(surface, 0.0, "xpbd")
        for path, tool in CLOSED_HOLE_EARLIER_STROKES:
            one_valid_incision(sim, surface, path, *tool)
        last = strokes.zigzag([-0.007002189609525514, -0.010395852182969161], 1.2155217866691008,
                              0.022108052663544143, 0.002603699679355064, 0.012869540201519173)
        tool = (74.3084937751052, scale * 0.0031040609890540314, 0.0025703138063052446, 0.012907917542793617,
                0.042295742719601404)
        coverage.append(assert_no_hole_after(sim, surface, last, tool, min_coverage=0.0))
    assert np.mean(coverage) > 0.41, coverage


CLOSED_HOLE_EARLIER_STROKES = [
    (strokes.line([-0.006656050058832554, -0.005764308439809899], 1.974226117067275, 0.01176763336215509),
     (45.592824804821774, 0.0022495116386117803, 0.0016801838502343183, 0.014207051494555683, 0.04026428382489911)),
    (strokes.line([-0.010661819499559147, -0.007262831817727671], 1.155171124601644, 0.011697369943822665),
     (33.89031834829305, 0.00045218829778666877, 0.001089240823208989, 0.026982255349827577, 0.03831933222138794)),
    (strokes.arc([-0.016530580950033978, -0.01019973837659601], 1.0565210436312966, 0.02725489014213224,
                 -0.021245425732069566),
     (55.00383399406928, 0.0008959149967073036, 0.0011100664896029773, 0.02826044809026842, 0.04340795717346328)),
]
"""The earlier strokes of the closed-hole case: (path, tool)."""


def three_wounds_case():
    """(surface, Simulator, strokes) of fuzz case 408484264 (seed 1): a jittered 1.7 mm cylinder
    mesh under gravity and the foundation; three strokes (a line, an arc crossing the line, a
    line crossing both), then a zigzag (r 1.8 mm, 68 degrees) across them: (path, tool) each."""
    surface = cylinder(0.03130150261237247, 0.044741808593288995, 2.2685263937178792, 0.001720539860519368,
                       jitter=0.4, seed=1259241167)
    sim = supported_sim(surface, 0.008872471094784336)
    cuts = [
        (strokes.line([-0.00015823494289544699, 0.014529069952606971], 5.378775409428625, 0.023876525727815567),
         (68.77708803935082, 0.002602749535065474, 0.0019267473642884845, 0.005061849641357852,
          0.03497688154405176)),
        (strokes.arc([0.013496449365498587, 0.013279149837227359], -2.195159243914991, 0.02072909612718036,
                     -0.019271772948568813),
         (32.154892698695804, 0.0010904020792632733, 0.001285885024586735, 0.03583557935113656,
          0.045754404165442276)),
        (strokes.line([0.010372971623954036, 0.020718875592195048], -2.0251226717224657, 0.02688637637136526),
         (56.62794726230003, 0.0018819342242904797, 0.0038409024293346258, 0.0068083156315887,
          0.049007669209568755)),
        (strokes.zigzag([0.001359332048389025, 0.012286010060656553], -1.1207695885842939, 0.01119161007651807,
                        0.004992023859504431, 0.01228116090990181),
         (67.55018131375604, 0.00184115080411736, 0.0023291807802089575, 0.005208498318493966,
          0.036714450317080344)),
    ]
    return surface, sim, cuts


def test_an_arc_across_an_earlier_wound_goes_on_past_it():
    """The second stroke of the three-wounds case, an arc (r 1.1 mm, 32 degrees) across the
    first wound: past the wound its slit had ended in the opening, and the next event's first
    sample, at the opening's border, counted as tissue, so the band closed onto the lip pair
    behind the wound; all later events were refused (0.32 of the path opened). A slit that ends
    in an opening goes on from that opening's border; with the crossings in the gaping wound
    carried into its slit (not onto a lip), the arc opens >= 0.8 of its path and joins the wound
    (no border loop more), every event accepted."""
    surface, sim, cuts = three_wounds_case()
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, *cuts[0]), joins=False)
    arc = cut_stroke(sim, surface, *cuts[1])
    assert arc.result.incisions == 1 and arc.result.border_loops_added == 0
    assert sim.cutter.totals["skipped_events"] == 0, sim.cutter.skipped
    assert opened_fraction(sim, surface, arc, arc.stroke.length - end_allowance(sim, arc.stroke)) >= 0.8


@pytest.mark.xfail(strict=True, reason=(
    "regression of the coverage guarantee (at 7817b16): the second stroke (an arc, r 1.1 mm, which "
    "joins the first wound) opens 0.86 of its path short of the end allowance (0.32 before a slit "
    "ending in an opening went on from that opening's border); the zigzag (r 1.8 mm) opens 0.50 "
    "and adds a border loop: its rest curve lies for most of its length in the earlier openings "
    "(the blade's crossings carried into the slits the tool pushes open), where nothing is cut, "
    "so the strips beside an opening (cut/sweep/beside.py) do not reach it (>= 0.85 before the "
    "redesign). At 19ed9c9 the second stroke left rest triangles of 0.001 deg"))
def test_a_zigzag_across_three_earlier_wounds_joins_them():
    """Four strokes on a jittered 1.7 mm cylinder mesh under gravity and the foundation, the last
    a zigzag (r 1.8 mm, 68 degrees) across the three earlier wounds (fuzz case 408484264, seed
    1), once left with a hole of one missing triangle beside the zigzag's end that was refused
    closing over. Nothing is closed over now; every stroke keeps the cut's guarantees
    (``assert_cut_guarantees``): the first adds one border loop, each later one crosses an
    earlier wound and joins it, adding none."""
    surface, sim, cuts = three_wounds_case()
    for k, (path, tool) in enumerate(cuts):
        assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, path, tool), joins=k > 0)


@pytest.mark.xfail(strict=True, reason=(
    "regression of the coverage guarantee: the zigzag's middle leg runs along the first wound, "
    "within about 0.3 mm of its curve for ~8 mm, and the thick tool's (r 2.8 mm) push widens that "
    "wound's opening: the crossings there are carried into the first wound's slit in the rest "
    "shape (BladeContact.material; before 259bf92 onto its lips), and "
    "tissue_at_rest.on_tissue_at_rest takes that stretch as in the opening (edge clearance "
    "1.17 mm), so the band leaves it: one station (at "
    "1.0 mm), 0.48 of the path opened (stroke_quality.coverage; 0.45 short of the end allowance by "
    "opened_fraction)"))
def test_a_thick_zigzag_across_an_earlier_cut_joins_it():
    """A thick tool (r 2.8 mm on a 1.56 mm grid, 46 degrees, gravity and the foundation on)
    drawn in a zigzag across an earlier cut (fuzz case 1461883172, seed 20261216): once a hole
    open to that wound whose fills were put off until it stayed open (coverage 0; a known
    defect then). No fill is put off now; both strokes keep the cut's guarantees
    (``assert_cut_guarantees``): the first adds one border loop, the zigzag joins its wound."""
    surface = flat_grid(0.036629300770886386, 0.0015647787636662376)
    sim = supported_sim(surface, 0.026617031967400742)
    first = strokes.line([-0.0015925782943863667, 0.007461524231106489], 4.082171763108944, 0.013006440877780235)
    tool = (42.66024242951193, 0.0010255224794052317, 0.002633525991210475, 0.03526371591671693, 0.04453941216440853)
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, first, tool), joins=False)
    second = strokes.zigzag([-0.006007462387141013, 0.007435145690268105], -1.4129884219169735, 0.010018133327602931,
                            0.003374948936818331, 0.010120849815772293)
    tool = (45.511919910802334, 0.0028014336635634866, 0.0019813485704094536, 0.02526845832930826,
            0.039908469957029465)
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, second, tool), joins=True)


ZIGZAG_CORNERS = {
    # case 3553598660: r 0.9 mm, 72 degrees, 6.6 mm/s on a turned 2.2 mm grid. At a corner one
    # event left a lone triangle of three lip nodes, 0.17 x 0.11 mm, apart from the tissue: one
    # more border loop after the stroke. It held the newest lip pair the next event closes onto:
    # a scrap (SCRAP_AREA) waits while it does, and goes after. Since a station comes sooner
    # round a sharp bend the corner trims off no fleck (scraps: tests/test_islands.py).
    "fleck_3553598660": ((0.04180556395866199, 0.002155298933406245, 0.9054308440633906), 0.0174190527701845,
                         ([0.0010852060343109259, 0.007539082805061414], 5.610058160419436, 0.016947978218351617,
                          0.004421071785975865, 0.013283373429235103),
                         (71.71438862510428, 0.0008979414892694119, 0.0017136699107866305, 0.006580731192383419,
                          0.035453971742899194)),
    # case 2649647853: r 0.8 mm, 42 degrees, 3.1 cm/s on a turned 2.8 mm grid, with links. With a
    # station a spacing on, the band's straight lip lines cut across the corner, the corner's lip
    # pair went with the island cut off inside it, and the next band closed onto the pair before
    # the corner: one more border loop was left in the tissue.
    "lip_pair_2649647853": ((0.040259136085277085, 0.0027947805060384873, 0.07602181993168088), 0.01777705400405221,
                            ([0.0038513695572780986, 0.006230964062944231], 4.740756483088703, 0.01584235787827188,
                             0.00763991771855002, 0.028395039066569434),
                            (42.26546659686966, 0.0007928880311687104, 0.003722601364148634, 0.030756039857979655,
                             0.048445360119734895)),
}


@pytest.mark.parametrize("case", sorted(ZIGZAG_CORNERS))
def test_a_zigzag_corner_leaves_no_hole_and_opens_the_whole_path(case):
    """Zigzags of the fuzz (seed 1) on turned grids, gravity and the foundation on
    (``ZIGZAG_CORNERS`` says what each corner once left): round a bend of more than
    ``STATION_TURN_DEG`` a station comes sooner, no hole is left and the whole path opens."""
    (size, spacing, angle), interval, zigzag, tool = ZIGZAG_CORNERS[case]
    surface = flat_grid(size, spacing, angle=angle)
    sim = supported_sim(surface, interval)
    assert_no_hole_after(sim, surface, strokes.zigzag(*zigzag), tool)


@pytest.mark.parametrize("angle_deg", [12.0, 18.0])
def test_a_stroke_crossing_an_earlier_wound_at_a_shallow_angle_cuts_on_past_it(angle_deg):
    """A second 22 mm stroke (r 1 mm, 60 degrees) crossing a first one at its middle, 12 or 18
    degrees off its line. Where the band meets the first wound, a thin wedge of tissue lies
    between them, and the band touches the wound's border at a node or at one of its own points:
    the tissue's outline passes that point twice. Each such point is one vertex and its corners
    are the wedges of tissue (``layout._corners``), whose tips go with the band
    (``layout.corner_cut``). Before, a degenerate triangle at a point GEOS gave twice (12
    degrees: coverage 0.88) or a 17 degree corner no fill could mend (18 degrees: 0.50) refused
    the event, and every event after it, until the tool left. Now no event is refused, the
    stroke opens at least 0.9 of its path, and the cut's guarantees hold in the rest shape."""
    surface = flat_grid(0.05, 0.002)
    sim = supported_sim(surface, 1.0 / 60.0)
    tool = (60.0, 0.001, 0.002, 0.02, 0.04)
    one_valid_incision(sim, surface, strokes.line([-0.012, 0.0], 0.0, 0.024), *tool)
    a = math.radians(angle_deg)
    second = strokes.line([-0.011 * math.cos(a), -0.011 * math.sin(a)], a, 0.022)
    result = one_valid_incision(sim, surface, second, *tool)
    assert sim.cutter.skipped == {}
    assert result.coverage >= 0.9
    assert result.slivers == 0 and result.unfilled_holes == 0
    assert_sound_rest_shape(sim.model, sim.cutter.live_new_triangles())


@pytest.mark.parametrize("angle_deg, centre_mm, length_mm", [(12.0, 3.0, 14.0), (16.0, -2.0, 12.0)])
def test_a_stroke_starting_beside_a_wound_and_crossing_it_at_a_shallow_angle_opens_its_path(
        angle_deg, centre_mm, length_mm):
    """A second stroke (r 1 mm, 60 degrees) that starts 1.5 mm beside a first wound and crosses
    it at a shallow angle, as a surgeon's second pass off the first line does, opens >= 0.9 of
    its path, with no cut event refused. At 16 degrees (2 mm back) it opens 0.93: the run from
    its start to the wound, about a spacing, too short for a station where they fall, gets one
    halfway (0.70 before). At 12 degrees (centred 3 mm along) it opens 0.95: the last run, from
    the wound to the tip, gets one halfway too (0.81 before: both its lip lines met the wound's
    border at one node, the tip was never laid and the last event was refused three times)."""
    surface = flat_grid(0.05, 0.002)
    sim = supported_sim(surface, 1.0 / 60.0)
    tool = (60.0, 0.001, 0.002, 0.02, 0.04)
    one_valid_incision(sim, surface, strokes.line([-0.012, 0.0], 0.0, 0.024), *tool)
    a = math.radians(angle_deg)
    start = np.array([centre_mm * 1e-3, 0.0]) - 0.5e-3 * length_mm * np.array([math.cos(a), math.sin(a)])
    result = one_valid_incision(sim, surface, strokes.line(start.tolist(), a, 1e-3 * length_mm), *tool)
    assert result.coverage >= 0.9
    assert sim.cutter.skipped == {}


@pytest.mark.parametrize("angle_deg, radius_mm", [(25.0, 1.5), (35.0, 1.5)])
def test_a_stroke_crossing_a_wound_near_its_end_at_a_shallow_angle_opens_the_run_past_it(
        angle_deg, radius_mm):
    """A second 12 mm stroke (60 degrees, 2 cm/s) whose trace crosses a first wound 25 or 35
    degrees off its line, 3 or 2 mm before its end. Past the wound its curve runs within the
    edge clearance of the wound's border for about a spacing: no sample there is clear of it,
    and at ``BESIDE_RUN`` = 1 spacing no run was long enough for its strip to be cut off, so
    that run stayed uncut (0.78 and 0.86 covered). At half a spacing the strip goes, and the
    stroke opens >= 0.95 of its path with no cut event refused."""
    surface = flat_grid(0.05, 0.002)
    sim = supported_sim(surface, 1.0 / 60.0)
    one_valid_incision(sim, surface, strokes.line([-0.012, 0.0], 0.0, 0.024), 60.0, 0.001, 0.002, 0.02, 0.04)
    a, length, past = math.radians(angle_deg), 0.012, {25.0: 0.003, 35.0: 0.002}[angle_deg]
    start = -(length - past) * np.array([math.cos(a), math.sin(a)])
    result = one_valid_incision(sim, surface, strokes.line(start.tolist(), a, length), 60.0, 1e-3 * radius_mm,
                                0.002, 0.02, 0.04)
    assert result.coverage >= 0.95
    assert sim.cutter.skipped == {}
    assert result.slivers == 0 and result.unfilled_holes == 0
    assert_sound_rest_shape(sim.model, sim.cutter.live_new_triangles())


def test_xpbds_links_leave_the_small_triangles_of_a_crossing_cut_uncrushed():
    """Fuzz case 1773829024: XPBD at one 1 ms substep, residual links, gravity and the
    foundation on a 2 mm grid; a line, a zigzag across it and an arc across both. The arc's
    cut makes small triangles (rest edges down to 0.25 spacings) whose light nodes carry the
    links of the springs it crossed. While a link was softened less than the springs holding
    its nodes (``kernels.residual.link_constraints``) it pulled its pair from 1.29 to 0.70 mm
    and laid a triangle of 27 deg at rest flat (0.01 deg). Now every stroke leaves its
    triangles at least 10 deg as the skin lies, and the cut's guarantees hold at rest."""
    surface = flat_grid(0.03792329682448638, 0.0019671057392551938)
    sim = supported_sim(surface, 0.0, integrator="xpbd")
    cuts = [(strokes.line([0.0049899074769061, -0.0017237862192948372], 3.3752359622888353, 0.01617575447815047),
             (73.82551440849952, 0.0015309562212694004, 0.0011199448045208658, 0.005600496290715482,
              0.04841422389179258)),
            (strokes.zigzag([0.004982398411882598, -0.009363503623281158], -3.875983890383182, 0.018039926726972993,
                            0.0022536564870621503, 0.02046093073744712),
             (38.89453757808428, 0.0004723125812956441, 0.0016257833223895487, 0.008636846108428934,
              0.04940160080798367)),
            (strokes.arc([0.002869057962869493, -0.007043001744858142], -3.651534350706141, 0.01383793268377947,
                         -0.02165012982078109),
             (65.72486066234868, 0.0005928674396894452, 0.002497865643165087, 0.012401524841293234,
              0.04260491930352786))]
    for path, tool in cuts:
        result = one_valid_incision(sim, surface, path, *tool)
        assert result.slivers == 0, result.min_new_angle_deg
    assert_sound_rest_shape(sim.model, sim.cutter.live_new_triangles())


@pytest.mark.parametrize("offset_mm, turn_deg", [(0.4, 0.0), (0.8, 4.0)])
def test_a_stroke_beside_an_earlier_wound_cuts_off_the_strip_between_them(offset_mm, turn_deg):
    """A second 16 mm stroke (r 1 mm, 60 degrees) drawn beside a first one, 0.4 mm off its line,
    or 0.8 mm off and turned 4 degrees: its curve runs nearer the first wound's border than the
    edge clearance (lip offset + CLEARANCE spacings, 0.85 mm), where no slit fits between them,
    and the blade passes through the strip of tissue in between. That strip goes (``beside``):
    the second stroke opens at least 0.95 of its path (``StrokeResult.coverage``: a new opening
    across the trace; before, nothing: coverage 0), joins the first wound (no border loop
    added), and keeps the cut's guarantees in the rest shape with no sliver as the skin lies."""
    surface = flat_grid(0.05, 0.002)
    sim = supported_sim(surface, 1.0 / 60.0)
    tool = (60.0, 0.001, 0.002, 0.02, 0.04)
    one_valid_incision(sim, surface, strokes.line([-0.012, 0.0], 0.0, 0.024), *tool)
    loops = border_loop_count(sim.model.triangles)
    second = strokes.line([-0.008, offset_mm * 1e-3], math.radians(turn_deg), 0.016)
    result = one_valid_incision(sim, surface, second, *tool)
    assert result.coverage >= 0.95
    assert border_loop_count(sim.model.triangles) == loops
    assert result.slivers == 0 and result.unfilled_holes == 0
    assert_sound_rest_shape(sim.model, sim.cutter.live_new_triangles())


def cut_across_a_neck():
    """(model, sim, mask (19,) of the points across the neck that lie over a live triangle at
    rest) after a straight cut along y = 5.6 mm across two openings one cell apart (x 5-6 and
    7-8 mm, y 5-6 mm) in a grid of 1 mm cells, lip offset 0.25 mm; the mesh checked after
    every event."""
    model = grid_without({(5, 5), (5, 7)}, n=14)
    sim = Simulator(model, dt=1e-3, gravity=None, device=DEVICE,
                    cutting=CutSettings(spacing=1e-3, lip_offset=2.5e-4))
    y = 5.6e-3
    cut_along(sim, [[2e-3, y, 0.0], [11e-3, y, 0.0]], radius=1e-3, step=5e-4)
    across = np.column_stack([np.linspace(6.05e-3, 6.95e-3, 19), np.full(19, y), np.zeros(19)])
    chart, rest, _ = tissue_near(model, np.flatnonzero(model.active))
    return model, sim, on_triangles(chart, rest, across)


def test_a_neck_of_tissue_between_two_openings_is_cut_through():
    """The cut of ``cut_across_a_neck``: the neck between the openings (x 6-7 mm) is narrower
    than twice the edge clearance (0.55 mm), so no point of it lies clear of its borders, yet
    the blade passes through it. It is cut through (``tissue_at_rest.necks``; before, the cut
    point moved over it piece by piece and left it whole): no triangle lies over the cut's line
    across the neck at rest, the mesh keeps every invariant after every event, and the cut's
    triangles keep the smallest angle in the rest shape."""
    model, sim, over_neck = cut_across_a_neck()
    assert not over_neck.any()
    assert_sound_rest_shape(model, sim.cutter.live_new_triangles())


def test_a_neck_the_fill_cannot_cut_through_is_left_as_it_was(monkeypatch):
    """The same cut, with a re-mesh that refuses every piece whose slit would cross the neck:
    the event cuts the piece once more with the neck left whole (over an opening, as before
    necks were cut), so no event is refused for it, the neck's tissue stays, and the mesh keeps
    every invariant."""
    import warp_cut.cut.cutter as cutter_module

    real = cutter_module.cut_piece
    tried = []

    def refusing(editor, inc, u, on_tissue, near, positions, **kw):
        x = inc.point_at(u)[:, 0]
        neck = on_tissue & (x > 6.0e-3) & (x < 7.0e-3)
        tried.append(bool(neck.any()))
        if neck.any():
            raise SlitDoesNotFit(Refusal.NO_FILL, "a test refusing the neck")
        return real(editor, inc, u, on_tissue, near, positions, **kw)

    monkeypatch.setattr(cutter_module, "cut_piece", refusing)
    _, sim, over_neck = cut_across_a_neck()
    assert any(tried)  # the neck was tried
    assert Refusal.NO_FILL.value not in sim.cutter.skipped  # the retry without the neck fitted
    assert over_neck.all()


def test_a_zigzags_sharp_corners_leave_no_small_triangle():
    """A thick tool (r 5.3 mm on a 2.7 mm jittered cylinder mesh, 66 degrees, gravity and the
    foundation on) cutting a zigzag that turns 108 degrees at each corner: on the inside of a
    corner the lip lines of the legs before and after it meet, and a new lip made 0.07 spacings
    from the one before left triangles with rest edges down to 0.01 spacings (fuzz seed 1). A lip
    that near an earlier lip of its side is that lip (``LIP_MATCH``): no triangle the stroke made
    has a rest edge under 0.2 spacings, and the stroke keeps the cut's guarantees. The flaps are
    left in place (``freed.flap_area`` 0): without bend matching the lips a sliver apart made a
    chain of small triangles hung on one edge, which the flaps' removal took away at the
    incision's end and so hid (13 flap triangles removed against 2)."""
    surface = cylinder(0.014364956389277947, 0.044462654021712025, 2.0 * math.pi, 0.002695077962205331, jitter=0.4,
                       seed=2045298393)
    sim = supported_sim(surface, 0.03248200095958432)
    first = sim.model.triangle_table.count
    path = strokes.zigzag([-0.002706384350793341, 0.0027240781753918595], 1.425310623465873, 0.02852964074385817,
                          0.007446934328652736, 0.02128180382321027)
    tool = (66.49447139966853, 0.005285331417758956, 0.001856389369619768, 0.01213434983831525, 0.03527155013801858)
    sim.cutter.freed.flap_area = 0.0
    assert_cut_guarantees(sim, surface, cut_stroke(sim, surface, path, tool), joins=False)
    small, shortest = new_rest_edges(sim.model, first, surface.spacing)
    assert small == 0, f"{small} triangles with a rest edge under 0.2 spacings (shortest {shortest:.3f})"


def test_an_arc_across_a_zigzag_wound_leaves_no_free_piece_in_it():
    """XPBD on an unsupported 2 mm jittered disk (fuzz seed 1): an arc (r 1.8 mm) crosses a
    zigzag wound (r 0.86 mm) twice and cuts free the tissue between the zigzag's legs and
    itself. Its last event met the wound with lips matched to the wound's border nodes, no new
    point where a lip line meets it, and the search for islands ran only after edits that made
    such a point: a free piece of 24 triangles (and one of 7) was left floating in the wound, a
    hole by the border loops. Every edit is searched now: the tissue stays one piece, no hole."""
    surface = jittered_delaunay(0.0219761386843677, 0.0020348249979797034, 0.2737666837528252, seed=1166024082)
    sim = unsupported_sim(surface, 0.02416281833417054, integrator="xpbd")
    zigzag = strokes.zigzag([0.009890230507654611, 0.0001225322446404225], 3.039326963793948, 0.02052183284146154,
                            0.0044394909278388265, 0.0139492739723282)
    one_valid_incision(sim, surface, zigzag, 36.80471860849521, 0.0008577330835782815, 0.0022092768601948394,
                       0.011633597824938596, 0.037490082806364)
    arc = strokes.arc([0.008346768439198609, 0.0003868666960245362], -3.4159272222089205, 0.022309057158027414,
                      0.02951026579156906)
    result = one_valid_incision(sim, surface, arc, 31.73733960087174, 0.0017987696680811936, 0.0036982197100704837,
                                0.019552129809666058, 0.03833279834473959)
    assert result.unfilled_holes == 0
    assert sim.cutter.totals["removed_islands"] >= 1
    assert border_loop_count(sim.model.triangles) == 2  # the disk's rim and the one wound


def last_of_strokes(sim, surface, cuts) -> object:
    """Cut each (path, tool) of ``cuts`` in turn (tool: tilt [deg], radius, depth [m], speed [m/s],
    length [m]), the earlier ones by ``one_valid_incision``; the last one's StrokeResult, judged
    as the fuzz judges it (its coverage leaves out what the earlier strokes opened), after
    asserting that it kept the cut's invariants, made one incision and left no hole."""
    border = original_border(sim.model)
    for path, tool in cuts[:-1]:
        one_valid_incision(sim, surface, path, *tool)
    path, tool = cuts[-1]
    result = one_valid_incision(sim, surface, path, *tool, border_keys=border)
    assert result.unfilled_holes == 0
    return result


def test_a_zigzag_through_a_neck_between_two_wounds_goes_on_past_it():
    """A thin tool (r 0.6 mm on a 2.9 mm saddle mesh, 70 degrees) zigzags across two earlier
    wounds (fuzz seed 1). Between them it cut a neck of tissue through, from one wound to the
    other, with no lip pair in it (too short for one); the incision then went back to where it
    had resumed at the first wound for every later piece (no pair stood since), took the slit
    it had just cut for tissue, and every fill split its region's outline: ten events refused
    and 0.53 of the stroke opened. A piece that goes back like that and does not fit is tried
    once more from the cut point (``piece.goes_back``), and the rest of the stroke opens."""
    surface = saddle(0.04365928584277638, -20.37012806069866, 0.0028551680150088006, jitter=0.0, seed=2122172015)
    sim = supported_sim(surface, 0.016994566123543844)
    cuts = [(strokes.zigzag([-0.008731857168555276, -0.009702063520616973], 0.6850659331964546,
                            0.018491447947399382, 0.002903922676900491, 0.02893952090916288),
             (40.508749037921504, 0.0006862478220407722, 0.0031504024351972338, 0.017561779253598885,
              0.042233878710463336)),
            (strokes.zigzag([-0.006084752478645935, 0.002036456912225945], -0.9004742343285783,
                            0.011048763998307176, 0.008405839199567548, 0.03410941302867886),
             (43.43508360270144, 0.0056824879273695466, 0.0011526735784027778, 0.012153867876759431,
              0.042851828464078444)),
            (strokes.zigzag([-0.0043032702010718715, -0.012537004907345573], 1.220401566539596,
                            0.023390209026714234, 0.005788241988653325, 0.033934604263488495),
             (70.47606442693089, 0.0006058673940795901, 0.0015856953460682702, 0.025792154578681916,
              0.04838027493657575))]
    result = last_of_strokes(sim, surface, cuts)
    assert result.coverage >= 0.9
