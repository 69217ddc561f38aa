"""StepReadout: the few numbers a step reports to the host, read without per-step allocations.

After every step the Simulator needs one int (the stability guard's first bad node) and, with
a tool, the tool statistics (force, contact count, contact position sum). On the CPU a Warp
array's memory is host memory: the readout keeps numpy views of the device arrays made once,
so reading costs an index and clearing the statistics a ``fill``. On other devices it keeps
pinned host buffers: ``fetch`` queues one small device-to-host copy per array on the device's
stream and waits once.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels.diagnostics import NO_BAD_NODE

__all__ = ["StepReadout", "NO_BAD_NODE"]


class StepReadout:
    """Host access to a solver's report arrays.

    Args:
        first_bad: (1,) int32 device array, the lowest bad node index or ``NO_BAD_NODE``.
        tool_force: (1,) vec3 [N], contact_count (1,) int32, contact_position_sum (1,) vec3 [m]:
            the tool statistics accumulated over a step's substeps.
        views: read through zero-copy views (default: when the arrays live on the CPU);
            False copies into separate host buffers, the path every other device takes.
    """

    def __init__(self, first_bad: wp.array, tool_force: wp.array, contact_count: wp.array,
                 contact_position_sum: wp.array, *, views: bool | None = None):
        self._device_arrays = (first_bad, tool_force, contact_count, contact_position_sum)
        self.device = first_bad.device
        self.views = self.device.is_cpu if views is None else bool(views)
        if self.views:
            self._pairs = ()
            host = [a.numpy() for a in self._device_arrays]
        else:
            pinned = not self.device.is_cpu
            buffers = [wp.empty(a.shape, dtype=a.dtype, device="cpu", pinned=pinned)
                       for a in self._device_arrays]
            self._pairs = tuple(zip(buffers, self._device_arrays))
            host = [b.numpy() for b in buffers]
        self._bad, self._force, self._count, self._position_sum = host

    def fetch(self, tool_stats: bool = True) -> None:
        """Bring the step's report to the host (nothing to do with views): the first bad node,
        and the tool statistics when ``tool_stats``. Waits for the step's kernels."""
        if not self._pairs:
            return
        for host, device in self._pairs[: 4 if tool_stats else 1]:
            wp.copy(host, device)
        wp.synchronize_device(self.device)

    @property
    def first_bad(self) -> int:
        """Lowest index of a node the guard found bad since the last ``clear_bad_node``, or
        ``NO_BAD_NODE`` (as of the last ``fetch``)."""
        return int(self._bad[0])

    def tool_stats(self) -> tuple[np.ndarray, int, np.ndarray]:
        """(force (3,) float64 [N], contact count, contact position sum (3,) float64 [m]),
        summed over the substeps (as of the last ``fetch``)."""
        return (self._force[0].astype(np.float64), int(self._count[0]),
                self._position_sum[0].astype(np.float64))

    def clear_tool_stats(self) -> None:
        """Zero the tool statistics through the views (with views only: elsewhere the solver
        zeroes them with its recorded launch)."""
        if not self.views:
            raise RuntimeError("clear_tool_stats needs views of host memory")
        self._force.fill(0.0)
        self._count.fill(0)
        self._position_sum.fill(0.0)

    def clear_bad_node(self) -> None:
        """Reset the stability guard (after the state was overwritten)."""
        if self.views:
            self._bad.fill(NO_BAD_NODE)
        else:
            self._device_arrays[0].fill_(NO_BAD_NODE)
            self._bad.fill(NO_BAD_NODE)
