"""Continuous collision detection: the exact first time a node enters the moving tool cylinder.

Over one interval (parameter tau in [0, 1]) the tool's end points move linearly,
``p0(tau) = p0a + tau (p0b - p0a)`` and ``p1(tau)`` likewise, and each node moves linearly,
``x(tau) = x + tau * interval * v`` (``interval = 0`` holds the nodes still). With the node
relative to the tip, ``q = x - p0``, and the axis ``u = p1 - p0`` (both linear in tau), the
node is inside the cylinder of radius r (paper section 2.2) iff

    g1 = q.u >= 0,   g2 = |u|^2 - q.u >= 0,   g3 = r^2 |u|^2 - |q x u|^2 > 0,

polynomials in tau of degree 2, 2 and 4 (1, 1 and 2 when the tool only translates, u constant).
Their roots in [0, 1] cut the interval into pieces on which every sign is constant; the first
piece whose midpoint passes the paper's test starts at the first-contact time. A translating
tool is solved in closed form (linear and quadratic formulas). Otherwise the quartic's roots are
bracketed between the roots of its derivative, which are bracketed between the roots of its
second derivative (a quadratic), and each bracket holding a sign change is bisected to float64
precision. Contacts of zero duration (exact tangency) are not reported; the discrete test,
strict in the distance, does not report them either.

All arithmetic is float64: the roots are differences of nearly equal squares.
"""

import warp as wp

from .flags import is_active

wp.set_module_options({"enable_backward": False})

NO_CONTACT = 2.0
"""contact_tau value of a node the tool does not reach within the interval (any value > 1)."""

TOOL_MIN_LENGTH = 1.0e-12
"""Tools shorter than this [m] have no volume and touch nothing (as in the discrete test)."""

BISECTION_STEPS = 64
"""Halvings of a bracket: 2^-64 of the interval, below float64 resolution."""

_NONE = wp.constant(wp.float64(NO_CONTACT))

vec5d = wp.types.vector(length=5, dtype=wp.float64)
"""Polynomial coefficients c0 + c1 t + c2 t^2 + c3 t^3 + c4 t^4."""
vec9d = wp.types.vector(length=9, dtype=wp.float64)
"""Candidate times: the interval start and the roots of g1 (2), g2 (2) and g3 (4)."""


@wp.func
def poly_eval(c: vec5d, t: wp.float64):
    """c0 + c1 t + ... + c4 t^4 (Horner)."""
    return (((c[4] * t + c[3]) * t + c[2]) * t + c[1]) * t + c[0]


@wp.func
def poly_derivative(c: vec5d):
    """Coefficients of the derivative."""
    return vec5d(c[1], wp.float64(2.0) * c[2], wp.float64(3.0) * c[3], wp.float64(4.0) * c[4],
                 wp.float64(0.0))


@wp.func
def quadratic_roots(a: wp.float64, b: wp.float64, c: wp.float64):
    """Real roots of a t^2 + b t + c in [0, 1], ascending, missing ones as NO_CONTACT.

    Closed form without cancellation (q = -(b + sign(b) sqrt(disc)) / 2, roots q/a and c/q);
    a = 0 falls back to the linear root. A polynomial that is zero everywhere has no roots."""
    zero = wp.float64(0.0)
    r0 = _NONE
    r1 = _NONE
    if a == zero:
        if b != zero:
            r0 = -c / b
    else:
        disc = b * b - wp.float64(4.0) * a * c
        if disc >= zero:
            s = wp.sqrt(disc)
            if b < zero:
                s = -s
            q = wp.float64(-0.5) * (b + s)
            if q == zero:
                r0 = zero  # b = c = 0: double root at 0
            else:
                r0 = q / a
                r1 = c / q
    if r0 < zero or r0 > wp.float64(1.0):
        r0 = _NONE
    if r1 < zero or r1 > wp.float64(1.0):
        r1 = _NONE
    if r1 < r0:
        tmp = r0
        r0 = r1
        r1 = tmp
    return wp.vec2d(r0, r1)


@wp.func
def bracketed_root(c: vec5d, lo: wp.float64, hi: wp.float64):
    """The root of c in [lo, hi] if c changes sign there (c monotonic on it), else NO_CONTACT."""
    zero = wp.float64(0.0)
    flo = poly_eval(c, lo)
    fhi = poly_eval(c, hi)
    if flo == zero:
        return lo
    if fhi == zero:
        return hi
    if (flo < zero) == (fhi < zero):
        return _NONE
    a = lo
    b = hi
    for _ in range(BISECTION_STEPS):
        m = wp.float64(0.5) * (a + b)
        fm = poly_eval(c, m)
        if (fm < zero) == (flo < zero):
            a = m
            flo = fm
        else:
            b = m
    return wp.float64(0.5) * (a + b)


