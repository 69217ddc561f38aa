"""Stage 1 of the cut (paper Algorithm 1): which nodes and springs the swept volume touches.

Between two cut events the tool's cross-section circle (radius r) sweeps a capsule: all
points within r of the segment a -> b. A node is inside when its distance to the segment is
below r; a spring is touched when the distance between its segment and a -> b is below r.
The kernels test a candidate list (the host finds it by walking the mesh around the tool) and
append hits to a compact list with an atomic counter, so the host reads only the hits.
"""

import warp as wp

from .flags import is_active

wp.set_module_options({"enable_backward": False})


@wp.func
def point_segment_distance(x: wp.vec3, a: wp.vec3, b: wp.vec3):
    ab = b - a
    denom = wp.dot(ab, ab)
    t = 0.0
    if denom > 0.0:
        t = wp.clamp(wp.dot(x - a, ab) / denom, 0.0, 1.0)
    return wp.length(x - (a + ab * t))


@wp.func
def segment_segment_distance(p0: wp.vec3, p1: wp.vec3, q0: wp.vec3, q1: wp.vec3):
    """Distance between segments p0-p1 and q0-q1 (Ericson, Real-Time Collision Detection 5.1.9),
    defined for degenerate (point) segments and parallel ones."""
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = wp.dot(d1, d1)
    e = wp.dot(d2, d2)
    f = wp.dot(d2, r)
    s = 0.0
    t = 0.0
    eps = 1.0e-30
    if a <= eps and e <= eps:
        return wp.length(r)
    if a <= eps:
        t = wp.clamp(f / e, 0.0, 1.0)
    else:
        c = wp.dot(d1, r)
        if e <= eps:
            s = wp.clamp(-c / a, 0.0, 1.0)
        else:
            b = wp.dot(d1, d2)
            denom = a * e - b * b
            if denom > eps * a * e:
                s = wp.clamp((b * f - c * e) / denom, 0.0, 1.0)
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = wp.clamp(-c / a, 0.0, 1.0)
            elif t > 1.0:
                t = 1.0
                s = wp.clamp((b - c) / a, 0.0, 1.0)
    return wp.length((p0 + d1 * s) - (q0 + d2 * t))


@wp.func
def append_hit(hits: wp.array(dtype=wp.int32), hit_count: wp.array(dtype=wp.int32), value: int):
    """Append ``value`` to the compact hit list (counted even when the list is full)."""
    k = wp.atomic_add(hit_count, 0, 1)
    if k < hits.shape[0]:
        hits[k] = value


@wp.kernel
def capsule_node_hits_among(
    positions: wp.array(dtype=wp.vec3),
    node_flags: wp.array(dtype=wp.int32),
    candidates: wp.array(dtype=wp.int32),
    a: wp.vec3,
    b: wp.vec3,
    radius: float,
    hits: wp.array(dtype=wp.int32),
    hit_count: wp.array(dtype=wp.int32),
):
    """One thread per candidate node index: active candidates within ``radius`` [m] of segment
    a-b are appended to ``hits`` (capacity len(hits); hit_count (1,) may exceed it, then the
    caller retries with a larger list)."""
    i = candidates[wp.tid()]
    if not is_active(node_flags[i]):
        return
    if point_segment_distance(positions[i], a, b) < radius:
        append_hit(hits, hit_count, i)


@wp.kernel
def capsule_spring_hits_among(
    positions: wp.array(dtype=wp.vec3),
    spring_indices: wp.array(dtype=wp.int32),
    candidates: wp.array(dtype=wp.int32),
    a: wp.vec3,
    b: wp.vec3,
    radius: float,
    hits: wp.array(dtype=wp.int32),
    hit_count: wp.array(dtype=wp.int32),
):
    """One thread per candidate spring slot: live springs whose segment comes within ``radius``
    [m] of segment a-b are appended to ``hits``."""
    s = candidates[wp.tid()]
    i = spring_indices[2 * s]
    j = spring_indices[2 * s + 1]
    if i < 0 or j < 0:
        return
    if segment_segment_distance(positions[i], positions[j], a, b) < radius:
        append_hit(hits, hit_count, s)


@wp.kernel
def segment_node_hits(
    positions: wp.array(dtype=wp.vec3),
    node_flags: wp.array(dtype=wp.int32),
    a: wp.vec3,
    b: wp.vec3,
    radius: float,
    hits: wp.array(dtype=wp.int32),
    hit_count: wp.array(dtype=wp.int32),
):
    """One thread per node slot: active nodes within ``radius`` [m] of segment a-b are
    appended to ``hits`` (where the cut looks for the skin around the tool and for what the
    swept capsule may touch)."""
    i = wp.tid()
    if not is_active(node_flags[i]):
        return
    if point_segment_distance(positions[i], a, b) < radius:
        append_hit(hits, hit_count, i)
