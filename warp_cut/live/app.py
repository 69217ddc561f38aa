"""``warp-cut live`` and ``warp-cut view``: a run or a recording, a local server, its page.

Each app starts its parts together (server first, so a taken port stops it before any work)
and stops them in reverse order: frame pushing, simulation, then the server, whose port is then
free again. ``serve`` prints the address and runs until Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import sys
import threading

from .engine import LiveCut
from .playback import RunPlayback
from .server import server_url, start_server, wait_for_interrupt

__all__ = ["LiveApp", "PlayerApp", "serve"]


class LiveApp:
    """A LiveCut with its page. ``live`` is started (real time) by ``start``."""

    def __init__(self, live: LiveCut, *, host: str = "127.0.0.1", port: int = 0, rate: float = 30.0,
                 out_dir=None):
        from .viewer import LiveViewer  # noqa: PLC0415 - needs viser, an optional dependency (live extra)

        self.live = live
        self.server = start_server(host, port, label=f"warp-cut live: {live.scene.name}")
        try:
            self.viewer = LiveViewer(live, self.server, rate=rate, out_dir=out_dir)
        except BaseException:
            self.server.stop()
            raise
        self.url = server_url(self.server)

    def start(self) -> None:
        self.live.start()
        self.viewer.start()

    def stop(self) -> None:
        self.viewer.stop()
        self.live.stop()
        self.server.stop()


class PlayerApp:
    """A RunPlayback with its page."""

    def __init__(self, playback: RunPlayback, *, host: str = "127.0.0.1", port: int = 0):
        from .player import PlayerViewer  # noqa: PLC0415 - needs viser, an optional dependency (live extra)

        self.playback = playback
        self.server = start_server(host, port, label=f"warp-cut view: {playback.name}")
        try:
            self.viewer = PlayerViewer(playback, self.server)
        except BaseException:
            self.server.stop()
            raise
        self.url = server_url(self.server)

    def start(self) -> None:
        self.viewer.start()

    def stop(self) -> None:
        self.viewer.stop()
        self.server.stop()


def serve(app, what: str) -> None:
    """Start ``app``, print its address, run until Ctrl-C or SIGTERM, stop it cleanly."""
    app.start()
    try:
        wait_for_interrupt(ready=lambda: print(f"warp-cut: {what} at {app.url}  (Ctrl-C stops)", flush=True))
    finally:
        app.stop()
    others = [t.name for t in threading.enumerate() if t.name.startswith("warp-cut-")]
    print("warp-cut: stopped" + (f" (threads still running: {others})" if others else ""),
          file=sys.stderr, flush=True)
