"""The per-time-sample USD checker finds each broken rule, at the time it is broken."""

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from warp_cut.cli import main
from warp_cut.io.usd_check import check_usd, validate_usd

pytestmark = pytest.mark.invalid_usd

SQUARE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)


def _stage(path, up=UsdGeom.Tokens.z):
    stage = Usd.Stage.CreateNew(str(path))
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    UsdGeom.SetStageUpAxis(stage, up)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetTimeCodesPerSecond(10)
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(2)
    return stage


def _mesh(stage, points_by_time, faces_by_time):
    mesh = UsdGeom.Mesh.Define(stage, "/World/M")
    for t, pts in points_by_time.items():
        pts = np.asarray(pts, np.float32)
        mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(pts), t)
        finite = pts[np.all(np.isfinite(pts), axis=1)]
        mesh.GetExtentAttr().Set(Vt.Vec3fArray.FromNumpy(np.array([finite.min(0), finite.max(0)])), t)
    for t, faces in faces_by_time.items():
        mesh.GetFaceVertexCountsAttr().Set([len(f) for f in faces], t)
        mesh.GetFaceVertexIndicesAttr().Set([int(i) for f in faces for i in f], t)
    return mesh


GOOD_FACES = [[0, 1, 2], [0, 2, 3]]


def test_a_valid_time_varying_mesh_passes(tmp_path):
    path = tmp_path / "ok.usda"
    stage = _stage(path)
    # the point count and topology change at t = 1, consistently
    _mesh(stage, {0: SQUARE, 1: SQUARE[:3], 2: SQUARE[:3]}, {0: GOOD_FACES, 1: [[0, 1, 2]]})
    stage.Save()
    assert check_usd(path) == []
    assert validate_usd(path) == []


@pytest.mark.parametrize("case, message", [
    ("index", "outside the 3 points"),
    ("nan", "finite"),
    ("repeat", "repeats a vertex"),
    ("counts", "sum to"),
    ("extent", "extent"),
    ("primvar", "needs 3"),
])
def test_each_broken_rule_is_found_at_its_time(tmp_path, case, message):
    path = tmp_path / f"{case}.usda"
    stage = _stage(path)
    points = {0: SQUARE, 1: SQUARE[:3], 2: SQUARE[:3]}
    faces = {0: GOOD_FACES, 1: [[0, 1, 2]]}
    if case == "index":
        faces = {0: GOOD_FACES}  # the point count drops at t = 1 but the topology does not
    elif case == "nan":
        points[1] = np.array([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]], np.float32)
    elif case == "repeat":
        faces[1] = [[0, 1, 1]]
    mesh = _mesh(stage, points, faces)
    if case == "counts":
        mesh.GetFaceVertexCountsAttr().Set([3, 3], 1)
    elif case == "extent":
        mesh.GetExtentAttr().Set(Vt.Vec3fArray([Gf.Vec3f(0), Gf.Vec3f(0.5)]), 1)
    elif case == "primvar":
        pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                     UsdGeom.Tokens.vertex)
        pv.Set(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0)]))
        pv.SetIndices(Vt.IntArray([0, 1, 0, 1]), 0)  # right for 4 points, wrong for 3 at t = 1
    stage.Save()
    problems = check_usd(path)
    assert problems and all("/World/M at time 1" in p or "/World/M at time 2" in p for p in problems)
    assert any(message in p for p in problems), problems


def test_curves_metadata_and_transforms(tmp_path):
    path = tmp_path / "curves.usda"
    stage = _stage(path, up=UsdGeom.Tokens.y)
    curves = UsdGeom.BasisCurves.Define(stage, "/World/C")
    curves.CreateTypeAttr(UsdGeom.Tokens.cubic)
    curves.CreateBasisAttr(UsdGeom.Tokens.bezier)
    pts = np.zeros((5, 3), np.float32)
    curves.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(pts), 0)
    curves.GetCurveVertexCountsAttr().Set([5], 0)
    curves.GetExtentAttr().Set(Vt.Vec3fArray([Gf.Vec3f(0), Gf.Vec3f(0)]), 0)
    cyl = UsdGeom.Cylinder.Define(stage, "/World/T")
    cyl.AddTranslateOp().Set(Gf.Vec3d(0, 0, float("inf")), 1)
    stage.Save()
    problems = check_usd(path)
    assert any("upAxis" in p for p in problems)
    assert any("3 s + 1" in p and "/World/C at time 0" in p for p in problems)
    assert any("transform" in p and "/World/T at time 1" in p for p in problems)


def test_cli_usd_check(tmp_path, capsys):
    path = tmp_path / "bad.usda"
    stage = _stage(path)
    _mesh(stage, {0: SQUARE, 1: SQUARE[:3]}, {0: GOOD_FACES})
    stage.Save()
    assert main(["usd-check", str(path)]) == 1
    assert "outside the 3 points" in capsys.readouterr().out
    assert main(["usd-check", str(tmp_path / "missing.usdc")]) == 2
