"""Cylinder-based collision detection between the tool and the nodes (paper section 2.2).

The tool is a cylinder with axis p0 -> p1 and radius r. For a node N:

* Step 1: both angles p0-p1-N and p1-p0-N are at most 90 degrees, i.e.
  ``dot(N - p0, p1 - p0) >= 0`` and ``dot(N - p1, p0 - p1) >= 0`` (N projects onto the segment);
* Step 2: the distance d from N to the axis is below r (strictly): contact.

Degenerate inputs have a defined answer: ``p0 == p1`` is a zero-length tool with no
volume, so nothing is inside; ``r == 0`` likewise; a node on the axis (d = 0) is pushed
out along a fixed direction perpendicular to the axis.

Response: the node is moved to the cylinder surface along (N - p) / d and its velocity gains
the matching change (N' - N) / h. The contact force that makes this change inside the
integrator's update is ``I (N' - N) / h^2`` with the node's effective inertia I [kg]: m + h D
for semi-implicit Euler with implicit damping, the diagonal of the system matrix for implicit
Euler, m + h^2 (sum of its spring stiffnesses) for XPBD. Its equal and opposite reaction is
summed over the nodes into the tool force [N] (in a held contact it equals the spring force
the node exerts, whatever D is).
"""

import warp as wp

from .flags import is_active, is_pinned

wp.set_module_options({"enable_backward": False})

TOOL_MIN_LENGTH = 1.0e-12
"""Tools shorter than this [m] have no volume and touch nothing."""


@wp.func
def axis_normal(axis: wp.vec3):
    """A unit vector perpendicular to ``axis`` (the push direction for a node on the axis)."""
    a = wp.normalize(axis)
    c = wp.cross(a, wp.vec3(0.0, 0.0, 1.0))
    if wp.length(c) < 1.0e-3:
        c = wp.cross(a, wp.vec3(1.0, 0.0, 0.0))
    return wp.normalize(c)


@wp.func
def cylinder_contains(x: wp.vec3, p0: wp.vec3, p1: wp.vec3, radius: float):
    """True when x is inside the open cylinder (paper Steps 1 and 2)."""
    axis = p1 - p0
    if wp.length(axis) < TOOL_MIN_LENGTH:
        return False
    if wp.dot(x - p0, axis) < 0.0:
        return False
    if wp.dot(x - p1, -axis) < 0.0:
        return False
    a = wp.normalize(axis)
    rel = x - p0
    perp = rel - a * wp.dot(rel, a)
    return wp.length(perp) < radius


@wp.func
def push_out_target(x: wp.vec3, p0: wp.vec3, p1: wp.vec3, radius: float):
    """The point on the cylinder surface where a contained node is moved to."""
    a = wp.normalize(p1 - p0)
    rel = x - p0
    p = p0 + a * wp.dot(rel, a)
    perp = x - p
    d = wp.length(perp)
    n = axis_normal(a)
    if d > 0.0:
        n = perp / d
    return p + n * radius


@wp.kernel
def cylinder_contact_mask(
    positions: wp.array(dtype=wp.vec3),
    p0: wp.vec3,
    p1: wp.vec3,
    radius: float,
    inside: wp.array(dtype=wp.int32),
):
    """One thread per point; inside (point_count,) is 1 for contact, else 0."""
    i = wp.tid()
    if cylinder_contains(positions[i], p0, p1, radius):
        inside[i] = 1
    else:
        inside[i] = 0


@wp.func
def push_out_node(
    i: int,
    positions: wp.array(dtype=wp.vec3),
    velocities: wp.array(dtype=wp.vec3),
    inertia: wp.vec3,
    flags: int,
    p0: wp.vec3,
    p1: wp.vec3,
    radius: float,
    h: float,
    tool_force: wp.array(dtype=wp.vec3),
    contact_count: wp.array(dtype=wp.int32),
    contact_position_sum: wp.array(dtype=wp.vec3),
):
    """Detect node i, push it out, and accumulate the reaction on the tool (see the module doc).

    Inactive nodes are skipped; pinned nodes in contact are counted but not moved.
    """
    if not is_active(flags):
        return
    x = positions[i]
    if not cylinder_contains(x, p0, p1, radius):
        return
    wp.atomic_add(contact_count, 0, 1)
    wp.atomic_add(contact_position_sum, 0, x)
    if is_pinned(flags):
        return
    target = push_out_target(x, p0, p1, radius)
    dx = target - x
    positions[i] = target
    velocities[i] = velocities[i] + dx / h
    wp.atomic_sub(tool_force, 0, wp.cw_mul(dx, inertia) / (h * h))


