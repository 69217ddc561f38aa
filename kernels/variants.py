"""Kernels specialised per enabled-physics set.

A node kernel that may add gravity or test the tool is written once, with ``wp.static`` flags;
``specialised`` turns it into one kernel per flag set, each in its own Warp module named after
what it contains (``warp_cut.kernels.integrate_gravity_collision``). A Warp module compiles on
its first launch, so a scene never compiles the code of physics it disables.
"""

import warp as wp

_CACHE = {}


def specialised(base: str, make, **flags):
    """The kernel ``make(**flags)`` returns, registered as module ``warp_cut.kernels.<base>``
    plus ``_<flag>`` for every flag that is on (cached per flag set)."""
    key = (base, tuple(sorted(flags.items())))
    if key not in _CACHE:
        suffix = "".join(f"_{name}" for name, on in flags.items() if on)
        _CACHE[key] = wp.kernel(make(**flags), enable_backward=False,
                                module=f"warp_cut.kernels.{base}{suffix}", name=f"{base}{suffix}")
    return _CACHE[key]
