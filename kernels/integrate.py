"""Semi-implicit (symplectic) Euler with implicit linear damping (paper Eq. 1).

    v' = (v + h F / m) / (1 + h D / m) = (m v + h F) / (m + h D),    x' = x + h v'

The damping term ``-D v`` is taken at the new velocity, so a large D (the paper's
3 N s/m on milligram nodes) does not force a microscopic step: it only slows the
motion down. Pinned and inactive nodes keep their position and have zero velocity.
The kernel also clears ``forces`` for the next substep, which saves a launch.

One pass over the nodes does all per-node work of a substep: gravity (F += m g), the
foundation (``foundation_force``: F -= k_f A (x - X), the support holding each node to its rest
position X) and the tool (``collision.push_out_near_tool`` on the new position) are folded in
when a scene enables them, as separately compiled variants (``variants.specialised``). The new
state is checked in the same pass (``diagnostics.report_runaway``). On the CPU the variants are
compiled with multiply-adds fused as on CUDA (``variants.contracted_cpu_math``): 5-7 % off the pass.
"""

import warp as wp

from .chunks import chunk_start
from .collision import push_out_near_tool, tool_sphere
from .diagnostics import report_runaway
from .flags import is_free
from .variants import contracted_cpu_math, specialised, variant_family

wp.set_module_options({"enable_backward": False})


@wp.func
def foundation_force(x: wp.vec3, rest: wp.vec3, area: float, stiffness: float):
    """Force [N] of the support on a node at x [m] with rest position ``rest`` [m], lumped
    area [m^2] and foundation stiffness k_f [N/m^3]: -k_f A (x - rest)."""
    return (rest - x) * (stiffness * area)


@variant_family("integrate", options=contracted_cpu_math())
def _make(gravity: bool, collision: bool, foundation: bool):
    def integrate_semi_implicit(
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
        tool_pose: wp.array(dtype=wp.vec3),
        h: float,
        chunk: int,
        used_slots: wp.array(dtype=wp.int32),
        positions_out: wp.array(dtype=wp.vec3),
        velocities_out: wp.array(dtype=wp.vec3),
        tool_force: wp.array(dtype=wp.vec3),
        contact_count: wp.array(dtype=wp.int32),
        contact_position_sum: wp.array(dtype=wp.vec3),
        max_displacement_sq: float,
        first_bad: wp.array(dtype=wp.int32),
    ):
        i = chunk_start(wp.tid(), chunk)
        end = wp.min(i + chunk, used_slots[0])
        sphere = tool_sphere(tool_pose)
        while i < end:
            x = positions_in[i]
            flags = node_flags[i]
            m = node_mass[i]
            inertia = m + h * node_damping[i]
            v = wp.vec3(0.0)
            if is_free(flags):
                f = forces[i]
                if wp.static(gravity):
                    f = f + gravity_accel * m
                if wp.static(foundation):
                    f = f + foundation_force(x, rest_positions[i], node_area[i], foundation_stiffness)
                v = (velocities_in[i] * m + f * h) / inertia
                x = x + v * h
            positions_out[i] = x
            velocities_out[i] = v
            if wp.static(collision):
                x = push_out_near_tool(i, x, positions_out, velocities_out, wp.vec3(inertia), flags,
                                       tool_pose, sphere, h, tool_force, contact_count, contact_position_sum)
            report_runaway(i, flags, x, rest_positions, max_displacement_sq, first_bad)
            forces[i] = wp.vec3(0.0)
            i += 1

    return integrate_semi_implicit


def integrate_kernel(gravity: bool, collision: bool, foundation: bool = False):
    """The semi-implicit node kernel with gravity, the tool and the foundation on or off.

    Arguments, in order: positions_in, velocities_in (node_count,) vec3 [m], [m/s];
    forces (node_count,) vec3 [N], cleared on exit; node_mass [kg], node_damping D [N s/m]
    (node_count,) float32; node_flags (node_count,) int32; gravity_accel vec3 [m/s^2];
    rest_positions (node_count,) vec3 [m] (the foundation's anchors and the stability guard's
    reference), node_area (node_count,) float32 [m^2] and foundation_stiffness k_f [N/m^3]
    (read only by the foundation variant); tool_pose (3,) vec3: p0, p1 [m], (radius [m], 0, 0),
    radius 0 = no tool; h [s]; chunk and used_slots (4,) int32 (``DeviceModel.used_slots``:
    thread t handles nodes [t chunk, min((t + 1) chunk, used_slots[0])), so a launch over the
    node capacity skips the unused slots, whose state and forces nothing changes); outputs
    positions_out, velocities_out; tool_force (1,) vec3 [N], contact_count (1,) int32,
    contact_position_sum (1,) vec3 [m], accumulated; the stability guard
    (``diagnostics.report_runaway`` on the new state): max_displacement_sq [m^2], first_bad (1,)
    int32 lowered to the first bad node.
    """
    return specialised("integrate", _make, gravity=bool(gravity), collision=bool(collision),
                       foundation=bool(foundation))
