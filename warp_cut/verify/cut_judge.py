"""Judging a multi-stroke incision from the model's own arrays, after each stroke.

Which triangles the cut made: the triangle table never reuses a slot, so the triangles made
since the first cut are the live ones whose slot is at least the triangle count before it
(``Baseline.triangle_slots``). Over those (none: nan angles, zero counts):

* ``min_rest_angle_deg`` / ``min_current_angle_deg`` - their smallest interior angle [deg] in
  the rest shape (``model.points``) and as the skin lies now (``sim.positions``);
  ``rest_slivers`` / ``current_slivers`` count those below 10 deg.
* ``wound_against`` - triangles whose rest normal points against the rest surface: the
  Surface's normal at the parameters of the triangle's rest centroid (on an analytic surface
  the analytic normal; on a ``mesh_surface`` the normal of the original triangle the centroid
  projects into, interpolated from its corners). Wound wrong in the material: a cut error.
* ``folded`` - triangles whose current normal points against the surface's normal at the
  parameters of their current centroid (the test of ``validity``'s ``tri_flipped_*`` checks):
  turned over as the skin lies now (by the tool or the wound's motion, or made so).
  ``folded_tissue`` counts the original triangles so turned.

Over the whole live mesh:

* ``border_loops`` - pieces of the border edges (``stroke_quality.border_loop_count``);
  ``expected_loops`` = the original loops + one per separate wound + one for an island that
  came free (its own border); ``holes`` = border_loops - expected_loops (> 0: holes left open
  or a wound split; < 0: a wound closed over).
* ``open_area_mm2`` - the area [mm^2] of the parameter plane that the original triangles
  covered at rest and the live triangles no longer cover: the slits (about 2 lip offsets x
  their length), holes left open, channels left without lips, skin deleted or removed. It
  tells an open channel from a slit, which the border loops cannot (both are one loop).
* ``components`` - connected pieces of the live triangles (joined through shared nodes, so a
  piece hanging on one node is not free).
* ``island`` - for a set with an island outline: "free" (a piece all of whose triangles' rest
  centroids lie within half a spacing of the outline's inside), "removed" (no live triangle's
  rest centroid lies deeper than half a spacing inside it), else "attached"; "" without one.

Angles [deg], lengths [m]; arrays: points (n, 3), triangles (t, 3).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..mesh.geometry import SLIVER_DEG, triangle_min_angles, triangle_normals
from ..mesh.triangulate import border_loops, boundary_edges
from .mesh_surface import PolygonDomain

__all__ = ["Baseline", "Judgement", "baseline", "judge", "judge_arrays", "against", "component_count",
           "loop_count", "island_state", "surface_normal_at", "parameter_area"]


@dataclass(frozen=True)
class Baseline:
    """The tissue before the first stroke: its triangle slot count, border loops and the area
    [m^2] its triangles cover in the surface's parameter plane at rest."""

    triangle_slots: int
    border_loops: int
    area: float


@dataclass
class Judgement:
    """The state of the cut tissue (see the module docstring)."""

    cut_triangles: int = 0
    min_rest_angle_deg: float = float("nan")
    min_current_angle_deg: float = float("nan")
    rest_slivers: int = 0
    current_slivers: int = 0
    wound_against: int = 0
    folded: int = 0
    folded_tissue: int = 0
    border_loops: int = 0
    expected_loops: int = 0
    holes: int = 0
    open_area_mm2: float = float("nan")
    components: int = 0
    island: str = ""

    def as_row(self) -> dict:
        """The fields as a flat dict (for CSV rows)."""
        return asdict(self)


def baseline(model, surface) -> Baseline:
    """The ``Baseline`` of ``model`` on ``surface`` now (call before the first stroke)."""
    return Baseline(int(model.triangle_table.count), loop_count(model.triangles),
                    parameter_area(model.points, model.triangles, surface))


def parameter_area(points, triangles, surface) -> float:
    """Sum [m^2] of the areas of triangles (t, 3) over points (n, 3) [m] mapped to the
    surface's parameter plane."""
    tri = np.asarray(triangles, dtype=np.int64)
    if not len(tri):
        return 0.0
    uv = surface.uv_of(np.asarray(points, dtype=np.float64)[tri.ravel()]).reshape(-1, 3, 2)
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    return float(0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum())


def surface_normal_at(surface, points) -> np.ndarray:
    """The surface's unit normals (m, 3) at the parameters of points (m, 3) [m]."""
    uv = surface.uv_of(np.asarray(points, dtype=np.float64))
    return surface.normal(uv[:, 0], uv[:, 1])


