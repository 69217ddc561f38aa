"""Backward Euler by one linearised Newton step, solved with matrix-free preconditioned CG.

With forces f(x) (springs, residual links, gravity, the foundation), node masses M and damping
D, the step

    (M + h D - h^2 K) v' = M v + h f(x),    x' = x + h v'

is backward Euler linearised about x (Baraff and Witkin 1998), K = df/dx. A spring (i, j)
of stiffness k, rest length L0 and direction u (length L) contributes the block
``B = k [a I + (1 - a) u u^T]`` with ``a = max(0, 1 - L0 / L)``: its exact Jacobian when
stretched; when compressed the negative transverse term is dropped (a = 0), the usual
approximation that keeps the matrix symmetric positive definite so CG applies. A residual
link contributes its exact Jacobian ``F / r (I - d d^T / r^2)`` (r = sqrt(|d|^2 + eps^2)),
which is positive semi-definite. The matrix acts on a vector p as

    (A p)_i = (m_i + h D_i + h^2 k_f A_i) p_i + h^2 sum_(i,j) B_ij (p_i - p_j)

with rows of pinned and inactive nodes replaced by the identity (their v' is 0). The foundation
(a support of stiffness k_f A_i holding node i to its rest position X_i, force
-k_f A_i (x_i - X_i)) adds h^2 k_f A_i to the diagonal; it is compiled only into the variants
of the node kernels ``cg_start`` and ``cg_curvature`` that a scene with a foundation uses.

CG runs entirely on the device with a fixed number of iterations, so a step is a fixed
launch sequence that can be replayed as a graph: the scalars of iteration k live in
``cg (iterations + 1, 2)`` float64 (column 0: r.z, column 1: p.Ap), and once
``r.z <= tol^2 r0.z0`` every later kernel returns at once. Jacobi preconditioner (the 3x3
block diagonals' diagonal).
"""

import warp as wp

from .chunks import chunk_start
from .diagnostics import report_runaway
from .flags import is_free
from .integrate import foundation_force
from .springs import SPRING_MIN_LENGTH
from .variants import specialised, variant_family

wp.set_module_options({"enable_backward": False})


@wp.func
def spring_block_geometry(xi: wp.vec3, xj: wp.vec3, rest: float):
    """(u, a) of the spring block B = k [a I + (1 - a) u u^T]; a < 0 flags a zero-length
    spring (no direction, B = 0)."""
    d = xj - xi
    length2 = wp.dot(d, d)
    if length2 < SPRING_MIN_LENGTH * SPRING_MIN_LENGTH:
        return wp.vec3(0.0), -1.0
    length = wp.sqrt(length2)
    return d / length, wp.max(0.0, 1.0 - rest / length)


@wp.func
def spring_block_apply(u: wp.vec3, a: float, k: float, p: wp.vec3):
    """B p for the spring block B (see the module doc)."""
    if a < 0.0:
        return wp.vec3(0.0)
    return k * (a * p + (1.0 - a) * wp.dot(u, p) * u)


@wp.func
def spring_block_diagonal(u: wp.vec3, a: float, k: float):
    """The diagonal of the spring block B as a vec3."""
    if a < 0.0:
        return wp.vec3(0.0)
    return k * (wp.vec3(a) + (1.0 - a) * wp.cw_mul(u, u))


@wp.func
def link_block_apply(xi: wp.vec3, xj: wp.vec3, magnitude: float, eps: float, p: wp.vec3):
    """B p for a residual link's Jacobian block F / r (I - d d^T / r^2)."""
    d = xj - xi
    r2 = wp.dot(d, d) + eps * eps
    r = wp.sqrt(r2)
    return (magnitude / r) * (p - d * (wp.dot(d, p) / r2))


@wp.func
def converged(cg: wp.array2d(dtype=wp.float64), k: int, tol2: float):
    return cg[k, 0] <= wp.float64(tol2) * cg[0, 0]


