"""XPBD (Macklin et al. 2016) with small steps: one constraint iteration per substep.

Per substep h:

1. predict with the explicit forces f (the foundation ``-k_f A (x - X)`` and the hinges when a
   scene asks for them) and gravity: ``x~ = x + h v + h^2 (f / m + g)``;
2. one Jacobi pass over the springs as distance constraints ``C = |x_j - x_i| - L0`` with
   compliance ``alpha = 1 / k``: ``dlambda = -C / (w~_i + w~_j + alpha / h^2)`` and
   ``dx_i = w_i dlambda grad_i C``, summed per node. The split weights ``w~ = n w`` (n: the
   node's count of live springs, w = 1/m, 0 for pinned nodes) make the parallel (Jacobi) sum
   stable: a node never moves more than its most violated constraint asks, however stiff
   the springs, while soft springs (k h^2 w << 1) give exactly the explicit spring force;
   in the same pass the residual links, as zero-length springs of their secant stiffness F / r
   (``warp_cut.kernels.residual.link_constraints``; the valence n counts them too);
3. the tool pushes nodes out of the cylinder (as in the other integrators), then
   ``v = (x' - x) / h / (1 + h D / m)``: damping acts on the velocity after the solve, so a
   resting state (v = 0) is an equilibrium whatever D is, and a large D only slows motion.

With lambda reset every substep (one iteration), the spring and link part is unconditionally
stable: a link's stiffness F / eps on a light lip node does not bound the step. The foundation
and the hinges are explicit forces (their stiffnesses bound the step, see
``warp_cut.sim.stability``). At equilibrium the one-iteration pass is a spring of stiffness
``k / (1 + k h^2 (n_i w_i + n_j w_j))``: XPBD converges to the sheet's stiffness as h -> 0.
"""

import warp as wp

from .chunks import chunk_start
from .collision import push_out_near_tool, tool_sphere
from .diagnostics import report_runaway
from .flags import is_free
from .integrate import foundation_force
from .springs import SPRING_MIN_LENGTH
from .variants import specialised, variant_family

wp.set_module_options({"enable_backward": False})


@wp.kernel
def spring_valence(
    spring_indices: wp.array(dtype=wp.int32),
    spring_stiffness: wp.array(dtype=wp.float32),
    chunk: int,
    count: int,
    valence: wp.array(dtype=wp.float32),
    stiffness_sum: wp.array(dtype=wp.float32),
):
    """valence (node_count,) += 1 and stiffness_sum [N/m] += k at both ends of every live
    spring (the caller zeroes both)."""
    s = chunk_start(wp.tid(), chunk)
    end = wp.min(s + chunk, count)
    while s < end:
        i = spring_indices[2 * s]
        j = spring_indices[2 * s + 1]
        if i >= 0 and j >= 0:
            wp.atomic_add(valence, i, 1.0)
            wp.atomic_add(valence, j, 1.0)
            wp.atomic_add(stiffness_sum, i, spring_stiffness[s])
            wp.atomic_add(stiffness_sum, j, spring_stiffness[s])
        s += 1


@wp.func
def inverse_mass(flags: int, mass: float):
    if not is_free(flags):
        return 0.0
    return 1.0 / mass


@wp.kernel
def distance_constraints(
    positions: wp.array(dtype=wp.vec3),
    spring_indices: wp.array(dtype=wp.int32),
    spring_rest_length: wp.array(dtype=wp.float32),
    spring_stiffness: wp.array(dtype=wp.float32),
    node_mass: wp.array(dtype=wp.float32),
    node_flags: wp.array(dtype=wp.int32),
    valence: wp.array(dtype=wp.float32),
    inv_h2: float,
    chunk: int,
    count: int,
    delta: wp.array(dtype=wp.vec3),
):
    """delta (node_count,) [m] += the Jacobi corrections of the springs' distance constraints."""
    s = chunk_start(wp.tid(), chunk)
    end = wp.min(s + chunk, count)
    while s < end:
        i = spring_indices[2 * s]
        j = spring_indices[2 * s + 1]
        k = spring_stiffness[s]
        if i >= 0 and j >= 0 and k > 0.0:
            d = positions[j] - positions[i]
            length2 = wp.dot(d, d)
            wi = inverse_mass(node_flags[i], node_mass[i])
            wj = inverse_mass(node_flags[j], node_mass[j])
            if length2 >= SPRING_MIN_LENGTH * SPRING_MIN_LENGTH and wi + wj > 0.0:
                length = wp.sqrt(length2)
                c = length - spring_rest_length[s]
                dlambda = c / (valence[i] * wi + valence[j] * wj + inv_h2 / k)
                n = d / length
                wp.atomic_add(delta, i, n * (wi * dlambda))
                wp.atomic_sub(delta, j, n * (wj * dlambda))
        s += 1


