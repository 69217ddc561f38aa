"""USD export: stage layout, values against the simulation, topology changes, a killed run."""

import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom

from warp_cut import Material, TissueModel, Tool
from warp_cut.cli import main
from warp_cut.cut.classes import NODE_CLASS_COLORS, NodeClass
from warp_cut.io.usd_check import check_usd, validate_usd
from warp_cut.io.usd_export import UsdRecorder, axis_quaternion
from warp_cut.runner import run_scene
from warp_cut.scene import load_scene

TINY = ["tissue.size=[0.02,0.02]", "duration=0.1"]


def _assert_valid(path):
    assert check_usd(path) == []
    assert validate_usd(path) == []


class _Positions:
    """Observer keeping each frame's positions and time (the reference the USD must match)."""

    def __init__(self):
        self.frames = []

    def on_frame(self, sim, frame):
        live = np.flatnonzero(sim.model.active)  # the device arrays may hold spare slots
        self.frames.append((frame, sim.time, sim.state.positions.numpy()[live]))

    def finish(self, metrics):
        pass


@pytest.fixture(scope="module")
def press_run(tmp_path_factory):
    """One run of skin_press (TINY for 0.3 s, no cut: positions only) recorded twice in chunks
    of 4 frames: ``plain`` as it goes, ``flushed`` with a flush at frame 6 (``flush`` read the
    stage on disk right then); ``ref`` holds every frame's positions."""
    scene = load_scene("skin_press", TINY + ["duration=0.3"])
    root = tmp_path_factory.mktemp("press")
    plain = UsdRecorder(root / "plain" / "press.usdc", scene, chunk_frames=4)
    flushed = UsdRecorder(root / "flushed" / "press.usdc", scene, chunk_frames=4)
    ref, flush = _Positions(), _FlushAt(flushed, 6)  # chunk 1 holds frames 4-6, the next starts at 7
    result = run_scene(scene, observers=[ref, plain, flushed, flush])
    return SimpleNamespace(scene=scene, result=result, ref=ref, plain=Path(plain.path),
                           flushed=Path(flushed.path), flush=flush)


