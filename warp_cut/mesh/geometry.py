"""Triangle geometry on numpy arrays: angles, areas, normals, edges.

Conventions: ``points`` (n, 3) float64 [m]; ``triangles`` (t, 3) integer node indices,
counter-clockwise seen from the side the normal ``(p1 - p0) x (p2 - p0)`` points to.
Negative indices are an error here (Warp, like numpy, would wrap them silently).
Degenerate triangles never give NaN.

Every triangle area and every triangle edge list in warp_cut comes from here: areas from
:func:`triangle_areas`, edges from :func:`half_edges` (directed, in winding order) and
:func:`edges_of` (unique, undirected).
"""

from __future__ import annotations

import numpy as np

__all__ = ["cross3", "plane_frame", "triangle_angles", "triangle_min_angles", "triangle_areas", "corner_areas",
           "triangle_normals",
           "half_edges", "edges_of", "edge_keys", "boundary_nodes", "compact_surface", "SLIVER_DEG"]

SLIVER_DEG = 10.0
"""A triangle whose smallest angle is below this [deg] is a sliver (SPEC section 4)."""


# --------------------------------------------------------------------------
# input normalisation
# --------------------------------------------------------------------------
def _as_points(points) -> np.ndarray:
    """Points as float64, shape (n, 3) (an empty input gives (0, 3)).

    Raises:
        ValueError: The points are not of shape (n, 3).
    """
    p = np.asarray(points, dtype=np.float64)
    if p.size == 0:
        return p.reshape(0, 3)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {p.shape}")
    return p


def _as_index_array(a, width: int, name: str, keep_dtype: bool = False) -> np.ndarray:
    """An integer index array of shape (k, width).

    Args:
        a: Index rows, array-like of shape (k, width) (an empty input gives (0, width)).
        width: Indices per row (3 for triangles, 2 for springs).
        name: Name used in error messages.
        keep_dtype: Keep the integer dtype of ``a`` instead of converting to int64.

    Raises:
        ValueError: Wrong shape or a non-integer dtype.
    """
    arr = np.asarray(a)
    if arr.size == 0:
        return np.zeros((0, width), dtype=arr.dtype if (keep_dtype and arr.dtype.kind in "iu") else np.int64)
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name} must have shape (k, {width}), got {arr.shape}")
    if arr.dtype.kind not in "iu":
        raise ValueError(f"{name} must have an integer dtype, got {arr.dtype}")
    return arr if keep_dtype else arr.astype(np.int64, copy=False)


def _check_index_range(idx: np.ndarray, n: int, name: str) -> None:
    """Strict range check used by the low-level geometry helpers.

    Raises:
        ValueError: An index of ``idx`` is outside [0, n).
    """
    if idx.size and (idx.min() < 0 or idx.max() >= n):
        raise ValueError(
            f"{name} index out of range [0, {n}): min {int(idx.min())}, max {int(idx.max())}"
        )


def _as_pairs(x, name: str) -> np.ndarray:
    """Node pairs given as None, a set/list of pairs or an (e, 2) array, as (e, 2) int64."""
    if x is None:
        return np.zeros((0, 2), dtype=np.int64)
    if isinstance(x, (set, frozenset)):
        x = list(x)
    return _as_index_array(x, 2, name)


