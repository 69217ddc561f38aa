"""Warp's process-wide settings that warp_cut changes."""

from __future__ import annotations

import warp as wp

__all__ = ["quiet_warp"]


def quiet_warp() -> None:
    """Let Warp print warnings and errors only (no per-module compile messages).

    Process-wide: sets ``warp.config.log_level`` to ``warp.LOG_WARNING``. The CLI, batch
    workers, tests and benchmarks call it before their first launch.
    """
    wp.config.log_level = wp.LOG_WARNING