@wp.kernel
def spring_matvec(
    positions: wp.array(dtype=wp.vec3),
    spring_indices: wp.array(dtype=wp.int32),
    spring_rest_length: wp.array(dtype=wp.float32),
    spring_stiffness: wp.array(dtype=wp.float32),
    p: wp.array(dtype=wp.vec3),
    h2: float,
    cg: wp.array2d(dtype=wp.float64),
    k_iter: int,
    tol2: float,
    chunk: int,
    count: int,
    ap: wp.array(dtype=wp.vec3),
    diagonal: wp.array(dtype=wp.vec3),
):
    """ap += h^2 sum B (p_i - p_j) over springs (thread t: springs [t chunk, (t+1) chunk)).
    Does nothing once iteration ``k_iter`` has converged; with k_iter < 0 (set-up) it always
    runs and also adds h^2 diag(B) into ``diagonal`` at both ends."""
    if k_iter >= 0:
        if converged(cg, k_iter, tol2):
            return
    s = chunk_start(wp.tid(), chunk)
    end = wp.min(s + chunk, count)
    while s < end:
        i = spring_indices[2 * s]
        j = spring_indices[2 * s + 1]
        if i >= 0 and j >= 0:
            u, a = spring_block_geometry(positions[i], positions[j], spring_rest_length[s])
            k = spring_stiffness[s]
            y = h2 * spring_block_apply(u, a, k, p[i] - p[j])
            wp.atomic_add(ap, i, y)
            wp.atomic_sub(ap, j, y)
            if k_iter < 0:
                dg = h2 * spring_block_diagonal(u, a, k)
                wp.atomic_add(diagonal, i, dg)
                wp.atomic_add(diagonal, j, dg)
        s += 1


@wp.kernel
def link_matvec(
    positions: wp.array(dtype=wp.vec3),
    link_indices: wp.array(dtype=wp.int32),
    link_force: wp.array(dtype=wp.float32),
    link_smoothing: wp.array(dtype=wp.float32),
    p: wp.array(dtype=wp.vec3),
    h2: float,
    cg: wp.array2d(dtype=wp.float64),
    k_iter: int,
    tol2: float,
    ap: wp.array(dtype=wp.vec3),
    diagonal: wp.array(dtype=wp.vec3),
):
    """One thread per link: ap += h^2 B (p_i - p_j); with k_iter < 0 (set-up) also adds the
    block's diagonal into ``diagonal``."""
    if k_iter >= 0:
        if converged(cg, k_iter, tol2):
            return
    l = wp.tid()
    i = link_indices[2 * l]
    j = link_indices[2 * l + 1]
    if i < 0 or j < 0:
        return
    xi = positions[i]
    xj = positions[j]
    y = h2 * link_block_apply(xi, xj, link_force[l], link_smoothing[l], p[i] - p[j])
    wp.atomic_add(ap, i, y)
    wp.atomic_sub(ap, j, y)
    if k_iter < 0:
        d = xj - xi
        eps = link_smoothing[l]
        r2 = wp.dot(d, d) + eps * eps
        dg = (h2 * link_force[l] / wp.sqrt(r2)) * (wp.vec3(1.0) - wp.cw_mul(d, d) / r2)
        wp.atomic_add(diagonal, i, dg)
        wp.atomic_add(diagonal, j, dg)


@wp.kernel
def cg_reset(cg: wp.array2d(dtype=wp.float64)):
    """Zero the CG scalars, one thread per iteration row."""
    k = wp.tid()
    cg[k, 0] = wp.float64(0.0)
    cg[k, 1] = wp.float64(0.0)


