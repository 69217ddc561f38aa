"""Spring forces of the mass-spring model (paper Eq. 2, with the physical sign).

The force on node i from spring (i, j) is ``K (|x_j - x_i| - L0) (x_j - x_i) / |x_j - x_i|``:
a stretched spring pulls its ends together. At zero length the direction is
undefined and the force is zero (finite, and the pair is at rest length 0 only
if ``L0 == 0``, where the force is zero anyway).
"""

import warp as wp

wp.set_module_options({"enable_backward": False})

SPRING_MIN_LENGTH = 1.0e-12
"""Below this length [m] a spring has no direction and exerts no force."""


@wp.kernel
def spring_forces(
    positions: wp.array(dtype=wp.vec3),
    spring_indices: wp.array(dtype=wp.int32),
    spring_rest_length: wp.array(dtype=wp.float32),
    spring_stiffness: wp.array(dtype=wp.float32),
    forces: wp.array(dtype=wp.vec3),
):
    """One thread per spring; accumulates into ``forces`` (node_count,) [N].

    spring_indices: (2 * spring_count,) int32, negative = deleted slot.
    spring_rest_length [m], spring_stiffness [N/m]: (spring_count,).
    """
    s = wp.tid()
    i = spring_indices[2 * s]
    j = spring_indices[2 * s + 1]
    if i < 0 or j < 0:
        return
    d = positions[j] - positions[i]
    length = wp.length(d)
    if length < SPRING_MIN_LENGTH:
        return
    f = d * (spring_stiffness[s] * (length - spring_rest_length[s]) / length)
    wp.atomic_add(forces, i, f)
    wp.atomic_sub(forces, j, f)