@wp.func
def roots_between_breaks(c: vec5d, breaks: vec5d):
    """Roots in [0, 1] of c, monotonic between consecutive ``breaks`` (ascending, in [0, 1],
    padded with NO_CONTACT), ascending and padded with NO_CONTACT."""
    out = vec5d(_NONE, _NONE, _NONE, _NONE, _NONE)
    count = 0
    lo = wp.float64(0.0)
    for k in range(6):
        hi = wp.float64(1.0)
        if k < 5:
            hi = wp.min(breaks[k], wp.float64(1.0))
        if hi > lo or (k == 0 and hi == lo):
            root = bracketed_root(c, lo, hi)
            # a root on a shared bracket end is found twice: keep it once
            if root <= wp.float64(1.0) and count < 5:
                if count == 0 or root > out[count - 1]:
                    out[count] = root
                    count += 1
            lo = hi
    return out


@wp.func
def quartic_roots(c: vec5d):
    """Real roots in [0, 1] of a polynomial of degree <= 4, ascending, padded with NO_CONTACT."""
    d1 = poly_derivative(c)
    d2 = poly_derivative(d1)
    r2 = quadratic_roots(d2[2], d2[1], d2[0])
    critical = roots_between_breaks(d1, vec5d(r2[0], r2[1], _NONE, _NONE, _NONE))
    return roots_between_breaks(c, critical)


@wp.func
def inside_at(q0: wp.vec3d, dq: wp.vec3d, u0: wp.vec3d, du: wp.vec3d, radius: wp.float64,
              t: wp.float64):
    """The paper's two-step test at parameter t for the relative node q and axis u."""
    q = q0 + dq * t
    u = u0 + du * t
    uu = wp.dot(u, u)
    if uu < wp.float64(TOOL_MIN_LENGTH * TOOL_MIN_LENGTH):
        return False
    qu = wp.dot(q, u)
    if qu < wp.float64(0.0) or qu > uu:
        return False
    c = wp.cross(q, u)
    return wp.dot(c, c) < radius * radius * uu


@wp.func
def first_entry(q0: wp.vec3d, dq: wp.vec3d, u0: wp.vec3d, du: wp.vec3d, radius: wp.float64):
    """Earliest tau in [0, 1] at which the node is inside the moving cylinder, or NO_CONTACT."""
    zero = wp.float64(0.0)
    # g1 = q.u and |u|^2 as polynomials in tau
    qu = vec5d(wp.dot(q0, u0), wp.dot(q0, du) + wp.dot(dq, u0), wp.dot(dq, du), zero, zero)
    uu = vec5d(wp.dot(u0, u0), wp.float64(2.0) * wp.dot(u0, du), wp.dot(du, du), zero, zero)
    # q x u = c0 + c1 tau + c2 tau^2
    c0 = wp.cross(q0, u0)
    c1 = wp.cross(q0, du) + wp.cross(dq, u0)
    c2 = wp.cross(dq, du)
    rr = radius * radius
    g3 = vec5d(rr * uu[0] - wp.dot(c0, c0),
               rr * uu[1] - wp.float64(2.0) * wp.dot(c0, c1),
               rr * uu[2] - wp.dot(c1, c1) - wp.float64(2.0) * wp.dot(c0, c2),
               -wp.float64(2.0) * wp.dot(c1, c2),
               -wp.dot(c2, c2))
    r1 = quadratic_roots(qu[2], qu[1], qu[0])
    r2 = quadratic_roots(uu[2] - qu[2], uu[1] - qu[1], uu[0] - qu[0])
    r3 = vec5d(_NONE, _NONE, _NONE, _NONE, _NONE)
    if wp.dot(du, du) <= wp.float64(1.0e-24) * wp.dot(u0, u0):
        # translating tool (up to rounding of the poses): g1, g2 linear, g3 quadratic (closed form)
        q3 = quadratic_roots(g3[2], g3[1], g3[0])
        r3[0] = q3[0]
        r3[1] = q3[1]
    else:
        r3 = quartic_roots(g3)
    cand = vec9d(zero, r1[0], r1[1], r2[0], r2[1], r3[0], r3[1], r3[2], r3[3])
    best = _NONE
    for k in range(9):
        start = cand[k]
        if start < wp.float64(1.0) and start < best:
            end = wp.float64(1.0)
            for j in range(9):
                if cand[j] > start and cand[j] < end:
                    end = cand[j]
            if end > start:
                if inside_at(q0, dq, u0, du, radius, wp.float64(0.5) * (start + end)):
                    best = start
    return best


