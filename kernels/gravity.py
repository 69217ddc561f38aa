"""Gravity ``m g`` on every active node (paper Eq. 2, term G)."""

import warp as wp

from .flags import is_active

wp.set_module_options({"enable_backward": False})


@wp.kernel
def gravity_forces(
    node_mass: wp.array(dtype=wp.float32),
    node_flags: wp.array(dtype=wp.int32),
    gravity: wp.vec3,
    forces: wp.array(dtype=wp.vec3),
):
    """One thread per node. node_mass [kg] (node_count,); gravity [m/s^2]; forces [N]."""
    i = wp.tid()
    if not is_active(node_flags[i]):
        return
    forces[i] = forces[i] + gravity * node_mass[i]