@variant_family("xpbd_predict")
def _make_predict(gravity: bool, foundation: bool):
    def xpbd_predict(
        positions_in: wp.array(dtype=wp.vec3),
        velocities_in: wp.array(dtype=wp.vec3),
        forces: wp.array(dtype=wp.vec3),
        node_mass: wp.array(dtype=wp.float32),
        node_damping: wp.array(dtype=wp.float32),
        node_flags: wp.array(dtype=wp.int32),
        gravity_accel: wp.vec3,
        rest_positions: wp.array(dtype=wp.vec3),
        node_area: wp.array(dtype=wp.float32),
        foundation_stiffness: float,
        h: float,
        chunk: int,
        count: int,
        positions_out: wp.array(dtype=wp.vec3),
    ):
        i = chunk_start(wp.tid(), chunk)
        end = wp.min(i + chunk, count)
        while i < end:
            x = positions_in[i]
            flags = node_flags[i]
            if not is_free(flags):
                positions_out[i] = x
            else:
                m = node_mass[i]
                f = forces[i]
                if wp.static(gravity):
                    f = f + gravity_accel * m
                if wp.static(foundation):
                    f = f + foundation_force(x, rest_positions[i], node_area[i], foundation_stiffness)
                positions_out[i] = x + velocities_in[i] * h + f * (h * h / m)
            forces[i] = wp.vec3(0.0)
            i += 1

    return xpbd_predict


@variant_family("xpbd_finish")
def _make_finish(collision: bool):
    def xpbd_finish(
        positions_in: wp.array(dtype=wp.vec3),
        node_mass: wp.array(dtype=wp.float32),
        node_damping: wp.array(dtype=wp.float32),
        node_flags: wp.array(dtype=wp.int32),
        stiffness_sum: wp.array(dtype=wp.float32),
        tool_pose: wp.array(dtype=wp.vec3),
        h: float,
        chunk: int,
        count: int,
        delta: wp.array(dtype=wp.vec3),
        positions_out: wp.array(dtype=wp.vec3),
        velocities_out: wp.array(dtype=wp.vec3),
        tool_force: wp.array(dtype=wp.vec3),
        contact_count: wp.array(dtype=wp.int32),
        contact_position_sum: wp.array(dtype=wp.vec3),
        rest_positions: wp.array(dtype=wp.vec3),
        max_displacement_sq: float,
        first_bad: wp.array(dtype=wp.int32),
    ):
        i = chunk_start(wp.tid(), chunk)
        end = wp.min(i + chunk, count)
        sphere = tool_sphere(tool_pose)
        while i < end:
            flags = node_flags[i]
            m = node_mass[i]
            free = is_free(flags)
            if free:
                positions_out[i] = positions_out[i] + delta[i]
            if wp.static(collision):
                push_out_near_tool(i, positions_out[i], positions_out, velocities_out,
                                   wp.vec3(m + h * h * stiffness_sum[i]), flags, tool_pose, sphere, h,
                                   tool_force, contact_count, contact_position_sum)
            if free:
                v = (positions_out[i] - positions_in[i]) / h
                velocities_out[i] = v * (m / (m + h * node_damping[i]))
            else:
                velocities_out[i] = wp.vec3(0.0)
            report_runaway(i, flags, positions_out[i], rest_positions, max_displacement_sq, first_bad)
            delta[i] = wp.vec3(0.0)
            i += 1

    return xpbd_finish


def predict_kernel(gravity: bool, foundation: bool = False):
    """Step 1 (see the module doc). Arguments: positions_in, velocities_in, forces (cleared),
    node_mass, node_damping (unused here), node_flags, gravity_accel [m/s^2], rest_positions
    [m], node_area [m^2], foundation_stiffness k_f [N/m^3], h, chunk, count, positions_out
    (the prediction x~)."""
    return specialised("xpbd_predict", _make_predict, gravity=bool(gravity),
                       foundation=bool(foundation))


def finish_kernel(collision: bool):
    """Step 3. Arguments: positions_in (x at the start), node_mass, node_damping, node_flags,
    stiffness_sum (node_count,) [N/m] (sum of k of the node's springs, for the tool reaction),
    tool_pose (3,) vec3, h, chunk, count, delta (cleared), positions_out (x~ in, x' out),
    velocities_out, tool_force, contact_count, contact_position_sum; rest_positions,
    max_displacement_sq [m^2], first_bad (1,) int32: the stability guard, as in
    ``integrate.integrate_kernel``."""
    return specialised("xpbd_finish", _make_finish, collision=bool(collision))