@wp.func
def beyond_reach(q0: wp.vec3d, dq: wp.vec3d, u0: wp.vec3d, du: wp.vec3d, radius: wp.float64):
    """Cheap conservative test: True if the node stays outside the tool's bounding sphere
    (centre the axis midpoint, radius sqrt((|u| / 2)^2 + r^2)) over the whole interval.
    |u| is convex in tau, so its largest value is at an end."""
    half = wp.float64(0.5)
    d0 = q0 - u0 * half  # node relative to the midpoint, linear in tau
    dd = dq - du * half
    t = wp.float64(0.0)
    ddd = wp.dot(dd, dd)
    if ddd > wp.float64(0.0):
        t = wp.clamp(-wp.dot(d0, dd) / ddd, wp.float64(0.0), wp.float64(1.0))
    d = d0 + dd * t
    u1 = u0 + du
    reach = wp.float64(0.25) * wp.max(wp.dot(u0, u0), wp.dot(u1, u1)) + radius * radius
    return wp.dot(d, d) > reach * wp.float64(1.0000001)


@wp.func
def to_vec3d(x: wp.vec3):
    return wp.vec3d(wp.float64(x[0]), wp.float64(x[1]), wp.float64(x[2]))


@wp.kernel
def swept_cylinder_first_contact(
    positions: wp.array(dtype=wp.vec3),
    velocities: wp.array(dtype=wp.vec3),
    node_flags: wp.array(dtype=wp.int32),
    interval: wp.float64,
    p0a: wp.vec3d,
    p1a: wp.vec3d,
    p0b: wp.vec3d,
    p1b: wp.vec3d,
    radius: wp.float64,
    contact_tau: wp.array(dtype=wp.float64),
    earliest: wp.array(dtype=wp.float64),
):
    """One thread per node: first tau in [0, 1] inside the tool moving from pose a to pose b.

    positions [m], velocities [m/s]: (node_count,) vec3 at tau = 0; interval [s] scales the
    node motion (0: nodes still). contact_tau (node_count,) float64 out: tau or NO_CONTACT
    (inactive nodes: NO_CONTACT). earliest (1,) float64: atomic minimum, the caller sets it
    to NO_CONTACT first."""
    i = wp.tid()
    tau = _NONE
    if is_active(node_flags[i]):
        x = to_vec3d(positions[i])
        dx = to_vec3d(velocities[i]) * interval
        q0 = x - p0a
        dq = dx - (p0b - p0a)
        u0 = p1a - p0a
        du = (p1b - p0b) - u0
        if not beyond_reach(q0, dq, u0, du, radius):
            tau = first_entry(q0, dq, u0, du, radius)
    contact_tau[i] = tau
    if tau < _NONE:
        wp.atomic_min(earliest, 0, tau)


@wp.kernel
def earliest_contact_nodes(
    contact_tau: wp.array(dtype=wp.float64),
    earliest: wp.array(dtype=wp.float64),
    tolerance: wp.float64,
    positions: wp.array(dtype=wp.vec3),
    velocities: wp.array(dtype=wp.vec3),
    interval: wp.float64,
    first_node: wp.array(dtype=wp.int32),
    point_sum: wp.array(dtype=wp.vec3d),
    node_count: wp.array(dtype=wp.int32),
):
    """One thread per node: the nodes reached within ``tolerance`` (in tau) of the earliest.

    first_node (1,) int32: atomic minimum of their indices (caller sets it to node_count);
    point_sum (1,) vec3d [m]: sum of their positions at their contact tau; node_count (1,)."""
    i = wp.tid()
    tau = contact_tau[i]
    if tau < _NONE and tau <= earliest[0] + tolerance:
        wp.atomic_min(first_node, 0, i)
        wp.atomic_add(point_sum, 0, to_vec3d(positions[i]) + to_vec3d(velocities[i]) * (interval * tau))
        wp.atomic_add(node_count, 0, 1)
