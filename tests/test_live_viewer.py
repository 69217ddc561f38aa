"""warp_cut/live pages (viser, no browser): what the page holds after a scripted cut, the
controls driving the run, the player against the USD it reads, and the commands' exit codes,
port handling, the address the server really listens on, and clean shutdown."""

import ipaddress
import json
import os
import re
import select
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

pytest.importorskip("viser", reason="the live extra is not installed (pip install -e '.[live]')")

from warp_cut.cli import main  # noqa: E402
from warp_cut.cut.classes import NodeClass  # noqa: E402
from warp_cut.errors import InputError  # noqa: E402
from warp_cut.io.usd_export import axis_quaternion  # noqa: E402
from warp_cut.live import LiveCut  # noqa: E402
from warp_cut.live.app import LiveApp, PlayerApp  # noqa: E402
from warp_cut.live.playback import RunPlayback  # noqa: E402
from warp_cut.live.scene_view import CLASS_RGB  # noqa: E402
from warp_cut.live.scripted import stroke_targets, wait_until_arrived  # noqa: E402
from warp_cut.live.server import start_server, warn_if_exposed  # noqa: E402
from warp_cut.scene import load_scene  # noqa: E402

SMALL = ["tissue.size=[0.06,0.04]"]


def _port_is_free(port: int, host: str = "127.0.0.1") -> bool:
    """True if a new server can listen on host:port: nothing listens there any more. (With
    SO_REUSEADDR, as servers bind: the closed connections' TIME_WAIT entries, which outlive
    the process by a minute, do not count.)"""
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError:
            return False
    return True


def _socket_inodes(pid: int) -> set[str]:
    """Inodes of the sockets process ``pid`` holds open (its /proc/PID/fd links socket:[N])."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            found = re.fullmatch(r"socket:\[(\d+)\]", os.readlink(fd))
        except OSError:  # closed meanwhile
            continue
        if found:
            inodes.add(found.group(1))
    return inodes


def _proc_address(field: str) -> tuple[str, int]:
    """(address, port) of a /proc/net/tcp{,6} address field: the address in hex, as 32-bit
    words in the machine's byte order, a colon, the port in hex."""
    address, port = field.split(":")
    raw = bytes.fromhex(address)
    if sys.byteorder == "little":
        raw = b"".join(raw[k:k + 4][::-1] for k in range(0, len(raw), 4))
    return str(ipaddress.ip_address(raw)), int(port, 16)


def _listening_addresses(pid: int, port: int) -> list[str]:
    """The addresses process ``pid`` listens on at TCP ``port``, as the kernel's socket
    tables give them: the sockets in state LISTEN (0A) of /proc/PID/net/tcp and tcp6 whose
    inode is one of the process's open sockets."""
    inodes, found = _socket_inodes(pid), []
    for table in ("tcp", "tcp6"):
        path = Path(f"/proc/{pid}/net/{table}")
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            fields = line.split()
            address, listened = _proc_address(fields[1])
            if fields[3] == "0A" and fields[9] in inodes and listened == port:
                found.append(address)
    return sorted(found)


def _refused(host: str, port: int) -> bool:
    """True if a TCP connection to host:port is refused (nothing listens on that address)."""
    try:
        socket.create_connection((host, port), timeout=10).close()
    except ConnectionRefusedError:
        return True
    return False


needs_proc = pytest.mark.skipif(not Path("/proc/self/net/tcp").exists(),
                                reason="reads the listening sockets from /proc/PID/net/tcp")


def _no_threads_left():
    return not [t.name for t in threading.enumerate() if t.name.startswith("warp-cut-")]


@pytest.fixture
def busy_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        yield s.getsockname()[1]


