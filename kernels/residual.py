"""Residual-stress links (paper Eq. 3-4, SPEC section 1).

When a cut deletes a spring whose two end nodes survive, the pair stays joined by a
link pulling them together with magnitude ``sigma_r * A`` (sigma_r = E * eps_r [Pa],
A [m^2]). To keep the force smooth and finite as the distance goes to zero, the
direction is regularised with a smoothing length ``eps`` [m]:

    f_i = F * d / sqrt(|d|^2 + eps^2),   d = x_j - x_i,   f_j = -f_i

so the magnitude is F for |d| >> eps and falls smoothly to 0 at |d| = 0. Its largest
stiffness is F / eps, which the stable-step estimate uses. Its Jacobian
``df_i/dx_j = F / r (I - d d^T / r^2)`` with r = sqrt(|d|^2 + eps^2) is symmetric positive
definite, which the implicit integrator uses as is. XPBD solves the links with its springs
instead, as zero-length constraints of the secant stiffness F / r (``link_constraints``), so
they do not bound its step.
"""

import warp as wp

from .xpbd import inverse_mass

wp.set_module_options({"enable_backward": False})


@wp.func
def residual_force(xi: wp.vec3, xj: wp.vec3, magnitude: float, eps: float):
    """Force [N] of a residual link on its first node."""
    d = xj - xi
    return d * (magnitude / wp.sqrt(wp.dot(d, d) + eps * eps))


@wp.kernel
def residual_link_forces(
    positions: wp.array(dtype=wp.vec3),
    link_indices: wp.array(dtype=wp.int32),
    link_force: wp.array(dtype=wp.float32),
    link_smoothing: wp.array(dtype=wp.float32),
    forces: wp.array(dtype=wp.vec3),
):
    """One thread per link; accumulates into ``forces`` (node_count,) [N].

    link_indices: (2 * link_count,) int32, negative = deleted slot.
    link_force: magnitude sigma_r * A [N]; link_smoothing: eps [m], (link_count,).
    """
    k = wp.tid()
    i = link_indices[2 * k]
    j = link_indices[2 * k + 1]
    if i < 0 or j < 0:
        return
    f = residual_force(positions[i], positions[j], link_force[k], link_smoothing[k])
    wp.atomic_add(forces, i, f)
    wp.atomic_sub(forces, j, f)


@wp.kernel
def link_valence(
    link_indices: wp.array(dtype=wp.int32),
    valence: wp.array(dtype=wp.float32),
):
    """valence (node_count,) += 1 at both ends of every live residual link (one thread each;
    link_indices: (2 * link_count,), negative = deleted slot)."""
    k = wp.tid()
    i = link_indices[2 * k]
    j = link_indices[2 * k + 1]
    if i >= 0 and j >= 0:
        wp.atomic_add(valence, i, 1.0)
        wp.atomic_add(valence, j, 1.0)


@wp.kernel
def link_constraints(
    positions: wp.array(dtype=wp.vec3),
    link_indices: wp.array(dtype=wp.int32),
    link_force: wp.array(dtype=wp.float32),
    link_smoothing: wp.array(dtype=wp.float32),
    node_mass: wp.array(dtype=wp.float32),
    node_flags: wp.array(dtype=wp.int32),
    valence: wp.array(dtype=wp.float32),
    stiffness_sum: wp.array(dtype=wp.float32),
    inv_h2: float,
    delta: wp.array(dtype=wp.vec3),
):
    """delta (node_count,) [m] += the Jacobi corrections of the residual links (one thread each).

    A link of magnitude F [N] and smoothing eps [m] pulls with ``F d / r``, r = sqrt(|d|^2 +
    eps^2): a zero-length spring of the secant stiffness F / r at the predicted positions.
    As a compliant constraint (compliance r / F), one Jacobi pass gives
    ``dx_i = w_i a d / T``, a = F h^2 / r, with ``T = 1 + a (n_i w_i + n_j w_j)``: the explicit
    ``h^2 F d / (r m_i)`` while F h^2 w << r, and never past each other however light the nodes
    (at most closing the gap).

    T is at least ``1 + h^2 (K_i w_i + K_j w_j)`` (K: the node's spring stiffness sum
    ``stiffness_sum`` [N/m]): one Jacobi pass softens a spring k by ``1 + k h^2 (n_i w_i +
    n_j w_j)``, and the link is softened as much as the springs that hold its nodes, so their
    fixed point balances the link's force as the springs' equilibrium does. Without the
    bound, on nodes light against h^2 K (small triangles a cut made) a link much softer than
    the springs (F / r << k) was softened far less than they were and pulled its pair most of
    the way together, crushing their triangles.
    """
    k = wp.tid()
    i = link_indices[2 * k]
    j = link_indices[2 * k + 1]
    force = link_force[k]
    if i < 0 or j < 0 or force <= 0.0:
        return
    wi = inverse_mass(node_flags[i], node_mass[i])
    wj = inverse_mass(node_flags[j], node_mass[j])
    if wi + wj <= 0.0:
        return
    d = positions[j] - positions[i]
    eps = link_smoothing[k]
    r = wp.sqrt(wp.dot(d, d) + eps * eps)
    a = force / (r * inv_h2)
    springs = 1.0 + (stiffness_sum[i] * wi + stiffness_sum[j] * wj) / inv_h2
    g = d * (a / wp.max(1.0 + a * (valence[i] * wi + valence[j] * wj), springs))
    wp.atomic_add(delta, i, g * wi)
    wp.atomic_sub(delta, j, g * wj)
