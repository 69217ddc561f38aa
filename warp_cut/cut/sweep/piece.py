"""Which piece of an incision's rest curve one cut event cuts, and when it waits.

An event cuts from the incision's last cut to arc length ``upto`` (the blade's crossing, less
what stays behind it): that piece is sampled every tenth of a spacing, each sample judged on
the tissue or over an opening (``tissue_at_rest.on_tissue_at_rest``) and beside one
(``beside.beside_opening``). A neck of tissue between two openings, too narrow for any sample
to lie clear of its borders, is cut through (``tissue_at_rest.necks``; where the fill cannot
do that, ``without_necks`` leaves it as it was). The event waits (the next one, a longer
piece, tries again) while

* the blade's travel has not yet kept or undone a start joined to an earlier wound;
* the piece is shorter than ``MIN_ADVANCE`` spacings;
* a slit from its start holds no lip pair yet (it has width once it does);
* its tip would lie in an opening (the blade is not yet through it);
* a run past an opening is too short for a lip pair (``slit_band.samples_to_cut``);

an incision's last cut (``final``) waits for none of these but the first two. A piece all over
an opening cuts nothing, and the cut point moves on past it. Lengths in metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...sim.control import Tool
from ..curve.incision import Incision
from ..tolerances import FIRST_STATION, LAST_STATION, MIN_ADVANCE, NECK_REACH
from .beside import Beside, beside_opening
from .event_band import clearance, edge_clearance
from .slit_band import samples_to_cut
from .tissue_at_rest import necks, tissue_and_edge

__all__ = ["Piece", "goes_back", "piece_to_cut", "without_necks"]


@dataclass
class Piece:
    """The samples of one event's piece of rest curve: arc lengths ``u`` (k,) [m], rest
    ``points`` (k, 3) [m], which lie ``on_tissue`` (k,) bool, those ``beside`` an opening
    (``beside.Beside``), and the live nodes ``near`` it (node slots); ``necks`` (k,) bool: the
    samples across a neck of tissue between two openings (``tissue_at_rest.necks``), counted
    in ``on_tissue``."""

    u: np.ndarray
    points: np.ndarray
    on_tissue: np.ndarray
    beside: Beside
    near: np.ndarray
    necks: np.ndarray


def without_necks(model, inc: Incision, piece: Piece) -> Piece:
    """``piece`` with its necks left uncut: over an opening, and beside one where a border lies
    across the curve (``beside.beside_opening``)."""
    on_tissue = piece.on_tissue & ~piece.necks
    beside = beside_opening(model, inc, piece.u, on_tissue, piece.near, edge_clearance(inc))
    return Piece(piece.u, piece.points, on_tissue, beside, piece.near, np.zeros_like(piece.necks))


def piece_to_cut(model, nodes_near, inc: Incision, tool: Tool | None, upto: float, final: bool, *,
                 from_cut_point: bool = False) -> Piece | None:
    """The samples of the piece of ``inc``'s curve from its last cut to arc length ``upto`` [m]
    that this event cuts, or None while it waits (see the module docstring). ``nodes_near(a, b,
    radius)``: the live nodes whose rest positions lie within ``radius`` [m] of the segment a-b
    (``BladeContact.nodes_near_at_rest``); ``tool``: the tool now (None: the blade has left);
    ``from_cut_point``: from the cut point even while no lip pair stands (``goes_back``)."""
    s = inc.spacing
    if inc.entry is not None:  # the blade's travel has not yet kept or undone a joined start
        if not final:
            return None
        inc.entry = None
    unopened = inc.last_pair(model.active) < 0  # until a lip pair stands, cut from the start again
    u_from = _start(inc, unopened and not from_cut_point)
    if upto - u_from < MIN_ADVANCE * s:
        return None
    if tool is not None and unopened and inc.starts_on_tissue and inc.resume_u == 0.0 \
            and not inc.next_stations(upto - LAST_STATION * s):
        return None  # from its start the slit opens once it holds its first lip pair (it has width then)
    u = np.linspace(u_from, upto, max(9, int(np.ceil((upto - u_from) / (0.1 * s))) + 1))
    points = inc.point_at(u)
    near = nodes_near(points[0], points[-1], clearance(inc) + 3.0 * s + 0.5 * (upto - u_from))
    edge = edge_clearance(inc)
    over, clear = tissue_and_edge(model, points, near, edge, inc.slit_nodes)
    on_tissue = over & clear
    if tool is not None and not on_tissue[-1]:
        return None  # the tip would lie in an opening: wait till the blade is through it
    crossed = necks(u, over, clear, NECK_REACH * edge)
    on_tissue |= crossed
    if not final:  # a run past an opening waits until it can hold a lip pair
        keep = samples_to_cut(u, on_tissue, (FIRST_STATION + LAST_STATION) * s)
        if keep == 0:
            return None
        u, points, on_tissue, crossed, over = u[:keep], points[:keep], on_tissue[:keep], crossed[:keep], over[:keep]
    beside = beside_opening(model, inc, u, on_tissue, near, edge)
    if not (on_tissue | beside.mask).any():  # all of it over an opening or at its edge: nothing to cut
        stop = _last_over_an_opening(over)
        if stop is not None:
            inc.cut_point = points[stop].copy()
        return None
    return Piece(u, points, on_tissue, beside, near, crossed)


def goes_back(model, inc: Incision) -> bool:
    """Whether ``piece_to_cut`` goes back behind the cut point: no lip pair stands since the
    incision started or resumed at an opening, so each piece is cut from there again (the slit
    has no width to go on from yet), and the cut point lies further on. Where such a piece does
    not fit, the Cutter tries once more from the cut point: what lies behind it may be cut
    through already (a neck from one wound to the next, with no room for a pair), and a piece
    taking that slit for tissue again is refused at every event."""
    if inc.last_pair(model.active) >= 0:
        return False
    return _start(inc, back=False) > _start(inc, back=True) + MIN_ADVANCE * inc.spacing


def _start(inc: Incision, back: bool) -> float:
    """Arc length [m] a piece starts at: where the incision started or resumed if ``back`` (or
    nothing was cut yet), else the cut point."""
    if back or inc.cut_point is None:
        return inc.resume_u
    return float(inc.project(inc.cut_point[None])[0][0])


def _last_over_an_opening(over: np.ndarray) -> int | None:
    """Where the cut point moves on to in a piece with nothing to cut (``over`` (k,) bool: its
    samples over the tissue): its last sample over an opening (its last if it ends over one;
    else the one before the tissue it ends on, so the next piece holds the whole of that tissue
    and sees a neck it crosses: ``tissue_at_rest.necks``); None (it stays) if the piece lies
    all over the tissue."""
    gaps = np.flatnonzero(~over)
    return int(gaps[-1]) if len(gaps) else None