@wp.func
def tool_reach2(p0: wp.vec3, p1: wp.vec3, radius: float):
    """Squared radius [m^2] of a sphere about (p0 + p1) / 2 holding the whole cylinder
    (with a 0.1 % margin): a node outside it cannot be in contact, a cheap first test."""
    return (0.25 * wp.length_sq(p1 - p0) + radius * radius) * 1.001


@wp.func
def tool_sphere(tool_pose: wp.array(dtype=wp.vec3)):
    """The sphere holding the tool in ``tool_pose`` (p0, p1, (radius, 0, 0)) as vec4: its centre
    [m] and squared radius [m^2] (``tool_reach2``), -1 for no tool (radius 0) so that no node is
    near. A node pass reads it once per thread, before its loop over nodes."""
    p0 = tool_pose[0]
    p1 = tool_pose[1]
    radius = tool_pose[2][0]
    centre = 0.5 * (p0 + p1)
    reach2 = -1.0
    if radius > 0.0:
        reach2 = tool_reach2(p0, p1, radius)
    return wp.vec4(centre[0], centre[1], centre[2], reach2)


@wp.func
def push_out_near_tool(
    i: int,
    x: wp.vec3,
    positions: wp.array(dtype=wp.vec3),
    velocities: wp.array(dtype=wp.vec3),
    inertia: wp.vec3,
    flags: int,
    tool_pose: wp.array(dtype=wp.vec3),
    sphere: wp.vec4,
    h: float,
    tool_force: wp.array(dtype=wp.vec3),
    contact_count: wp.array(dtype=wp.int32),
    contact_position_sum: wp.array(dtype=wp.vec3),
):
    """``push_out_node`` for node i, whose new position x [m] is in positions[i], when x is
    inside ``sphere`` (``tool_sphere`` of ``tool_pose``). Returns the node's position after:
    x, or where it was pushed to."""
    d = x - wp.vec3(sphere[0], sphere[1], sphere[2])
    if wp.dot(d, d) <= sphere[3]:
        push_out_node(i, positions, velocities, inertia, flags, tool_pose[0], tool_pose[1],
                      tool_pose[2][0], h, tool_force, contact_count, contact_position_sum)
        return positions[i]
    return x


@wp.kernel
def cylinder_push_out(
    positions: wp.array(dtype=wp.vec3),
    velocities: wp.array(dtype=wp.vec3),
    node_mass: wp.array(dtype=wp.float32),
    node_damping: wp.array(dtype=wp.float32),
    node_flags: wp.array(dtype=wp.int32),
    tool_pose: wp.array(dtype=wp.vec3),
    h: float,
    inertia: wp.array(dtype=wp.vec3),
    tool_force: wp.array(dtype=wp.vec3),
    contact_count: wp.array(dtype=wp.int32),
    contact_position_sum: wp.array(dtype=wp.vec3),
):
    """One thread per node: detect, push out, and accumulate the reaction on the tool.

    inertia (node_count,) vec3 [kg]: the effective inertia per node, or an empty array for
    m + h D.

    tool_pose (3,) vec3: p0 [m], p1 [m], (radius [m], 0, 0) - an array, so a captured
    launch sees each new pose. tool_force (1,) [N], contact_count (1,), contact_position_sum
    (1,) [m]: accumulated, the caller clears them.
    """
    i = wp.tid()
    effective = wp.vec3(node_mass[i] + h * node_damping[i])
    if inertia.shape[0] > 0:
        effective = inertia[i]
    push_out_node(i, positions, velocities, effective, node_flags[i],
                  tool_pose[0], tool_pose[1], tool_pose[2][0], h, tool_force, contact_count,
                  contact_position_sum)


@wp.kernel
def clear_tool_stats(
    tool_force: wp.array(dtype=wp.vec3),
    contact_count: wp.array(dtype=wp.int32),
    contact_position_sum: wp.array(dtype=wp.vec3),
):
    """Zero the three (1,) tool statistics in one launch (one thread)."""
    tool_force[0] = wp.vec3(0.0)
    contact_count[0] = 0
    contact_position_sum[0] = wp.vec3(0.0)