def _checked(points, triangles) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) float64 and triangles (t, 3) int64, every index in [0, n)."""
    p = _as_points(points)
    tri = _as_index_array(triangles, 3, "triangles")
    _check_index_range(tri, len(p), "triangles")
    return p, tri


# --------------------------------------------------------------------------
# geometry kernels on corner arrays (t, 3, 3)
# --------------------------------------------------------------------------
def cross3(a, b) -> np.ndarray:
    """a x b of 3-vectors along the last axis, shapes (..., 3) broadcast against each other.

    The same as ``np.cross`` for 3-vectors, without its axis handling: a few microseconds
    instead of ~20 on the small arrays a cut event works on, where it is called thousands of
    times per second of cutting."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def plane_frame(normal) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (3,), (3,) completing the unit ``normal`` (3,) to a right-handed frame
    (e1, e2, normal): e1 = normal x (world X, or world Y when the normal is near X)."""
    normal = np.asarray(normal, dtype=np.float64)
    helper = [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0]
    e1 = cross3(normal, helper)
    e1 /= np.linalg.norm(e1)
    return e1, cross3(normal, e1)


def _cross_of_corners(c: np.ndarray) -> np.ndarray:
    """(p1 - p0) x (p2 - p0) [m^2], shape (t, 3), of corners c [m], shape (t, 3, 3)."""
    return cross3(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])


def _angles_of_corners(c: np.ndarray) -> np.ndarray:
    """Interior angles [deg], shape (t, 3), of corners c [m], shape (t, 3, 3) (see triangle_angles)."""
    t = c.shape[0]
    if t == 0:
        return np.zeros((0, 3))
    p0, p1, p2 = c[:, 0], c[:, 1], c[:, 2]
    # at each vertex: vector to the next vertex (a) and to the previous one (b)
    a = np.stack([p1 - p0, p2 - p1, p0 - p2], axis=1)
    b = np.stack([p2 - p0, p0 - p1, p1 - p2], axis=1)
    sin_part = np.linalg.norm(cross3(a, b), axis=-1)
    cos_part = np.einsum("tij,tij->ti", a, b)
    # atan2 is well conditioned for all angles and atan2(0, 0) == 0 (no NaN)
    ang = np.degrees(np.arctan2(sin_part, cos_part))

    finite = np.isfinite(c).all(axis=(1, 2))
    undef = ((np.linalg.norm(a, axis=-1) == 0) | (np.linalg.norm(b, axis=-1) == 0)) & finite[:, None]
    n_undef = undef.sum(axis=1)
    if n_undef.any():
        # angle at a vertex with a zero-length incident edge is undefined: share
        # what is left of 180 degrees equally among the undefined vertices
        defined_sum = np.where(undef, 0.0, ang).sum(axis=1)
        fill = np.clip(180.0 - defined_sum, 0.0, 180.0) / np.maximum(n_undef, 1)
        partial = (n_undef > 0) & (n_undef < 3)
        ang = np.where(undef & partial[:, None], fill[:, None], ang)
        full = n_undef == 3  # all three corners coincide
        ang[full] = (0.0, 0.0, 180.0)
    ang[~finite] = np.nan
    return ang


# --------------------------------------------------------------------------
# public geometry helpers
# --------------------------------------------------------------------------
def triangle_angles(points, triangles) -> np.ndarray:
    """Interior angles of every triangle.

    Computed as ``atan2(|a x b|, a . b)``, which is accurate for very small and very large
    angles. Degenerate triangles never give NaN: collinear distinct vertices give
    ``0/0/180``; if two vertices coincide the angle at the third is 0 and the two coincident
    vertices share the remaining 180 (90/90); if all three coincide the result is
    ``(0, 0, 180)``. Angles sum to 180 (up to rounding) for every triangle with finite
    coordinates; rows with non-finite coordinates are NaN.

    Args:
        points: Node positions [m], shape (n, 3).
        triangles: Node indices, shape (t, 3), integer, each in [0, n).

    Returns:
        Angles [deg], shape (t, 3) float64; column ``k`` is the angle at vertex
        ``triangles[:, k]``.

    Raises:
        ValueError: Wrong shapes, a non-integer index array or an index outside [0, n).
    """
    p, tri = _checked(points, triangles)
    return _angles_of_corners(p[tri])


def triangle_min_angles(points, triangles) -> np.ndarray:
    """Smallest interior angle of every triangle (a zero-area triangle has 0).

    Args:
        points: Node positions [m], shape (n, 3).
        triangles: Node indices, shape (t, 3), integer, each in [0, n).

    Returns:
        Minimum angles [deg], shape (t,) float64 (see :func:`triangle_angles` for degenerate
        triangles).
    """
    ang = triangle_angles(points, triangles)
    return ang.min(axis=1) if ang.size else np.zeros(0)


def triangle_areas(points, triangles) -> np.ndarray:
    """Area of every triangle, ``|(p1 - p0) x (p2 - p0)| / 2``.

    Args:
        points: Node positions [m], shape (n, 3).
        triangles: Node indices, shape (t, 3), integer, each in [0, n).

    Returns:
        Areas [m^2], shape (t,) float64, >= 0.

    Raises:
        ValueError: Wrong shapes, a non-integer index array or an index outside [0, n).
    """
    p, tri = _checked(points, triangles)
    if len(tri) == 0:
        return np.zeros(0)
    return corner_areas(p[tri])


def corner_areas(corners: np.ndarray) -> np.ndarray:
    """Areas [m^2] (t,) of triangles given by their corners [m] (t, 3, 3), unchecked (for
    callers that made the array themselves: a cut adding one triangle at a time)."""
    return 0.5 * np.linalg.norm(_cross_of_corners(corners), axis=1)


def triangle_normals(points, triangles) -> np.ndarray:
    """Unit normals by the right-hand rule, ``normalize((p1 - p0) x (p2 - p0))``.

    Counter-clockwise triangles seen from +Z have normal +Z. Zero-area triangles get the
    zero vector; rows with non-finite coordinates are NaN.

    Args:
        points: Node positions [m], shape (n, 3).
        triangles: Node indices, shape (t, 3), integer, each in [0, n).

    Returns:
        Unit normals (dimensionless), shape (t, 3) float64.

    Raises:
        ValueError: Wrong shapes, a non-integer index array or an index outside [0, n).
    """
    p, tri = _checked(points, triangles)
    if len(tri) == 0:
        return np.zeros((0, 3))
    cr = _cross_of_corners(p[tri])
    nrm = np.linalg.norm(cr, axis=1)
    out = np.zeros_like(cr)
    ok = nrm > 0
    out[ok] = cr[ok] / nrm[ok, None]
    out[~np.isfinite(nrm)] = np.nan
    return out


def half_edges(triangles) -> np.ndarray:
    """Directed edges of every triangle in winding order: (v0, v1), (v1, v2), (v2, v0).

    Args:
        triangles: Node indices, shape (t, 3), integer.

    Returns:
        Directed edges, shape (3 t, 2), the dtype of ``triangles``; rows ``3 k .. 3 k + 2``
        belong to triangle ``k``.
    """
    tri = _as_index_array(triangles, 3, "triangles", keep_dtype=True)
    return tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)


def edges_of(triangles, *, return_counts: bool = False):
    """Unique undirected edges of a triangle list.

    Self pairs ``(i, i)`` coming from triangles with a repeated vertex are not edges and
    are dropped.

    Args:
        triangles: Node indices, shape (t, 3), integer.
        return_counts: Also return how many triangles use each edge.

    Returns:
        Edges, shape (e, 2), the integer dtype of ``triangles``, each row sorted ``(i < j)``,
        rows sorted lexicographically; with ``return_counts`` also the triangle count of each
        edge, shape (e,) int64 (1 on a boundary, 2 inside a manifold mesh).
    """
    e = np.sort(half_edges(triangles), axis=1)
    e = e[e[:, 0] != e[:, 1]]
    return np.unique(e, axis=0, return_counts=return_counts)


def edge_keys(pairs: np.ndarray, node_count: int) -> np.ndarray:
    """One int64 key per node pair, ``lo * node_count + hi``, for fast set operations.

    Args:
        pairs: Node pairs, shape (e, 2), each row sorted (lo <= hi) and in [0, node_count).
        node_count: Number of node slots (the key base).

    Returns:
        Keys, shape (e,) int64; equal keys mean equal pairs.
    """
    return pairs[:, 0].astype(np.int64) * np.int64(node_count) + pairs[:, 1]


def boundary_nodes(node_count: int, triangles) -> np.ndarray:
    """Nodes on a boundary edge (an edge used by exactly one triangle).

    Args:
        node_count: Number of nodes (the length of the mask).
        triangles: Node indices, shape (t, 3), integer, each in [0, node_count).

    Returns:
        Mask, shape (node_count,) bool.
    """
    edges, counts = edges_of(np.asarray(triangles, dtype=np.int64).reshape(-1, 3), return_counts=True)
    mask = np.zeros(node_count, dtype=bool)
    mask[edges[counts == 1].ravel()] = True
    return mask


def compact_surface(active, triangles) -> tuple[np.ndarray, np.ndarray]:
    """The live surface with its nodes numbered 0..k-1 (for files and viewers).

    Args:
        active: Which node slots are alive, shape (n,) bool.
        triangles: Live triangles, node slots, shape (t, 3), integer.

    Returns:
        The live node slots, shape (k,) int64, and the triangles in their numbering, shape
        (t, 3) int64.

    Raises:
        ValueError: A triangle uses a deleted node (the tissue's invariant broken).
    """
    keep = np.flatnonzero(np.asarray(active, dtype=bool))
    remap = np.full(len(active), -1, dtype=np.int64)
    remap[keep] = np.arange(len(keep))
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    faces = remap[tri] if len(tri) else np.zeros((0, 3), np.int64)
    if np.any(faces < 0):
        bad = int(np.flatnonzero(np.any(faces < 0, axis=1))[0])
        raise ValueError(f"triangle {bad} {tri[bad].tolist()} uses a deleted node")
    return keep, faces
