"""Checks of an exported USD stage, time sample by time sample, and the USD validators.

``check_usd`` opens a stage and, for every time at which any attribute of a prim is sampled
(and at the start time code), checks:

* stage metadata: defaultPrim, upAxis Z, metersPerUnit 1, timeCodesPerSecond > 0, start <= end;
* Mesh: points present and finite; every face has >= 3 distinct vertices; face vertex counts
  sum to the index count; indices address the points of that time; extent is the points' bounds;
* primvars (any prim): the element count matches the interpolation at that time (constant 1,
  uniform faces, vertex/varying points, faceVarying face vertices); indices within the values;
  float values finite;
* BasisCurves: points finite; curve vertex counts sum to the point count; a cubic bezier
  nonperiodic curve has 3 s + 1 >= 4 vertices; extent contains the points;
* Cylinder: radius and height finite and >= 0;
* every Xformable: a finite local-to-world transform.

``validate_usd`` runs every validator ``pxr.UsdValidation`` has registered.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdValidation

__all__ = ["check_usd", "validate_usd"]

_EXTENT_TOLERANCE = 1e-6
"""Relative tolerance [-] of an authored extent against the points' bounds (float32 data)."""


def _times(prim, start: float, end: float) -> list[float]:
    """The start time code and every time sample of ``prim``'s attributes in [start, end], sorted."""
    times = {float(start)}
    interval = Gf.Interval(start, end)
    for attr in prim.GetAttributes():
        times.update(attr.GetTimeSamplesInInterval(interval))
    return sorted(times)


def _array(value, dtype=np.float64) -> np.ndarray:
    """A USD value as a numpy array (an empty one for None)."""
    return np.asarray(value if value is not None else [], dtype=dtype)


def _check_extent(where: str, extent, points: np.ndarray, exact: bool, pad: float = 0.0) -> list[str]:
    """Problems of an authored extent (2, 3) [m] against points (n, 3) [m]: it must contain
    them (grown by ``pad`` [m]) and, if ``exact``, be their bounds."""
    ext = _array(extent)
    if ext.shape != (2, 3) or not np.all(np.isfinite(ext)):
        return [f"{where}: extent must be two finite points, got shape {ext.shape}"]
    if len(points) == 0:
        return []
    lo, hi = points.min(axis=0), points.max(axis=0)
    tol = _EXTENT_TOLERANCE * max(1.0, float(np.abs(points).max())) + pad
    if np.any(ext[0] > lo + tol) or np.any(ext[1] < hi - tol):
        return [f"{where}: extent {ext.tolist()} does not contain the points {[lo.tolist(), hi.tolist()]}"]
    if exact and (np.any(np.abs(ext[0] - lo) > tol) or np.any(np.abs(ext[1] - hi) > tol)):
        return [f"{where}: extent {ext.tolist()} is not the points' bounds {[lo.tolist(), hi.tolist()]}"]
    return []


def _check_mesh(mesh, t: float, where: str) -> tuple[list[str], dict]:
    """Problems of a Mesh at time ``t``, and its element counts for the primvar check."""
    problems = []
    points = _array(mesh.GetPointsAttr().Get(t))
    counts = _array(mesh.GetFaceVertexCountsAttr().Get(t), np.int64)
    indices = _array(mesh.GetFaceVertexIndicesAttr().Get(t), np.int64)
    sizes = {"points": len(points), "faces": len(counts), "face_vertices": len(indices)}
    if mesh.GetPointsAttr().Get(t) is None:
        return [f"{where}: no points"], sizes
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        problems.append(f"{where}: points must be finite (n, 3)")
        return problems, sizes
    if np.any(counts < 3):
        problems.append(f"{where}: face {int(np.flatnonzero(counts < 3)[0])} has fewer than 3 vertices")
    elif counts.sum() != len(indices):
        problems.append(f"{where}: face vertex counts sum to {int(counts.sum())} but there are "
                        f"{len(indices)} face vertex indices")
    elif len(indices):
        if indices.min() < 0 or indices.max() >= len(points):
            bad = int(indices.max() if indices.max() >= len(points) else indices.min())
            problems.append(f"{where}: face vertex index {bad} "
                            f"outside the {len(points)} points")
        else:
            starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
            for k in np.unique(counts):
                rows = indices[starts[counts == k][:, None] + np.arange(k)]
                srt = np.sort(rows, axis=1)
                bad = np.flatnonzero(np.any(srt[:, 1:] == srt[:, :-1], axis=1))
                if len(bad):
                    problems.append(f"{where}: a face repeats a vertex: {rows[bad[0]].tolist()}")
                    break
    problems += _check_extent(where, mesh.GetExtentAttr().Get(t), points, exact=True)
    return problems, sizes


