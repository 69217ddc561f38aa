"""Mesh invariants and quality metrics for the warp_cut surface model.

After every topology edit (a cut) the triangle-surface mass-spring model must still be a valid
mesh. This module states those invariants, checks them in a vectorised way (numpy only, no
Python loops over all elements) and computes the quality metrics used to judge a cut (minimum
angle, sliver count, ...).

Conventions:
    points: Node positions [m], shape (n, 3) float64.
    triangles: Node indices, shape (t, 3) integer, counter-clockwise seen from the side the
        surface normal ``(p1 - p0) x (p2 - p0)`` points to.
    springs: Node indices, shape (s, 2) integer, unordered pairs.
    active: Live nodes, shape (n,) bool; deleted nodes may stay in the arrays as inactive
        slots, but no triangle or spring may reference them and their coordinates and masses
        are not checked.
    masses: Node masses [kg], shape (n,) float.

Negative indices are always an error: Warp (like numpy) wraps them silently, so ``-1`` would
address the last node instead of failing.

:func:`check_mesh` runs the groups of checks in order (nodes and masses, triangle indices,
triangle geometry, edge topology, spring pairs, spring lengths) and then counts slivers. Every
problem message starts with the name of the check that produced it (see :data:`CHECKS`);
:attr:`MeshReport.problem_counts` maps each failed check name to the number of offending
elements.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .geometry import (
    SLIVER_DEG,
    _as_index_array,
    _as_pairs,
    _as_points,
    edge_keys,
    edges_of,
    half_edges,
    triangle_angles,
    triangle_areas,
    triangle_min_angles,
    triangle_normals,
)

__all__ = [
    "CUT_CHECKS",
    "cuttable_problems",
    "CHECKS",
    "MeshInvalid",
    "MeshReport",
    "check_mesh",
    # geometry re-exported for the callers of the checks
    "edges_of",
    "triangle_angles",
    "triangle_areas",
    "triangle_min_angles",
    "triangle_normals",
]

#: Name -> description of every invariant checked by :func:`check_mesh`.
CHECKS: dict[str, str] = {
    "points_finite": "coordinates of active nodes are finite",
    "mass_invalid": "masses of active nodes are finite and > 0",
    "mass_total": "total active mass equals expected_total_mass (relative tolerance)",
    "tri_index_negative": "triangle indices are >= 0 (Warp wraps negative indices silently)",
    "tri_index_range": "triangle indices are < node count",
    "tri_inactive_node": "triangles reference only active nodes",
    "tri_repeated_vertex": "triangles have three distinct vertices",
    "tri_duplicate": "no two triangles have the same vertex set",
    "tri_degenerate": "triangle area >= min_area",
    "tri_flipped": "triangle normal does not point against reference_normal",
    "edge_nonmanifold": "no edge is shared by more than two triangles",
    "winding_inconsistent": "an edge shared by two triangles is traversed in opposite directions",
    "spring_index_negative": "spring indices are >= 0 (Warp wraps negative indices silently)",
    "spring_index_range": "spring indices are < node count",
    "spring_inactive_node": "springs reference only active nodes",
    "spring_self": "no spring connects a node to itself",
    "spring_duplicate": "no two springs connect the same pair of nodes (in either order)",
    "spring_zero_length": "spring rest-state length (current distance) >= min_length",
    "spring_missing": "every triangle edge is a spring",
    "spring_stray": "every spring is a triangle edge or an allowed extra spring",
}

_SHOW = 5  # how many offending elements a message lists


class MeshInvalid(ValueError):
    """Raised by :meth:`MeshReport.raise_if_invalid`; lists every problem.

    Attributes:
        problems: One message per failed check (see :attr:`MeshReport.problems`).
        report: The report the problems come from, or None.
    """

    def __init__(self, problems: list[str], report: MeshReport | None = None, context: str = ""):
        self.problems = list(problems)
        self.report = report
        head = f"{context}: " if context else ""
        super().__init__(
            f"{head}mesh invalid ({len(self.problems)} problem(s)):\n  - " + "\n  - ".join(self.problems)
        )


@dataclass
class MeshReport:
    """Result of :func:`check_mesh`.

    Attributes:
        valid: True iff ``problems`` is empty.
        problems: One message per failed check; each starts with the check name (see
            :data:`CHECKS`), gives the count, the first offending indices and their values.
        min_angle_deg: Smallest interior angle [deg] over all triangles whose indices are in
            range and whose corners are finite (NaN if none).
        slivers: Number of triangles (restricted to ``sliver_triangles`` if given) with
            minimum angle < ``sliver_angle_deg``.
        triangle_count: Rows of the triangle array.
        spring_count: Rows of the spring array.
        node_count: Number of active nodes.
        problem_counts: Check name -> number of offending elements.
        edge_count: Unique triangle edges.
        boundary_edge_count: Unique triangle edges used by one triangle.
        nonmanifold_edge_count: Unique triangle edges used by more than two triangles.
        inconsistent_edge_count: Interior edges traversed in the same direction by both
            triangles.
        degenerate_count: Triangles with area < ``min_area``.
        flipped_count: Triangles whose normal points against ``reference_normal``.
        max_angle_deg: Largest interior angle [deg] (NaN if none).
        min_area: Smallest triangle area [m^2] (NaN if none).
        min_spring_length: Shortest spring [m] (NaN if none).
        total_mass: Sum of the masses of the active nodes [kg] (None if masses not given).
        sliver_angle_deg: Threshold [deg] used for ``slivers``.
        sliver_indices: Triangle indices counted in ``slivers``, shape (slivers,) int64.
    """

    valid: bool
    problems: list[str]
    min_angle_deg: float
    slivers: int
    triangle_count: int
    spring_count: int
    node_count: int
    problem_counts: dict[str, int] = field(default_factory=dict)
    edge_count: int = 0
    boundary_edge_count: int = 0
    nonmanifold_edge_count: int = 0
    inconsistent_edge_count: int = 0
    degenerate_count: int = 0
    flipped_count: int = 0
    max_angle_deg: float = float("nan")
    min_area: float = float("nan")
    min_spring_length: float = float("nan")
    total_mass: float | None = None
    sliver_angle_deg: float = SLIVER_DEG
    sliver_indices: np.ndarray = field(
        default_factory=lambda: np.zeros(0, dtype=np.int64), repr=False, compare=False
    )

    def failed(self, check: str) -> bool:
        """True if the named check (a key of :data:`CHECKS`) reported a problem."""
        return check in self.problem_counts

    def raise_if_invalid(self, context: str = "") -> MeshReport:
        """Return self if valid.

        Args:
            context: Prefix of the error message (e.g. ``"after cut 3"``).

        Raises:
            MeshInvalid: Listing all problems.
        """
        if self.problems:
            raise MeshInvalid(self.problems, self, context)
        return self

    def summary(self) -> str:
        """One-line human readable summary."""
        state = "valid" if self.valid else f"INVALID ({len(self.problems)} problems: {', '.join(self.problem_counts)})"
        return (
            f"mesh {state}: {self.node_count} nodes, {self.triangle_count} triangles, "
            f"{self.spring_count} springs, min angle {self.min_angle_deg:.3g} deg, "
            f"{self.slivers} slivers (< {self.sliver_angle_deg:g} deg)"
        )


# --------------------------------------------------------------------------
# problem messages
# --------------------------------------------------------------------------
def _fmt(arr) -> str:
    """Compact single-line rendering of a small int/float array (floats as %.6g)."""

    def one(x) -> str:
        if isinstance(x, list):
            return "[" + ", ".join(one(y) for y in x) + "]"
        if isinstance(x, float):
            return f"{x:.6g}"
        return str(x)

    return one(np.asarray(arr).tolist())


def _first(idx: np.ndarray) -> str:
    """First few indices, with a trailing ', ...' if there are more."""
    s = _fmt(idx[:_SHOW])
    return s[:-1] + ", ...]" if len(idx) > _SHOW else s


def _edge_list(keys: np.ndarray, n: int) -> str:
    """The node pairs of the first few edge keys (see ``edge_keys``), e.g. ``[[0, 1], [1, 2]]``."""
    k = keys[:_SHOW]
    return _fmt(np.stack([k // n, k % n], 1))


def _message(count: int, noun: str, what: str, listing: str, values: str = "") -> str:
    """The text of one problem: ``{count} {noun}(s) {what}; {listing} -> {values}``.

    Args:
        count: Number of offending elements.
        noun: What is counted (``"triangle"``, ``"active node"``).
        what: What is wrong with them (may be empty).
        listing: The first offenders, e.g. ``"triangles [3, 7]"``.
        values: Their offending values, e.g. ``"nodes [[0, 1, 9]]"`` (may be empty).
    """
    text = f"{count} {noun}(s)" + (f" {what}" if what else "") + f"; {listing}"
    return text + (f" -> {values}" if values else "")


class _Problems:
    """The problems found so far, in check order, with a count per check name."""

    def __init__(self):
        self.messages: list[str] = []
        self.counts: dict[str, int] = {}

    def add(self, check: str, count: int, text: str) -> None:
        """Record ``count`` offenders of ``check`` (a key of CHECKS) described by ``text``."""
        self.counts[check] = self.counts.get(check, 0) + int(count)
        self.messages.append(f"{check}: {text}")

    def offenders(self, check: str, bad: np.ndarray, noun: str, what: str, *values,
                  label: str | None = None) -> None:
        """Record the elements ``bad`` failing ``check``, if there are any.

        Args:
            check: A key of CHECKS.
            bad: Indices of the offending elements, shape (k,).
            noun: What an element is (counted as ``{noun}(s)``).
            what: What is wrong with them.
            *values: ``(name, array over all elements)`` pairs; the rows of the first few
                offenders are shown as ``name [values]``.
            label: What the indices are listed as (``{label}s [...]``; default ``noun``).
        """
        if not bad.size:
            return
        shown = bad[:_SHOW]
        text = ", ".join(f"{name} {_fmt(arr[shown])}".lstrip() for name, arr in values)
        self.add(check, bad.size, _message(bad.size, noun, what, f"{label or noun}s {_first(bad)}", text))


# --------------------------------------------------------------------------
# input normalisation
# --------------------------------------------------------------------------
def _active_mask(active, n: int) -> np.ndarray:
    """Active nodes as a (n,) bool mask (all active if None)."""
    if active is None:
        return np.ones(n, dtype=bool)
    act = np.asarray(active, dtype=bool)
    if act.shape != (n,):
        raise ValueError(f"active must have shape ({n},), got {act.shape}")
    return act


def _reference_direction(reference_normal) -> np.ndarray | None:
    """The reference normal as a (3,) float64 array (None if not given), checked non-zero."""
    if reference_normal is None:
        return None
    ref = np.asarray(reference_normal, dtype=np.float64).reshape(-1)
    if ref.shape != (3,) or not np.isfinite(ref).all() or not ref.any():
        raise ValueError(f"reference_normal must be a finite non-zero (3,) vector, got {reference_normal!r}")
    return ref


def _sliver_selection(sliver_triangles, t: int) -> np.ndarray:
    """The triangles a sliver is counted on as a (t,) bool mask (all if None)."""
    if sliver_triangles is None:
        return np.ones(t, dtype=bool)
    sel = np.asarray(sliver_triangles)
    if sel.dtype == bool:
        if sel.shape != (t,):
            raise ValueError(f"sliver_triangles bool mask must have shape ({t},), got {sel.shape}")
        return sel
    sel = sel.reshape(-1)
    if sel.size and sel.dtype.kind not in "iu":
        raise ValueError(f"sliver_triangles must be integer indices or a bool mask, got {sel.dtype}")
    sel = sel.astype(np.int64)
    if sel.size and (sel.min() < 0 or sel.max() >= t):
        raise ValueError(f"sliver_triangles index out of range [0, {t})")
    mask = np.zeros(t, dtype=bool)
    mask[sel] = True
    return mask


# --------------------------------------------------------------------------
# the groups of checks, in the order check_mesh runs them
# --------------------------------------------------------------------------
def _check_nodes(p, act, masses, expected_total_mass, mass_rtol, found: _Problems):
    """points_finite, mass_invalid, mass_total.

    Returns:
        Finite-coordinate mask, shape (n,) bool, and the total active mass [kg] (None without
        masses).
    """
    finite = np.isfinite(p).all(axis=1)
    found.offenders("points_finite", np.flatnonzero(act & ~finite), "active node",
                    "with non-finite coordinates", ("", p), label="node")
    if masses is None:
        if expected_total_mass is not None:
            raise ValueError("expected_total_mass given but masses is None")
        return finite, None
    m = np.asarray(masses, dtype=np.float64)
    if m.shape != (len(p),):
        raise ValueError(f"masses must have shape ({len(p)},), got {m.shape}")
    found.offenders("mass_invalid", np.flatnonzero(act & ~(np.isfinite(m) & (m > 0))), "active node",
                    "with non-finite or non-positive mass", ("kg", m), label="node")
    total = float(np.sum(m[act]))
    if expected_total_mass is not None:
        exp = float(expected_total_mass)
        if not abs(total - exp) <= mass_rtol * abs(exp):
            found.add("mass_total", 1,
                      f"total active mass {total!r} kg != expected {exp!r} kg "
                      f"(rel. error {abs(total - exp) / abs(exp) if exp else float('inf'):.3g} > {mass_rtol:g})")
    return finite, total


def _check_indices(idx, prefix: str, noun: str, n: int, act, found: _Problems):
    """{prefix}_index_negative, {prefix}_index_range, {prefix}_inactive_node of elements ``idx`` (e, k).

    Returns:
        Rows whose indices are in range, shape (e,) bool, and ``idx`` with the other rows set
        to node 0 (safe to index with).
    """
    neg = (idx < 0).any(axis=1)
    high = (idx >= n).any(axis=1)
    ok = ~(neg | high)
    found.offenders(f"{prefix}_index_negative", np.flatnonzero(neg), noun, "with negative node index",
                    ("nodes", idx))
    found.offenders(f"{prefix}_index_range", np.flatnonzero(high), noun, f"with node index >= node count {n}",
                    ("nodes", idx))
    safe = np.where(ok[:, None], idx, 0)
    found.offenders(f"{prefix}_inactive_node", np.flatnonzero(ok & ~act[safe].all(axis=1)), noun,
                    "referencing inactive nodes", ("nodes", idx))
    return ok, safe


def _duplicate_rows(rows: np.ndarray, n: int) -> np.ndarray:
    """Mask (k,) of the rows of ``rows`` (k, 3), each sorted, that occur more than once."""
    if n < 2_000_000:  # n**3 fits in int64: 1-D keys sort much faster than rows
        n64 = np.int64(n)
        _, inv, cnt = np.unique((rows[:, 0] * n64 + rows[:, 1]) * n64 + rows[:, 2],
                                return_inverse=True, return_counts=True)
    else:
        _, inv, cnt = np.unique(rows, axis=0, return_inverse=True, return_counts=True)
    return cnt[inv.reshape(-1)] > 1


def _check_triangle_indices(tri, n: int, act, found: _Problems):
    """tri_index_negative, tri_index_range, tri_inactive_node, tri_repeated_vertex, tri_duplicate.

    Returns:
        In-range rows, shape (t,) bool; ``tri`` safe to index with (bad rows -> node 0); rows
        with a repeated vertex, shape (t,) bool.
    """
    ok, safe = _check_indices(tri, "tri", "triangle", n, act, found)
    repeated = (tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2]) | (tri[:, 0] == tri[:, 2])
    found.offenders("tri_repeated_vertex", np.flatnonzero(repeated), "triangle",
                    "without three distinct vertices", ("nodes", tri))
    cand = np.flatnonzero(ok & ~repeated)
    if cand.size > 1:
        found.offenders("tri_duplicate", cand[_duplicate_rows(np.sort(tri[cand], axis=1), n)], "triangle",
                        "sharing their vertex set with another", ("nodes", tri))
    return ok, safe, repeated


@dataclass
class _Geometry:
    """Per-triangle geometry, NaN / False for triangles with bad indices or corners."""

    min_angles: np.ndarray  # [deg], (t,)
    areas: np.ndarray  # [m^2], (t,)
    degenerate: np.ndarray  # (t,) bool
    flipped: np.ndarray  # (t,) bool
    max_angle: float = float("nan")  # [deg]


def _check_triangle_geometry(p, tri, usable, min_area: float, ref, found: _Problems) -> _Geometry:
    """tri_degenerate, tri_flipped (against ``ref``, if given) over the ``usable`` triangles (t,) bool."""
    t = len(tri)
    geo = _Geometry(np.full(t, np.nan), np.full(t, np.nan), np.zeros(t, bool), np.zeros(t, bool))
    idx = np.flatnonzero(usable)
    if not idx.size:
        return geo
    angles = triangle_angles(p, tri[idx])
    geo.min_angles[idx] = angles.min(axis=1)
    geo.max_angle = float(angles.max())
    geo.areas[idx] = triangle_areas(p, tri[idx])
    geo.degenerate[idx] = geo.areas[idx] < min_area
    found.offenders("tri_degenerate", np.flatnonzero(geo.degenerate), "triangle",
                    f"with area < min_area={min_area:g} m^2", ("m^2", geo.areas))
    if ref is not None:
        cosine = np.full(t, np.nan)
        cosine[idx] = triangle_normals(p, tri[idx]) @ (ref / np.linalg.norm(ref))
        geo.flipped[idx] = (cosine[idx] < 0) & ~geo.degenerate[idx]
        found.offenders("tri_flipped", np.flatnonzero(geo.flipped), "triangle",
                        f"with normal against reference {_fmt(ref)}", ("cos(normal, ref)", cosine))
    return geo


@dataclass
class _Edges:
    """The unique triangle edges and their topology counts."""

    keys: np.ndarray  # edge_keys of the unique edges, (e,) int64, sorted
    boundary: int = 0
    nonmanifold: int = 0
    inconsistent: int = 0


def _check_edge_topology(tri, n: int, usable, found: _Problems) -> _Edges:
    """edge_nonmanifold, winding_inconsistent over the ``usable`` triangles (t,) bool."""
    idx = np.flatnonzero(usable)
    if not idx.size:
        return _Edges(np.zeros(0, dtype=np.int64))
    he = half_edges(tri[idx])
    he_tri = np.repeat(idx, 3)
    sign = np.where(he[:, 0] < he[:, 1], 1, -1)
    keys, inv, cnt = np.unique(edge_keys(np.sort(he, axis=1), n), return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    edges = _Edges(keys, boundary=int((cnt == 1).sum()))

    nonman = np.flatnonzero(cnt > 2)
    edges.nonmanifold = int(nonman.size)
    if nonman.size:
        found.add("edge_nonmanifold", nonman.size, _message(
            nonman.size, "edge", "shared by more than two triangles", f"edges {_edge_list(keys[nonman], n)}",
            f"triangle counts {_fmt(cnt[nonman[:_SHOW]])}; triangles {_first(np.unique(he_tri[cnt[inv] > 2]))}"))

    inconsistent = (cnt == 2) & (np.bincount(inv, weights=sign, minlength=len(keys)) != 0)
    edges.inconsistent = int(inconsistent.sum())
    if edges.inconsistent:
        found.add("winding_inconsistent", edges.inconsistent, _message(
            edges.inconsistent, "interior edge", "traversed in the same direction by both triangles",
            f"edges {_edge_list(keys[inconsistent], n)}; triangles {_first(np.unique(he_tri[inconsistent[inv]]))}"))
    return edges


def _check_spring_pairs(spr, n: int, act, tri_edge_keys, extra_springs, found: _Problems):
    """spring_index_negative, spring_index_range, spring_inactive_node, spring_self,
    spring_duplicate, spring_stray, spring_missing.

    Returns:
        Springs with in-range indices joining two distinct nodes, shape (s,) bool, and
        ``spr`` safe to index with (bad rows -> node 0).
    """
    ok, safe = _check_indices(spr, "spring", "spring", n, act, found)
    self_pair = spr[:, 0] == spr[:, 1]
    found.offenders("spring_self", np.flatnonzero(self_pair), "self spring", "", ("nodes", spr), label="spring")
    pair_idx = np.flatnonzero(ok & ~self_pair)
    keys = edge_keys(np.sort(spr[pair_idx], axis=1), n)
    spring_keys, inv, cnt = np.unique(keys, return_inverse=True, return_counts=True)
    found.offenders("spring_duplicate", pair_idx[cnt[inv.reshape(-1)] > 1], "spring",
                    "connecting the same node pair as another (either order)", ("nodes", spr))
    if pair_idx.size:
        extra = np.sort(_as_pairs(extra_springs, "extra_springs"), axis=1)
        extra = extra[(extra >= 0).all(axis=1) & (extra < n).all(axis=1) & (extra[:, 0] != extra[:, 1])]
        stray = ~np.isin(keys, np.union1d(tri_edge_keys, edge_keys(extra, n)))
        found.offenders("spring_stray", pair_idx[stray], "spring",
                        "that are neither triangle edges nor allowed extra springs", ("nodes", spr))
    missing = tri_edge_keys[~np.isin(tri_edge_keys, spring_keys, assume_unique=True)]
    if missing.size:
        found.add("spring_missing", missing.size, _message(
            missing.size, "triangle edge", "without a spring",
            f"edges {_edge_list(missing, n)}" + (", ..." if missing.size > _SHOW else "")))
    return ok & ~self_pair, safe


def _check_spring_lengths(p, spr, usable, min_length: float, found: _Problems) -> np.ndarray:
    """spring_zero_length over the ``usable`` springs (s,) bool.

    Returns:
        Spring lengths [m], shape (s,), NaN where not usable.
    """
    lengths = np.full(len(spr), np.nan)
    idx = np.flatnonzero(usable)
    lengths[idx] = np.linalg.norm(p[spr[idx, 1]] - p[spr[idx, 0]], axis=1)
    found.offenders("spring_zero_length", idx[lengths[idx] < min_length], "spring",
                    f"shorter than min_length={min_length:g} m", ("nodes", spr), ("lengths m", lengths))
    return lengths


def _nanmin(x: np.ndarray) -> float:
    """Smallest finite value of ``x`` (NaN if none)."""
    x = x[np.isfinite(x)]
    return float(x.min()) if x.size else float("nan")


# --------------------------------------------------------------------------
# the checker
# --------------------------------------------------------------------------
def check_mesh(points, triangles, springs, *, active=None, masses=None, extra_springs=None,
               reference_normal=None, expected_total_mass: float | None = None,
               sliver_angle_deg: float = SLIVER_DEG, min_length: float = 1e-12, min_area: float = 1e-18,
               sliver_triangles=None, mass_rtol: float = 1e-9) -> MeshReport:
    """Check every mesh invariant (see :data:`CHECKS`) and compute quality metrics.

    Each cause is reported once: geometric checks skip elements with bad indices or non-finite
    corners, topological checks skip elements with out-of-range indices, and spring/edge set
    comparisons skip self pairs.

    Args:
        points: Node positions [m], shape (n, 3).
        triangles: Node indices, shape (t, 3) integer.
        springs: Node indices, shape (s, 2) integer.
        active: Live nodes, shape (n,) bool (default all). Inactive slots may hold anything
            (NaN coordinates, zero mass) but must not be referenced.
        masses: Node masses [kg], shape (n,); active masses must be finite and > 0.
        extra_springs: Springs allowed not to be triangle edges (e.g. bending springs), a set
            of pairs or shape (e, 2) integer; order within a pair does not matter.
        reference_normal: Shape (3,); triangles whose unit normal has a negative dot product
            with it are flipped (degenerate triangles are not flip-tested).
        expected_total_mass: [kg], requires ``masses``; compared to the total active mass
            with relative tolerance ``mass_rtol``.
        sliver_angle_deg: [deg]; a triangle is a sliver if its minimum angle is below.
        min_length: [m]; springs shorter than this are reported.
        min_area: [m^2]; triangles smaller than this are reported.
        sliver_triangles: Integer indices or a (t,) bool mask restricting the sliver count
            (e.g. to triangles made by a cut); ``min_angle_deg`` is always over all triangles.
        mass_rtol: Relative tolerance of the total-mass check.

    Returns:
        The report: every problem found, and the quality metrics.

    Raises:
        ValueError: Malformed input (wrong shapes, non-integer index arrays, a zero reference
            normal, ``expected_total_mass`` without ``masses``).
    """
    p = _as_points(points)
    n = len(p)
    tri = _as_index_array(triangles, 3, "triangles")
    spr = _as_index_array(springs, 2, "springs")
    act = _active_mask(active, n)
    ref = _reference_direction(reference_normal)
    sliver_mask = _sliver_selection(sliver_triangles, len(tri))

    found = _Problems()
    finite, total_mass = _check_nodes(p, act, masses, expected_total_mass, mass_rtol, found)
    tri_ok, tri_safe, tri_repeated = _check_triangle_indices(tri, n, act, found)
    tri_geo = tri_ok & finite[tri_safe].all(axis=1)
    geo = _check_triangle_geometry(p, tri, tri_geo, min_area, ref, found)
    edges = _check_edge_topology(tri, n, tri_ok & ~tri_repeated, found)
    spr_pair, spr_safe = _check_spring_pairs(spr, n, act, edges.keys, extra_springs, found)
    lengths = _check_spring_lengths(p, spr, spr_pair & finite[spr_safe].all(axis=1), min_length, found)
    with np.errstate(invalid="ignore"):
        slivers = np.flatnonzero(sliver_mask & tri_geo & (geo.min_angles < sliver_angle_deg))

    return MeshReport(
        valid=not found.messages, problems=found.messages, problem_counts=found.counts,
        min_angle_deg=_nanmin(geo.min_angles), max_angle_deg=geo.max_angle,
        slivers=int(slivers.size), sliver_indices=slivers, sliver_angle_deg=float(sliver_angle_deg),
        triangle_count=len(tri), spring_count=len(spr), node_count=int(act.sum()),
        edge_count=int(edges.keys.size), boundary_edge_count=edges.boundary,
        nonmanifold_edge_count=edges.nonmanifold, inconsistent_edge_count=edges.inconsistent,
        degenerate_count=int(geo.degenerate.sum()), flipped_count=int(geo.flipped.sum()),
        min_area=_nanmin(geo.areas), min_spring_length=_nanmin(lengths), total_mass=total_mass,
    )


CUT_CHECKS = ("tri_repeated_vertex", "tri_duplicate", "tri_degenerate", "edge_nonmanifold",
              "winding_inconsistent")
"""The invariants a mesh must meet before it can be cut: the cut walks hole borders along
edges (two triangles an edge, one winding) and keeps triangles oriented."""


def cuttable_problems(points, triangles, *, relative_min_area: float = 1e-6) -> list[str]:
    """Why a triangle mesh cannot be cut ([] if it can): non-manifold edges, inconsistent
    winding, duplicate faces, triangles with a repeated vertex or (nearly) no area.

    Args:
        points: Node positions [m], shape (n, 3).
        triangles: Node indices, shape (t, 3).
        relative_min_area: A triangle smaller than this times the squared median edge length
            is degenerate.

    Returns:
        One message per failed check (see ``CUT_CHECKS``), naming the first offending
        triangles or edges.
    """
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    pts = np.asarray(points, dtype=np.float64)
    lengths = np.linalg.norm(pts[tri[:, [1, 2, 0]]] - pts[tri], axis=2) if len(tri) else np.zeros(0)
    scale = float(np.median(lengths)) if lengths.size else 0.0
    report = check_mesh(pts, tri, np.zeros((0, 2), np.int64), min_area=relative_min_area * scale ** 2)
    return [p for p in report.problems if p.split(":", 1)[0] in CUT_CHECKS]
