"""The browser page of ``warp-cut view`` (viser): a finished run replayed, with a timeline.

The frame slider shows any frame; play advances at the run's frame rate times the speed
(looping when asked). The drawing is the live view's (``SceneView``), so colours match.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from .loop_thread import LoopThread
from .playback import RunPlayback
from .scene_view import SceneView, mesh_spacing

__all__ = ["PlayerViewer"]


class PlayerViewer:
    """The page of a RunPlayback on a running viser server."""

    def __init__(self, playback: RunPlayback, server):
        self.playback, self.server = playback, server
        first = playback.frame(0)
        self.view = SceneView(server, mesh_spacing(first))
        self.view.look_at(first)
        self.current = -1
        self._lock = threading.Lock()
        self._looper = LoopThread(self._loop, "warp-cut-view-player")
        self._gui()
        self.show(0)

    def _gui(self) -> None:
        gui, pb = self.server.gui, self.playback
        self.status_md = gui.add_markdown("")
        last = max(1, pb.frame_count - 1)  # a slider needs max > min
        self.slider = gui.add_slider("frame", 0, last, 1, 0, disabled=pb.frame_count < 2)
        self.playing = gui.add_checkbox("play", False)
        self.loop = gui.add_checkbox("loop", True)
        self.speed = gui.add_slider("speed", 0.1, 4.0, 0.1, 1.0)
        if pb.forces is not None:
            t = np.arange(pb.frame_count) / pb.fps
            gui.add_uplot((t, np.linalg.norm(pb.forces, axis=1)),
                          ({"label": "t [s]"}, {"label": "|F| [N]", "stroke": "green"}),
                          title="tool force", aspect=2.5, scales={"x": {"time": False}})
        self.slider.on_update(lambda event: self.show(int(self.slider.value)))

    def show(self, k: int) -> None:
        """Draw frame k (clamped to the run)."""
        k = int(min(max(k, 0), self.playback.frame_count - 1))
        with self._lock:
            if k == self.current:
                return
            frame = self.playback.frame(k)
            self.view.show(frame)
            self.current = k
        force = np.linalg.norm(frame.force)
        self.status_md.content = (f"**{self.playback.name}** · frame {k} / {self.playback.frame_count - 1}"
                                  f" · t {frame.time:.3f} s · |F| {force:.4f} N")

    def _next(self) -> int | None:
        """The frame after the current one, or None at the end without looping."""
        k = self.current + 1
        if k < self.playback.frame_count:
            return k
        return 0 if self.loop.value else None

    def _loop(self) -> None:
        while not self._looper.stopping.is_set():
            if not self.playing.value:
                self._looper.stopping.wait(0.05)
                continue
            start = time.perf_counter()
            k = self._next()
            if k is None:
                self.playing.value = False
                continue
            self.slider.value = k  # draws it (the slider's callback)
            period = 1.0 / (self.playback.fps * float(self.speed.value))
            self._looper.stopping.wait(max(0.0, period - (time.perf_counter() - start)))

    def start(self) -> None:
        """Run the play loop on a thread of its own until ``stop``."""
        self._looper.start()

    def stop(self, timeout: float = 10.0) -> None:
        self._looper.stop(timeout)
