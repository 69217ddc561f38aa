"""The stable explicit step, computed from masses, stiffnesses and node valence.

For semi-implicit Euler the linear stability limit of an undamped system is
``h < 2 / omega_max`` with ``omega_max^2 = lambda_max(M^-1 K)``. Gershgorin's theorem bounds
``lambda_max <= max_i R_i / m_i`` with the row sum ``R_i = sum_j k_ij g_ij (1 + [j free])``:
each spring at node i counts once on the diagonal and once more off it unless its other end is
pinned; ``g = max(1, |1 - L0 / L|)`` is the geometric factor (the transverse stiffness of a
stretched or compressed spring), a residual link counts with its largest stiffness F / eps, and
the foundation (a support of stiffness k_f A_i at node i, ``warp_cut.sim.model``) adds k_f A_i
on the diagonal (once: it joins the node to its fixed rest position).
With every neighbour free, R_i = 2 S_i (S_i the stiffness sum at node i), so

    h_undamped = min_i sqrt(2 m_i / S_i)

is always safe; springs to pinned nodes only make it larger. With the implicit damping of the integrator
(c = D / m), a mode of frequency omega is stable for ``h < (c + sqrt(c^2 + 4 omega^2)) / omega^2``,
which grows with c. The damped limit takes this per node, with c_i = D_i / m_i and
omega_i^2 = R_i / m_i, and the smallest over the nodes:

    h_damped = min_i (D_i + sqrt(D_i^2 + 4 R_i m_i)) / R_i

It is exact for mass-proportional damping and tends to 2 D / R_i for heavily damped light
nodes, whatever their mass (the step of the overdamped motion x' = -K x / D); the tests check
it against the eigenvalues of the iteration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["StepLimit", "stable_time_step", "node_stiffness_sums", "node_step_limits",
           "spring_geometric_factor", "foundation_rows", "RowSums"]


@dataclass(frozen=True)
class StepLimit:
    """Result of ``stable_time_step``.

    step: the stable step [s] (damped if requested), inf when nothing can oscillate.
    undamped_step: min_i sqrt(2 m_i / S_i) [s].
    node: the node with the largest Gershgorin frequency (-1 if none).
    omega_max: that frequency bound [rad/s].
    """

    step: float
    undamped_step: float
    node: int
    omega_max: float


def spring_geometric_factor(lengths: np.ndarray, rest_lengths: np.ndarray) -> np.ndarray:
    """max(1, |1 - L0 / L|) per spring: the transverse stiffness relative to K."""
    L = np.maximum(np.asarray(lengths, dtype=np.float64), 1e-12)
    return np.maximum(1.0, np.abs(1.0 - np.asarray(rest_lengths) / L))


def _add_rows(sums, pairs, k, free, positions=None, rest=None, rows=None) -> None:
    """Add the Gershgorin contributions of springs or links ``pairs`` (e, 2) of stiffness ``k``
    (e,) to ``sums``: k g (1 + [other end free]) at each end (g, the geometric factor, when
    ``rest`` lengths are given; ``positions`` indexable by a node list). ``rows``: a (node_count,)
    mask of the rows to add to (default all)."""
    if not len(pairs):
        return
    i, j = pairs[:, 0], pairs[:, 1]
    if rest is not None:
        lengths = np.linalg.norm(positions[j] - positions[i], axis=1)
        k = k * spring_geometric_factor(lengths, rest)
    for a, b in ((i, j), (j, i)):
        keep = slice(None) if rows is None else rows[a]
        np.add.at(sums, a[keep], (k * (1.0 + free[b]))[keep])


def foundation_rows(model, nodes=slice(None)) -> np.ndarray:
    """The foundation's diagonal k_f A_i [N/m] at ``nodes`` (all by default): 0 without one."""
    k_f = model.foundation_stiffness
    masses = model.masses[nodes]  # lumped area = mass / (density x thickness), see node_areas
    return k_f * masses / model.material.areal_density if k_f > 0 else np.zeros_like(masses)


def node_stiffness_sums(model, positions: np.ndarray | None = None) -> np.ndarray:
    """Gershgorin row sums R_i [N/m], (node_count,): springs and residual links at each node,
    counted twice unless the other end is pinned, and the foundation's k_f A_i (see the module
    docstring)."""
    x = model.points if positions is None else np.asarray(positions, dtype=np.float64)
    sums = foundation_rows(model).astype(np.float64)
    free = (~model.pinned).astype(np.float64)
    _add_rows(sums, model.springs, model.stiffness, free, x, model.rest_lengths)
    _add_rows(sums, model.links, model.link_force / np.maximum(model.link_smoothing, 1e-30), free)
    return sums