@variant_family("implicit_start")
def _make_start(foundation: bool):
    def cg_start(
        velocities: wp.array(dtype=wp.vec3),
        forces: wp.array(dtype=wp.vec3),
        node_mass: wp.array(dtype=wp.float32),
        node_damping: wp.array(dtype=wp.float32),
        node_flags: wp.array(dtype=wp.int32),
        positions: wp.array(dtype=wp.vec3),
        rest_positions: wp.array(dtype=wp.vec3),
        node_area: wp.array(dtype=wp.float32),
        foundation_stiffness: float,
        h: float,
        chunk: int,
        count: int,
        ap: wp.array(dtype=wp.vec3),
        diagonal: wp.array(dtype=wp.vec3),
        x: wp.array(dtype=wp.vec3),
        r: wp.array(dtype=wp.vec3),
        z: wp.array(dtype=wp.vec3),
        p: wp.array(dtype=wp.vec3),
        inv_diagonal: wp.array(dtype=wp.vec3),
        cg: wp.array2d(dtype=wp.float64),
    ):
        i = chunk_start(wp.tid(), chunk)
        end = wp.min(i + chunk, count)
        while i < end:
            flags = node_flags[i]
            zero = wp.vec3(0.0)
            if not is_free(flags):
                x[i] = zero
                r[i] = zero
                z[i] = zero
                p[i] = zero
                diagonal[i] = wp.vec3(node_mass[i])
                inv_diagonal[i] = wp.vec3(1.0)
            else:
                m = node_mass[i]
                md = m + h * node_damping[i]
                f = forces[i]
                if wp.static(foundation):
                    f = f + foundation_force(positions[i], rest_positions[i], node_area[i],
                                             foundation_stiffness)
                    md = md + h * h * foundation_stiffness * node_area[i]
                v = velocities[i]
                res = v * m + f * h - (ap[i] + v * md)
                dg = diagonal[i] + wp.vec3(md)
                inv = wp.vec3(1.0 / dg[0], 1.0 / dg[1], 1.0 / dg[2])
                zi = wp.cw_mul(res, inv)
                x[i] = v
                r[i] = res
                z[i] = zi
                p[i] = zi
                diagonal[i] = dg
                inv_diagonal[i] = inv
                wp.atomic_add(cg, 0, 0, wp.float64(wp.dot(res, zi)))
            forces[i] = zero
            ap[i] = zero
            i += 1

    return cg_start


def cg_start_kernel(foundation: bool):
    """Start CG from x = v: r = M v + h f - A v (ap holds the stiffness part of A v),
    z = r / diag, p = z, cg[0, 0] = r.z. ``diagonal`` (the stiffness part on entry) becomes
    the whole diagonal of A [kg], ``inv_diagonal`` its inverse; clears ``forces`` and ``ap``.
    Pinned and inactive nodes: x = r = z = p = 0. With ``foundation`` the support's force
    -k_f A (x - X) is added to f and h^2 k_f A to the diagonal.

    Arguments: velocities, forces, node_mass, node_damping, node_flags, positions [m],
    rest_positions [m], node_area [m^2], foundation_stiffness [N/m^3], h, chunk, count, ap,
    diagonal, x, r, z, p, inv_diagonal, cg.
    """
    return specialised("implicit_start", _make_start, foundation=bool(foundation))


@variant_family("implicit_curvature")
def _make_curvature(foundation: bool):
    def cg_curvature(
        p: wp.array(dtype=wp.vec3),
        node_mass: wp.array(dtype=wp.float32),
        node_damping: wp.array(dtype=wp.float32),
        node_flags: wp.array(dtype=wp.int32),
        node_area: wp.array(dtype=wp.float32),
        foundation_stiffness: float,
        h: float,
        k_iter: int,
        tol2: float,
        chunk: int,
        count: int,
        ap: wp.array(dtype=wp.vec3),
        cg: wp.array2d(dtype=wp.float64),
    ):
        if converged(cg, k_iter, tol2):
            return
        i = chunk_start(wp.tid(), chunk)
        end = wp.min(i + chunk, count)
        while i < end:
            flags = node_flags[i]
            if not is_free(flags):
                ap[i] = wp.vec3(0.0)
            else:
                pi = p[i]
                md = node_mass[i] + h * node_damping[i]
                if wp.static(foundation):
                    md = md + h * h * foundation_stiffness * node_area[i]
                y = ap[i] + pi * md
                ap[i] = y
                wp.atomic_add(cg, k_iter, 1, wp.float64(wp.dot(pi, y)))
            i += 1

    return cg_curvature


