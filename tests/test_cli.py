"""warp_cut/cli.py: outputs, exit codes, and nothing written on bad input or instability."""

import csv
import json
import math
import subprocess
import sys
import time

import numpy as np
import pytest

from warp_cut.cli import main
from warp_cut.io.usd_check import check_usd, validate_usd
from warp_cut.runner import TIMESERIES_COLUMNS, run_scene
from warp_cut.scene import load_scene
from warp_cut.ticks import Pacer

FAST = ["--set", "duration=0.1", "--set", "tissue.size=[0.03,0.02]"]


DEFAULT_RUN = ["--set", "tissue.size=[0.05,0.03]", "--set", "duration=0.8"]
"""The default scene on a 5 x 3 cm patch until its cut is 1 cm long."""


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    """``warp-cut run`` of the default scene (DEFAULT_RUN), its USD included: the directory."""
    out = tmp_path_factory.mktemp("default") / "run"
    assert main(["run", "--out", str(out), "--quiet"] + DEFAULT_RUN) == 0
    return out


def test_run_default_scene_writes_metrics_and_timeseries(default_run):
    out = default_run
    metrics = json.loads((out / "metrics.json").read_text())
    for key in ("name", "nodes", "springs", "triangles", "steps", "dt", "substeps", "sim_time_s",
                "wall_time_s", "realtime_factor", "first_contact_time_s", "first_contact_point",
                "max_tool_force_n", "finite"):
        assert key in metrics
    assert metrics["finite"] is True and metrics["sim_time_s"] == pytest.approx(0.8)
    assert metrics["steps"] * metrics["dt"] == pytest.approx(0.8)
    rows = list(csv.reader((out / "timeseries.csv").open()))
    assert rows[0] == TIMESERIES_COLUMNS + ["incision_width_m"]  # the default scene cuts
    assert len(rows) == 1 + 1 + round(0.8 * 60)
    assert (out / "final_mesh.ply").is_file()
    usd = out / "straight_incision.usdc"
    assert check_usd(usd) == [] and validate_usd(usd) == []
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary left


_PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4",
              "uint": "u4", "float": "f4", "double": "f8"}


