"""Semi-implicit (symplectic) Euler with implicit linear damping (paper Eq. 1).

    v' = (v + h F / m) / (1 + h D / m),    x' = x + h v'

The damping term ``-D v`` is taken at the new velocity, so a large D (the paper's
3 N s/m on milligram nodes) does not force a microscopic step: it only slows the
motion down. Pinned and inactive nodes keep their position and have zero velocity.
The kernel also clears ``forces`` for the next substep, which saves a launch.
"""

import warp as wp

wp.set_module_options({"enable_backward": False})


@wp.kernel
def integrate_semi_implicit(
    positions_in: wp.array(dtype=wp.vec3),
    velocities_in: wp.array(dtype=wp.vec3),
    forces: wp.array(dtype=wp.vec3),
    node_mass: wp.array(dtype=wp.float32),
    node_damping: wp.array(dtype=wp.float32),
    node_flags: wp.array(dtype=wp.int32),
    h: float,
    positions_out: wp.array(dtype=wp.vec3),
    velocities_out: wp.array(dtype=wp.vec3),
):
    """One thread per node. node_damping D [N s/m]; h [s]; forces [N], cleared on exit."""
    i = wp.tid()
    x = positions_in[i]
    flags = node_flags[i]
    if (flags & 1) == 0 or (flags & 2) != 0:
        positions_out[i] = x
        velocities_out[i] = wp.vec3(0.0)
        forces[i] = wp.vec3(0.0)
        return
    m = node_mass[i]
    v = (velocities_in[i] + forces[i] * (h / m)) / (1.0 + h * node_damping[i] / m)
    positions_out[i] = x + v * h
    velocities_out[i] = v
    forces[i] = wp.vec3(0.0)
