"""The stable explicit step, bounded element by element.

Semi-implicit Euler with implicit damping, ``v' = (M + h D)^-1 (M v - h K x)``, ``x' = x + h v'``,
has eigenvalues mu that solve, for the eigenvector x, the scalar equation of one damped
oscillator with m = x^H M x, d = x^H D x, k = x^H K x. That oscillator is stable while

    h <= d / k + sqrt((d / k)^2 + 4 m / k),

which grows with m / k and with d / k. Both are bounded below over all x by
1 / Lambda_M and 1 / Lambda_D, with Lambda_M >= lambda_max(M^-1 K) and
Lambda_D >= lambda_max(D^-1 K), so

    h_damped = a + sqrt(a^2 + 4 / Lambda_M),  a = 1 / Lambda_D,

is stable for any damping (not only mass-proportional), and h_undamped = 2 / sqrt(Lambda_M).

The bounds come from the elements (Irons' element eigenvalue theorem): write K = sum_e K_e and
split every node's mass (or damping) among its elements, M = sum_e M_e; then
x^T K x = sum_e x^T K_e x <= max_e lambda_max(M_e^-1 K_e) x^T M x. The elements are the
triangles (a spring on two triangles gives each half its stiffness), springs on no triangle and
residual links (two-node elements, a link with its largest stiffness F / eps), and the
foundation (a one-node element of stiffness k_f A_i, ``warp_cut.sim.model``). A node's mass
goes to its elements in proportion to the stiffness it has in each (S_i is the sum), so a
two-node element rates S_a / m_a + S_b / m_b and the regular triangle lattice rates exactly its
largest frequency (9 k / m, where Gershgorin's row sums give 12 k / m). A pinned node does not
move: its rows are left out (a principal submatrix has no larger eigenvalue).

The limit does not depend on where the nodes are. A spring of length L has the tangent stiffness
k [u u^T + (1 - L0 / L)(I - u u^T)]: along itself k, across it k (1 - L0 / L), which is below k
when stretched and negative when compressed. A negative stiffness is a buckling mode: it grows
at its physical rate whatever the step (the iteration's eigenvalue is real and above 1, no
oscillation), so it sets no step. Bounding each spring's positive part by k I makes K no larger
than the scalar graph Laplacian (times the 3 x 3 identity) that the elements bound; the tests
check this on a compressed sheet against the eigenvalues of the iteration.

The sheet's bending (hinges, ``warp_cut.sim.bending``), when it has any, is added on top
(Weyl: lambda_max(M^-1 (K + B)) <= lambda_max(M^-1 K) + lambda_max(M^-1 B)), its part bounded by
Gershgorin's row sums of M^-1 B and D^-1 B (``bending_node_rows``): each hinge holds
k_h g g^T with k_h |g|^2 capped (``warp_cut.sim.bending.hinge_caps``), whatever the shape (the
term k_h (theta - theta_0) d2 theta, which vanishes at rest, is left out as the springs'
transverse stiffness is).

``node_stiffness_sums`` keeps Gershgorin's row sums for XPBD's explicit part
(``warp_cut.solvers.xpbd``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .bending import bending_rows
from .slots import member

__all__ = ["StepLimit", "stable_time_step", "node_stiffness_sums", "foundation_rows", "bending_node_rows",
           "damped_step", "ElementRates"]


@dataclass(frozen=True)
class StepLimit:
    """Result of ``stable_time_step``.

    step: the stable step [s] (damped if requested), inf when nothing can oscillate.
    undamped_step: 2 / omega_max [s].
    node: a node of the element that limits the step most (-1 if none).
    omega_max: the bound sqrt(Lambda_M) on the largest frequency [rad/s].
    """

    step: float
    undamped_step: float
    node: int
    omega_max: float


def foundation_rows(model, nodes=slice(None)) -> np.ndarray:
    """The foundation's diagonal k_f A_i [N/m] at ``nodes`` (all by default): 0 without one."""
    k_f = model.foundation_stiffness
    masses = model.masses[nodes]  # lumped area = mass / (density x thickness), see node_areas
    return k_f * masses / model.material.areal_density if k_f > 0 else np.zeros_like(masses)


def bending_node_rows(model, hinge_slots=None) -> np.ndarray:
    """A bound B_i [N/m] (node slots,) on Gershgorin's row sums of the bending stiffness of the
    hinges at ``hinge_slots`` (all live ones by default), whatever the shape
    (``warp_cut.sim.bending.bending_rows``): 0 without bending."""
    table = model.hinge_table
    slots = table.live_slots() if hinge_slots is None else np.asarray(hinge_slots, dtype=np.int64)
    return bending_rows(model.node_count, table.column("nodes")[slots], table.column("cap")[slots])