def _check_curves(curves, t: float, where: str) -> tuple[list[str], dict]:
    """Problems of a BasisCurves at time ``t``, and its element counts for the primvar check."""
    points = _array(curves.GetPointsAttr().Get(t))
    counts = _array(curves.GetCurveVertexCountsAttr().Get(t), np.int64)
    # varying counts segments on curves, not points: not checked
    sizes = {"points": len(points), "faces": len(counts), "varying": None,
             "face_vertices": len(points)}
    problems = []
    if len(points) and (points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points))):
        return [f"{where}: points must be finite (n, 3)"], sizes
    if counts.sum() != len(points):
        problems.append(f"{where}: curve vertex counts sum to {int(counts.sum())} but there are "
                        f"{len(points)} points")
    cubic_bezier = (curves.GetTypeAttr().Get(t) == UsdGeom.Tokens.cubic
                    and curves.GetBasisAttr().Get(t) == UsdGeom.Tokens.bezier
                    and curves.GetWrapAttr().Get(t) == UsdGeom.Tokens.nonperiodic)
    if cubic_bezier and np.any((counts < 4) | ((counts - 1) % 3 != 0)):
        problems.append(f"{where}: a cubic bezier curve needs 3 s + 1 >= 4 vertices, got {counts.tolist()}")
    widths = _array(curves.GetWidthsAttr().Get(t))
    pad = 0.5 * float(widths.max()) if len(widths) else 0.0
    problems += _check_extent(where, curves.GetExtentAttr().Get(t), points, exact=False, pad=pad)
    return problems, sizes


def _check_primvars(prim, t: float, where: str, sizes: dict) -> list[str]:
    """Problems of ``prim``'s primvars at time ``t`` against the element counts ``sizes``."""
    expected_by = {UsdGeom.Tokens.constant: 1, UsdGeom.Tokens.uniform: sizes.get("faces"),
                   UsdGeom.Tokens.vertex: sizes.get("points"),
                   UsdGeom.Tokens.varying: sizes.get("varying", sizes.get("points")),
                   UsdGeom.Tokens.faceVarying: sizes.get("face_vertices")}
    problems = []
    for pv in UsdGeom.PrimvarsAPI(prim).GetPrimvars():
        values = pv.Get(t)
        if values is None:
            continue
        name = pv.GetPrimvarName()
        expected = expected_by.get(pv.GetInterpolation())
        if expected is None:
            continue
        expected *= max(1, pv.GetElementSize())
        vals = np.asarray(values)
        if vals.dtype.kind == "f" and not np.all(np.isfinite(vals)):
            problems.append(f"{where}: primvar {name} holds a non-finite value")
        if pv.IsIndexed():
            idx = _array(pv.GetIndices(t), np.int64)
            if len(idx) != expected:
                problems.append(f"{where}: primvar {name} has {len(idx)} indices, "
                                f"{pv.GetInterpolation()} needs {expected}")
            elif len(idx) and (idx.min() < 0 or idx.max() >= len(vals)):
                problems.append(f"{where}: primvar {name} index outside its {len(vals)} values")
        elif len(vals) != expected and not (pv.GetInterpolation() == UsdGeom.Tokens.constant):
            problems.append(f"{where}: primvar {name} has {len(vals)} values, "
                            f"{pv.GetInterpolation()} needs {expected}")
    return problems


def check_usd(path) -> list[str]:
    """Check an exported stage time sample by time sample (see the module doc).

    Args:
        path: The USD file (its value-clip chunks are read through it).

    Returns:
        One message per problem found; an empty list if there is none.
    """
    path = Path(path)
    if not path.is_file():
        return [f"{path}: file not found"]
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        return [f"{path}: not a readable USD stage"]
    problems = []
    default = stage.GetDefaultPrim()
    if not default or default.GetPath() != "/World":
        problems.append(f"{path}: defaultPrim must be /World")
    if UsdGeom.GetStageUpAxis(stage) != UsdGeom.Tokens.z:
        problems.append(f"{path}: upAxis must be Z")
    if UsdGeom.GetStageMetersPerUnit(stage) != 1.0:
        problems.append(f"{path}: metersPerUnit must be 1")
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    if not stage.GetTimeCodesPerSecond() > 0 or not start <= end:
        problems.append(f"{path}: needs timeCodesPerSecond > 0 and start <= end, got "
                        f"{stage.GetTimeCodesPerSecond()}, {start}, {end}")
    for prim in stage.Traverse():
        times = _times(prim, start, end)
        for t in times:
            where = f"{path}: {prim.GetPath()} at time {t:g}"
            sizes: dict = {}
            if prim.IsA(UsdGeom.Mesh):
                found, sizes = _check_mesh(UsdGeom.Mesh(prim), t, where)
                problems += found
            elif prim.IsA(UsdGeom.BasisCurves):
                found, sizes = _check_curves(UsdGeom.BasisCurves(prim), t, where)
                problems += found
            elif prim.IsA(UsdGeom.Cylinder):
                cyl = UsdGeom.Cylinder(prim)
                for attr in (cyl.GetRadiusAttr(), cyl.GetHeightAttr()):
                    value = attr.Get(t)
                    if value is None or not np.isfinite(value) or value < 0:
                        problems.append(f"{where}: {attr.GetName()} must be finite and >= 0, got {value}")
            if prim.IsA(UsdGeom.Imageable):
                problems += _check_primvars(prim, t, where, sizes)
            if prim.IsA(UsdGeom.Xformable):
                m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(t))
                if not np.all(np.isfinite(m)):
                    problems.append(f"{where}: transform is not finite")
    return problems


def validate_usd(path) -> list[str]:
    """Run every registered ``pxr.UsdValidation`` validator on a stage.

    Args:
        path: The USD file.

    Returns:
        One ``"validator: message"`` line per error found; an empty list if there is none.
    """
    stage = Usd.Stage.Open(str(path))
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    errors = UsdValidation.ValidationContext(validators).Validate(stage)
    return [f"{e.GetName()}: {e.GetMessage()}" for e in errors]
