"""Spring forces of the mass-spring model (paper Eq. 2, with the physical sign).

The force on node i from spring (i, j) is ``K (|x_j - x_i| - L0) (x_j - x_i) / |x_j - x_i|``:
a stretched spring pulls its ends together. At zero length the direction is
undefined and the force is zero (finite, and the pair is at rest length 0 only
if ``L0 == 0``, where the force is zero anyway).

Kernels here take ``chunk`` and ``count``: thread t handles springs
``[t * chunk, min((t + 1) * chunk, count))`` (``chunks.chunk_start``).
"""

import warp as wp

from .chunks import chunk_start

wp.set_module_options({"enable_backward": False})

SPRING_MIN_LENGTH = 1.0e-12
"""Below this length [m] a spring has no direction and exerts no force."""


@wp.func
def spring_force(xi: wp.vec3, xj: wp.vec3, rest: float, k: float):
    """Force [N] on the first node of a spring (i, j) with rest length [m] and stiffness [N/m]."""
    d = xj - xi
    length2 = wp.dot(d, d)
    if length2 < SPRING_MIN_LENGTH * SPRING_MIN_LENGTH:
        return wp.vec3(0.0)
    return d * (k - k * rest / wp.sqrt(length2))


@wp.func
def flush_run(forces: wp.array(dtype=wp.vec3), node: int, f: wp.vec3):
    """Add the summed force f [N] of a run of springs to their first node (none when node < 0)."""
    if node >= 0:
        wp.atomic_add(forces, node, f)


@wp.kernel
def spring_forces(
    positions: wp.array(dtype=wp.vec3),
    spring_indices: wp.array(dtype=wp.int32),
    spring_rest_length: wp.array(dtype=wp.float32),
    spring_stiffness: wp.array(dtype=wp.float32),
    chunk: int,
    count: int,
    forces: wp.array(dtype=wp.vec3),
):
    """Accumulates into ``forces`` (node_count,) [N]; launch dim ceil(count / chunk).

    spring_indices: (2 * spring_count,) int32, negative = deleted slot.
    spring_rest_length [m], spring_stiffness [N/m]: (spring_count,).
    Springs in a row with the same first node (springs are listed in node order) read its
    position once and add their summed force to it once, when the run ends.
    """
    s = chunk_start(wp.tid(), chunk)
    end = wp.min(s + chunk, count)
    run = wp.int32(-1)  # first node of the current run
    xi = wp.vec3(0.0)
    fi = wp.vec3(0.0)  # the run's force on it
    while s < end:
        i = spring_indices[2 * s]
        j = spring_indices[2 * s + 1]
        if i >= 0 and j >= 0:
            if i != run:
                flush_run(forces, run, fi)
                run = i
                xi = positions[i]
                fi = wp.vec3(0.0)
            f = spring_force(xi, positions[j], spring_rest_length[s], spring_stiffness[s])
            fi += f
            wp.atomic_sub(forces, j, f)
        s += 1
    flush_run(forces, run, fi)