def cg_curvature_kernel(foundation: bool):
    """ap += (M + h D) p (+ h^2 k_f A p with ``foundation``), identity rows for pinned /
    inactive nodes; cg[k, 1] = p.Ap. Arguments: p, node_mass, node_damping, node_flags,
    node_area [m^2], foundation_stiffness [N/m^3], h, k_iter, tol2, chunk, count, ap, cg."""
    return specialised("implicit_curvature", _make_curvature, foundation=bool(foundation))


@wp.kernel
def cg_descend(
    p: wp.array(dtype=wp.vec3),
    inv_diagonal: wp.array(dtype=wp.vec3),
    k_iter: int,
    tol2: float,
    chunk: int,
    count: int,
    ap: wp.array(dtype=wp.vec3),
    x: wp.array(dtype=wp.vec3),
    r: wp.array(dtype=wp.vec3),
    z: wp.array(dtype=wp.vec3),
    cg: wp.array2d(dtype=wp.float64),
):
    """alpha = r.z / p.Ap; x += alpha p; r -= alpha Ap; z = r / diag; cg[k + 1, 0] = r.z;
    clears ap for the next product."""
    if converged(cg, k_iter, tol2):
        return
    pap = cg[k_iter, 1]
    alpha = 0.0
    if pap > wp.float64(0.0):
        alpha = float(cg[k_iter, 0] / pap)
    i = chunk_start(wp.tid(), chunk)
    end = wp.min(i + chunk, count)
    while i < end:
        x[i] = x[i] + alpha * p[i]
        ri = r[i] - alpha * ap[i]
        zi = wp.cw_mul(ri, inv_diagonal[i])
        r[i] = ri
        z[i] = zi
        ap[i] = wp.vec3(0.0)
        wp.atomic_add(cg, k_iter + 1, 0, wp.float64(wp.dot(ri, zi)))
        i += 1


@wp.kernel
def cg_direction(
    z: wp.array(dtype=wp.vec3),
    k_iter: int,
    tol2: float,
    chunk: int,
    count: int,
    p: wp.array(dtype=wp.vec3),
    cg: wp.array2d(dtype=wp.float64),
):
    """p = z + beta p with beta = cg[k + 1, 0] / cg[k, 0]."""
    if converged(cg, k_iter, tol2):
        return
    beta = float(cg[k_iter + 1, 0] / cg[k_iter, 0])
    i = chunk_start(wp.tid(), chunk)
    end = wp.min(i + chunk, count)
    while i < end:
        p[i] = z[i] + beta * p[i]
        i += 1


@wp.kernel
def implicit_advance(
    positions_in: wp.array(dtype=wp.vec3),
    velocity_new: wp.array(dtype=wp.vec3),
    node_flags: wp.array(dtype=wp.int32),
    h: float,
    chunk: int,
    count: int,
    positions_out: wp.array(dtype=wp.vec3),
    velocities_out: wp.array(dtype=wp.vec3),
    rest_positions: wp.array(dtype=wp.vec3),
    max_displacement_sq: float,
    first_bad: wp.array(dtype=wp.int32),
):
    """x' = x + h v' (free nodes); pinned and inactive nodes stay, with zero velocity.
    The new state is checked (``diagnostics.report_runaway``: rest_positions [m],
    max_displacement_sq [m^2], first_bad (1,) int32 lowered to the first bad node)."""
    i = chunk_start(wp.tid(), chunk)
    end = wp.min(i + chunk, count)
    while i < end:
        flags = node_flags[i]
        x = positions_in[i]
        if not is_free(flags):
            positions_out[i] = x
            velocities_out[i] = wp.vec3(0.0)
        else:
            v = velocity_new[i]
            positions_out[i] = x + h * v
            velocities_out[i] = v
        report_runaway(i, flags, positions_out[i], rest_positions, max_displacement_sq, first_bad)
        i += 1


@wp.kernel
def zero_vectors(chunk: int, count: int, a: wp.array(dtype=wp.vec3)):
    """a[i] = 0 for i < count."""
    i = chunk_start(wp.tid(), chunk)
    end = wp.min(i + chunk, count)
    while i < end:
        a[i] = wp.vec3(0.0)
        i += 1
