"""Per-node health checks and reductions.

``report_runaway`` is the stability guard: every integrator's last node pass calls it on the
state it writes, so a step reports its lowest bad node in one int (``first_bad``) without a
pass of its own; ``find_runaway_nodes`` runs the same test over a given state.
"""

import warp as wp

from .flags import is_active

wp.set_module_options({"enable_backward": False})


NO_BAD_NODE = wp.constant(2147483647)
"""Value of a ``first_bad`` (1,) int32 that holds no node (the largest int32)."""


@wp.func
def is_runaway(x: wp.vec3, v: wp.vec3, rest: wp.vec3, max_displacement: float):
    """True when position x [m] or velocity v [m/s] is not finite, or x is farther than
    max_displacement [m] from the rest position (inf: finiteness alone)."""
    if not (wp.isfinite(x) and wp.isfinite(v)):
        return True
    return wp.length(x - rest) > max_displacement


@wp.func
def report_runaway(
    i: int,
    flags: wp.int32,
    x: wp.vec3,
    v: wp.vec3,
    rest_positions: wp.array(dtype=wp.vec3),
    max_displacement: float,
    first_bad: wp.array(dtype=wp.int32),
):
    """Lower first_bad[0] to i when node i is active and ``is_runaway``: the stability guard
    each integrator's last node pass runs on the state it writes (no extra launch or pass)."""
    if is_active(flags):
        if is_runaway(x, v, rest_positions[i], max_displacement):
            wp.atomic_min(first_bad, 0, i)


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
    report_runaway(i, node_flags[i], positions[i], velocities[i], rest_positions,
                   max_displacement, first_bad)


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
