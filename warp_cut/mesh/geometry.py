"""Triangle geometry on numpy arrays: angles, areas, normals, edges.

Conventions: ``points`` (n, 3) float64 [m]; ``triangles`` (t, 3) integer node indices,
counter-clockwise seen from the side the normal ``(p1 - p0) x (p2 - p0)`` points to.
Negative indices are an error here (Warp, like numpy, would wrap them silently).
Degenerate triangles never give NaN.
"""

from __future__ import annotations

import numpy as np

__all__ = ["triangle_angles", "triangle_min_angles", "triangle_areas", "triangle_normals",
           "edges_of"]


# --------------------------------------------------------------------------
# input normalisation
# --------------------------------------------------------------------------
def _as_points(points) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.size == 0:
        return p.reshape(0, 3)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {p.shape}")
    return p


def _as_index_array(a, width: int, name: str, keep_dtype: bool = False) -> np.ndarray:
    arr = np.asarray(a)
    if arr.size == 0:
        return np.zeros((0, width), dtype=arr.dtype if (keep_dtype and arr.dtype.kind in "iu") else np.int64)
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name} must have shape (k, {width}), got {arr.shape}")
    if arr.dtype.kind not in "iu":
        raise ValueError(f"{name} must have an integer dtype, got {arr.dtype}")
    return arr if keep_dtype else arr.astype(np.int64, copy=False)


def _check_index_range(idx: np.ndarray, n: int, name: str) -> None:
    """Strict range check used by the low-level geometry helpers."""
    if idx.size and (idx.min() < 0 or idx.max() >= n):
        raise ValueError(
            f"{name} index out of range [0, {n}): min {int(idx.min())}, max {int(idx.max())}"
        )


def _as_pairs(x, name: str) -> np.ndarray:
    """Springs given as a set/list of pairs or an (e, 2) array -> (e, 2) int64."""
    if x is None:
        return np.zeros((0, 2), dtype=np.int64)
    if isinstance(x, (set, frozenset)):
        x = list(x)
    return _as_index_array(x, 2, name)


def _corners(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(t, 3, 3) corner coordinates."""
    return points[triangles]


# --------------------------------------------------------------------------
# geometry kernels on corner arrays (t, 3, 3)
# --------------------------------------------------------------------------
def _cross_of_corners(c: np.ndarray) -> np.ndarray:
    return np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])


def _angles_of_corners(c: np.ndarray) -> np.ndarray:
    t = c.shape[0]
    if t == 0:
        return np.zeros((0, 3))
    p0, p1, p2 = c[:, 0], c[:, 1], c[:, 2]
    # at each vertex: vector to the next vertex (a) and to the previous one (b)
    a = np.stack([p1 - p0, p2 - p1, p0 - p2], axis=1)
    b = np.stack([p2 - p0, p0 - p1, p1 - p2], axis=1)
    sin_part = np.linalg.norm(np.cross(a, b), axis=-1)
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

    Parameters
    ----------
    points : (n, 3) float array, metres.
    triangles : (t, 3) int array of node indices (must be in ``[0, n)``).

    Returns
    -------
    (t, 3) float64 array, degrees; column ``k`` is the angle at vertex
    ``triangles[:, k]``.  Computed as ``atan2(|a x b|, a . b)``, which is
    accurate for very small and very large angles.  Degenerate triangles
    never give NaN: collinear distinct vertices give ``0/0/180``; if two
    vertices coincide the angle at the third is 0 and the two coincident
    vertices share the remaining 180 (90/90); if all three coincide the
    result is ``(0, 0, 180)``.  Angles sum to 180 (up to rounding) for every
    triangle with finite coordinates; rows with non-finite coordinates are
    NaN.
    """
    p = _as_points(points)
    tri = _as_index_array(triangles, 3, "triangles")
    _check_index_range(tri, len(p), "triangles")
    return _angles_of_corners(_corners(p, tri))


def triangle_min_angles(points, triangles) -> np.ndarray:
    """Smallest interior angle of every triangle, ``(t,)`` float64 degrees.

    See :func:`triangle_angles` for the treatment of degenerate triangles
    (a zero-area triangle has minimum angle 0).
    """
    ang = triangle_angles(points, triangles)
    return ang.min(axis=1) if ang.size else np.zeros(0)


def triangle_areas(points, triangles) -> np.ndarray:
    """Area of every triangle, ``(t,)`` float64, square metres (>= 0)."""
    p = _as_points(points)
    tri = _as_index_array(triangles, 3, "triangles")
    _check_index_range(tri, len(p), "triangles")
    if len(tri) == 0:
        return np.zeros(0)
    return 0.5 * np.linalg.norm(_cross_of_corners(_corners(p, tri)), axis=1)


def triangle_normals(points, triangles) -> np.ndarray:
    """Unit normals ``(t, 3)`` float64 (dimensionless), right-hand rule.

    ``n = normalize((p1 - p0) x (p2 - p0))``, i.e. counter-clockwise
    triangles seen from +Z have normal +Z.  Zero-area triangles get the zero
    vector; rows with non-finite coordinates are NaN.
    """
    p = _as_points(points)
    tri = _as_index_array(triangles, 3, "triangles")
    _check_index_range(tri, len(p), "triangles")
    if len(tri) == 0:
        return np.zeros((0, 3))
    cr = _cross_of_corners(_corners(p, tri))
    nrm = np.linalg.norm(cr, axis=1)
    out = np.zeros_like(cr)
    ok = nrm > 0
    out[ok] = cr[ok] / nrm[ok, None]
    out[~np.isfinite(nrm)] = np.nan
    return out


def edges_of(triangles) -> np.ndarray:
    """Unique undirected edges of a triangle list.

    Parameters
    ----------
    triangles : (t, 3) integer array.

    Returns
    -------
    (e, 2) array (same integer dtype as ``triangles``), each row sorted
    ``(i < j)``, rows sorted lexicographically.  Self pairs ``(i, i)`` coming
    from triangles with a repeated vertex are not edges and are dropped.
    """
    tri = _as_index_array(triangles, 3, "triangles", keep_dtype=True)
    if len(tri) == 0:
        return np.zeros((0, 2), dtype=tri.dtype)
    e = tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    e = np.sort(e, axis=1)
    e = e[e[:, 0] != e[:, 1]]
    if len(e) == 0:
        return e
    return np.unique(e, axis=0)


# --------------------------------------------------------------------------
# report
# --------------------------------------------------------------------------
