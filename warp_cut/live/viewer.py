"""The browser page of ``warp-cut live`` (viser): a thin layer over LiveCut.

A thread pushes the latest ViewFrame to the page up to ``rate`` times a second (``SceneView``)
with the status line and the force plot. The controls call LiveCut's commands; a refused value
shows its message in the page. The drag handle (a transform gizmo at the target tip, its Z axis
along the blade) and the tilt / heading / depth sliders all set the target pose, and each shows
the others' changes. viser has no keyboard events: nudges are buttons.
"""

from __future__ import annotations

import collections
import time
from pathlib import Path

import numpy as np

from ..errors import InputError, WarpCutError
from ..io.usd_export import axis_quaternion
from .engine import LiveCut
from .loop_thread import LoopThread
from .scene_view import SceneView, mesh_spacing

__all__ = ["LiveViewer"]

_NUDGE_M = 1e-3
_NUDGES = {"-x": (-1, 0, 0), "+x": (1, 0, 0), "-y": (0, -1, 0), "+y": (0, 1, 0),
           "up": (0, 0, 1), "down": (0, 0, -1)}
_PLOT_SECONDS = 5.0


def _rotation_z(wxyz) -> np.ndarray:
    """Third column of the rotation matrix of the unit quaternion (w, x, y, z): where +Z goes."""
    w, x, y, z = (float(v) for v in wxyz)
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])


