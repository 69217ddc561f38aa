"""LaunchSequence: a fixed list of kernel launches, recorded once and replayed every substep.

A Python ``wp.launch`` costs tens of microseconds of argument packing; a small mesh's whole
substep costs less. So a solver records its launches once (per pair of state buffers, step
size and model counts) and replays them:

* ``"graph"``: a captured Warp graph (CUDA graphs on a GPU; Warp's CPU capture on the CPU),
  about a microsecond per launch;
* ``"commands"``: prepared launch commands (``record_cmd=True``), a few microseconds each;
* ``"launch"``: plain ``wp.launch`` every time (the reference the others are measured against).

``"auto"`` replays commands until its owner calls ``capture`` (a solver does once the sequence
has been replayed ``AUTO_CAPTURE_AFTER`` times; a solver's first recording is captured at once,
its step loads the kernels anyway), and keeps the commands when the device or Warp
version cannot capture. A capture costs a few hundred microseconds on the CPU, a graph replay
saves about ten per launch: a sequence a cut replaces after a few steps (a new step size) is
not worth one, and the step that records a sequence stays short.

Scalars (step size, counts) are baked in: a change of any of them is a new sequence.
Values that change every step (the tool pose) live in device arrays the kernels read.
"""

from __future__ import annotations

import warp as wp

__all__ = ["LaunchSequence", "REPLAY_MODES", "AUTO_CAPTURE_AFTER"]

REPLAY_MODES = ("auto", "graph", "commands", "launch")
"""Accepted values of a solver's ``replay`` option."""
AUTO_CAPTURE_AFTER = 32
"""Replays of an ``"auto"`` sequence as commands before a solver captures it into a graph."""


class LaunchSequence:
    """Kernel launches on one device, added with ``add`` then replayed with ``launch``.

    Args:
        device: Warp device the launches run on.
        mode: One of REPLAY_MODES.

    Attributes:
        graph: The captured graph (None until captured: at ``finalize`` in ``"graph"`` mode,
            by ``capture`` in ``"auto"`` mode).
        replays: ``launch`` calls so far.

    Raises:
        ValueError: An unknown mode.
    """

    def __init__(self, device, mode: str = "auto"):
        if mode not in REPLAY_MODES:
            raise ValueError(f"replay must be one of {REPLAY_MODES}, got {mode!r}")
        self.device = device
        self.mode = mode
        self._plain: list[tuple] = []
        self._commands: list = []
        self.graph = None
        self.replays = 0

    def add(self, kernel, count: int, inputs: list) -> None:
        """Append a launch.

        Args:
            kernel: A Warp kernel.
            count: Threads (skipped when 0).
            inputs: The kernel's arguments, in order.
        """
        if count <= 0:
            return
        if self.mode == "launch":
            self._plain.append((kernel, int(count), list(inputs)))
        else:
            self._commands.append(wp.launch(kernel, dim=int(count), inputs=inputs,
                                            device=self.device, record_cmd=True))

    def finalize(self, capture_now: bool = False) -> LaunchSequence:
        """Capture the recorded commands into a graph now in ``"graph"`` mode, and in
        ``"auto"`` mode if ``capture_now`` (a first recording, whose step is long anyway:
        Warp's first capture in a process costs milliseconds).

        Returns:
            self.

        Raises:
            Exception: Whatever Warp raised, if capture failed.
        """
        if self.mode == "graph" or capture_now:
            self.capture()
        return self

    @property
    def capturable(self) -> bool:
        """Whether ``capture`` would make a graph: ``"auto"`` mode, commands, none yet."""
        return self.mode == "auto" and self.graph is None and bool(self._commands)

    def capture(self) -> None:
        """Capture the commands into ``graph``. In ``"auto"`` mode a device or Warp build that
        cannot capture keeps the commands; in ``"graph"`` mode its error propagates. Other
        modes: nothing to do."""
        if self.mode == "graph":
            self._capture()
        elif self.capturable:
            try:
                self._capture()
            except Exception:  # noqa: BLE001 - commands still work
                self.graph = None
                self.mode = "commands"  # not tried again

    def _capture(self) -> None:
        """Capture the commands into ``graph``; Warp's error propagates."""
        if not self._commands:
            return
        with wp.ScopedCapture(device=self.device, force_module_load=False) as capture:
            for cmd in self._commands:
                cmd.launch()
        self.graph = capture.graph

    def __len__(self) -> int:
        """Kernel launches in the sequence (one replay runs them all)."""
        return len(self._plain) + len(self._commands)

    @property
    def kind(self) -> str:
        """How ``launch`` runs: "graph", "commands" or "launch"."""
        return "graph" if self.graph is not None else ("launch" if self.mode == "launch" else "commands")

    def launch(self) -> None:
        """Run the sequence once (as a graph, prepared commands or plain launches)."""
        self.replays += 1
        if self.graph is not None:
            wp.capture_launch(self.graph)
        elif self.mode == "launch":
            for kernel, dim, inputs in self._plain:
                wp.launch(kernel, dim=dim, inputs=inputs, device=self.device)
        else:
            for cmd in self._commands:
                cmd.launch()