def test_page_holds_the_cut_mesh_and_wound_colours():
    live = LiveCut("straight_incision", SMALL)
    app = LiveApp(live, port=0)
    port = app.server.get_port()
    try:
        view = app.viewer.view
        faces_before = np.array(view.handles["surface"].faces)
        targets = stroke_targets(live, 0.012)
        live.set_target(targets["in"])
        wait_until_arrived(live)
        live.set_target(targets["along"])
        held = []  # the triangle count the page holds, frame by frame while the blade cuts
        while not live.arrived:
            live.advance(live.steps_per_frame)
            app.viewer.push()
            held.append(len(view.handles["surface"].faces))
        assert len(set(held)) >= 5  # it changed again and again as the cut proceeded
        for move in (lambda: live.set_target(targets["out"]), live.return_to_start):
            move()
            wait_until_arrived(live)
        assert app.viewer.push()
        _, frame = live.view_frame()
        surface = view.handles["surface"]
        assert np.array_equal(surface.faces, frame.faces) and np.array_equal(surface.vertices, frame.points)
        assert not np.array_equal(surface.faces, faces_before)  # the topology the page holds changed
        colours = {tuple(c) for c in np.asarray(view.handles["dots"].colors)}
        for cls in (NodeClass.LIP, NodeClass.BLUE, NodeClass.YELLOW):
            assert tuple(CLASS_RGB[cls]) in colours
        assert "incision" in view.handles
        p0, p1, _ = frame.tool
        assert np.asarray(view.handles["tool"].position) == pytest.approx(0.5 * (p0 + p1))
        assert not app.viewer.push()  # nothing new: nothing sent
    finally:
        app.stop()
        live.close()
    assert _port_is_free(port) and _no_threads_left()


def test_controls_drive_the_target_and_show_each_other():
    live = LiveCut("straight_incision", SMALL)
    app = LiveApp(live, port=0)
    viewer = app.viewer
    try:
        tip, axis = np.array([0.005, 0.002, 0.01]), np.array([0.0, -0.5, np.sqrt(3) / 2])
        gizmo = SimpleNamespace(position=tip, wxyz=np.array(axis_quaternion(axis)))
        viewer._on_gizmo(SimpleNamespace(client=object(), target=gizmo))
        assert live.target.tip == pytest.approx(tip) and live.target.axis == pytest.approx(axis)
        assert viewer.tilt.value == pytest.approx(60.0) and viewer.heading.value == pytest.approx(90.0)
        assert viewer.depth.value == pytest.approx(-10.0)  # 10 mm above the rest surface z = 0
        viewer.tilt.value = 45.0  # as if dragged in the page
        assert live.target.tilt_deg == pytest.approx(45.0)
        assert np.asarray(viewer.gizmo.wxyz) == pytest.approx(axis_quaternion(live.target.axis))
        viewer.depth.value = 2.5
        assert live.depth() == pytest.approx(0.0025)
        viewer.nudge.value = "+x"
        assert live.target.tip[0] == pytest.approx(0.006)
        viewer.k.value, viewer.gravity.value = 400.0, False
        viewer.apply.value = True  # a click: rebuilds with K = 400 N/m and no gravity
        assert live.generation == 2 and np.all(live.sim.model.stiffness == 400.0)
        assert live.sim.gravity is None
        viewer.cutting.value = False
        assert not live.cutting
        shown = []
        viewer.notify = lambda title, body, error=False: shown.append((title, body, error))
        viewer.er.value = 0.995  # past the scene's range (a typed value is not clamped)
        viewer.apply.value = True
        assert live.generation == 2  # refused: the run goes on as it was
        assert shown and shown[-1][2] and "material.residual_strain" in shown[-1][1]
    finally:
        app.stop()
        live.close()


def test_taken_port_unknown_scene_and_bad_values_exit_2(busy_port, tmp_path, capsys):
    with pytest.raises(InputError, match=f"--port {busy_port}"):
        start_server("127.0.0.1", busy_port)
    assert main(["live", "--port", str(busy_port)]) == 2
    assert f"--port {busy_port}" in capsys.readouterr().err
    assert main(["live", "no_such_scene", "--port", "0"]) == 2
    assert "scene not found" in capsys.readouterr().err
    assert main(["live", "--set", "material.stiffness=-1", "--port", "0"]) == 2
    assert "material.stiffness" in capsys.readouterr().err
    assert main(["live", "--speed", "0", "--port", "0"]) == 2
    assert "speed" in capsys.readouterr().err
    assert main(["live", "--port", "70000"]) == 2
    assert main(["view", str(tmp_path / "nothing")]) == 2
    assert "no such run directory" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["view", str(tmp_path / "empty")]) == 2
    assert "no USD file" in capsys.readouterr().err