def against(points, triangles, reference) -> np.ndarray:
    """Mask (t,) of triangles whose normal (right-hand rule over ``points``) points against
    ``reference(centroids)``, a function of (t, 3) centroids [m] giving (t, 3) normals."""
    tri = np.asarray(triangles, dtype=np.int64)
    if not len(tri):
        return np.zeros(0, dtype=bool)
    p = np.asarray(points, dtype=np.float64)
    ref = reference(p[tri].mean(axis=1))
    return np.einsum("ij,ij->i", triangle_normals(p, tri), ref) < 0.0


def _component_labels(triangles: np.ndarray) -> np.ndarray:
    """Label (t,) of each triangle's piece (triangles (t, 3) joined through shared nodes)."""
    nodes, local = np.unique(triangles, return_inverse=True)
    parent = np.arange(len(nodes))

    def root(v: int) -> int:
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    local = local.reshape(-1, 3)
    for a, b, c in local:
        ra = root(a)
        parent[root(b)] = ra
        parent[root(c)] = ra
    return np.array([root(a) for a in local[:, 0]], dtype=np.int64)


def component_count(triangles) -> int:
    """Connected pieces of triangles (t, 3) joined through shared nodes (0 if none)."""
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    return int(len(np.unique(_component_labels(tri)))) if len(tri) else 0


def loop_count(triangles) -> int:
    """Pieces of the border edges of triangles (t, 3) (border loops when none is pinched)."""
    tri = np.asarray(triangles, dtype=np.int64)
    edges = boundary_edges(tri) if len(tri) else np.zeros((0, 2), np.int64)
    return border_loops(edges) if len(edges) else 0


def island_state(rest_points, triangles, surface, outline, spacing: float) -> str:
    """"free", "removed" or "attached" (module docstring): the live ``triangles`` at their
    ``rest_points`` against the island ``outline`` (k, 2) [m] in the surface's parameter plane."""
    tri = np.asarray(triangles, dtype=np.int64)
    inside = PolygonDomain(np.asarray(outline, dtype=np.float64))
    if not len(tri):
        return "removed"
    depth = inside.depth(surface.uv_of(np.asarray(rest_points)[tri].mean(axis=1)))
    labels = _component_labels(tri)
    for label in np.unique(labels):
        if (depth[labels == label] >= -0.5 * spacing).all():
            return "free"
    return "attached" if (depth > 0.5 * spacing).any() else "removed"


def judge_arrays(rest_points, positions, triangles, made, surface, *, base_loops: int, wounds: int,
                 outline=None, base_area: float | None = None) -> Judgement:
    """The Judgement of live ``triangles`` (t, 3) whose mask ``made`` (t,) marks those the cut
    made; rest_points and positions (n, 3) [m]; ``base_loops`` the original border loops,
    ``wounds`` the separate wounds expected; ``outline`` (k, 2) [m] the island's, or None;
    ``base_area`` [m^2] the original triangles' parameter area (None: no open area)."""
    tri = np.asarray(triangles, dtype=np.int64)
    made = np.asarray(made, dtype=bool)
    rest, now = np.asarray(rest_points, np.float64), np.asarray(positions, np.float64)
    out = Judgement(cut_triangles=int(made.sum()))
    normal_of = lambda c: surface_normal_at(surface, c)  # noqa: E731 - (m, 3) -> (m, 3)
    if made.any():
        rest_angles, now_angles = triangle_min_angles(rest, tri[made]), triangle_min_angles(now, tri[made])
        out.min_rest_angle_deg, out.min_current_angle_deg = float(rest_angles.min()), float(now_angles.min())
        out.rest_slivers = int((rest_angles < SLIVER_DEG).sum())
        out.current_slivers = int((now_angles < SLIVER_DEG).sum())
        out.wound_against = int(against(rest, tri[made], normal_of).sum())
    folded = against(now, tri, normal_of)
    out.folded, out.folded_tissue = int((folded & made).sum()), int((folded & ~made).sum())
    out.border_loops, out.components = loop_count(tri), component_count(tri)
    if outline is not None:
        out.island = island_state(rest, tri, surface, outline, surface.spacing)
    out.expected_loops = base_loops + wounds + (out.island == "free")
    out.holes = out.border_loops - out.expected_loops
    if base_area is not None:
        out.open_area_mm2 = 1e6 * (base_area - parameter_area(rest, tri, surface))
    return out


def judge(model, positions, surface, base: Baseline, *, wounds: int, outline=None) -> Judgement:
    """The Judgement of the model now (see ``judge_arrays``): ``positions`` (node_count, 3) [m]
    the current positions (``sim.positions``), ``base`` from before the first stroke."""
    made = model.triangle_table.live_slots() >= base.triangle_slots
    return judge_arrays(model.points, positions, model.triangles, made, surface,
                        base_loops=base.border_loops, wounds=wounds, outline=outline, base_area=base.area)
