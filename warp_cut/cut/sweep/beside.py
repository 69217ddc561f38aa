"""Strips of tissue beside an opening that the blade cuts off.

A piece of rest curve whose samples lie in the tissue but nearer an opening (an earlier wound,
the tissue's edge) than the edge clearance does not make a slit there: no strip of tissue
thinner than that clearance may be left between a lip and the opening. Where the opening lies
across the curve (a stroke running beside an earlier wound, or meeting it at a shallow angle)
the blade passes through that thin strip, so it goes: the event takes out of the tissue the
strip from the opening's border to the lip line on the curve's other side (``strip_polygons``),
and the opening widens to the blade's path. Where the opening lies ahead instead (a stroke
meeting a wound head on), the band's run ends at it as before (``slit_band``).

Lengths in metres; the curve's left side is +1 (``Incision.lip_position``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...mesh.geometry import cross3
from ..chart import RegionChart
from ..curve.incision import Incision
from ..tolerances import BESIDE_RUN
from .slit_band import runs_of
from .tissue_at_rest import on_triangles, tissue_near

__all__ = ["Beside", "beside_opening", "strip_polygons"]

_SIDES = (1, -1)


@dataclass
class Beside:
    """The samples of a piece of curve beside an opening.

    Attributes:
        mask: (k,) bool: in the tissue, not clear of a border, with a border across the curve
            within the edge clearance on a side.
        first: (2, k) distance [m] across the curve to the first border on the left (row 0) and
            the right (row 1), inf beyond reach.
        second: (2, k) the same to the border after it (the far side of that opening).
    """

    mask: np.ndarray
    first: np.ndarray
    second: np.ndarray

    @classmethod
    def none(cls, count: int) -> Beside:
        """No sample beside an opening."""
        return cls(np.zeros(count, dtype=bool), np.full((2, count), np.inf), np.full((2, count), np.inf))


def _across_curve(inc: Incision, u: np.ndarray) -> np.ndarray:
    """Unit vectors (k, 3) across ``inc``'s curve to its left at arc lengths ``u`` (k,) [m]."""
    across = cross3(inc.normal_at(u), inc.tangent_at(u))
    return across / np.maximum(np.linalg.norm(across, axis=1, keepdims=True), 1e-300)


def beside_opening(model, inc: Incision, u: np.ndarray, on_tissue: np.ndarray, nodes: np.ndarray,
                   edge: float) -> Beside:
    """Which samples of ``inc``'s curve at ``u`` (k,) [m] that are not ``on_tissue`` (k,) lie in
    the tissue at the triangles of ``nodes`` with a border across the curve within ``edge`` [m]
    on a side (the incision's own slit left out)."""
    count = len(u)
    if on_tissue.all():
        return Beside.none(count)
    chart, rest, ends = tissue_near(model, nodes, inc.slit_nodes)
    if chart is None:
        return Beside.none(count)
    points = inc.point_at(u)
    inside = on_triangles(chart, rest, points)
    candidates = inside & ~on_tissue
    if not candidates.any():
        return Beside.none(count)
    first, second = _borders_across(chart, points, _across_curve(inc, u), ends, reach=edge + inc.spacing)
    mask = _strip_runs(candidates & (first.min(axis=0) <= edge), inside, u, BESIDE_RUN * inc.spacing)
    return Beside(mask, first, second)


def _strip_runs(mask: np.ndarray, inside: np.ndarray, u: np.ndarray, least: float) -> np.ndarray:
    """``mask`` (k,) without its runs of True shorter than ``least`` [m] along ``u`` (k,) [m]
    and those between two samples in an opening (not ``inside`` the tissue): a curve that
    leaves an opening for a moment and goes back in (a recut wandering off the wound's line)
    cuts no strip off its side."""
    out = mask.copy()
    for first, last in runs_of(mask):
        before, after = first - 1, last + 1
        between = before >= 0 and after < len(mask) and not inside[before] and not inside[after]
        if between or u[last] - u[first] < least:
            out[first:last + 1] = False
    return out


def _borders_across(chart: RegionChart, points: np.ndarray, across: np.ndarray, ends: np.ndarray,
                    reach: float) -> tuple[np.ndarray, np.ndarray]:
    """(first, second), each (2, k): distances [m] from each point (k, 3) along +-``across``
    (k, 3) to the nearest and next border segments ``ends`` (e, 2, 3) it crosses within
    ``reach`` [m] (inf if none), in ``chart``."""
    k = len(points)
    first, second = np.full((2, k), np.inf), np.full((2, k), np.inf)
    if not len(ends):
        return first, second
    p = chart.to2d(points)
    d = chart.direction2d(across)
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    a, b = chart.to2d(ends[:, 0]), chart.to2d(ends[:, 1])
    q = b - a
    rel = a[None] - p[:, None]                                             # (k, e, 2)
    for row, side in enumerate(_SIDES):
        r = side * d                                                      # (k, 2)
        denom = r[:, None, 0] * q[None, :, 1] - r[:, None, 1] * q[None, :, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (rel[..., 0] * q[None, :, 1] - rel[..., 1] * q[None, :, 0]) / denom
            w = (rel[..., 0] * r[:, None, 1] - rel[..., 1] * r[:, None, 0]) / denom
        hit = (np.abs(denom) > 1e-300) & (w >= 0.0) & (w <= 1.0) & (t >= 0.0) & (t <= reach)
        t = np.sort(np.where(hit, t, np.inf), axis=1)
        first[row] = t[:, 0]
        second[row] = t[:, 1] if t.shape[1] > 1 else np.inf
    return first, second


def strip_polygons(inc: Incision, u: np.ndarray, beside: Beside, edge: float) -> list[np.ndarray]:
    """The strips (each a polygon (m, 3) of rest points) the blade cuts off along each run of
    samples ``beside`` an opening at ``u`` (k,) [m]: on a side whose border lies within ``edge``
    [m] across the curve, out to the middle of that opening (a quarter spacing past its border
    at most); on the other side, to the lip line, with a vertex about every spacing (they become
    nodes of the new border)."""
    strips = []
    runs = runs_of(beside.mask)
    if not runs:
        return strips
    sample = float(np.median(np.diff(u))) if len(u) > 1 else inc.spacing  # [m] between samples
    step = max(1, int(round(inc.spacing / max(sample, 1e-300))))          # samples a spacing apart
    curve, across = inc.point_at(u), _across_curve(inc, u)
    for first_sample, last_sample in runs:
        run = np.arange(first_sample, last_sample + 1)
        sides = []
        for row, side in enumerate(_SIDES):
            first, second = beside.first[row, run], beside.second[row, run]
            near = first <= edge
            with np.errstate(invalid="ignore"):  # inf - inf where no border lies across
                past = np.minimum(0.5 * np.where(np.isfinite(second), second - first, np.inf), 0.25 * inc.spacing)
            reach = np.where(near, first + past, inc.lip_offset)
            keep = near | ((run - run[0]) % step == 0)
            keep[[0, -1]] = True
            sides.append(curve[run[keep]] + side * reach[keep, None] * across[run[keep]])
        strips.append(np.concatenate([sides[0], sides[1][::-1]]))
    return strips
