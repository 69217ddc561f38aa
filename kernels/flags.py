"""Node flag bits and the device functions that test them (the one copy of the flag logic).

``node_flags`` is an ``int32`` bit set per node slot: ``NODE_ACTIVE`` when the slot holds a live
node, ``NODE_PINNED`` when a boundary condition holds the node fixed. Kernels test a node with
``is_active``, ``is_pinned`` or ``is_free`` (active and not pinned: the nodes that move), never
with bare bit masks. This module holds no kernels, so it is never compiled on its own: the
functions are inlined into the kernels that call them.
"""

import warp as wp

NODE_ACTIVE = wp.constant(1)
"""Flag bit: the node slot holds a live node."""
NODE_PINNED = wp.constant(2)
"""Flag bit: the node is held fixed by a boundary condition."""


@wp.func
def is_active(flags: wp.int32):
    """True when the node slot holds a live node."""
    return (flags & NODE_ACTIVE) != 0


@wp.func
def is_pinned(flags: wp.int32):
    """True when the node is held fixed (it may be inactive too)."""
    return (flags & NODE_PINNED) != 0


@wp.func
def is_free(flags: wp.int32):
    """True for a live node that is not pinned: the integrators move only these."""
    return is_active(flags) and not is_pinned(flags)
