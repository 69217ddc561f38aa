"""Mesh invariants and quality metrics for the warp_cut surface model.

After every topology edit (a cut) the triangle-surface mass-spring model must
still be a valid mesh.  This module states those invariants, checks them in a
vectorised way (numpy only, no Python loops over all elements) and computes
the quality metrics used to judge a cut (minimum angle, sliver count, ...).

Conventions
-----------
* ``points``    : ``(n, 3)`` float64, node positions in metres.
* ``triangles`` : ``(t, 3)`` integer node indices, counter-clockwise when seen
  from the side the surface normal points to (``n = (p1-p0) x (p2-p0)``).
* ``springs``   : ``(s, 2)`` integer node indices, unordered pairs.
* ``active``    : ``(n,)`` bool; deleted nodes may stay in the arrays as
  inactive slots, but no triangle or spring may reference them and their
  coordinates / masses are not checked.
* ``masses``    : ``(n,)`` float, kilograms.

Negative indices are always an error: Warp (like numpy) wraps them silently,
so ``-1`` would address the last node instead of failing.

Check names
-----------
Every problem message starts with the name of the check that produced it
(see :data:`CHECKS`); :attr:`MeshReport.problem_counts` maps each failed
check name to the number of offending elements.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .geometry import (  # noqa: F401 - re-exported
    _angles_of_corners,
    _as_index_array,
    _as_pairs,
    _as_points,
    _cross_of_corners,
    edges_of,
    triangle_angles,
    triangle_areas,
    triangle_min_angles,
    triangle_normals,
)

__all__ = [
    "CHECKS",
    "MeshInvalid",
    "MeshReport",
    "check_mesh",
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
    """Raised by :meth:`MeshReport.raise_if_invalid`; lists every problem."""

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

    Attributes
    ----------
    valid : True iff ``problems`` is empty.
    problems : one message per failed check; each starts with the check name
        (see :data:`CHECKS`), gives the count, the first offending indices
        and their values.
    min_angle_deg : smallest interior angle over all triangles whose indices
        are in range and whose corners are finite (degrees; NaN if none).
    slivers : number of triangles (restricted to ``sliver_triangles`` if
        given) with minimum angle < ``sliver_angle_deg``.
    triangle_count, spring_count : rows of the input arrays.
    node_count : number of active nodes.
    problem_counts : check name -> number of offending elements.
    edge_count, boundary_edge_count, nonmanifold_edge_count,
    inconsistent_edge_count : counts over the unique triangle edges
        (boundary = used by one triangle).
    degenerate_count, flipped_count : triangle counts.
    max_angle_deg : largest interior angle (degrees; NaN if none).
    min_area : smallest triangle area (m^2; NaN if none).
    min_spring_length : shortest spring (m; NaN if none).
    total_mass : sum of masses of active nodes (kg; None if masses not given).
    sliver_angle_deg : threshold used for ``slivers``.
    sliver_indices : triangle indices counted in ``slivers``.
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
    sliver_angle_deg: float = 10.0
    sliver_indices: np.ndarray = field(
        default_factory=lambda: np.zeros(0, dtype=np.int64), repr=False, compare=False
    )

    def failed(self, check: str) -> bool:
        """True if the named check (a key of :data:`CHECKS`) reported a problem."""
        return check in self.problem_counts

    def raise_if_invalid(self, context: str = "") -> MeshReport:
        """Raise :class:`MeshInvalid` listing all problems; return self if valid."""
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
# the checker
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


def _pair_keys(sorted_pairs: np.ndarray, n: int) -> np.ndarray:
    """Unique int64 key of in-range sorted pairs (lo * n + hi)."""
    return sorted_pairs[:, 0] * np.int64(n) + sorted_pairs[:, 1]


def _check_indices(idx, prefix: str, noun: str, n: int, act, add):
    """Report negative, out-of-range and inactive node indices of elements ``idx`` (e, k);
    returns (rows whose indices are in range, idx with bad rows set to node 0)."""
    neg = (idx < 0).any(axis=1)
    high = (idx >= n).any(axis=1)
    ok = ~(neg | high)
    for check, mask, what in ((f"{prefix}_index_negative", neg, "negative node index"),
                              (f"{prefix}_index_range", high, f"node index >= node count {n}")):
        bad = np.flatnonzero(mask)
        if bad.size:
            add(check, bad.size,
                f"{bad.size} {noun}(s) with {what}; {noun}s {_first(bad)} -> nodes {_fmt(idx[bad[:_SHOW]])}")
    safe = np.where(ok[:, None], idx, 0)
    bad = np.flatnonzero(ok & ~act[safe].all(axis=1))
    if bad.size:
        add(f"{prefix}_inactive_node", bad.size,
            f"{bad.size} {noun}(s) referencing inactive nodes; {noun}s {_first(bad)} -> nodes {_fmt(idx[bad[:_SHOW]])}")
    return ok, safe


def check_mesh(
    points,
    triangles,
    springs,
    *,
    active=None,
    masses=None,
    extra_springs=None,
    reference_normal=None,
    expected_total_mass: float | None = None,
    sliver_angle_deg: float = 10.0,
    min_length: float = 1e-12,
    min_area: float = 1e-18,
    sliver_triangles=None,
    mass_rtol: float = 1e-9,
) -> MeshReport:
    """Check every mesh invariant and compute quality metrics.

    Parameters
    ----------
    points : (n, 3) float, metres.
    triangles : (t, 3) int node indices.
    springs : (s, 2) int node indices.
    active : (n,) bool, optional (default all active).  Inactive slots may hold
        anything (NaN coordinates, zero mass) but must not be referenced.
    masses : (n,) float kg, optional; active masses must be finite and > 0.
    extra_springs : set of pairs or (e, 2) int array, optional; springs allowed
        not to be triangle edges (e.g. bending springs).  Order within a pair
        does not matter.
    reference_normal : (3,) float, optional; triangles whose unit normal has a
        negative dot product with it are reported as flipped (degenerate
        triangles are not flip-tested).
    expected_total_mass : float kg, optional; requires ``masses``; compared to
        the total active mass with relative tolerance ``mass_rtol``.
    sliver_angle_deg : degrees; a triangle is a sliver if its min angle is below.
    min_length : metres; springs shorter than this are reported.
    min_area : square metres; triangles smaller than this are reported.
    sliver_triangles : optional int indices or (t,) bool mask; restricts the
        sliver count (e.g. to triangles created by a cut).  ``min_angle_deg``
        is always over all triangles.
    mass_rtol : relative tolerance of the total-mass check.

    Returns
    -------
    MeshReport.  Malformed inputs (wrong shapes, non-integer index arrays,
    ``expected_total_mass`` without ``masses``) raise ``ValueError`` instead.

    Each cause is reported once: geometric checks skip elements with bad
    indices or non-finite corners, topological checks skip elements with
    out-of-range indices, and spring/edge set comparisons skip self pairs.
    """
    p = _as_points(points)
    n = len(p)
    tri = _as_index_array(triangles, 3, "triangles")
    spr = _as_index_array(springs, 2, "springs")
    t, s = len(tri), len(spr)

    if active is None:
        act = np.ones(n, dtype=bool)
    else:
        act = np.asarray(active, dtype=bool)
        if act.shape != (n,):
            raise ValueError(f"active must have shape ({n},), got {act.shape}")

    problems: list[str] = []
    counts: dict[str, int] = {}

    def add(check: str, count: int, text: str) -> None:
        counts[check] = counts.get(check, 0) + int(count)
        problems.append(f"{check}: {text}")

    # ---------------------------------------------------------------- nodes
    finite_pt = np.isfinite(p).all(axis=1)
    bad = np.flatnonzero(act & ~finite_pt)
    if bad.size:
        add("points_finite", bad.size,
            f"{bad.size} active node(s) with non-finite coordinates; nodes {_first(bad)} -> {_fmt(p[bad[:_SHOW]])}")

    total_mass: float | None = None
    if masses is not None:
        m = np.asarray(masses, dtype=np.float64)
        if m.shape != (n,):
            raise ValueError(f"masses must have shape ({n},), got {m.shape}")
        bad = np.flatnonzero(act & ~(np.isfinite(m) & (m > 0)))
        if bad.size:
            add("mass_invalid", bad.size,
                f"{bad.size} active node(s) with non-finite or non-positive mass; nodes {_first(bad)} "
                f"-> kg {_fmt(m[bad[:_SHOW]])}")
        total_mass = float(np.sum(m[act]))
        if expected_total_mass is not None:
            exp = float(expected_total_mass)
            if not abs(total_mass - exp) <= mass_rtol * abs(exp):
                add("mass_total", 1,
                    f"total active mass {total_mass!r} kg != expected {exp!r} kg "
                    f"(rel. error {abs(total_mass - exp) / abs(exp) if exp else float('inf'):.3g} > {mass_rtol:g})")
    elif expected_total_mass is not None:
        raise ValueError("expected_total_mass given but masses is None")

    # ---------------------------------------------------- triangle indices
    tri_ok, safe_tri = _check_indices(tri, "tri", "triangle", n, act, add)

    tri_rep = (tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2]) | (tri[:, 0] == tri[:, 2])
    bad = np.flatnonzero(tri_rep)
    if bad.size:
        add("tri_repeated_vertex", bad.size,
            f"{bad.size} triangle(s) without three distinct vertices; triangles {_first(bad)} "
            f"-> nodes {_fmt(tri[bad[:_SHOW]])}")

    cand = np.flatnonzero(tri_ok & ~tri_rep)
    if cand.size > 1:
        st = np.sort(tri[cand], axis=1)
        if n < 2_000_000:  # n**3 fits in int64: 1-D keys sort much faster than rows
            n64 = np.int64(n)
            _, inv, cnt = np.unique((st[:, 0] * n64 + st[:, 1]) * n64 + st[:, 2],
                                    return_inverse=True, return_counts=True)
        else:
            _, inv, cnt = np.unique(st, axis=0, return_inverse=True, return_counts=True)
        inv = inv.reshape(-1)
        bad = cand[cnt[inv] > 1]
        if bad.size:
            add("tri_duplicate", bad.size,
                f"{bad.size} triangle(s) sharing their vertex set with another; triangles {_first(bad)} "
                f"-> nodes {_fmt(tri[bad[:_SHOW]])}")

    # ------------------------------------------------- triangle geometry
    tri_geo = tri_ok & finite_pt[safe_tri].all(axis=1)
    geo_idx = np.flatnonzero(tri_geo)
    min_angles = np.full(t, np.nan)
    areas = np.full(t, np.nan)
    max_angle = float("nan")
    degenerate = np.zeros(t, dtype=bool)
    flipped = np.zeros(t, dtype=bool)
    if geo_idx.size:
        c = p[tri[geo_idx]]
        ang = _angles_of_corners(c)
        min_angles[geo_idx] = ang.min(axis=1)
        max_angle = float(ang.max())
        cr = _cross_of_corners(c)
        nrm = np.linalg.norm(cr, axis=1)
        areas[geo_idx] = 0.5 * nrm
        degenerate[geo_idx] = areas[geo_idx] < min_area
        bad = np.flatnonzero(degenerate)
        if bad.size:
            add("tri_degenerate", bad.size,
                f"{bad.size} triangle(s) with area < min_area={min_area:g} m^2; triangles {_first(bad)} "
                f"-> m^2 {_fmt(areas[bad[:_SHOW]])}")
        if reference_normal is not None:
            ref = np.asarray(reference_normal, dtype=np.float64).reshape(-1)
            rn = np.linalg.norm(ref) if ref.shape == (3,) else 0.0
            if not (np.isfinite(rn) and rn > 0):
                raise ValueError(f"reference_normal must be a finite non-zero (3,) vector, got {reference_normal!r}")
            cosang = (cr @ (ref / rn)) / np.where(nrm > 0, nrm, 1.0)
            flipped[geo_idx] = (cosang < 0) & ~degenerate[geo_idx]
            bad = np.flatnonzero(flipped)
            if bad.size:
                cos_full = np.full(t, np.nan)
                cos_full[geo_idx] = cosang
                add("tri_flipped", bad.size,
                    f"{bad.size} triangle(s) with normal against reference {_fmt(ref)}; triangles {_first(bad)} -> "
                    f"cos(normal, ref) {_fmt(cos_full[bad[:_SHOW]])}")
    elif reference_normal is not None:
        ref = np.asarray(reference_normal, dtype=np.float64).reshape(-1)
        if ref.shape != (3,) or not np.isfinite(ref).all() or not ref.any():
            raise ValueError(f"reference_normal must be a finite non-zero (3,) vector, got {reference_normal!r}")

    # ------------------------------------------------------ edge topology
    topo_idx = np.flatnonzero(tri_ok & ~tri_rep)
    edge_keys = np.zeros(0, dtype=np.int64)
    boundary_count = nonmanifold_count = inconsistent_count = 0
    if topo_idx.size:
        he = tri[topo_idx][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)  # directed half-edges
        he_tri = np.repeat(topo_idx, 3)
        lo, hi = he.min(axis=1), he.max(axis=1)
        sign = np.where(he[:, 0] < he[:, 1], 1, -1)
        edge_keys, inv, cnt = np.unique(lo * np.int64(n) + hi, return_inverse=True, return_counts=True)
        inv = inv.reshape(-1)
        sign_sum = np.bincount(inv, weights=sign, minlength=len(edge_keys))
        boundary_count = int((cnt == 1).sum())

        nonman = np.flatnonzero(cnt > 2)
        nonmanifold_count = int(nonman.size)
        if nonman.size:
            k = edge_keys[nonman[:_SHOW]]
            add("edge_nonmanifold", nonman.size,
                f"{nonman.size} edge(s) shared by more than two triangles; edges {_fmt(np.stack([k // n, k % n], 1))} "
                f"-> triangle counts {_fmt(cnt[nonman[:_SHOW]])}; triangles {_first(np.unique(he_tri[cnt[inv] > 2]))}")

        incons = (cnt == 2) & (sign_sum != 0)
        inconsistent_count = int(incons.sum())
        if inconsistent_count:
            k = edge_keys[np.flatnonzero(incons)[:_SHOW]]
            add("winding_inconsistent", inconsistent_count,
                f"{inconsistent_count} interior edge(s) traversed in the same direction by both triangles; "
                f"edges {_fmt(np.stack([k // n, k % n], 1))}; triangles {_first(np.unique(he_tri[incons[inv]]))}")

    # ------------------------------------------------------ spring indices
    spr_ok, safe_spr = _check_indices(spr, "spring", "spring", n, act, add)

    spr_self = spr[:, 0] == spr[:, 1]
    bad = np.flatnonzero(spr_self)
    if bad.size:
        add("spring_self", bad.size,
            f"{bad.size} self spring(s); springs {_first(bad)} -> nodes {_fmt(spr[bad[:_SHOW]])}")

    pair_idx = np.flatnonzero(spr_ok & ~spr_self)
    spring_keys = np.zeros(0, dtype=np.int64)
    if pair_idx.size:
        sp = np.sort(spr[pair_idx], axis=1)
        keys = _pair_keys(sp, n)
        spring_keys, inv, cnt = np.unique(keys, return_inverse=True, return_counts=True)
        inv = inv.reshape(-1)
        bad = pair_idx[cnt[inv] > 1]
        if bad.size:
            add("spring_duplicate", bad.size,
                f"{bad.size} spring(s) connecting the same node pair as another (either order); springs {_first(bad)} "
                f"-> nodes {_fmt(spr[bad[:_SHOW]])}")

        # stray springs: neither a triangle edge nor allowed
        extra = _as_pairs(extra_springs, "extra_springs")
        extra = np.sort(extra, axis=1)
        extra = extra[(extra >= 0).all(axis=1) & (extra < n).all(axis=1) & (extra[:, 0] != extra[:, 1])]
        allowed = np.union1d(edge_keys, _pair_keys(extra, n))
        stray = ~np.isin(keys, allowed)
        bad = pair_idx[stray]
        if bad.size:
            add("spring_stray", bad.size,
                f"{bad.size} spring(s) that are neither triangle edges nor allowed extra springs; "
                f"springs {_first(bad)} "
                f"-> nodes {_fmt(spr[bad[:_SHOW]])}")

    # springs missing for triangle edges
    if edge_keys.size:
        missing = edge_keys[~np.isin(edge_keys, spring_keys, assume_unique=True)]
        if missing.size:
            k = missing[:_SHOW]
            add("spring_missing", missing.size,
                f"{missing.size} triangle edge(s) without a spring; edges {_fmt(np.stack([k // n, k % n], 1))}"
                + (", ..." if missing.size > _SHOW else ""))

    # spring lengths
    lengths = np.full(s, np.nan)
    len_idx = np.flatnonzero(spr_ok & ~spr_self & finite_pt[safe_spr].all(axis=1))
    if len_idx.size:
        lengths[len_idx] = np.linalg.norm(p[spr[len_idx, 1]] - p[spr[len_idx, 0]], axis=1)
        bad = len_idx[lengths[len_idx] < min_length]
        if bad.size:
            add("spring_zero_length", bad.size,
                f"{bad.size} spring(s) shorter than min_length={min_length:g} m; springs {_first(bad)} "
                f"-> nodes {_fmt(spr[bad[:_SHOW]])}, lengths m {_fmt(lengths[bad[:_SHOW]])}")

    # ------------------------------------------------------------ quality
    if sliver_triangles is None:
        sliver_mask = np.ones(t, dtype=bool)
    else:
        sel = np.asarray(sliver_triangles)
        if sel.dtype == bool:
            if sel.shape != (t,):
                raise ValueError(f"sliver_triangles bool mask must have shape ({t},), got {sel.shape}")
            sliver_mask = sel
        else:
            sel = sel.reshape(-1)
            if sel.size and sel.dtype.kind not in "iu":
                raise ValueError(f"sliver_triangles must be integer indices or a bool mask, got {sel.dtype}")
            sel = sel.astype(np.int64)
            if sel.size and (sel.min() < 0 or sel.max() >= t):
                raise ValueError(f"sliver_triangles index out of range [0, {t})")
            sliver_mask = np.zeros(t, dtype=bool)
            sliver_mask[sel] = True
    with np.errstate(invalid="ignore"):
        sliver_idx = np.flatnonzero(sliver_mask & tri_geo & (min_angles < sliver_angle_deg))

    def _nanmin(x: np.ndarray) -> float:
        x = x[np.isfinite(x)]
        return float(x.min()) if x.size else float("nan")

    return MeshReport(
        valid=not problems,
        problems=problems,
        min_angle_deg=_nanmin(min_angles),
        slivers=int(sliver_idx.size),
        triangle_count=t,
        spring_count=s,
        node_count=int(act.sum()),
        problem_counts=counts,
        edge_count=int(edge_keys.size),
        boundary_edge_count=boundary_count,
        nonmanifold_edge_count=nonmanifold_count,
        inconsistent_edge_count=inconsistent_count,
        degenerate_count=int(degenerate.sum()),
        flipped_count=int(flipped.sum()),
        max_angle_deg=max_angle,
        min_area=_nanmin(areas),
        min_spring_length=_nanmin(lengths),
        total_mass=total_mass,
        sliver_angle_deg=float(sliver_angle_deg),
        sliver_indices=sliver_idx,
    )
