"""The band one event takes out of the tissue, built from the model (Stage 3's input).

``slit_band.plan_band`` lays the band out along the incision's curve; here its ends are found
in the tissue as it is: the newest live lip pair it closes onto, the incision's start, or the
border of an opening it runs into (``event_band``); the end of the slit cut before, past that
pair, which the event cuts again (``add_old_tip``: the region takes it back into its tissue,
or, where nodes of it are not the slit's to re-make, the band takes it in); and the new lips
kept out of such an end (``clear_of_old_tip``). ``clearance`` and ``edge_clearance`` say how
far from the curve the band sweeps tissue nodes and how far from a border the curve must lie
to count as in the tissue. Lengths in metres.
"""

from __future__ import annotations

import numpy as np
import shapely

from ..chart import RegionChart
from ..curve.incision import Incision
from ..tolerances import CLEARANCE, LAST_STATION
from .region import Region, border_edges
from .slit_band import CUT_BEFORE, BandPoint, SlitBand, plan_band

__all__ = ["event_band", "add_old_tip", "clear_of_old_tip", "clearance", "edge_clearance"]


def clearance(inc: Incision) -> float:
    """How far from the curve [m] the swept band deletes tissue nodes: the sweep radius, at least
    the lip offset plus ``CLEARANCE`` spacings."""
    return max(inc.sweep_radius, inc.lip_offset + CLEARANCE * inc.spacing)


def edge_clearance(inc: Incision) -> float:
    """How far from a border of the tissue [m] a point of the curve must lie to count as in the
    tissue: the lip offset plus ``CLEARANCE`` spacings (nearer, the band goes on into the
    opening: no thinner strip of tissue is left between them)."""
    return inc.lip_offset + CLEARANCE * inc.spacing


def event_band(model, inc: Incision, u: np.ndarray, on_tissue: np.ndarray, first: bool,
          near: np.ndarray) -> SlitBand:
    """The event's band: onto the newest live lip pair when the piece starts at it, round the
    start in the incision's first event (or while it has no pair yet), onto the borders of the
    tissue at ``near`` (node slots) where it runs into an opening. Once the slit cut so far ends
    in an opening (it has no tip), a piece starts from that opening's border, whatever the
    first sample's clearance from it: the newest pair lies behind the opening."""
    active = model.active
    ends_open = inc.cut_point is not None and inc.tip_node < 0 and not first
    k = -1 if ends_open else inc.last_pair(active)
    pair = (inc.left[k], inc.right[k]) if k >= 0 else None
    start = inc.start_node if inc.start_node >= 0 and active[inc.start_node] else None
    start_possible = pair is None and not ends_open and ((first and inc.starts_on_tissue) or start is not None)
    stations = inc.next_stations(float(u[-1]) - LAST_STATION * inc.spacing)
    borders = [(a, b) for a, b in border_edges(model, model.index.triangles_at(near)).tolist()
               if not (a in inc.slit_nodes and b in inc.slit_nodes)]
    return plan_band(inc, u, on_tissue, stations=stations, pair=pair,
                     pair_u=inc.station_u[k] if k >= 0 else 0.0, start=start, start_possible=start_possible,
                     extension=edge_clearance(inc) + inc.lip_offset, margin=LAST_STATION * inc.spacing,
                     points=model.points, borders=borders)


def old_tip_outline(model, inc: Incision, region: Region) -> list[int] | None:
    """The end of the slit cut before, past its newest lip pair: the slit's outline (node slots)
    from the left lip of that pair round the old tip to the right one, along the region's
    outline (None: no pair, or no such outline)."""
    k = inc.last_pair(model.active)
    if k < 0:
        return None
    left, right = inc.left[k], inc.right[k]
    following = {}
    for a, b in region.outline():
        following.setdefault(a, []).append(b)
    chain, v = [left], left
    while v != right and len(chain) <= len(following) + 1:
        nexts = [w for w in following.get(v, []) if w in inc.slit_nodes or w == right]
        if not nexts:
            return None
        v = nexts[0]
        chain.append(v)
    if v != right or len(chain) < 3:
        return None
    return chain


def add_old_tip(model, inc: Incision, region: Region, band: SlitBand, provisional: set[int]) -> list | None:
    """Take the end of the slit cut before, past its newest lip pair (``old_tip_outline``), into
    the event. Where every node of it but the pair is ``provisional`` (the slit runs on from
    there), it is cut again: the region takes that opening back into its tissue
    (``Region.healed``) and the band alone decides what is open, so the old tip leaves no
    finger where the curve turned after it. Otherwise the band takes it in (a polygon of
    nodes), so that band and old slit join without a sliver of tissue between them; that run
    is returned (None: healed, no pair, or no such outline)."""
    chain = old_tip_outline(model, inc, region)
    if chain is None:
        return None
    if set(chain[1:-1]) <= provisional:
        region.healed.append(chain)
        return None
    run = [BandPoint(model.points[w], 0, CUT_BEFORE, 0.0, w) for w in chain]
    band.runs.append(run)
    return run


def clear_of_old_tip(band: SlitBand, old_run: list, inc: Incision, chart: RegionChart, margin: float) -> None:
    """Keep the new lips out of the end of the slit cut before (``old_run``, the old tip's
    outline): the curve, refitted as the blade moved on, can run a little to one side of the
    curve the old tip was cut along, and a lip in that opening would be no node of the tissue
    left. Such a lip moves out across the curve until it lies ``margin`` [m] outside the
    opening, by up to a lip offset (one that cannot stays: the fill then refuses the slit and
    a later event tries again, ``cut_piece._check_slit``). Leaving the station out instead would lengthen
    the slit's end without a lip pair, and a longer end catches the next stations' lips."""
    opening = shapely.Polygon(chart.to2d(np.array([p.rest for p in old_run]))).buffer(margin)
    steps = np.linspace(0.0, inc.lip_offset, 11)[1:]
    for run in band.runs:
        if run is old_run:
            continue
        for k, p in enumerate(run):
            if p.station < 0 or p.node >= 0 or not opening.contains(shapely.Point(chart.to2d(p.rest))):
                continue
            across = p.rest - inc.point_at(p.u)[0]
            across /= max(float(np.linalg.norm(across)), 1e-300)
            moved = [p.rest + d * across for d in steps]
            clear = [x for x in moved if not opening.contains(shapely.Point(chart.to2d(x)))]
            if clear:
                run[k] = BandPoint(clear[0], p.side, p.station, p.u, p.node)
