"""Hinge bending forces (``warp_cut.sim.bending``: energy 1/2 k_h (theta - theta_0)^2 per hinge).

Each hinge [a, b, k, l] pushes its four nodes along the dihedral angle's gradient g,
f_v = -k (theta - theta_0) g_v (Bridson et al. 2003), which sums to zero over the four, with
k = min(k_h, cap / |g|^2) (``warp_cut.sim.bending.hinge_caps``). A hinge whose triangle has
(nearly) no area exerts no force.
"""

import warp as wp

from .chunks import chunk_start

wp.set_module_options({"enable_backward": False})

HINGE_MIN_AREA2 = 1.0e-30
"""Below this |N|^2 [m^4] (four times a triangle's squared area) a hinge exerts no force."""


@wp.kernel
def hinge_forces(
    positions: wp.array(dtype=wp.vec3),
    hinge_indices: wp.array(dtype=wp.int32),
    hinge_rest_angle: wp.array(dtype=wp.float32),
    hinge_stiffness: wp.array(dtype=wp.float32),
    hinge_cap: wp.array(dtype=wp.float32),
    chunk: int,
    count: int,
    forces: wp.array(dtype=wp.vec3),
):
    """Accumulates into ``forces`` (node_count,) [N]; launch dim ceil(count / chunk).

    hinge_indices: (4 * hinge_count,) int32 [a, b, k, l] per hinge, negative = deleted slot.
    hinge_rest_angle theta_0 [rad], hinge_stiffness k_h [N m], hinge_cap [N/m]: (hinge_count,).
    """
    s = chunk_start(wp.tid(), chunk)
    end = wp.min(s + chunk, count)
    while s < end:
        a = hinge_indices[4 * s]
        b = hinge_indices[4 * s + 1]
        k = hinge_indices[4 * s + 2]
        l = hinge_indices[4 * s + 3]
        if a >= 0 and b >= 0 and k >= 0 and l >= 0:
            xa = positions[a]
            xb = positions[b]
            xk = positions[k]
            xl = positions[l]
            e = xb - xa
            n1 = wp.cross(e, xk - xa)
            n2 = wp.cross(xl - xa, e)
            q1 = wp.dot(n1, n1)
            q2 = wp.dot(n2, n2)
            length = wp.length(e)
            if q1 > HINGE_MIN_AREA2 and q2 > HINGE_MIN_AREA2 and length > 0.0:
                unit_e = e / length
                u1 = n1 / wp.sqrt(q1)
                u2 = n2 / wp.sqrt(q2)
                theta = wp.atan2(wp.dot(wp.cross(u1, u2), unit_e), wp.dot(u1, u2))
                w1 = n1 / q1
                w2 = n2 / q2
                ga = wp.dot(xb - xk, unit_e) * w1 + wp.dot(xb - xl, unit_e) * w2
                gb = wp.dot(xk - xa, unit_e) * w1 + wp.dot(xl - xa, unit_e) * w2
                gk = -length * w1
                gl = -length * w2
                g2 = wp.dot(ga, ga) + wp.dot(gb, gb) + wp.dot(gk, gk) + wp.dot(gl, gl)
                k_eff = wp.min(hinge_stiffness[s], hinge_cap[s] / g2)
                c = -k_eff * (theta - hinge_rest_angle[s])
                wp.atomic_add(forces, a, c * ga)
                wp.atomic_add(forces, b, c * gb)
                wp.atomic_add(forces, k, c * gk)
                wp.atomic_add(forces, l, c * gl)
        s += 1
