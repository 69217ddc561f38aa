"""Where the tissue is in the rest shape: the questions a cut event asks of rest points.

Whether rest points lie in the tissue (on a live triangle, clear of every border) or in an
opening (an earlier wound, beyond the tissue's edge), and where a new incision starts when the
blade's swept disc reaches an earlier wound. Lengths in metres; points (k, 3).
"""

from __future__ import annotations

import numpy as np

from ...sim.model import TissueModel
from ...sim.slots import member
from ..chart import RegionChart, barycentric
from ..curve.incision import Incision
from .region import border_edges, distance_to_segments
from .slit_band import runs_of

__all__ = ["on_tissue_at_rest", "tissue_and_edge", "necks", "rest_point_on_tissue", "joined_start", "tissue_near",
           "on_triangles"]


def tissue_near(model: TissueModel, nodes: np.ndarray, own=frozenset()):
    """(chart of the live triangles at ``nodes`` at rest (None without any), their rest corners
    (t, 3, 3) [m], the rest ends (e, 2, 3) [m] of their edges on a border of the tissue but those
    of the slit of nodes ``own``)."""
    tris = np.array(model.index.triangles_at(nodes), dtype=np.int64)
    if not len(tris):
        return None, np.zeros((0, 3, 3)), np.zeros((0, 2, 3))
    rest = model.points[model.triangle_table.column("corners")[tris]]
    chart = RegionChart.of_triangles(rest)  # a point over a triangle, off its plane (a curve's chord) is on it
    border = border_edges(model, tris)
    if own:
        border = border[~member(border, list(own)).all(axis=1)]
    return chart, rest, model.points[border]


def on_tissue_at_rest(model: TissueModel, points: np.ndarray, nodes: np.ndarray, edge: float,
                      own=frozenset()) -> np.ndarray:
    """Mask (k,) of the rest points (k, 3) [m] lying on the rest shape of a live triangle at
    ``nodes`` (within a hundredth of its size) and farther than ``edge`` [m] from the tissue's
    borders (but those of the slit of nodes ``own``: an incision's own): in the tissue, not in
    an opening nor at its edge."""
    over, clear = tissue_and_edge(model, points, nodes, edge, own)
    return over & clear


def tissue_and_edge(model: TissueModel, points: np.ndarray, nodes: np.ndarray, edge: float,
                    own=frozenset()) -> tuple[np.ndarray, np.ndarray]:
    """Masks (k,) of the rest points (k, 3) [m] over a live triangle at ``nodes`` and of those
    farther than ``edge`` [m] from the tissue's borders (but those of the slit of nodes
    ``own``); their and is ``on_tissue_at_rest``."""
    chart, rest, ends = tissue_near(model, nodes, own)
    if chart is None:
        return np.zeros(len(points), dtype=bool), np.zeros(len(points), dtype=bool)
    away = distance_to_segments(points, ends[:, 0], ends[:, 1]) > edge
    return on_triangles(chart, rest, points), away


def necks(u: np.ndarray, over: np.ndarray, clear: np.ndarray, longest: float) -> np.ndarray:
    """Mask (k,) of a piece's samples at arc lengths ``u`` (k,) [m] across a neck of tissue
    between two openings: a run of samples over the tissue (``over`` (k,) bool) none of which
    lies clear of its borders (``clear`` (k,) bool), with a sample over no tissue on either
    side, no longer than ``longest`` [m] along the curve. The blade passes through such a neck
    and cuts it. A longer run runs beside a border rather than across a neck (a recut
    wandering off its wound's line), where nothing new is cut."""
    out = np.zeros(len(over), dtype=bool)
    for first, last in runs_of(np.asarray(over, dtype=bool)):
        between = first > 0 and last < len(over) - 1
        if between and u[last] - u[first] <= longest and not np.any(clear[first:last + 1]):
            out[first:last + 1] = True
    return out


def on_triangles(chart: RegionChart, rest: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Mask (k,) of the rest points (k, 3) [m] over one of the rest triangles ``rest`` (t, 3, 3)
    [m] in ``chart`` (within a hundredth of its size)."""
    lam = barycentric(chart.to2d(points), chart.to2d(rest))
    return np.nan_to_num(lam.min(axis=2), nan=-1.0).max(axis=1) >= -0.01


def rest_point_on_tissue(model: TissueModel, point: np.ndarray, spacing: float) -> bool:
    """True if the rest point ``point`` (3,) [m] lies on the tissue at rest, a tenth of the
    spacing [m] clear of its borders (the nodes near it found on the model: O(nodes), once per
    incision)."""
    near = np.flatnonzero(model.active & (np.linalg.norm(model.points - point, axis=1) <= 2.0 * spacing))
    return bool(on_tissue_at_rest(model, point[None], near, 0.1 * spacing)[0])


def joined_start(model: TissueModel, incisions: list[Incision], rest: np.ndarray, radius: float) -> np.ndarray:
    """Where a new incision starts [m] (3,): at ``rest``, or at the nearest live node of an
    earlier incision's slit within ``radius`` [m] of it (the blade's swept disc reaches that
    wound, so the new slit starts in it and joins it, as a T's stem does)."""
    best, nearest = None, radius
    for inc in incisions:
        nodes = np.fromiter((v for v in inc.slit_nodes if model.active[v]), dtype=np.int64)
        if not len(nodes):
            continue
        dist = np.linalg.norm(model.points[nodes] - rest, axis=1)
        k = int(np.argmin(dist))
        if dist[k] < nearest:
            best, nearest = int(nodes[k]), float(dist[k])
    return rest if best is None else model.points[best].astype(np.float64).copy()
