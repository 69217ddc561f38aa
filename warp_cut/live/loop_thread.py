"""LoopThread: a loop on a daemon thread of its own, from ``start`` until ``stop``.

The live run, its page and the player of finished runs each run one; the loop checks or waits
on ``stopping`` so that ``stop`` ends it between two passes.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

__all__ = ["LoopThread"]


class LoopThread:
    """Runs ``loop()`` on a daemon thread named ``name`` (``warp-cut-...``: the CLI waits for
    those at shutdown).

    Attributes:
        stopping: Set by ``stop``; the loop returns once it sees it.
    """

    def __init__(self, loop: Callable[[], None], name: str):
        self._loop, self.name = loop, name
        self.stopping = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def running(self) -> bool:
        """Whether the thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def is_current(self) -> bool:
        """Whether the caller runs on this thread."""
        return threading.current_thread() is self._thread

    def start(self) -> None:
        """Start the thread (nothing if it runs already)."""
        if self.running:
            return
        self.stopping.clear()
        self._thread = threading.Thread(target=self._loop, name=self.name, daemon=True)
        self._thread.start()

    def stop(self, timeout: float) -> bool:
        """Ask the loop to end and wait up to ``timeout`` [s]; False if it is still running."""
        self.stopping.set()
        thread, self._thread = self._thread, None
        if thread is None:
            return True
        thread.join(timeout)
        return not thread.is_alive()
