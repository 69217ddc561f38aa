"""Stage 3's layout in the rest shape: the region's tissue less the slit's band, as outline
loops in a flat chart of the rest surface, filled.

``lay_out`` takes the band out of the region's triangles as polygons (GEOS through Shapely),
names the vertices of the tissue's new outline (region nodes, band nodes, the band's new points,
points where a lip line meets a border: ``NewPoint``), leaves out a new point within ``MERGE``
spacings of a node next to it (node matching), and fills the outline with the nodes inside at
``REFINE_ANGLE_DEG`` (``fill.fill_region``). The ``Layout`` it returns is what
``cut_piece.cut_piece`` checks and writes; ``matched_lips`` and ``sharp_corners`` read it. Lengths
in metres.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import shapely

from ...errors import InputError
from ..chart import RegionChart
from ..curve.incision import Incision
from ..sweep.region import Region
from ..sweep.slit_band import BandPoint, SlitBand
from ..tolerances import COARSEN, CORNER_CUT, CROSSING_MERGE, MATCH, MERGE, MIN_EDGE, REFINE_ANGLE_DEG
from .fill import Fill, fill_region

__all__ = ["Layout", "NewPoint", "Refusal", "SlitDoesNotFit", "Turn", "lay_out", "matched_lips", "sharp_corners",
           "corner_cut", "edge_of"]


class Refusal(enum.Enum):
    """Why an event's slit did not fit its region (``SlitDoesNotFit.reason``); each value is
    the message the Cutter counts refused events under (``Cutter.skipped``)."""

    NO_TISSUE = "no tissue around the piece"
    NOTHING_LEFT = "the band leaves no tissue in its region"
    NO_FILL = "the region cannot be filled"
    SPLITS_OUTLINE = "the refinement splits the region's outline however far it grows"
    UNDER_ANGLE = "the fill leaves a triangle under the smallest angle however far it grows"
    UNDER_ANGLE_AT_REST = "the fill, lifted from its chart onto the curved rest surface, leaves a triangle under the " \
        "smallest angle"
    SLIT_NOT_LAID = "the fill does not lay every point of the slit once"


class SlitDoesNotFit(Exception):
    """The slit of an event could not be laid out in its region (nothing was edited).

    Args:
        reason: Why (a ``Refusal``).
        detail: What exactly, for the message (e.g. which points of the slit are missing).
    """

    def __init__(self, reason: Refusal, detail: str = ""):
        super().__init__(f"{reason.value}: {detail}" if detail else reason.value)
        self.reason = reason
        self.detail = detail


class Turn(NamedTuple):
    """A corner of the tissue's new outline (the tissue on its left): the outline vertex's id
    (``Layout.ids``' entry) and the rows of ``Fill.points`` of the vertex, the one before it
    and the one after it."""

    vertex: int
    row: int
    before: int
    after: int


@dataclass
class Layout:
    """A region's fill: ``ids`` of its vertices (node ids >= 0, new points < 0: ``points[-1-k]``),
    the fill, the chart, which outline edges it may not split, and the outline's turns."""

    ids: list
    points: list
    fill: Fill
    chart: RegionChart
    fixed: set
    turns: list[Turn]
    """Every corner along the tissue's new outline: a vertex the outline passes twice (where
    two pieces of tissue touch) has two."""
    cut_across: set
    """Fixed outline edges the band cuts across (the region must grow across them)."""
    stations: list
    """Arc lengths [m] of the band's new stations (``BandPoint.station`` indexes them)."""
    resumed_at: float | None = None
    """Where the band's last run begins at an opening's border [m] (``SlitBand.resumed_at``)."""
    band_lips: dict = field(default_factory=dict)
    """(station, side) -> the node a lip of the band was matched to (``cut_piece._match_lips``)."""
    matched: dict = field(default_factory=dict)
    """New point id (< 0) -> the node on the outline next to it that it was matched to
    (``MERGE``): that node stands in for it."""


@dataclass(frozen=True)
class NewPoint:
    """A node the layout makes: a band point, or where a lip line meets a border (``band`` None)."""

    band: BandPoint | None
    chart: np.ndarray


def matched_lips(layout: Layout) -> dict:
    """(station, side) -> node of the lips matched to a node: by the band (``cut_piece._match_lips``) or by
    the outline, next to them (``MERGE``), each node standing in for one lip only (two lips on
    one node would be no slit)."""
    lips: dict = dict(layout.band_lips)
    for v, node in layout.matched.items():
        band = layout.points[-1 - v].band
        if band is not None and band.station >= 0 and node not in lips.values():
            lips[(band.station, band.side)] = node
    return lips


def edge_of(ids: list, edge: tuple[int, int]) -> tuple[int, int]:
    """The sorted node pair of a fill edge (indices into ``ids``)."""
    a, b = ids[edge[0]], ids[edge[1]]
    return (min(a, b), max(a, b))


def lay_out(model, inc: Incision, region: Region, band: SlitBand, chart: RegionChart, wedges: list) -> Layout:
    """The region's tissue less the band (and the sharp ``wedges`` (3, 2) chart triangles cut off
    before), in ``chart``, filled.

    Raises:
        SlitDoesNotFit: No tissue is left, or the fill found no area.
    """
    corners = model.triangle_table.column("corners")[sorted(region.triangles)]
    triangles = list(shapely.polygons(chart.to2d(model.points[corners])))
    tissue = shapely.union_all(triangles + region.healed_polygons(chart))
    rings = [_distinct(chart.to2d(np.array([p.rest for p in run]))) for run in band.runs]
    strips = [chart.to2d(strip) for strip in band.strips]
    cut = shapely.union_all([shapely.make_valid(shapely.Polygon(r)) for r in rings + strips if len(r) >= 3]
                            + [shapely.Polygon(w) for w in wedges])
    grid = 1e-6 * inc.spacing  # slivers of rounding where the band runs along a border collapse on it
    left = shapely.orient_polygons(shapely.set_precision(tissue.difference(cut), grid), exterior_cw=False)
    pieces = [g for g in getattr(left, "geoms", [left]) if isinstance(g, shapely.Polygon)
              and g.area > (0.01 * inc.spacing) ** 2]
    if not pieces:
        raise SlitDoesNotFit(Refusal.NOTHING_LEFT)
    table = _VertexTable(model, chart, region, band, MATCH * inc.spacing)
    loops, points, matched = _loops(pieces, table, MERGE * inc.spacing)
    loops = [_merge_crossings(loop, points, CROSSING_MERGE * inc.spacing) for loop in loops]
    outline = {v for loop in loops for v in loop}
    inside = _inside(pieces, sorted(region.nodes() - region.deleted - outline), model, chart, MERGE * inc.spacing)
    ids = sorted(v for v in outline if v >= 0) + inside + sorted((v for v in outline if v < 0), reverse=True)
    where = {v: k for k, v in enumerate(ids)}
    chart_points = _chart_points(ids, points, model, chart)
    edges = [(where[a], where[b]) for loop in loops for a, b in zip(loop, loop[1:] + loop[:1]) if a != b]
    try:
        fill = fill_region(chart_points, edges, min_angle_deg=REFINE_ANGLE_DEG, min_edge=MIN_EDGE * inc.spacing,
                           coarsen_below=COARSEN * inc.spacing)
    except InputError as err:
        raise SlitDoesNotFit(Refusal.NO_FILL, str(err)) from err
    fixed = {(min(a, b), max(a, b)) for a, b in region.outline() if not region.on_mesh_border(a, b)}
    kept = {(min(a, b), max(a, b)) for loop in loops for a, b in zip(loop, loop[1:] + loop[:1])}
    cut_across = {e for e in fixed if e not in kept and not {*e} & region.deleted}
    turns = _corners([Turn(b, where[b], where[a], where[c]) for loop in loops
                      for a, b, c in zip(loop[-1:] + loop[:-1], loop, loop[1:] + loop[:1])], chart_points)
    band_lips = {(p.station, p.side): p.node for run in band.runs for p in run if p.node >= 0 and p.station >= 0}
    return Layout(ids, points, fill, chart, fixed, turns, cut_across, band.stations, band.resumed_at,
                   band_lips, matched)


def _corners(turns: list[Turn], points: np.ndarray) -> list[Turn]:
    """The outline's ``turns`` as the corners of tissue they
    make: where the outline passes a vertex more than once (two pieces of tissue, or a hole and
    the outline, touching there: GEOS may pair the edges either way), each edge leaving it is
    paired with the edge coming in that is next counter-clockwise from it, the tissue on the
    left lying between them. ``points`` (n, 2): the rows' chart points."""
    rows: dict = {}
    for turn in turns:
        rows.setdefault(turn.row, []).append(turn)
    out = []
    for row, at in rows.items():
        if len(at) == 1:
            out += at
            continue
        befores = np.array([t.before for t in at])
        d = points[befores] - points[row]
        back = np.arctan2(d[:, 1], d[:, 0])  # directions of the edges coming in, seen from the vertex
        for v, _, _, after in at:
            d = points[after] - points[row]
            ccw = (back - np.arctan2(d[1], d[0])) % (2.0 * np.pi)
            out.append(Turn(v, row, int(befores[np.argmin(ccw)]), after))
    return out


def _inside(pieces: list, nodes: list[int], model, chart: RegionChart, clear: float) -> list[int]:
    """The nodes of ``nodes`` inside a piece of tissue and farther than ``clear`` [m] from
    every piece's outline, in the chart: those the fill keeps as inner points."""
    if not nodes:
        return []
    xy = chart.to2d(model.points[nodes])
    within = np.zeros(len(nodes), dtype=bool)
    for piece in pieces:
        within |= shapely.contains_xy(piece, xy[:, 0], xy[:, 1])
    points = shapely.points(xy)
    away = np.all([shapely.distance(piece.boundary, points) > clear for piece in pieces], axis=0)
    return [v for v, keep in zip(nodes, within & away) if keep]


def _chart_points(ids: list[int], points: list[NewPoint], model, chart: RegionChart) -> np.ndarray:
    """Chart coordinates (len(ids), 2) [m] of the vertex ids: a node's rest position, a new
    point's own."""
    out = np.empty((len(ids), 2))
    nodes = [k for k, v in enumerate(ids) if v >= 0]
    if nodes:
        out[nodes] = chart.to2d(model.points[[ids[k] for k in nodes]])
    for k, v in enumerate(ids):
        if v < 0:
            out[k] = points[-1 - v].chart
    return out


def _distinct(ring: np.ndarray) -> np.ndarray:
    """The ring (k, 2) without a point equal to the one before it (cyclically): a band whose two
    ends close on one node."""
    if len(ring) < 2:
        return ring
    keep = np.any(ring != np.roll(ring, 1, axis=0), axis=1)
    return ring[keep]


class _VertexTable:
    """What lies at a chart point: a node id (the region's nodes, the band's existing nodes) or a
    BandPoint (a new point of the band), found within ``tolerance`` [m] (GEOS returns the input
    vertices it keeps, but only to rounding)."""

    def __init__(self, model, chart: RegionChart, region: Region, band: SlitBand, tolerance: float):
        nodes = sorted(region.nodes())
        band_points = [p for run in band.runs for p in run]
        self.items: list = nodes + [p.node if p.node >= 0 else p for p in band_points]
        rest = np.concatenate([model.points[nodes].reshape(-1, 3)] + [p.rest[None] for p in band_points])
        self.xy = chart.to2d(rest)
        self.tolerance = tolerance

    def get(self, points: np.ndarray) -> list:
        """The item at each of ``points`` (m, 2), or None."""
        if not len(self.xy):
            return [None] * len(points)
        d = np.linalg.norm(self.xy[None] - np.asarray(points)[:, None], axis=2)
        nearest = np.argmin(d, axis=1)
        return [self.items[k] if d[row, k] <= self.tolerance else None for row, k in enumerate(nearest.tolist())]

    def nodes_xy(self) -> np.ndarray:
        """Chart points (k, 2) of the node items."""
        mask = np.array([isinstance(v, (int, np.integer)) for v in self.items], dtype=bool)
        return self.xy[mask]


def _loops(pieces: list, table: _VertexTable, merge: float) -> tuple[list[list[int]], list[NewPoint], dict]:
    """The outline loops of the tissue left (the tissue on their left) as vertex ids, the new
    points (band points on the new outline, and points where a lip line meets a border), and
    the new points matched to a node: one nearer than ``merge`` [m] to its neighbour on the loop
    that is a node is left out, the loop going straight on to that node (node matching: no
    tiny edge)."""
    points: list[NewPoint] = []
    made: dict = {}
    matched: dict = {}
    loops = []
    for poly in pieces:
        for ring in [poly.exterior, *poly.interiors]:
            coords = np.asarray(ring.coords)[:-1]
            ids = []
            for xy, hit in zip(coords, table.get(coords)):
                if isinstance(hit, (int, np.integer)):
                    ids.append(int(hit))
                    continue
                band = hit if isinstance(hit, BandPoint) else None
                # one vertex per band point: GEOS may return it twice, apart by rounding
                key = tuple(xy) if band is None else id(band)
                if key not in made:
                    points.append(NewPoint(band, xy))
                    made[key] = -len(points)
                ids.append(made[key])
            keep = [k for k in range(len(ids)) if ids[k] != ids[k - 1]]  # two points matched one vertex
            loops.append(_merge_near([ids[k] for k in keep], coords[keep], merge, matched))
    return [loop for loop in loops if len(loop) >= 3], points, matched


def _merge_near(ids: list[int], coords: np.ndarray, merge: float, matched: dict) -> list[int]:
    """``ids`` without the new points (< 0) that lie within ``merge`` [m] of a neighbouring node
    (>= 0) on the loop; ``matched`` takes each such point's node."""
    n = len(ids)
    keep = []
    for k in range(n):
        v = ids[k]
        if v < 0:
            near = [j for j in ((k - 1) % n, (k + 1) % n) if ids[j] >= 0
                    and np.linalg.norm(coords[j] - coords[k]) < merge]
            if near:
                matched[v] = ids[min(near, key=lambda j: np.linalg.norm(coords[j] - coords[k]))]
                continue
        keep.append(v)
    return keep


def _merge_crossings(loop: list[int], points: list[NewPoint], merge: float) -> list[int]:
    """``loop`` without the points where a lip line crosses a border (new points that are no band
    point) lying within ``merge`` [m] of the next new point on the loop: two crossings that near
    (a lip line over the corner of an earlier wound's border) made an edge of a hundredth of a
    spacing, and a triangle that small, which any motion crushes."""
    out = list(loop)
    k = 0
    while len(out) > 3 and k < len(out):
        v = out[k]
        if v < 0 and points[-1 - v].band is None and any(
                w < 0 and np.linalg.norm(points[-1 - v].chart - points[-1 - w].chart) < merge
                for w in (out[k - 1], out[(k + 1) % len(out)])):
            del out[k]
            continue
        k += 1
    return out


def corner_angle(chart: np.ndarray, turn: tuple) -> float:
    """The angle [deg] of tissue at the corner ``turn`` (``Layout.turns``'s entry), from the edge
    leaving it counter-clockwise to the edge coming in; ``chart`` (n, 2): the rows' points."""
    _, row, before, after = turn
    a, b = chart[after] - chart[row], chart[before] - chart[row]
    return float(np.degrees(np.arctan2(a[0] * b[1] - a[1] * b[0], a @ b)) % 360.0)


def sharp_corners(layout: Layout, protected: set[int]) -> list[tuple[tuple, np.ndarray | None]]:
    """Corners of the tissue's new outline under ``REFINE_ANGLE_DEG`` (the fill cannot mend them),
    each as (its turn (``Layout.turns``'s entry), None) at a node of the region's own outline
    (the region takes its fan in), else (its turn, the corner's triangle (3, 2) in the chart: it
    goes with the band)."""
    chart = layout.fill.points
    out = []
    for turn in layout.turns:
        v, row, before, after = turn
        if v in protected or corner_angle(chart, turn) >= REFINE_ANGLE_DEG:
            continue
        wedge = np.array([chart[before], chart[row], chart[after]])
        out.append((turn, None if v >= 0 and layout.ids[before] >= 0 and layout.ids[after] >= 0 else wedge))
    return out


def corner_cut(layout: Layout, turn: tuple, spacing: float) -> np.ndarray:
    """The tip (3, 2) in the chart of the sharp corner ``turn`` (``Layout.turns``'s entry), to go
    with the band: the triangle of its vertex and the points on its two outline edges as far
    from it as makes the cut ``CORNER_CUT`` spacings wide (the whole edge, if shorter). The
    tissue left there is thinner than that, and each new corner has about 90 degrees plus half
    the old one. For a node on a border of the tissue (an earlier wound's edge), whose corner
    taking in its fan does not remove."""
    _, row, before, after = turn
    chart = layout.fill.points
    corner = chart[row]
    sides = [chart[before] - corner, chart[after] - corner]
    lengths = [float(np.linalg.norm(side)) for side in sides]
    half_sin = max(np.sin(np.radians(corner_angle(chart, turn)) / 2.0), 1e-6)  # sin of half the corner
    reach = 0.5 * CORNER_CUT * spacing / half_sin
    ends = [corner + side * min(1.0, reach / max(length, 1e-300)) for side, length in zip(sides, lengths)]
    return np.array([ends[0], corner, ends[1]])