@needs_proc
def test_the_server_listens_on_127_0_0_1_alone_by_default():
    """The socket the server listens on (read from the kernel's tables) is bound to 127.0.0.1:
    a connection there is accepted, one to another loopback address of this machine refused."""
    server = start_server(port=0)
    port = server.get_port()
    try:
        assert _listening_addresses(os.getpid(), port) == ["127.0.0.1"]
        socket.create_connection(("127.0.0.1", port), timeout=10).close()
        assert _refused("127.0.0.2", port)
    finally:
        server.stop()
    assert _listening_addresses(os.getpid(), port) == []


@needs_proc
def test_host_0_0_0_0_listens_on_every_address_and_warns(capsys):
    server = start_server("0.0.0.0", 0)
    port = server.get_port()
    try:
        assert _listening_addresses(os.getpid(), port) == ["0.0.0.0"]
        socket.create_connection(("127.0.0.2", port), timeout=10).close()  # any address of this machine
    finally:
        server.stop()
    assert "warning: serving on 0.0.0.0" in capsys.readouterr().err


def test_a_host_beyond_this_machine_is_warned_about(capsys):
    assert not warn_if_exposed("127.0.0.1") and not warn_if_exposed("localhost")
    assert not warn_if_exposed("::1") and not warn_if_exposed("127.0.0.2")
    assert capsys.readouterr().err == ""
    assert warn_if_exposed("0.0.0.0") and warn_if_exposed("192.0.2.7")
    assert "warning: serving on 0.0.0.0" in capsys.readouterr().err