def read_ply(path) -> dict:
    """A binary little-endian PLY of one vertex element (scalar properties) and one face
    element (a list of vertex indices), parsed by hand: {"vertex": structured array,
    "face": (f, n) int}."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert header[0] == "ply" and header[1] == "format binary_little_endian 1.0"
    elements = []
    for line in header[2:-1]:
        words = line.split()
        if words[0] == "element":
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property":
            elements[-1][2].append(words[1:])
    (vname, vcount, vprops), (fname, fcount, fprops) = elements
    assert (vname, fname) == ("vertex", "face") and fprops[0][0] == "list"
    vertex_dtype = np.dtype([(name, "<" + _PLY_TYPES[kind]) for kind, name in vprops])
    vertex = np.frombuffer(data, vertex_dtype, vcount, end)
    count_type, index_type = (np.dtype("<" + _PLY_TYPES[t]) for t in fprops[0][1:3])
    offset, faces = end + vertex.nbytes, []
    for _ in range(fcount):
        n = int(np.frombuffer(data, count_type, 1, offset)[0])
        offset += count_type.itemsize
        faces.append(np.frombuffer(data, index_type, n, offset))
        offset += n * index_type.itemsize
    assert offset == len(data)
    return {"vertex": vertex, "face": np.array(faces)}


class _LastFrame:
    """Observer keeping the simulator (the state at the end once the run is over)."""

    def on_frame(self, sim, frame):
        self.sim = sim

    def finish(self, metrics):
        pass


def test_final_mesh_ply_is_the_model_at_the_end_of_the_run(default_run):
    ply = read_ply(default_run / "final_mesh.ply")
    # the same run in this process (runs are deterministic on the CPU), kept to its end
    last = _LastFrame()
    run_scene(load_scene(None, [a for a in DEFAULT_RUN if a != "--set"]), observers=[last])
    model, x = last.sim.model, last.sim.positions
    live = np.flatnonzero(model.active)
    assert len(live) < model.node_count  # the cut deleted nodes: the numbering is compacted
    vertex = ply["vertex"]
    assert len(vertex) == len(live)
    xyz = np.column_stack([vertex["x"], vertex["y"], vertex["z"]])
    np.testing.assert_array_equal(xyz, x[live].astype(np.float32))
    np.testing.assert_array_equal(vertex["node_class"], model.node_class[live])
    assert len(np.unique(vertex["node_class"])) > 1  # classes set by the cut
    # faces: the live triangles, each node replaced by its rank among the live nodes
    triangles = model.triangles
    assert np.all(model.active[triangles])
    np.testing.assert_array_equal(ply["face"], np.searchsorted(live, triangles))


def first_touch(points, tip, velocity, axis, radius, length):
    """Earliest time [s] a cylinder (tip at ``tip`` + velocity t, unit ``axis``, radius,
    length) contains one of the still ``points`` (n, 3), by hand: relative to the tool a
    point moves along d = -velocity; its axial coordinate s(t) must lie in [0, length]
    (linear in t) and its squared distance to the axis, a quadratic, stay below r^2."""
    q0 = np.asarray(points, float) - tip
    d = -np.asarray(velocity, float)
    s0, ds = q0 @ axis, d @ axis
    w0, w1 = q0 - np.outer(s0, axis), d - ds * axis
    a, b, c = w1 @ w1, 2 * w0 @ w1, np.einsum("ij,ij->i", w0, w0) - radius**2
    disc = b * b - 4 * a * c
    ok = disc > 0
    root = np.sqrt(np.where(ok, disc, 0.0))
    t_in, t_out = (-b - root) / (2 * a), (-b + root) / (2 * a)
    # s(t) = s0 + ds t within [0, length]
    lo, hi = np.sort(np.stack([-s0 / ds, (length - s0) / ds]), axis=0)
    start, end = np.maximum(t_in, lo), np.minimum(t_out, hi)
    ok &= end > start
    return float(np.min(np.maximum(start[ok], 0.0)))


def test_press_scene_makes_contact_at_the_closed_form_time(tmp_path):
    # gravity off: the sheet lies still at z = 0 until the tool reaches it, so the first
    # contact is the closed-form meeting of the descending cylinder with the rest nodes
    out = tmp_path / "press"
    assert main(["run", "skin_press", "--out", str(out), "--quiet", "--no-usd", "--set",
                 "duration=0.5", "--set", "physics.gravity=false"]) == 0
    m = json.loads((out / "metrics.json").read_text())
    scene = load_scene("skin_press")
    (t0, t1), path = (0.0, 0.5), scene.tool_path()
    p0, p1 = (np.asarray(p) for p in path.endpoints_at(t0))
    velocity = (np.asarray(path.endpoints_at(t1)[0]) - p0) / (t1 - t0)
    axis = (p1 - p0) / np.linalg.norm(p1 - p0)
    points = scene.build_model().points.astype(np.float32).astype(np.float64)
    t_touch = first_touch(points, p0, velocity, axis, scene.tool.radius, np.linalg.norm(p1 - p0))
    assert 0.2 < t_touch < 0.3  # the rim, 0.87 mm below the tip at 30 degrees, meets the sheet
    # continuous detection: that time, to the float32 coordinates (~1e-9 m at 18 mm/s)
    assert m["first_contact_time_exact_s"] == pytest.approx(t_touch, abs=1e-7)
    # the per-step test: at the end of the step that holds it
    assert m["first_contact_time_s"] == pytest.approx(math.ceil(t_touch / m["dt"]) * m["dt"], abs=1e-9)
    rows = list(csv.DictReader((out / "timeseries.csv").open()))
    force = np.array([[float(r[f"tool_f{c}"]) for c in "xyz"] for r in rows])
    t = np.array([float(r["t"]) for r in rows])
    assert np.all(force[t < t_touch] == 0) and np.all(np.linalg.norm(force[t > t_touch + 0.02], axis=1) > 0)
    assert m["max_tool_force_n"] >= np.linalg.norm(force, axis=1).max() > 0


def test_bad_input_exit_2_and_nothing_written(tmp_path, capsys):
    out = tmp_path / "never"
    assert main(["run", "--out", str(out), "--set", "tool.radius=-0.001"]) == 2
    assert "tool.radius" in capsys.readouterr().err
    assert not out.exists()
    assert main(["run", str(tmp_path / "missing.toml"), "--out", str(out)]) == 2
    assert not out.exists()


def test_unstable_exit_3_and_nothing_written(tmp_path, capsys):
    out = tmp_path / "boom"
    code = main(["run", "skin_press", "--out", str(out), "--quiet", "--set", "physics.collision=false",
                 "--set", "material.damping=0", "--set", "solver.substeps=1",
                 "--set", "solver.dt=0.01", "--set", "duration=0.5"] + FAST[2:])
    assert code == 3
    err = capsys.readouterr().err
    assert "unstable" in err and "stable step" in err
    assert not out.exists()


def test_validate_checks_without_running(tmp_path):
    assert main(["validate", "skin_press"]) == 0
    bad = tmp_path / "bad.toml"
    bad.write_text("name = 'x'\n[tissue]\nspacing = -1\n")
    assert main(["validate", str(bad)]) == 2


def test_console_script_exit_code(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("this is = = not toml")
    proc = subprocess.run([sys.executable, "-m", "warp_cut.cli", "validate", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "bad.toml" in proc.stderr


def _write_obj(path, points, faces):
    lines = [f"v {x} {y} {z}" for x, y, z in points] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


NONMANIFOLD = (  # a fan of four triangles on a 2 mm square, and a fin on its inner edge 1-4 (three on it)
    [(0, 0, 0), (0.002, 0, 0), (0.002, 0.002, 0), (0, 0.002, 0), (0.001, 0.001, 0), (0.0015, 0.0005, 0.001)],
    [(0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4), (1, 4, 5)],
)


@pytest.mark.parametrize("cutting", [True, False])
def test_non_manifold_mesh_is_refused_only_for_cutting(tmp_path, capsys, cutting):
    """A mesh the cut cannot work on (an edge with three triangles) is refused when cutting is
    on: exit 2, the file and the problem named, no traceback, nothing written. Without cutting it
    is simulated as it is."""
    mesh = tmp_path / "fan.obj"
    _write_obj(mesh, *NONMANIFOLD)
    scene = tmp_path / "fan.toml"
    scene.write_text(f'name = "fan"\nduration = 0.01\n[tissue]\nkind = "mesh"\npath = "{mesh.name}"\n'
                     f'pinned = "none"\n[physics]\ncutting = {str(cutting).lower()}\ngravity = [0.0, 0.0, 0.0]\n'
                     '[tool]\nradius = 0.0005\n[[tool.keyframes]]\nt = 0.0\np0 = [0.001, 0.001, 0.01]\n'
                     'p1 = [0.001, 0.001, 0.05]\n')
    out = tmp_path / "out"
    code = main(["run", str(scene), "--out", str(out), "--quiet", "--no-usd"])
    err = capsys.readouterr().err
    if cutting:
        assert code == 2 and not out.exists()
        assert "fan.obj" in err and "edge_nonmanifold" in err and "Traceback" not in err
    else:
        assert code == 0 and (out / "metrics.json").exists()


def test_run_cut_in_background_is_as_quiet_as_the_loop(tmp_path):
    """``warp-cut run --cut-in-background --quiet``: the worker logs at the loop's Warp level, so
    its kernel loads are not printed; the run writes its metrics, one incision made."""
    out = tmp_path / "bg"
    proc = subprocess.run([sys.executable, "-m", "warp_cut.cli", "run", "--cut-in-background", "--quiet",
                           "--no-usd", "--out", str(out), *FAST, "--set", "duration=0.5"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "Module " not in proc.stdout + proc.stderr and "initialized" not in proc.stdout + proc.stderr
    metrics = json.loads((out / "metrics.json").read_text())
    # paced at real time; the run's wall time starts a few lines after the pacer's clock
    assert metrics["cut"]["incisions"] == 1 and metrics["realtime_factor"] <= 1.0 * 1.01


@pytest.mark.parametrize("extra", [["--cut-in-background", "--pace", "0"], ["--cut-in-background", "--pace", "nan"],
                                   ["--cut-in-background", "--pace", "-3"], ["--cut-in-background", "--pace", "1e4"],
                                   ["--pace", "3"]])
def test_a_bad_pace_exits_2_and_writes_nothing(tmp_path, capsys, extra):
    """``--pace`` outside (0, 1000], or without ``--cut-in-background`` (only a background cut's
    run is paced): exit 2, a message naming the option and its range, nothing written."""
    out = tmp_path / "paced"
    assert main(["run", "--out", str(out), "--quiet", "--no-usd", *FAST, *extra]) == 2
    err = capsys.readouterr().err
    assert "pace" in err and "Traceback" not in err
    assert ("(0, 1000]" in err) if "--cut-in-background" in extra else ("--cut-in-background" in err)
    assert not out.exists()


def test_a_background_run_paced_at_three_times_real_time(tmp_path, monkeypatch):
    """``--cut-in-background --pace 3``: the loop is held to three steps per step dt of wall
    time: tick k waits until (k + 1) dt / 3 after the start, so the run is never faster than 3x
    (how close to 3x a machine gets is measured by benchmarks/bench_pace.py, not here); the cut
    still makes its one incision."""
    waits, wait = [], Pacer.wait  # (period, tick, deadline, returned at) of every wait of the pacer

    def recorded_wait(pacer, k):
        wait(pacer, k)
        waits.append((pacer.period, k, pacer.start + (k + 1) * pacer.period, time.perf_counter()))
    monkeypatch.setattr(Pacer, "wait", recorded_wait)
    out = tmp_path / "fast"
    assert main(["run", "--cut-in-background", "--pace", "3", "--quiet", "--no-usd", "--out", str(out),
                 *FAST, "--set", "duration=0.5"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["cut"]["incisions"] == 1
    period, ticks, deadline, returned = np.array(waits).T
    assert np.array_equal(ticks, np.arange(metrics["steps"]))  # every tick waited for
    assert np.allclose(period, metrics["dt"] / 3, rtol=1e-12, atol=0)
    assert np.all(returned >= deadline)  # no tick ran before its deadline: never faster than 3x
    # the run's wall time starts a few lines after the pacer's clock: at most 3x up to that gap
    assert metrics["realtime_factor"] <= 3.0 * 1.01