def node_step_limits(R, m, D) -> tuple[np.ndarray, np.ndarray]:
    """(damped, undamped) stable steps [s] per node from row sums R [N/m] > 0, masses m [kg]
    and damping D [N s/m] (see the module docstring)."""
    return (D + np.sqrt(D * D + 4.0 * R * m)) / R, 2.0 * np.sqrt(m / R)


def stable_time_step(model, positions: np.ndarray | None = None, *,
                     include_damping: bool = True, sums: np.ndarray | None = None) -> StepLimit:
    """The stable step of semi-implicit Euler for ``model`` at ``positions`` (default: rest).
    ``sums``: precomputed Gershgorin row sums (e.g. kept up to date by a RowSums)."""
    free = ~model.pinned & model.active
    sums = node_stiffness_sums(model, positions) if sums is None else sums
    candidates = free & (sums > 0)
    if not np.any(candidates):
        return StepLimit(float("inf"), float("inf"), -1, 0.0)
    omega2 = np.zeros(model.node_count)
    omega2[candidates] = sums[candidates] / model.masses[candidates]
    node = int(np.argmax(omega2))
    w2 = float(omega2[node])
    undamped = 2.0 / np.sqrt(w2)
    if not include_damping:
        return StepLimit(undamped, undamped, node, float(np.sqrt(w2)))
    per_node, _ = node_step_limits(sums[candidates], model.masses[candidates],
                                   model.damping[candidates])
    k = int(np.argmin(per_node))
    node = int(np.flatnonzero(candidates)[k])
    return StepLimit(float(per_node[k]), float(undamped), node, float(np.sqrt(w2)))


class RowSums:
    """Gershgorin row sums and per-node stable steps kept up to date across topology edits at
    the cost of the nodes an edit touches (``node_stiffness_sums`` is O(springs)); the global
    limit is then one reduction over the per-node steps."""

    def __init__(self, model, positions: np.ndarray | None = None):
        self.model = model
        self.sums = node_stiffness_sums(model, positions)
        self.damped = np.full(model.node_count, np.inf)
        self.undamped = np.full(model.node_count, np.inf)
        self._node_steps(np.arange(model.node_count))

    def _node_steps(self, nodes: np.ndarray) -> None:
        model = self.model
        R = self.sums[nodes]
        m = model.masses[nodes]
        D = model.damping[nodes]
        ok = model.active[nodes] & ~model.pinned[nodes] & (R > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            damped, undamped = node_step_limits(R, m, D)
        self.damped[nodes] = np.where(ok, damped, np.inf)
        self.undamped[nodes] = np.where(ok, undamped, np.inf)

    def limit(self) -> StepLimit:
        """The current StepLimit (as ``stable_time_step`` would compute it)."""
        if not np.isfinite(self.damped).any():
            return StepLimit(float("inf"), float("inf"), -1, 0.0)
        node = int(np.argmin(self.damped))
        k = int(np.argmin(self.undamped))
        return StepLimit(float(self.damped[node]), float(self.undamped[k]), k,
                         float(2.0 / self.undamped[k]))

    def update(self, nodes, editor, positions) -> None:
        """Recompute the rows of ``nodes`` from the editor's adjacency; ``positions`` is
        indexable by node ([m]) for the geometric factor."""
        model = self.model
        grow = model.node_count - len(self.sums)
        if grow > 0:
            self.sums = np.concatenate([self.sums, np.zeros(grow)])
            self.damped = np.concatenate([self.damped, np.full(grow, np.inf)])
            self.undamped = np.concatenate([self.undamped, np.full(grow, np.inf)])
        nodes = np.asarray(sorted(nodes), dtype=np.int64)
        rows = np.zeros(model.node_count, dtype=bool)
        rows[nodes] = model.active[nodes]
        self.sums[nodes] = np.where(rows[nodes], foundation_rows(model, nodes), 0.0)
        free = (~model.pinned).astype(np.float64)
        springs, links = model.spring_table, model.link_table
        s = np.array(sorted({t for v in nodes[rows[nodes]] for t in editor.node_springs[v]}), np.int64)
        if len(s):
            _add_rows(self.sums, springs.column("pairs")[s], springs.column("stiffness")[s], free,
                      positions, springs.column("rest_length")[s], rows)
        l = np.array(sorted({t for v in nodes[rows[nodes]] for t in editor.node_links[v]}), np.int64)
        if len(l):
            _add_rows(self.sums, links.column("pairs")[l],
                      links.column("force")[l] / links.column("smoothing")[l], free, rows=rows)
        if len(nodes):
            self._node_steps(nodes)