class LiveViewer:
    """The page of a LiveCut on a viser server.

    Args:
        live: the LiveCut shown and driven.
        server: a running viser.ViserServer.
        rate: largest number of frames pushed to the page per second.
        out_dir: default directory of the Save button.
    """

    def __init__(self, live: LiveCut, server, *, rate: float = 30.0, out_dir=None):
        self.live, self.server = live, server
        self.rate = float(rate)
        self.out_dir = Path(out_dir or Path("out") / f"{live.scene.name}_live")
        _, frame = live.view_frame()
        self.view = SceneView(server, mesh_spacing(frame))
        self.view.look_at(frame)
        self._seq = -1
        self._syncing = False
        self._shown_target = live.target
        self._push_times: collections.deque = collections.deque(maxlen=64)
        self._force: collections.deque = collections.deque()
        self._looper = LoopThread(self._loop, "warp-cut-live-view")
        self._gui()
        self.push()

    # ------------------------------------------------------------------ page
    def _gui(self) -> None:
        gui = self.server.gui
        gui.configure_theme(control_width="large")
        self.status_md = gui.add_markdown("starting")
        self.plot = gui.add_uplot(
            (np.zeros(2), np.zeros(2)), ({"label": "t [s]"}, {"label": "|F| [N]", "stroke": "green"}),
            title="tool force", aspect=2.5, scales={"x": {"time": False}})
        self._scalpel_gui()
        self._run_gui()
        self._parameter_gui()
        pose = self.live.target
        self.gizmo = self.server.scene.add_transform_controls(
            "/scalpel_target", scale=0.02, position=pose.tip, wxyz=axis_quaternion(pose.axis),
            depth_test=False, opacity=0.8)
        self.gizmo.on_update(self._on_gizmo)

    def _scalpel_gui(self) -> None:
        gui, pose = self.server.gui, self.live.target
        with gui.add_folder("Scalpel (drag the handle, or)"):
            self.tilt = gui.add_slider("tilt [deg]", 5.0, 90.0, 1.0, round(pose.tilt_deg, 1))
            self.heading = gui.add_slider("heading [deg]", -180.0, 180.0, 5.0, round(pose.heading_deg, 1))
            self.depth = gui.add_slider("depth [mm]", -20.0, 15.0, 0.1, round(1e3 * self.live.depth(), 1))
            self.speed = gui.add_slider("max speed [mm/s]", 1.0, 100.0, 1.0, round(1e3 * self.live.speed))
            self.nudge = gui.add_button_group("nudge 1 mm", tuple(_NUDGES))
            self.lift = gui.add_button("lift out (back to start)")
        self.tilt.on_update(self._guarded(lambda: self.live.set_target(tilt_deg=self.tilt.value)))
        self.heading.on_update(self._guarded(lambda: self.live.set_target(heading_deg=self.heading.value)))
        self.depth.on_update(self._guarded(lambda: self.live.set_depth(1e-3 * self.depth.value)))
        self.speed.on_update(self._guarded(lambda: self.live.set_speed(1e-3 * self.speed.value)))
        self.nudge.on_click(self._guarded(
            lambda: self.live.nudge(*(_NUDGE_M * np.array(_NUDGES[self.nudge.value])))))
        self.lift.on_click(self._guarded(self.live.return_to_start))

    def _run_gui(self) -> None:
        gui = self.server.gui
        with gui.add_folder("Run"):
            self.pause = gui.add_checkbox("pause", self.live.paused)
            self.cutting = gui.add_checkbox("cutting", self.live.cutting)
            self.reset = gui.add_button("reset (tissue and scalpel anew)")
            self.save_dir = gui.add_text("save to", str(self.out_dir))
            self.save = gui.add_button("save run so far (USD + metrics)")
        self.pause.on_update(self._guarded(lambda: self.live.set_paused(self.pause.value)))
        self.cutting.on_update(self._guarded(lambda: self.live.set_cutting(self.cutting.value)))
        self.reset.on_click(self._guarded(self.live.reset, "reset"))
        self.save.on_click(self._guarded(self._save))

    def _parameter_gui(self) -> None:
        gui, p = self.server.gui, self.live.params
        with gui.add_folder("Material and tool"):
            gui.add_markdown("*Apply rebuilds the simulation from the scene: tissue, scalpel and "
                             "recording start anew.*")
            self.k = gui.add_slider("K [N/m]", 1.0, 2000.0, 1.0, round(p.stiffness, 1))
            self.d = gui.add_slider("D [N s/m]", 0.0, 20.0, 0.1, round(p.damping, 2))
            self.er = gui.add_slider("residual strain", 0.0, 0.5, 0.01, round(p.residual_strain, 3))
            self.radius = gui.add_slider("tool radius [mm]", 0.1, 5.0, 0.1, round(1e3 * p.tool_radius, 2))
            self.gravity = gui.add_checkbox("gravity", p.gravity)
            self.apply = gui.add_button("apply (restarts)")
        self.apply.on_click(self._guarded(self._apply, "rebuilt"))

    # ------------------------------------------------------------------ actions
    def _guarded(self, action, done: str | None = None):
        """A callback running ``action``, showing a refused value's message in the page,
        then showing the target pose on every control."""
        def callback(event) -> None:
            if self._syncing:
                return
            try:
                action()
            except (WarpCutError, OSError) as exc:  # a refused value, an unstable run, a directory not writable
                self.notify("not done", str(exc), error=True)
                return
            if done:
                self.notify(done, "")
            self._show_target()
        return callback

    def _on_gizmo(self, event) -> None:
        if event.client is None or self._syncing:
            return
        try:
            self.live.set_target_axis(np.asarray(event.target.position), _rotation_z(event.target.wxyz))
        except InputError as exc:
            self.notify("not done", str(exc), error=True)
        self._show_target(gizmo=False)

    def _apply(self) -> None:
        self.live.set_parameters(stiffness=self.k.value, damping=self.d.value,
                                 residual_strain=self.er.value, tool_radius=1e-3 * self.radius.value,
                                 gravity=self.gravity.value)

    def _save(self) -> None:
        paths = self.live.save(self.save_dir.value)
        usd = next((p for p in paths if str(p).endswith(".usdc")), None)
        self.notify("saved", f"{len(paths)} files in {self.save_dir.value}; check: warp-cut usd-check {usd}")

    def _show_target(self, gizmo: bool = True) -> None:
        pose = self._shown_target = self.live.target
        self._syncing = True
        try:
            self.tilt.value = round(pose.tilt_deg, 1)
            self.heading.value = round(pose.heading_deg, 1)
            self.depth.value = float(np.clip(round(1e3 * self.live.depth(pose), 1), -20.0, 15.0))
            if gizmo:
                self.gizmo.position, self.gizmo.wxyz = pose.tip, axis_quaternion(pose.axis)
        finally:
            self._syncing = False

    def notify(self, title: str, body: str, *, error: bool = False) -> None:
        """Show a message to every open page."""
        for client in self.server.get_clients().values():
            client.add_notification(title, body, color="red" if error else None,
                                    auto_close_seconds=None if error else 4.0)

    # ------------------------------------------------------------------ pushing frames
    def push(self) -> bool:
        """Draw the latest frame if it is new; returns whether it drew."""
        seq, frame = self.live.view_frame()
        if seq == self._seq:
            return False
        self._seq = seq
        self.view.show(frame)
        self._push_times.append(time.perf_counter())
        self._force.append((frame.time, float(np.linalg.norm(frame.force))))
        while self._force and (self._force[0][0] > frame.time or self._force[0][0] < frame.time - _PLOT_SECONDS):
            self._force.popleft()
        return True

    @property
    def frame_rate(self) -> float | None:
        """Frames pushed per second over the last ones (None until two)."""
        t = self._push_times
        if len(t) < 2 or t[-1] <= t[0] or time.perf_counter() - t[-1] > 1.0:
            return None
        return (len(t) - 1) / (t[-1] - t[0])

    def _status_text(self) -> str:
        s = self.live.status()
        rtf = "—" if s.realtime_factor is None else f"×{s.realtime_factor:.2f}"
        could = "" if s.compute_factor is None else f" (could run ×{s.compute_factor:.2f})"
        fps = "—" if self.frame_rate is None else f"{self.frame_rate:.0f}"
        lines = [f"**t** {s.time:.3f} s · **real time** {rtf}{could} · **view** {fps} fps",
                 f"**|F|** {np.linalg.norm(s.force):.4f} N · cutting {'on' if s.cutting else 'off'} · "
                 f"{s.incisions} incisions, {s.cut_events} cut events · frame {s.frame}"]
        if s.realtime_factor is not None and s.realtime_factor < 0.95 and not s.paused:
            lines.append(f"**cannot keep up with real time**: ×{s.realtime_factor:.2f}")
        if s.paused:
            lines.append("**paused**")
        if s.error:
            lines.append(f"**stopped**: {s.error} (reset, or apply new parameters)")
        return "  \n".join(lines)

    def _update_panel(self) -> None:
        if self.live.target is not self._shown_target:  # moved by a command, not this page
            self._show_target()
        self._syncing = True
        try:  # as above: a pause or cutting switch made by a command shows here
            self.pause.value, self.cutting.value = self.live.paused, self.live.cutting
        finally:
            self._syncing = False
        self.status_md.content = self._status_text()
        if len(self._force) >= 2:
            t, f = np.array(self._force).T
            self.plot.data = (t, f)

    def _loop(self) -> None:
        last_panel = 0.0
        while not self._looper.stopping.wait(1.0 / self.rate):
            self.push()
            now = time.perf_counter()
            if now - last_panel >= 0.25:
                self._update_panel()
                last_panel = now

    def start(self) -> None:
        """Push frames on a thread of its own until ``stop``."""
        self._looper.start()

    def stop(self, timeout: float = 10.0) -> None:
        """Stop pushing frames and wait for the thread."""
        self._looper.stop(timeout)
