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

FLOAT32_MAX = 3.4028234663852886e38
"""The largest finite float32."""


def displacement_limit_sq(max_displacement: float) -> float:
    """The ``max_displacement_sq`` [m^2] the guard compares with: max_displacement^2, capped
    at the largest float32 so that an infinite position still fails the test."""
    return min(float(max_displacement) ** 2, FLOAT32_MAX)


@wp.func
def report_runaway(
    i: int,
    flags: wp.int32,
    x: wp.vec3,
    rest_positions: wp.array(dtype=wp.vec3),
    max_displacement_sq: float,
    first_bad: wp.array(dtype=wp.int32),
):
    """Lower first_bad[0] to i when node i is active and its position x [m] is non-finite or
    farther than sqrt(max_displacement_sq) [m] from rest: one comparison, as NaN and inf
    fail ``<=``. The stability guard each integrator's last node pass runs on the state it
    writes (no extra launch or pass). The position alone is enough there: each integrator
    derives it from the new velocity (x' = x + h v') or the velocity from two finite
    positions, so a non-finite velocity makes the position non-finite in the same pass."""
    d = x - rest_positions[i]
    if not (wp.dot(d, d) <= max_displacement_sq):
        if is_active(flags):
            wp.atomic_min(first_bad, 0, i)


@wp.kernel
def find_runaway_nodes(
    positions: wp.array(dtype=wp.vec3),
    velocities: wp.array(dtype=wp.vec3),
    rest_positions: wp.array(dtype=wp.vec3),
    node_flags: wp.array(dtype=wp.int32),
    max_displacement_sq: float,
    first_bad: wp.array(dtype=wp.int32),
):
    """first_bad (1,): lowest index of an active node whose position or velocity is
    non-finite or that has moved farther than sqrt(max_displacement_sq) [m] from its rest
    position (unchanged if none). Any given state: velocities are tested too."""
    i = wp.tid()
    flags = node_flags[i]
    report_runaway(i, flags, positions[i], rest_positions, max_displacement_sq, first_bad)
    if is_active(flags) and not wp.isfinite(velocities[i]):
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
