"""Per-node health checks and reductions read once per output frame."""

import warp as wp

from .flags import is_active

wp.set_module_options({"enable_backward": False})


@wp.kernel
def find_runaway_nodes(
    positions: wp.array(dtype=wp.vec3),
    velocities: wp.array(dtype=wp.vec3),
    rest_positions: wp.array(dtype=wp.vec3),
    node_flags: wp.array(dtype=wp.int32),
    max_displacement: float,
    first_bad: wp.array(dtype=wp.int32),
):
    """first_bad (1,): lowest index of an active node whose state is non-finite or has
    moved farther than max_displacement [m] from its rest position (unchanged if none)."""
    i = wp.tid()
    if not is_active(node_flags[i]):
        return
    x = positions[i]
    v = velocities[i]
    bad = False
    for c in range(3):
        if not wp.isfinite(x[c]) or not wp.isfinite(v[c]):
            bad = True
    if not bad:
        if wp.length(x - rest_positions[i]) > max_displacement:
            bad = True
    if bad:
        wp.atomic_min(first_bad, 0, i)


@wp.kernel
def kinetic_energy(
    velocities: wp.array(dtype=wp.vec3),
    node_mass: wp.array(dtype=wp.float32),
    node_flags: wp.array(dtype=wp.int32),
    energy: wp.array(dtype=wp.float32),
):
    """energy (1,) [J] accumulates 0.5 m |v|^2 over active nodes."""
    i = wp.tid()
    if not is_active(node_flags[i]):
        return
    v = velocities[i]
    wp.atomic_add(energy, 0, 0.5 * node_mass[i] * wp.dot(v, v))