def _serve(args, host="127.0.0.1", timeout=120.0):
    """Start ``warp-cut ARGS``; return the process and the address it printed (on ``host``)."""
    proc = subprocess.Popen([sys.executable, "-m", "warp_cut.cli"] + args, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + timeout
    for line in proc.stdout:
        found = re.search(rf"at (http://{re.escape(host)}:(\d+))", line)
        if found:
            return proc, found.group(1), int(found.group(2))
        assert time.monotonic() < deadline, "no address printed"
    raise AssertionError(f"exited without serving: {proc.wait()} {proc.stderr.read()}")


def _interrupt(proc, port, host="127.0.0.1"):
    proc.send_signal(signal.SIGINT)
    code = proc.wait(timeout=60)
    err = proc.stderr.read()
    assert code == 0, err
    assert "stopped" in err and "Traceback" not in err and "threads still running" not in err
    assert _port_is_free(port, host)


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (from /proc)."""
    kids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:  # gone meanwhile
            continue
        if int(fields[1]) == pid:
            kids.append(int(stat.parent.name))
    return kids


@needs_proc
def test_live_command_serves_127_0_0_1_and_ctrl_c_stops_it_and_its_worker():
    """``warp-cut live skin_press --cut-in-background``: the page is served from a socket bound to
    127.0.0.1 (no --host); Ctrl-C stops the server, the simulation and the cut's worker, with
    no traceback from any of them, and frees the port."""
    proc, url, port = _serve(["live", "skin_press", "--cut-in-background", "--set", "tissue.size=[0.03,0.02]"])
    workers = _children(proc.pid)
    try:
        assert workers, "no worker process"
        assert _listening_addresses(proc.pid, port) == ["127.0.0.1"]
        with urllib.request.urlopen(url, timeout=30) as page:
            assert page.status == 200 and b"<html" in page.read().lower()
        for worker in workers:  # a terminal's Ctrl-C reaches the whole process group
            os.kill(worker, signal.SIGINT)
    finally:
        _interrupt(proc, port)
    assert [w for w in workers if not _has_ended(w, timeout=60)] == []


def _has_ended(pid: int, timeout: float) -> bool:
    """Whether process ``pid`` ends (or has ended) within ``timeout`` [s]: waits on its pidfd,
    which becomes readable when the process exits, whoever its parent is."""
    try:
        fd = os.pidfd_open(pid)
    except ProcessLookupError:  # gone, and reaped
        return True
    try:
        return bool(select.select([fd], [], [], timeout)[0])
    finally:
        os.close(fd)


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    """warp-cut run of the straight incision on a small patch, stopped mid-cut (USD written)."""
    out = tmp_path_factory.mktemp("run") / "cut"
    assert main(["run", "--quiet", "--out", str(out), "--set", "duration=0.8",
                 "--set", "tissue.size=[0.06,0.04]"]) == 0
    return out


def test_player_reads_every_frame_of_the_usd(finished_run):
    from pxr import Usd, UsdGeom

    pb = RunPlayback(finished_run)
    metrics = json.loads((finished_run / "metrics.json").read_text())
    assert pb.frame_count == metrics["frames"] + 1 and pb.fps == 60
    stage = Usd.Stage.Open(str(finished_run / "straight_incision.usdc"))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Tissue"))
    path = load_scene("straight_incision", ["tissue.size=[0.06,0.04]"]).tool_path()
    series = np.genfromtxt(finished_run / "timeseries.csv", delimiter=",", names=True)
    topologies = set()
    for k in range(0, pb.frame_count, 7):
        frame = pb.frame(k)
        assert np.array_equal(frame.points, np.array(mesh.GetPointsAttr().Get(k)))
        assert frame.time == pytest.approx(k / 60)
        pose = path.pose_at(frame.time)
        assert frame.tool[0] == pytest.approx(pose.p0, abs=1e-6) and frame.tool[1] == pytest.approx(pose.p1, abs=1e-6)
        assert frame.force == pytest.approx([series["tool_fx"][k], series["tool_fy"][k], series["tool_fz"][k]])
        topologies.add(frame.topology)
    assert len(topologies) > 1  # the cut changed it
    last = pb.frame(pb.frame_count - 1)
    ply = trimesh.load(finished_run / "final_mesh.ply", process=False)
    assert np.array_equal(last.faces, ply.faces) and last.points == pytest.approx(ply.vertices, abs=1e-9)
    assert np.array_equal(last.node_class, ply.metadata["_ply_raw"]["vertex"]["data"]["node_class"])
    assert last.incision is not None and (len(last.incision) - 1) % 3 == 0
    with pytest.raises(InputError, match="frame must be in"):
        pb.frame(pb.frame_count)


def test_player_page_shows_the_slider_frame_and_plays(finished_run):
    app = PlayerApp(RunPlayback(finished_run), port=0)
    port = app.server.get_port()
    viewer = app.viewer
    try:
        viewer.slider.value = 20
        assert viewer.current == 20
        assert np.array_equal(viewer.view.handles["surface"].vertices, app.playback.frame(20).points)
        app.start()
        viewer.speed.value, viewer.playing.value = 4.0, True
        deadline = time.monotonic() + 30
        while viewer.current in (20, 21) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert viewer.current not in (20, 21)  # it played on (the run has 49 frames, it loops)
    finally:
        app.stop()
    assert _port_is_free(port) and _no_threads_left()


@needs_proc
def test_view_command_serves_on_the_host_given_until_ctrl_c(finished_run):
    """``--host 127.0.0.2``: the socket is bound to that address (another loopback address,
    so the page stays on this machine) and to no other."""
    host = "127.0.0.2"
    proc, url, port = _serve(["view", str(finished_run), "--host", host], host=host)
    try:
        assert _listening_addresses(proc.pid, port) == [host]
        with urllib.request.urlopen(url, timeout=30) as page:
            assert page.status == 200
        assert _refused("127.0.0.1", port)
    finally:
        _interrupt(proc, port, host)