def _link_stiffness(model, slots) -> np.ndarray:
    """A residual link's largest stiffness F / eps [N/m] at link ``slots``."""
    links = model.link_table
    return links.column("force")[slots] / np.maximum(links.column("smoothing")[slots], 1e-30)


def node_stiffness_sums(model, links: bool = True) -> np.ndarray:
    """Gershgorin row sums R_i [N/m], (node_count,): every spring and residual link at node i
    (no link if not ``links``: a solver without residual stress), counted twice unless its
    other end is pinned, the foundation's k_f A_i once and the bending's row sum
    (``bending_node_rows``)."""
    sums = foundation_rows(model).astype(np.float64) + bending_node_rows(model)
    free = (~model.pinned).astype(np.float64)
    slots = model.link_table.live_slots() if links else np.zeros(0, dtype=np.int64)
    link_pairs = model.link_table.column("pairs")[slots]
    for pairs, k in ((model.springs, model.stiffness), (link_pairs, _link_stiffness(model, slots))):
        for a, b in ((pairs[:, 0], pairs[:, 1]), (pairs[:, 1], pairs[:, 0])):
            np.add.at(sums, a, k * (1.0 + free[b]))
    return sums


def damped_step(mass_rate: float, damping_rate: float) -> float:
    """a + sqrt(a^2 + 4 / Lambda_M) [s] with a = 1 / Lambda_D (a = 0 where some free node has
    no damping: Lambda_D is infinite)."""
    a = 1.0 / damping_rate if 0.0 < damping_rate < np.inf else 0.0
    return a + float(np.sqrt(a * a + 4.0 / mass_rate))


def _pair_rates(sums, weights_at, ends, free_at) -> np.ndarray:
    """lambda_max of two-node elements with ``ends`` (e, 2), (2, e) for the two weights:
    S_a / w_a + S_b / w_b over their free ends (inf where a free end with stiffness has no
    weight)."""
    return _node_ratio(sums, weights_at, ends, free_at).sum(axis=-1)


def _node_ratio(sums, weights_at, nodes, free_at) -> np.ndarray:
    """S_i / w_i at ``nodes`` (any shape) for the two weights (mass, damping), shape
    (2, *nodes.shape): 0 where pinned or without stiffness, inf where weightless."""
    s, w = sums[nodes], weights_at(nodes)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(w > 0, s / np.where(w > 0, w, 1.0), np.inf)
    return np.where(free_at(nodes) & (s > 0), ratio, 0.0)


_TRIANGLE_EDGES = ((0, 1), (1, 2), (2, 0))


