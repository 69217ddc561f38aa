"""LaunchSequence: a fixed list of kernel launches, recorded once and replayed every substep.

A Python ``wp.launch`` costs tens of microseconds of argument packing; a small mesh's whole
substep costs less. So a solver records its launches once (per pair of state buffers, step
size and model counts) and replays them:

* ``"graph"``: a captured Warp graph (CUDA graphs on a GPU; Warp's CPU capture on the CPU),
  about a microsecond per launch;
* ``"commands"``: prepared launch commands (``record_cmd=True``), a few microseconds each;
* ``"launch"``: plain ``wp.launch`` every time (the reference the others are measured against).

``"auto"`` tries a graph and falls back to commands when the device or Warp version cannot
capture. Scalars (step size, counts) are baked in: a change of any of them is a new sequence.
Values that change every step (the tool pose) live in device arrays the kernels read.
"""

from __future__ import annotations

import warp as wp

__all__ = ["LaunchSequence", "REPLAY_MODES"]

REPLAY_MODES = ("auto", "graph", "commands", "launch")
"""Accepted values of a solver's ``replay`` option."""


class LaunchSequence:
    """Kernel launches on one device, added with ``add`` then replayed with ``launch``.

    Args:
        device: Warp device the launches run on.
        mode: One of REPLAY_MODES.

    Attributes:
        graph: The captured graph after ``finalize`` (None if not captured).

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

    def finalize(self) -> LaunchSequence:
        """Capture the recorded commands into a graph when the mode asks for it.

        Returns:
            self.

        Raises:
            Exception: Whatever Warp raised, if mode is ``"graph"`` and capture failed.
        """
        if self.mode in ("auto", "graph") and self._commands:
            try:
                with wp.ScopedCapture(device=self.device, force_module_load=False) as capture:
                    for cmd in self._commands:
                        cmd.launch()
                self.graph = capture.graph
            except Exception:  # a device or Warp build that cannot capture: commands still work
                if self.mode == "graph":
                    raise
                self.graph = None
        return self

    @property
    def kind(self) -> str:
        """How ``launch`` runs: "graph", "commands" or "launch"."""
        return "graph" if self.graph is not None else ("launch" if self.mode == "launch" else "commands")

    def launch(self) -> None:
        """Run the sequence once (as a graph, prepared commands or plain launches)."""
        if self.graph is not None:
            wp.capture_launch(self.graph)
        elif self.mode == "launch":
            for kernel, dim, inputs in self._plain:
                wp.launch(kernel, dim=dim, inputs=inputs, device=self.device)
        else:
            for cmd in self._commands:
                cmd.launch()
