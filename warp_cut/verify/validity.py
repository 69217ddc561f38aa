"""Validity of a surface mesh, when generated and after every cut event.

The mesh invariants are ``warp_cut.mesh.checks.check_mesh``.

* ``surface_problems`` - a generated ``Surface``: ``check_mesh`` (indices, duplicates,
  degenerate triangles, winding, manifold edges, springs = edges), triangle normals against
  the analytic normal, points on the analytic surface, trimesh's winding and edge-use checks,
  and the expected topology (a disk or an open tube).
* ``cut_problems`` - a cut simulation after an event: ``check_mesh`` with masses and the mass
  balance (density x thickness x the sum of the triangles' rest areas), links only between
  live nodes, the device mirror of springs and node flags equal to the model's, the explicit
  integrator's substep within its safety fraction of the stable step kept up to date, no
  non-finite velocity, with bending the hinges those of the triangles (and their device
  mirror), and (given the Surface) no triangle turned against the analytic normal
  (reported apart for the triangles the latest edit made, those earlier edits made and the
  original ones: only the first are wound wrong by the cut itself).

Every problem is a string starting with the name of the check that failed.
"""

from __future__ import annotations

import numpy as np

from ..mesh.checks import check_mesh
from ..mesh.surfaces import flipped_triangles, surface_problems
from ..sim.bending import hinges_of
from ..sim.slots import member

__all__ = ["surface_problems", "cut_problems", "flipped_triangles", "FOLD_CHECKS"]

FOLD_CHECKS = ("tri_flipped_new", "tri_flipped_cut", "tri_flipped_tissue")
"""Checks that report triangles turned over by the motion where the nodes are now (a mass-spring
sheet has no resistance to folding: a triangle pushed across its neighbours by the tool stays
folded, and one made inside such tissue takes its current shape from it), not a wrong edit;
reported apart from the invariants. A wrong edit is ``tri_against_rest``."""


def _device_problems(sim) -> list[str]:
    model, dm = sim.model, sim.device_model
    problems = []
    pairs = model.spring_table.column("pairs").ravel().astype(np.int32)
    mirror = dm.spring_indices.numpy()[: len(pairs)]
    if not np.array_equal(mirror, pairs):
        problems.append(f"device_springs: {int((mirror != pairs).sum())} device spring indices "
                        "differ from the model's pairs")
    flags = dm.node_flags.numpy()[: model.node_count] & 1
    if not np.array_equal(flags, model.active.astype(flags.dtype)):
        problems.append(f"device_flags: {int((flags != model.active).sum())} device node flags "
                        "differ from the model's live nodes")
    return problems


def _hinge_problems(sim) -> list[str]:
    """With bending: the model's hinges are exactly those of its interior edges, and the
    device mirror holds the model's hinge table."""
    model = sim.model
    if model.material.bending_rigidity <= 0:
        return []
    problems = []
    have = {tuple(h) for h in model.hinges.tolist()}
    want = {tuple(h) for h in hinges_of(model.triangles).tolist()}
    if have != want:
        problems.append(f"hinges: {len(want - have)} interior edges without their hinge, "
                        f"{len(have - want)} hinges on no interior edge")
    nodes = model.hinge_table.column("nodes").ravel().astype(np.int32)
    if not np.array_equal(sim.device_model.hinge_indices.numpy()[: len(nodes)], nodes):
        problems.append("device_hinges: device hinge indices differ from the model's")
    return problems


def _step_problems(sim) -> list[str]:
    """The explicit integrator's substep within the safety fraction of the stable step kept
    up to date edit by edit. (The kept step itself is not compared with a recomputation here:
    its rows carry the geometric factor of the positions at the edit that last touched them,
    so it equals a full recomputation only on a tissue at rest, as in tests/test_cutting.py.)"""
    if sim.integrator != "semi_implicit":
        return []
    limit = sim.step_limit.step
    if not limit > 0:  # inf is legal: no free node has a spring
        return [f"stable_step: the kept stable step is {limit!r} s"]
    if sim.substep > sim.safety * limit * (1.0 + 1e-9):
        return [f"step_budget: substep {sim.substep:.6g} s exceeds {sim.safety} x the stable step {limit:.6g} s"]
    return []


def cut_problems(sim, surface=None, *, first_new_triangle: int | None = None) -> list[str]:
    """Why the cut simulation ``sim`` holds an invalid tissue now ([] if it does not).
    ``first_new_triangle``: triangle slots from this one on were made by the latest edit
    (their orientation is reported apart, see ``_flip_problems``)."""
    model = sim.model
    areal = model.material.density * model.material.thickness
    x = sim.positions
    report = check_mesh(x, model.triangles, model.springs, active=model.active,
                        masses=model.masses, expected_total_mass=areal * model.triangle_areas.sum())
    problems = list(report.problems)
    links = model.links
    if len(links) and not model.active[links.ravel()].all():
        problems.append("link_dead_node: a residual link joins a deleted node")
    v = sim.velocities[model.active]
    if not np.isfinite(v).all():
        problems.append("velocity_finite: a live node has a non-finite velocity")
    problems += _device_problems(sim) + _hinge_problems(sim) + _step_problems(sim)
    if surface is not None:
        problems += _flip_problems(sim, x, surface, first_new_triangle)
    return problems


def _flip_problems(sim, x, surface, first_new) -> list[str]:
    """Triangles turned against the analytic normal: ``tri_against_rest`` in the rest shape (a
    cut error: the cut is decided there), and where the nodes are now ``tri_flipped_new`` for
    those the latest edit made (made inside tissue the tool had folded: a new node's current
    position comes from the current shape of the rest triangle it lies in),
    ``tri_flipped_cut`` for those an earlier edit made and ``tri_flipped_tissue`` for original
    ones (turned over since, by the motion, e.g. the tool pushing nodes across each other)."""
    model = sim.model
    out = []
    against = flipped_triangles(model.points, model.triangles, surface.chart)
    if len(against):  # the rest shape is the cut's to keep right, whatever the motion did
        out.append(f"tri_against_rest: {len(against)} triangles wound against the analytic normal in the rest "
                   f"shape (slots {model.triangle_table.live_slots()[against][:5].tolist()})")
    flipped = flipped_triangles(x, model.triangles, surface.chart)
    if not len(flipped):
        return out
    slots = model.triangle_table.live_slots()[flipped]
    made = member(slots, np.fromiter(sim.cutter.new_triangles, dtype=np.int64)) \
        if sim.cutter is not None else np.zeros(len(slots), bool)
    new = slots >= (first_new if first_new is not None else np.iinfo(np.int64).max)
    for name, mask, what in (("tri_flipped_new", new, "made by the latest edit"),
                             ("tri_flipped_cut", made & ~new, "made by an earlier edit"),
                             ("tri_flipped_tissue", ~made & ~new, "of the original tissue")):
        if mask.any():
            out.append(f"{name}: {int(mask.sum())} triangles {what} against the analytic normal "
                       f"(slots {slots[mask][:5].tolist()})")
    return out