def _triangle_rates(weights_at, corners, edge_k, sums, free_at) -> np.ndarray:
    """lambda_max(W_T^-1 L_T) of triangles with ``corners`` (t, 3) and edge stiffnesses
    ``edge_k`` (t, 3) (edges 01, 12, 20), for the two node weights (mass, damping), shape
    (2, t): a node's weight split in proportion to its stiffness in the triangle out of
    ``sums``; pinned corners left out. inf where a free corner with stiffness has no weight."""
    t = len(corners)
    if not t:
        return np.zeros((2, 0))
    own = np.stack([edge_k[:, 0] + edge_k[:, 2], edge_k[:, 0] + edge_k[:, 1],
                    edge_k[:, 1] + edge_k[:, 2]], axis=1)
    moving = free_at(corners) & (own > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        share = weights_at(corners) * (own / sums[corners])
    weightless = (moving & ~(share > 0)).any(axis=-1)
    share = np.where(moving & (share > 0), share, 1.0)
    L = np.zeros((t, 3, 3))
    for e, (a, b) in enumerate(_TRIANGLE_EDGES):
        L[:, a, a] += edge_k[:, e]
        L[:, b, b] += edge_k[:, e]
        L[:, a, b] -= edge_k[:, e]
        L[:, b, a] -= edge_k[:, e]
    scale = np.where(moving, 1.0 / np.sqrt(share), 0.0)
    rates = np.linalg.eigvalsh(L * scale[..., :, None] * scale[..., None, :])[..., -1]
    return np.where(weightless, np.inf, rates)


def _edge_keys(pairs: np.ndarray, count: int) -> np.ndarray:
    """One integer per undirected node pair, (e,)."""
    lo, hi = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
    return lo.astype(np.int64) * count + hi


class ElementRates:
    """The element bounds Lambda_M and Lambda_D (module docstring), kept per element so that
    after a topology edit only the elements at the nodes it touched are rated again, and the
    largest rate of each kind is kept (found again by one pass only when the element that had it
    is rated again).

    Arrays over the slots of their tables, spanning the tables' capacity (0 in dead and spare
    slots): ``sums`` (nodes: S_i [N/m]), ``on_triangles`` (springs: live triangles on the
    spring), and ``rates[kind]`` of shape (2, capacity), the mass rate [1/s^2] and the damping
    rate [1/s] of each element of that kind: ``triangles``, ``springs`` (springs on no
    triangle), ``links``, ``foundation`` (nodes).
    """

    KINDS = ("triangles", "springs", "links", "foundation")

    def __init__(self, model, links: bool = True):
        self.model = model
        self.links = bool(links)
        """Whether the residual links act (a solver without residual stress leaves them out)."""
        self.sums = np.zeros(0)
        self.on_triangles = np.zeros(0, dtype=np.int64)
        self.rates = {kind: np.zeros((2, 0)) for kind in self.KINDS}
        self._top = {kind: [-1, -1] for kind in self.KINDS}
        """Slot of each kind's largest rate per weight (-1: unknown)."""
        self.bend = bending_node_rows(model)
        nodes = model.node_table.live_slots()
        self._rate(nodes, model.triangle_table.live_slots(), model.spring_table.live_slots(),
                   model.spring_table.live_slots(), self._acting(model.link_table.live_slots()))

    # ------------------------------------------------------------------ updates
    def update(self, change) -> None:
        """Rate again the elements at the nodes a ``ModelChange`` touched (their springs,
        links, triangles or mass changed), through the model's ``TopologyIndex``, and drop the
        elements it deleted."""
        self._grow()  # nodes made and deleted again in one edit may lie past the last capacity
        for kind, dead in (("triangles", change.deleted_triangles), ("springs", change.deleted_springs),
                           ("links", change.deleted_links), ("foundation", change.deleted_nodes)):
            self._set(kind, dead, 0.0)
        index = self.model.index
        nodes = np.asarray(change.touched_nodes, dtype=np.int64)
        alive = self.model.node_table.alive_buffer()
        nodes = nodes[alive[nodes]] if len(nodes) else nodes
        tris = index.triangles_at(nodes)
        corners = self.model.triangle_table.column("corners")[tris] if tris else np.zeros((0, 3), int)
        near = set(nodes.tolist()) | set(corners.ravel().tolist())
        self._rate(nodes, np.array(tris, np.int64), np.array(index.springs_at(near), np.int64),
                   np.array(index.springs_at(nodes), np.int64), self._acting(index.links_at(nodes)))
        self._rate_bending(change.hinge_nodes)

    def _acting(self, links) -> np.ndarray:
        """The link slots of ``links`` that act: all of them, or none without residual stress."""
        return np.asarray(links if self.links else [], dtype=np.int64)

    def _rate_bending(self, nodes) -> None:
        """The bending's row sums again at ``nodes`` (of hinges an edit made or deleted)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        if not len(nodes):
            return
        hinges = np.array(self.model.index.hinges_at(nodes), dtype=np.int64)
        rows = bending_node_rows(self.model, hinges)
        self.bend[nodes] = rows[nodes]

    def _grow(self) -> None:
        """Extend the slot arrays to the tables' capacities (which grow geometrically)."""
        model = self.model

        def grown(values, count):  # zeros appended along the last axis
            extra = count - values.shape[-1]
            return values if extra <= 0 else np.concatenate(
                [values, np.zeros(values.shape[:-1] + (extra,), values.dtype)], axis=-1)

        self.sums = grown(self.sums, model.node_table.capacity)
        self.bend = grown(self.bend, model.node_table.capacity)
        self.on_triangles = grown(self.on_triangles, model.spring_table.capacity)
        for kind, table in self.tables().items():
            self.rates[kind] = grown(self.rates[kind], table.capacity)

    def _rate(self, nodes, tris, springs_near, springs_at, links_at) -> None:
        """Node sums at ``nodes``, then the rates of every element at them: ``tris`` (all live
        triangles at ``nodes``), ``springs_at`` / ``links_at`` (at ``nodes``); ``springs_near``
        holds every spring at a corner of ``tris`` (to find their edges)."""
        self._grow()
        self._node_sums(nodes, springs_at, links_at)
        model = self.model
        corners = model.triangle_table.column("corners")[tris]
        edges = np.concatenate([corners[:, [a, b]] for a, b in _TRIANGLE_EDGES])
        edge_slots = self._spring_slots(edges, springs_near).reshape(3, len(tris)).T  # (t, 3), -1: none
        self._count_triangles(edge_slots, springs_at)
        free_at, weights_at = self._free_at, self._weights_at
        edge_k = self._triangle_edge_stiffness(edge_slots)
        alone = springs_at[self.on_triangles[springs_at] == 0]
        alone_pairs = model.spring_table.column("pairs")[alone]
        link_pairs = model.link_table.column("pairs")[links_at]
        supported = foundation_rows(model, nodes) > 0
        self._set("triangles", tris, _triangle_rates(weights_at, corners, edge_k, self.sums, free_at))
        self._set("springs", springs_at, 0.0)
        self._set("springs", alone, _pair_rates(self.sums, weights_at, alone_pairs, free_at))
        self._set("links", links_at, _pair_rates(self.sums, weights_at, link_pairs, free_at))
        self._set("foundation", nodes, np.where(supported, _node_ratio(self.sums, weights_at, nodes, free_at), 0.0))

    def _free_at(self, idx) -> np.ndarray:
        """Which of node slots ``idx`` (any shape) move: alive and not pinned."""
        table = self.model.node_table
        return table.alive_buffer()[idx] & ~table.buffer("pinned")[idx]

    def _weights_at(self, idx) -> np.ndarray:
        """(2, *idx.shape): the mass [kg] and the damping [N s/m] of node slots ``idx``."""
        return np.stack([self.model.masses[idx], self.model.damping[idx]])

    def _set(self, kind: str, slots, values) -> None:
        """rates[kind][:, slots] = values, keeping each weight's largest rate known: a larger
        new one takes its place; rewriting the largest one itself makes it unknown (found
        again by one pass over the kind's slots when asked, ``bounds``)."""
        slots = np.asarray(slots, dtype=np.int64)
        rates = self.rates[kind]
        rates[:, slots] = values
        if not len(slots):
            return
        for w in (0, 1):
            top = self._top[kind][w]
            if top < 0:
                continue  # unknown already
            if np.any(slots == top):
                self._top[kind][w] = -1
                continue
            k = int(np.argmax(rates[w, slots]))
            if rates[w, slots[k]] > rates[w, top]:
                self._top[kind][w] = int(slots[k])

    def _node_sums(self, nodes, springs_at, links_at) -> None:
        """S_i [N/m] at ``nodes``: their springs, residual links and foundation."""
        model = self.model
        self.sums[nodes] = foundation_rows(model, nodes)
        for pairs, k in ((model.spring_table.column("pairs")[springs_at],
                          model.spring_table.column("stiffness")[springs_at]),
                         (model.link_table.column("pairs")[links_at], _link_stiffness(model, links_at))):
            mine = member(pairs, nodes)  # (e, 2)
            for end in (0, 1):
                np.add.at(self.sums, pairs[mine[:, end], end], k[mine[:, end]])

    def _spring_slots(self, edges, springs_near) -> np.ndarray:
        """Spring slot of each node pair in ``edges`` (e, 2) among ``springs_near`` (-1 if none)."""
        if not len(springs_near):
            return np.full(len(edges), -1, dtype=np.int64)
        n = self.model.node_count
        keys = _edge_keys(self.model.spring_table.column("pairs")[springs_near], n)
        order = np.argsort(keys)
        keys, slots = keys[order], springs_near[order]
        wanted = _edge_keys(edges, n)
        at = np.minimum(np.searchsorted(keys, wanted), len(keys) - 1)
        return np.where(keys[at] == wanted, slots[at], -1)

    def _count_triangles(self, edge_slots, springs_at) -> None:
        """Live triangles on each spring of ``springs_at``, from the spring slots (t, 3) of the
        edges of triangles that hold all of theirs (-1: an edge without a spring)."""
        self.on_triangles[springs_at] = 0
        hit = edge_slots[edge_slots >= 0]
        np.add.at(self.on_triangles, hit[member(hit, springs_at)], 1)

    def _triangle_edge_stiffness(self, slots) -> np.ndarray:
        """(t, 3) stiffness each triangle gets of its edges' springs, their slots (t, 3) (a
        spring's stiffness split among its triangles; 0 for an edge without a spring, -1)."""
        k = self.model.spring_table.column("stiffness")
        safe = np.maximum(slots, 0)
        return np.where(slots >= 0, k[safe] / np.maximum(self.on_triangles[safe], 1), 0.0)

    # ------------------------------------------------------------------ limit
    def tables(self) -> dict:
        """The slot table of each element kind."""
        model = self.model
        return {"triangles": model.triangle_table, "springs": model.spring_table,
                "links": model.link_table, "foundation": model.node_table}

    def bounds(self) -> tuple[tuple, tuple]:
        """((Lambda_M [1/s^2], element), (Lambda_D [1/s], element)) over the live elements, each
        element a (kind, slot) pair (None when no element is rated above 0)."""
        found = []
        for w in (0, 1):
            best, where = 0.0, None
            for kind, pair in self.rates.items():
                rates = pair[w]  # 0 in dead and spare slots
                if not len(rates):
                    continue
                if self._top[kind][w] < 0:
                    self._top[kind][w] = int(np.argmax(rates))
                top = self._top[kind][w]
                if rates[top] > best:
                    best, where = float(rates[top]), (kind, top)
            found.append((best, where))
        return found[0], found[1]

    def bending_bounds(self) -> tuple[tuple, tuple]:
        """((max B_i / m_i [1/s^2], node), (max B_i / D_i [1/s], node)) over the free live nodes
        (Gershgorin's bound on the bending alone; 0 and -1 without bending)."""
        model = self.model
        nodes = np.flatnonzero(self.bend[: model.node_count] > 0) if model.material.bending_rigidity > 0 else []
        if not len(nodes):  # no pass over the nodes for a sheet that does not bend
            return (0.0, -1), (0.0, -1)
        rates = _node_ratio(self.bend, self._weights_at, nodes, self._free_at)  # (2, k), 0 where pinned
        best = np.argmax(rates, axis=1)
        found = [(float(rates[w, k]), int(nodes[k]) if rates[w, k] > 0 else -1) for w, k in enumerate(best)]
        return found[0], found[1]

    def limit(self, include_damping: bool = True) -> StepLimit:
        """The current StepLimit (as ``stable_time_step`` would compute it)."""
        (mass_rate, mass_element), (damping_rate, damping_element) = self.bounds()
        (bend_mass, bend_mass_node), (bend_damping, bend_damping_node) = self.bending_bounds()
        if bend_mass > 0:  # Weyl: the bounds add; the limiting node is the bending's if it is larger
            if bend_mass > mass_rate:
                mass_element = ("foundation", bend_mass_node)
            if bend_damping > damping_rate:
                damping_element = ("foundation", bend_damping_node)
            mass_rate, damping_rate = mass_rate + bend_mass, damping_rate + bend_damping
        if mass_rate <= 0.0:
            return StepLimit(float("inf"), float("inf"), -1, 0.0)
        undamped = 2.0 / np.sqrt(mass_rate)
        if not include_damping:
            return StepLimit(float(undamped), float(undamped), self._node_of(*mass_element), float(np.sqrt(mass_rate)))
        step = damped_step(mass_rate, damping_rate)
        damping_binds = np.isfinite(damping_rate) and damping_rate * damping_rate * 4.0 < mass_rate
        limiting = damping_element if damping_binds else mass_element
        return StepLimit(step, float(undamped), self._node_of(*limiting), float(np.sqrt(mass_rate)))

    def _node_of(self, kind: str, slot: int) -> int:
        """A free node of element ``slot`` of ``kind``: the one with the largest S_i / m_i."""
        model = self.model
        if kind == "foundation":
            return slot
        table = {"triangles": (model.triangle_table, "corners"), "springs": (model.spring_table, "pairs"),
                 "links": (model.link_table, "pairs")}[kind]
        nodes = np.asarray(table[0].column(table[1])[slot], dtype=np.int64)
        nodes = nodes[~model.pinned[nodes]] if (~model.pinned[nodes]).any() else nodes
        return int(nodes[np.argmax(self.sums[nodes] / model.masses[nodes])])


def stable_time_step(model, *, include_damping: bool = True, links: bool = True) -> StepLimit:
    """The stable step of semi-implicit Euler for ``model`` (any node positions, see the module
    docstring); ``links``: whether its residual links act (False: a solver without residual
    stress, which never applies them)."""
    return ElementRates(model, links).limit(include_damping)
