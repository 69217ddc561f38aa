"""Which items a thread of a chunked kernel handles.

Kernels that take ``chunk`` and ``count`` give thread t the items
``[t * chunk, min((t + 1) * chunk, count))``: on a GPU chunk = 1 (one thread per item), on the
CPU, where Warp runs the threads one after another, a large chunk spreads the per-thread cost.
"""

import warp as wp


@wp.func
def chunk_start(t: int, chunk: int):
    """First item of thread t. Clamped at 0 (it never is below): a start the compiler knows is
    non-negative lets it drop the negative-index wrap Warp adds to every array access indexed
    by the loop variable, which is a sixth of the instructions of a spring on the CPU."""
    return wp.max(t * chunk, 0)
