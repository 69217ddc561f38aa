"""Exceptions a user can act on. The CLI maps them to exit codes (2 bad input, 3 unstable)."""

from __future__ import annotations

__all__ = ["WarpCutError", "InputError", "SceneError", "ToolStartsInside", "SimulationUnstable",
           "CutWorkerError"]


class WarpCutError(Exception):
    """Base class of every warp_cut error."""


class InputError(WarpCutError, ValueError):
    """Bad input to the library: a wrong shape, range or value (CLI exit code 2)."""


class SceneError(InputError):
    """A scene or sweep file is invalid; the message names the file, the key and the allowed range.

    Args:
        path: The scene or sweep file (None for a scene built in memory).
        key: The dotted key at fault, e.g. ``"solver.dt"``.
        message: What is wrong and the allowed range.

    Attributes:
        path: The file as a string (``"<scene>"`` without one).
        key: The dotted key at fault.
    """

    def __init__(self, path, key: str, message: str):
        self.path = str(path) if path is not None else "<scene>"
        self.key = key
        super().__init__(f"{self.path}: [{key}] {message}")


class ToolStartsInside(InputError):
    """The tool's first pose already touches the tissue (the paper's premise is violated)."""


class SimulationUnstable(WarpCutError, RuntimeError):
    """The state became non-finite or ran away; raised before any NaN reaches an output.

    Args:
        node: The first bad node.
        time: Simulated time [s] of the check that failed.
        step: The integration substep used [s].
        safe_step: The estimated stable step [s].
        reason: What went wrong with the node (e.g. ``"has a non-finite position"``).

    Attributes:
        node: The first bad node.
        time: Simulated time [s].
        step: The integration substep used [s].
        safe_step: The estimated stable step [s].
    """

    def __init__(self, node: int, time: float, step: float, safe_step: float, reason: str):
        self.node = int(node)
        self.time = float(time)
        self.step = float(step)
        self.safe_step = float(safe_step)
        super().__init__(
            f"simulation unstable at t = {time:.6g} s: node {node} {reason}; "
            f"integration step used {step:.4g} s, estimated stable step {safe_step:.4g} s "
            f"(use a smaller dt or more substeps, or dt = \"auto\")"
        )


class CutWorkerError(WarpCutError, RuntimeError):
    """The background cut's worker process failed (the message carries its traceback) or
    died. A failed cut event leaves the worker's replica unknown: the cut stops there, and
    every later step raises this again."""