def test_stage_holds_every_frame_of_the_run(press_run):
    scene, result, ref, path = press_run.scene, press_run.result, press_run.ref, press_run.plain
    frames = scene.frame_count
    assert result.metrics["usd_frames"] == frames + 1 == len(ref.frames)
    stage = Usd.Stage.Open(str(path))
    assert stage.GetDefaultPrim().GetPath() == "/World"
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert stage.GetTimeCodesPerSecond() == scene.fps == stage.GetFramesPerSecond()
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (0, frames)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Tissue"))
    assert mesh.GetSubdivisionSchemeAttr().Get() == UsdGeom.Tokens.none
    tool = UsdGeom.Cylinder(stage.GetPrimAtPath("/World/Tool"))
    assert tool.GetAxisAttr().Get() == UsdGeom.Tokens.z
    assert tool.GetRadiusAttr().Get() == pytest.approx(scene.tool.radius)
    path_ = scene.tool_path()
    for frame, t, x in ref.frames:
        pts = np.array(mesh.GetPointsAttr().Get(frame))
        assert np.array_equal(pts, x)  # float32 written as is
        ext = np.array(mesh.GetExtentAttr().Get(frame))
        assert np.array_equal(ext, [x.min(axis=0), x.max(axis=0)])
        # the cylinder's end caps land on the tool's end points at this frame's time
        pose = path_.pose_at(t)
        m = UsdGeom.Xformable(tool).ComputeLocalToWorldTransform(frame)
        h = tool.GetHeightAttr().Get(frame)
        assert h == pytest.approx(pose.length)
        assert np.array(m.Transform(Gf.Vec3d(0, 0, -h / 2))) == pytest.approx(pose.p0, abs=1e-6)
        assert np.array(m.Transform(Gf.Vec3d(0, 0, h / 2))) == pytest.approx(pose.p1, abs=1e-6)
    # topology: triangles of the model, authored once per chunk file only (no cut here)
    assert np.array_equal(np.array(mesh.GetFaceVertexIndicesAttr().Get(5)).reshape(-1, 3),
                          scene.build_model().triangles)
    assert len(list((path.parent / "press_clips").glob("press.*.usdc"))) == -(-(frames + 1) // 4)
    _assert_valid(path)


def test_axis_quaternion_rotates_z_onto_the_axis():
    for d in ([1, 0, 0], [0, 0, 1], [0, 0, -1], [0.3, -0.4, 0.5], [0, 1e-9, -1]):
        w, x, y, z = axis_quaternion(d)
        q = Gf.Quatd(w, Gf.Vec3d(x, y, z))
        got = np.array(Gf.Rotation(q).TransformDir(Gf.Vec3d(0, 0, 1)))
        assert got == pytest.approx(np.array(d) / np.linalg.norm(d), abs=1e-9)


# ------------------------------------------------------------------ topology and classes
def _fake_sim(model, positions, time_s=0.0, incision=None, tool=None):
    """The attributes the exporter reads, on a model edited by hand."""
    return SimpleNamespace(model=model, state=SimpleNamespace(positions=SimpleNamespace(
        numpy=lambda: np.asarray(positions, np.float32))), time=time_s, incision_controls=incision,
        tool_pose=tool, substep=1e-3, step_limit=SimpleNamespace(step=1e-3))


def test_topology_change_and_classes_are_authored_when_they_change(tmp_path):
    patch = TissueModel.from_patch((0.01, 0.01), 0.002, material=Material(), pinned="border")
    # the attributes the exporter reads, as plain arrays a test can edit
    model = SimpleNamespace(points=patch.points.copy(), triangles=patch.triangles.copy(),
                            active=np.ones(patch.node_count, bool),
                            node_class=np.zeros(patch.node_count, np.int8), topology_version=0)
    model.node_count = n0 = patch.node_count
    path = tmp_path / "cut.usda"
    tool = Tool([0, 0, 0.001], [0.01, 0, 0.006], 0.0005)
    rec = UsdRecorder(path, fps=30, tool_radius=0.0005, chunk_frames=3)
    x = model.points.copy()
    for frame in range(4):
        rec.on_frame(_fake_sim(model, x + [0, 0, 1e-4 * frame], frame / 30, tool=tool), frame)
    # a cut: node 7 deleted (its triangles removed), two lip nodes appended, classes set
    gone = 7
    keep_tri = ~np.any(model.triangles == gone, axis=1)
    lips = np.array([[0.0005, 0.0001, 0.0], [0.0005, -0.0001, 0.0]])
    model.points = np.vstack([model.points, lips])
    model.node_count = n0 + 2
    model.active = np.append(model.active, [True, True])
    model.active[gone] = False
    new_tri = [[n0, n0 + 1, 8]]
    model.triangles = np.vstack([model.triangles[keep_tri], new_tri])
    model.node_class = np.append(model.node_class, [NodeClass.LIP, NodeClass.LIP]).astype(np.int8)
    model.node_class[[6, 8]] = [NodeClass.YELLOW, NodeClass.BLUE]
    model.topology_version += 1
    controls = np.array([[0, 0, 0], [0.001, 0, 0], [0.002, 0, 0], [0.003, 0, 0]], float)
    x = np.vstack([x, lips])
    x[gone] = np.nan  # a deleted slot's value must never reach the file
    for frame in range(4, 8):
        rec.on_frame(_fake_sim(model, x, frame / 30, incision=controls, tool=tool), frame)
    classes_at_cut = model.node_class.copy()
    model.node_class[9] = NodeClass.GREY  # a class change without a topology change
    rec.on_frame(_fake_sim(model, x, 8 / 30, incision=controls, tool=tool), 8)
    rec.finish()

    stage = Usd.Stage.Open(str(path))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Tissue"))
    fvi = mesh.GetFaceVertexIndicesAttr()
    # samples at each chunk's first frame (0, 3, 6) and at the cut (4), nothing else
    authored = set()
    for layer in (tmp_path / "cut_clips").glob("cut.*.usda"):
        authored |= set(Sdf.Layer.FindOrOpen(str(layer)).ListTimeSamplesForPath(
            "/World/Tissue.faceVertexIndices"))
    assert authored == {0.0, 3.0, 4.0, 6.0}
    assert len(mesh.GetPointsAttr().Get(3)) == n0
    assert len(mesh.GetPointsAttr().Get(5)) == n0 - 1 + 2
    node_index = np.array(UsdGeom.PrimvarsAPI(mesh).GetPrimvar("nodeIndex").Get(5))
    assert gone not in node_index and list(node_index[-2:]) == [n0, n0 + 1]
    faces = np.array(fvi.Get(5)).reshape(-1, 3)
    assert np.array_equal(node_index[faces], model.triangles)  # same triangles, model numbering
    assert np.array(mesh.GetPointsAttr().Get(5)) == pytest.approx(x[node_index])
    color = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("displayColor")
    assert color.GetInterpolation() == UsdGeom.Tokens.vertex and color.IsIndexed()
    palette = np.array(color.Get())
    assert palette == pytest.approx(np.array([NODE_CLASS_COLORS[c] for c in NodeClass]))
    assert set(np.array(color.GetIndices(2))) == {NodeClass.NORMAL}
    idx5 = np.array(color.GetIndices(5))
    assert np.array_equal(idx5, classes_at_cut[node_index])
    assert idx5[list(node_index).index(6)] == NodeClass.YELLOW and idx5[-1] == NodeClass.LIP
    assert np.array(color.GetIndices(8))[list(node_index).index(9)] == NodeClass.GREY
    assert np.array(color.GetIndices(7))[list(node_index).index(9)] == NodeClass.NORMAL
    curves = UsdGeom.BasisCurves(stage.GetPrimAtPath("/World/Incision"))
    assert curves.GetTypeAttr().Get() == "cubic" and curves.GetBasisAttr().Get() == "bezier"
    assert list(curves.GetCurveVertexCountsAttr().Get(2)) == []
    assert list(curves.GetCurveVertexCountsAttr().Get(5)) == [4]
    assert np.array(curves.GetPointsAttr().Get(6)) == pytest.approx(controls)
    _assert_valid(path)


class _Topology:
    """Observer keeping each frame's live nodes, their positions and classes, the triangles
    and the incision's control points (the reference a cut's USD must match)."""

    def __init__(self):
        self.frames = []

    def on_frame(self, sim, frame):
        model = sim.model
        live = np.flatnonzero(model.active)
        controls = sim.incision_controls
        self.frames.append((live, sim.state.positions.numpy()[live], model.triangles.copy(),
                            model.node_class[live].copy(),
                            None if controls is None else controls.copy()))

    def finish(self, metrics):
        pass


def test_a_real_cut_is_exported_with_its_topology_changes_and_incision(tmp_path):
    scene = load_scene("paper_width_curve", ["duration=0.8"])
    path = tmp_path / "cut" / "paper_width_curve.usdc"
    ref = _Topology()
    run_scene(scene, observers=[ref, UsdRecorder(path, scene, chunk_frames=16)])
    stage = Usd.Stage.Open(str(path))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Tissue"))
    primvars = UsdGeom.PrimvarsAPI(mesh)
    curves = UsdGeom.BasisCurves(stage.GetPrimAtPath("/World/Incision"))
    assert len(ref.frames) == scene.frame_count + 1 == stage.GetEndTimeCode() + 1
    for frame, (live, x, triangles, classes, controls) in enumerate(ref.frames):
        # each frame holds the live nodes of that frame (numbered by nodeIndex), the model's
        # triangles in that numbering, the node classes and the incision curve
        node_index = np.array(primvars.GetPrimvar("nodeIndex").Get(frame))
        np.testing.assert_array_equal(node_index, live)
        np.testing.assert_array_equal(np.array(mesh.GetPointsAttr().Get(frame)), x)
        faces = np.array(mesh.GetFaceVertexIndicesAttr().Get(frame)).reshape(-1, 3)
        np.testing.assert_array_equal(node_index[faces], triangles)
        assert set(mesh.GetFaceVertexCountsAttr().Get(frame)) <= {3}
        np.testing.assert_array_equal(np.array(primvars.GetPrimvar("displayColor").GetIndices(frame)),
                                      classes)
        counts = list(curves.GetCurveVertexCountsAttr().Get(frame))
        if controls is None:
            assert counts == []
        else:
            assert counts == [len(controls)] and (len(controls) - 1) % 3 == 0
            np.testing.assert_allclose(np.array(curves.GetPointsAttr().Get(frame)), controls,
                                       rtol=0, atol=1e-7)  # float32 in the file
    # the run did cut: the topology and the classes changed while it was recorded
    assert len({len(f[0]) for f in ref.frames}) > 1 and ref.frames[-1][4] is not None
    assert {NodeClass.NORMAL, NodeClass.LIP, NodeClass.BLUE} <= set(ref.frames[-1][3])
    # every time sample checked by the conftest fixture (usd-check and UsdValidation)


def test_export_refuses_a_triangle_on_a_deleted_node(tmp_path):
    patch = TissueModel.from_patch((0.01, 0.01), 0.002, material=Material())
    model = SimpleNamespace(points=patch.points, triangles=patch.triangles, node_count=patch.node_count,
                            active=np.ones(patch.node_count, bool), topology_version=0,
                            node_class=np.zeros(patch.node_count, np.int8))
    model.active[int(model.triangles[0, 0])] = False
    rec = UsdRecorder(tmp_path / "bad.usda", fps=30)
    with pytest.raises(ValueError, match="deleted node"):
        rec.on_frame(_fake_sim(model, model.points), 0)


def test_chunks_bound_the_frames_held_in_memory(tmp_path):
    model = TissueModel.from_patch((0.01, 0.01), 0.002, material=Material())
    rec = UsdRecorder(tmp_path / "m.usdc", fps=30, chunk_frames=5)
    for frame in range(23):
        rec.on_frame(_fake_sim(model, model.points), frame)
        held = rec._chunk.ListTimeSamplesForPath("/World/Tissue.points")
        assert len(held) == frame % 5 + 1
    rec.finish()
    assert rec.frames_written == 23
    _assert_valid(tmp_path / "m.usdc")


# ------------------------------------------------------------------ command line
CLI_RUN = ["run", "skin_press", "--quiet", "--set", TINY[0], "--set", TINY[1]]


@pytest.fixture(scope="module")
def chunked_cli_run(tmp_path_factory):
    """``warp-cut run`` of skin_press (TINY) with the USD in chunks of 2 frames: the directory."""
    out = tmp_path_factory.mktemp("cli") / "f"
    assert main(CLI_RUN + ["--out", str(out), "--usd-chunk", "2"]) == 0
    return out


def test_cli_usd_options(chunked_cli_run, tmp_path):
    base = CLI_RUN
    assert (chunked_cli_run / "skin_press.usdc").is_file()  # by default OUT/<scene name>.usdc
    _assert_valid(chunked_cli_run / "skin_press.usdc")
    out = tmp_path / "b"
    assert main(base + ["--out", str(out), "--no-usd"]) == 0
    assert not list(out.glob("*.usd*")) and not list(out.glob("*_clips"))
    dbg = tmp_path / "dbg" / "look.usda"
    assert main(base + ["--out", str(tmp_path / "c"), "--usd", str(dbg)]) == 0
    assert dbg.read_text().startswith("#usda")
    _assert_valid(dbg)


def test_cli_bad_usd_path_is_bad_input(tmp_path, capsys):
    out = tmp_path / "never"
    assert main(["run", "skin_press", "--out", str(out), "--usd", str(out / "x.obj")]) == 2
    assert "--usd" in capsys.readouterr().err and not out.exists()
    assert main(["run", "skin_press", "--out", str(out), "--usd-chunk", "0"]) == 2
    assert not out.exists()


def test_unstable_run_leaves_no_usd(tmp_path):
    out = tmp_path / "boom"
    code = main(["run", "skin_press", "--out", str(out), "--quiet", "--set", "physics.collision=false",
                 "--set", "material.damping=0", "--set", "solver.substeps=1", "--usd-chunk", "2",
                 "--set", "solver.dt=0.01", "--set", "duration=0.5", "--set", TINY[0]])
    assert code == 3 and not out.exists()


def test_killed_run_keeps_the_frames_written(tmp_path):
    """SIGKILL part-way: the stage on disk plays every frame of the completed chunks."""
    out = tmp_path / "killed"
    root = out / "long.usdc"
    cmd = [sys.executable, "-m", "warp_cut.cli", "run", "skin_press", "--quiet", "--out", str(out),
           "--usd-chunk", "5", "--set", "name='long'", "--set", TINY[0],
           "--set", "duration=1000", "--set", "fps=100"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        end = 0.0
        while time.monotonic() < deadline and end < 20:
            if root.exists():
                end = Sdf.Layer.OpenAsAnonymous(str(root)).endTimeCode
            time.sleep(0.05)
        assert end >= 20, "the run wrote no chunks in time"
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    stage = Usd.Stage.Open(str(root))
    end = int(stage.GetEndTimeCode())
    assert 20 <= end < 100_000 and (end + 1) % 5 == 0
    points = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Tissue")).GetPointsAttr()
    first = np.array(points.Get(0))
    for frame in sorted(set(range(0, end + 1, max(1, end // 200))) | {end}):
        x = np.array(points.Get(frame))
        assert x.shape == first.shape and np.all(np.isfinite(x))
    assert not (out / "metrics.json").exists()  # the run never finished
    _assert_valid(root)


def test_flatten_gives_one_file_with_the_same_animation(chunked_cli_run, tmp_path):
    out = chunked_cli_run
    flat = tmp_path / "flat.usda"
    assert main(["usd-flatten", str(out / "skin_press.usdc"), str(flat)]) == 0
    assert "clips" not in flat.read_text()
    a = Usd.Stage.Open(str(out / "skin_press.usdc"))
    b = Usd.Stage.Open(str(flat))
    assert b.GetEndTimeCode() == a.GetEndTimeCode()
    for t in range(int(a.GetEndTimeCode()) + 1):
        pa = a.GetAttributeAtPath("/World/Tissue.points").Get(t)
        assert np.array_equal(np.array(pa), np.array(b.GetAttributeAtPath("/World/Tissue.points").Get(t)))
    _assert_valid(flat)
    assert main(["usd-flatten", str(tmp_path / "none.usdc"), str(flat)]) == 2


class _FlushAt:
    """Observer flushing the recorder at one frame and reading the stage on disk right then."""

    def __init__(self, recorder, frame):
        self.recorder, self.frame = recorder, frame
        self.seen = None

    def on_frame(self, sim, frame):
        if frame == self.frame:
            self.recorder.flush()
            stage = Usd.Stage.Open(str(self.recorder.path))
            mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Tissue"))
            live = np.flatnonzero(sim.model.active)
            self.seen = (stage.GetEndTimeCode(), np.array(mesh.GetPointsAttr().Get(frame)),
                         sim.state.positions.numpy()[live].copy())

    def finish(self, metrics):
        pass


def test_flush_mid_chunk_writes_the_frames_so_far_and_recording_goes_on(press_run):
    scene, ref, path = press_run.scene, press_run.ref, press_run.flushed
    end, on_disk, expected = press_run.flush.seen
    assert end == 6 and np.array_equal(on_disk, expected)
    stage = Usd.Stage.Open(str(path))
    assert stage.GetEndTimeCode() == scene.frame_count
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Tissue"))
    for frame, _, x in ref.frames:  # every frame, on both sides of the early chunk end
        assert np.array_equal(np.array(mesh.GetPointsAttr().Get(frame)), x)
    starts = [a[0] for a in Usd.ClipsAPI(stage.GetPrimAtPath("/World")).GetClipActive()]
    assert starts[:4] == [0, 4, 7, 11]
    _assert_valid(path)
