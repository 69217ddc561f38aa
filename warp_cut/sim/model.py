"""TissueModel: what does not change during a step (paper section 2.1).

The model is the single topology store of a tissue: node rest positions, lumped masses,
pinned flags, springs with rest lengths and stiffness, triangles, residual-stress links and
the material. Device arrays, the stable step and everything else are derived from it.
All arrays are numpy on the host (float64 / int64).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from ..errors import InputError
from ..mesh.geometry import boundary_nodes, edges_of, triangle_areas
from ..mesh.patch import skin_patch_mesh
from .bending import dihedral_angles, hinge_caps, hinge_rates, hinge_stiffness, hinges_of, mass_caps
from .material import Material
from .prestress import prestressed_rest_lengths
from .slots import SlotTable
from .topology_index import TopologyIndex

__all__ = ["TissueModel", "triangle_edges", "lumped_masses", "boundary_nodes"]

DEFAULT_LINK_SMOOTHING = 0.25
"""Residual-link smoothing length as a fraction of the deleted spring's rest length."""


triangle_edges = edges_of
"""Unique undirected edges (e, 2), each sorted (i < j), of triangles (t, 3) (``mesh.geometry.edges_of``)."""


def lumped_masses(points: np.ndarray, triangles: np.ndarray, areal_density: float) -> np.ndarray:
    """Lumped node masses (n,) [kg]: areal_density [kg/m^2] x one third of the adjacent areas."""
    tri = np.asarray(triangles, dtype=np.int64)
    area = triangle_areas(points, tri)
    masses = np.zeros(len(points))
    np.add.at(masses, tri.ravel(), np.repeat(area * areal_density / 3.0, 3))
    return masses


def _per_item(value, count: int, name: str, lower_open: bool = False) -> np.ndarray:
    """A scalar or (count,) array as a float64 (count,) array, checked finite and >= 0 (> 0)."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(count, float(arr))
    if arr.shape != (count,):
        raise InputError(f"{name} must be a scalar or have shape ({count},), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite")
    if np.any(arr <= 0) if lower_open else np.any(arr < 0):
        bad = int(np.argmin(arr))
        raise InputError(
            f"{name}[{bad}] = {arr[bad]} must be {'> 0' if lower_open else '>= 0'}"
        )
    return arr


class TissueModel:
    """A mass-spring tissue: nodes, springs, triangles, residual links, material.

    Storage is slot tables (``warp_cut.sim.slots.SlotTable``) so that a cut edits in place:
    a deleted node keeps its slot (``active`` False) and node indices never change; deleted
    springs, triangles and links leave dead slots that the kernels skip.

    Node attributes, over all node slots (node_count = slots, deleted ones included):
        points: rest positions [m], (node_count, 3) float64.
        masses: lumped node masses [kg], (node_count,) float64, > 0.
        damping: per-node damping D [N s/m], (node_count,) float64.
        pinned: boundary-condition flags, (node_count,) bool; pinned nodes never move.
        active: (node_count,) bool; False for nodes deleted by a cut.
        node_class: (node_count,) int8 ``NodeClass``.
    Live-only attributes (copies, dead slots left out, aligned with each other):
        springs (spring_count, 2) int64 with i < j; rest_lengths L0 [m]; stiffness K [N/m];
        spring_class int8 ``SpringClass``.
        triangles (triangle_count, 3) int64, CCW seen from the outside; triangle_areas [m^2]
        (area when the triangle was made, used for lumped masses).
        links (link_count, 2) int64 residual-stress pairs; link_force sigma_r A [N];
        link_smoothing eps [m].
    hinge_table: with ``material.bending_rigidity`` > 0, a hinge per interior edge
        (``warp_cut.sim.bending``): ``nodes`` (4,) [a, b, k, l], ``rest_angle`` theta_0 [rad],
        ``stiffness`` k_h [N m], ``cap`` [N/m] (``hinge_caps``); empty without bending.
    material: the Material the model was built with.
    topology_version: incremented by every topology edit (exporters re-author topology).
    index: node -> springs, triangles, links, hinges (``TopologyIndex``), built on first use.
    """

    def __init__(self, points, masses, springs, rest_lengths, stiffness, damping,
                 pinned, triangles, material: Material):
        n = len(points)
        self._index: TopologyIndex | None = None
        self.node_table = SlotTable({
            "points": points, "masses": masses, "damping": damping,
            "pinned": pinned, "node_class": np.zeros(n, np.int8)})
        self.spring_table = SlotTable({
            "pairs": springs, "rest_length": rest_lengths, "stiffness": stiffness,
            "spring_class": np.zeros(len(springs), np.int8)}, key="pairs")
        self.triangle_table = SlotTable({
            "corners": triangles, "area": triangle_areas(points, triangles)}, key="corners")
        self.link_table = SlotTable({
            "pairs": np.zeros((0, 2), np.int64), "force": np.zeros(0),
            "smoothing": np.zeros(0)}, key="pairs")
        self.hinge_table = SlotTable({
            "nodes": np.zeros((0, 4), np.int64), "rest_angle": np.zeros(0),
            "stiffness": np.zeros(0), "cap": np.zeros(0)}, key="nodes")
        self.material = material
        self.bending_budget = np.inf
        """The most a hinge may add to the bending's rate B_i / m_i at a node [1/s^2]: that of
        the sheet's own hinges, so hinges a cut makes hold no harder for their nodes' masses
        (``warp_cut.sim.bending.mass_caps``; inf without bending)."""
        if material.bending_rigidity > 0:
            slots = self.add_hinges(hinges_of(triangles), points)
            caps, nodes = self.hinge_table.column("cap")[slots], self.hinge_table.column("nodes")[slots]
            self.bending_budget = float(hinge_rates(caps, nodes, self.masses).max()) if len(slots) else np.inf
        self.stiffness_model = "constant"
        """How springs made later (by a cut) get their stiffness: ``"constant"`` (the material's
        K) or ``"material"`` (van Gelder, from E, thickness and their triangles)."""
        self.prestress_tension = 0.0
        """The membrane tension T [N/m] the rest lengths carry (``apply_prestress``; 0: none).
        Springs a cut makes or changes get their rest lengths the same way
        (``TopologyEditor.finish``)."""
        self.topology_version = 0

    @property
    def index(self) -> TopologyIndex:
        """Node -> springs, triangles, links and hinges (``warp_cut.sim.topology_index``), built
        on first use and kept up to date by every edit from then on."""
        if self._index is None:
            self._index = TopologyIndex(self)
        return self._index

    @property
    def has_index(self) -> bool:
        """Whether the index has been built (an edit then keeps it up to date)."""
        return self._index is not None

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_index"] = None  # rebuilt where it is used (a worker's replica)
        return state

    # ----------------------------------------------------------------- node views
    def _node_view(name):  # noqa: N805 - property factory used in the class body
        def get(self):
            return self.node_table.column(name)

        def put(self, value):
            self.node_table.column(name)[:] = value
            self.node_table.set(name, np.arange(self.node_table.count), self.node_table.column(name))

        return property(get, put, doc=f"Node column '{name}' over all node slots (a view).")

    points = _node_view("points")
    masses = _node_view("masses")
    damping = _node_view("damping")
    pinned = _node_view("pinned")
    node_class = _node_view("node_class")
    del _node_view

    @property
    def active(self) -> np.ndarray:
        """(node_count,) bool view: nodes alive (not deleted by a cut)."""
        return self.node_table.alive

    # ----------------------------------------------------------------- live views
    @property
    def springs(self) -> np.ndarray:
        return self.spring_table.live("pairs")

    def _live_spring_column(name):  # noqa: N805 - property factory used in the class body
        def get(self):
            return self.spring_table.live(name)

        def put(self, value):
            table = self.spring_table
            table.set(name, table.live_slots(), np.broadcast_to(value, (table.live_count,)))

        return property(get, put, doc=f"Spring column '{name}' over live springs (a copy; "
                                      "assigning writes the live slots).")

    rest_lengths = _live_spring_column("rest_length")
    stiffness = _live_spring_column("stiffness")
    del _live_spring_column

    @property
    def spring_class(self) -> np.ndarray:
        return self.spring_table.live("spring_class")

    @property
    def triangles(self) -> np.ndarray:
        return self.triangle_table.live("corners")

    @property
    def triangle_areas(self) -> np.ndarray:
        return self.triangle_table.live("area")

    @property
    def links(self) -> np.ndarray:
        return self.link_table.live("pairs")

    @property
    def link_force(self) -> np.ndarray:
        return self.link_table.live("force")

    @property
    def link_smoothing(self) -> np.ndarray:
        return self.link_table.live("smoothing")

    # ----------------------------------------------------------------- constructors
    @classmethod
    def from_arrays(cls, points, springs, masses, pinned=None, triangles=None, *,
                    stiffness=None, damping=None, rest_lengths=None,
                    material: Material | None = None) -> TissueModel:
        """Build a model from raw arrays.

        points (n, 3) [m]; springs (s, 2) node indices; masses scalar or (n,) [kg] > 0;
        pinned None or (n,) bool or an index list; triangles None or (t, 3);
        stiffness scalar or (s,) [N/m] (default material.stiffness);
        damping scalar or (n,) [N s/m] (default material.damping);
        rest_lengths None (the initial lengths) or (s,) [m].
        """
        material = material or Material()
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
            raise InputError(f"points must have shape (n, 3) with n >= 1, got {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise InputError("points must be finite")
        n = len(pts)
        spr = np.asarray(springs, dtype=np.int64).reshape(-1, 2) if len(springs) else np.zeros((0, 2), np.int64)
        if len(spr):
            if spr.min() < 0 or spr.max() >= n:
                raise InputError(f"springs index a node outside 0..{n - 1}")
            if np.any(spr[:, 0] == spr[:, 1]):
                raise InputError(f"spring {int(np.flatnonzero(spr[:, 0] == spr[:, 1])[0])} joins a node to itself")
            spr = np.sort(spr, axis=1)
            uniq, first = np.unique(spr, axis=0, return_index=True)
            if len(uniq) != len(spr):
                dup = sorted(set(range(len(spr))) - set(first.tolist()))[0]
                raise InputError(f"spring {dup} {tuple(spr[dup])} is a duplicate")
        s = len(spr)
        m = _per_item(masses, n, "masses", lower_open=True)
        k = _per_item(material.stiffness if stiffness is None else stiffness, s, "stiffness")
        d = _per_item(material.damping if damping is None else damping, n, "damping")
        if rest_lengths is None:
            L0 = np.linalg.norm(pts[spr[:, 1]] - pts[spr[:, 0]], axis=1) if s else np.zeros(0)
        else:
            L0 = _per_item(rest_lengths, s, "rest_lengths")
        pin = np.zeros(n, dtype=bool)
        if pinned is not None:
            p = np.asarray(pinned)
            if p.dtype == bool:
                if p.shape != (n,):
                    raise InputError(f"pinned mask must have shape ({n},), got {p.shape}")
                pin = p.copy()
            elif p.size:
                p = p.astype(np.int64).ravel()
                if p.min() < 0 or p.max() >= n:
                    raise InputError(f"pinned indices must be in 0..{n - 1}")
                pin[p] = True
        if triangles is None:
            tri = np.zeros((0, 3), dtype=np.int64)
        else:
            tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
            if len(tri) and (tri.min() < 0 or tri.max() >= n):
                raise InputError(f"triangles index a node outside 0..{n - 1}")
        return cls(pts.copy(), m, spr, L0, k, d, pin, tri, material)

    @classmethod
    def from_triangles(cls, points, triangles, *, material: Material | None = None,
                       pinned=None, uniform_mass: float | None = None) -> TissueModel:
        """A surface mesh as a tissue: springs = unique edges, lumped masses from
        density x thickness x one third of the adjacent triangle areas (or a uniform mass [kg]).
        With ``material.residual_stress_model == "prestress"`` the rest lengths carry the
        membrane tension (``apply_prestress``)."""
        material = material or Material()
        pts = np.asarray(points, dtype=np.float64)
        tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        if len(tri) == 0:
            raise InputError("a tissue mesh needs at least one triangle")
        repeated = np.flatnonzero((tri == tri[:, [1, 2, 0]]).any(axis=1))
        if repeated.size:
            raise InputError(f"triangle {int(repeated[0])} {tuple(tri[repeated[0]].tolist())} repeats a node")
        if uniform_mass is not None:
            masses = float(uniform_mass)
        else:
            masses = lumped_masses(pts, tri, material.density * material.thickness)
            used = np.zeros(len(pts), dtype=bool)
            used[tri.ravel()] = True
            if not used.all():
                raise InputError(
                    f"{int((~used).sum())} mesh vertices belong to no triangle (first: "
                    f"{int(np.flatnonzero(~used)[0])}); remove them or give a uniform mass"
                )
        if isinstance(pinned, str):
            pinned = cls._pinned_by_rule(pts, tri, pinned)
        model = cls.from_arrays(pts, triangle_edges(tri), masses, pinned=pinned,
                                triangles=tri, material=material)
        if material.residual_stress_model == "prestress":
            model.apply_prestress()
        return model

    @classmethod
    def from_surface(cls, surface, *, material: Material | None = None, pinned="border") -> TissueModel:
        """The tissue on a generated surface mesh (``warp_cut.mesh.surfaces``): springs = its
        edges, lumped masses, its border pinned unless ``pinned`` says otherwise."""
        return cls.from_triangles(surface.points, surface.triangles, material=material, pinned=pinned)

    @classmethod
    def from_patch(cls, size=(0.10, 0.06), spacing: float = 2.0e-3, *,
                   material: Material | None = None, pinned="border") -> TissueModel:
        """A rectangular skin patch in the XY plane, centred on the origin (see skin_patch_mesh)."""

        pts, tri = skin_patch_mesh(size, spacing)
        return cls.from_triangles(pts, tri, material=material, pinned=pinned)

    @classmethod
    def from_mesh_file(cls, path, *, material: Material | None = None, pinned="border",
                       scale: float = 1.0) -> TissueModel:
        """A triangle mesh file (OBJ/STL/PLY, metres unless scaled) through trimesh,
        with duplicate vertices merged."""

        path = Path(path)
        if not path.is_file():
            raise InputError(f"{path}: mesh file not found")
        try:
            mesh = trimesh.load(path, force="mesh", process=True)
        except Exception as exc:  # trimesh raises many types for unreadable files
            raise InputError(f"{path}: cannot read mesh ({exc})") from exc
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise InputError(f"{path}: no triangles found")
        mesh.merge_vertices()
        mesh.remove_unreferenced_vertices()
        return cls.from_triangles(np.asarray(mesh.vertices) * scale, np.asarray(mesh.faces),
                                  material=material, pinned=pinned)

    @staticmethod
    def _pinned_by_rule(points, triangles, rule):
        if rule == "none":
            return None
        if rule == "border":
            return boundary_nodes(len(points), triangles)
        raise InputError(f"pinned must be 'border', 'none', a box or indices, got {rule!r}")

    # ----------------------------------------------------------------- sizes
    @property
    def node_count(self) -> int:
        """Node slots, deleted nodes included (the range of valid node indices)."""
        return self.node_table.count

    @property
    def active_node_count(self) -> int:
        """Nodes alive."""
        return self.node_table.live_count

    @property
    def spring_count(self) -> int:
        return self.spring_table.live_count

    @property
    def triangle_count(self) -> int:
        return self.triangle_table.live_count

    @property
    def link_count(self) -> int:
        return self.link_table.live_count

    @property
    def total_mass(self) -> float:
        """Sum of the masses of the live nodes [kg]."""
        return float(self.masses[self.active].sum())

    def pin_box(self, lower, upper) -> None:
        """Pin every node whose rest position lies inside the axis-aligned box [lower, upper] [m]."""
        lo = np.asarray(lower, dtype=np.float64)
        hi = np.asarray(upper, dtype=np.float64)
        self.pinned = self.pinned | np.all((self.points >= lo) & (self.points <= hi), axis=1)

    # ----------------------------------------------------------------- residual stress
    def add_residual_links(self, pairs, rest_lengths, *, area=None,
                           smoothing=None) -> np.ndarray:
        """Join node pairs (l, 2) by residual-stress links (SPEC section 1).

        Force magnitude sigma_r * A with sigma_r = E eps_r (paper Eq. 3) and, by default,
        A = thickness x rest length of the deleted spring [m^2]; ``area`` overrides A
        (scalar or (l,)). ``smoothing`` [m] defaults to 0.25 x the rest length.
        Returns the link slots.
        """
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        L0 = _per_item(rest_lengths, len(pairs), "rest_lengths")
        if len(pairs) and (pairs.min() < 0 or pairs.max() >= self.node_count):
            raise InputError(f"link pairs index a node outside 0..{self.node_count - 1}")
        A = self.material.thickness * L0 if area is None else _per_item(area, len(pairs), "area")
        eps = DEFAULT_LINK_SMOOTHING * L0 if smoothing is None else _per_item(
            smoothing, len(pairs), "smoothing", lower_open=True)
        eps = np.maximum(eps, 1e-9)
        slots = self.link_table.append(pairs=pairs, force=self.material.residual_stress * A,
                                       smoothing=eps)
        if self._index is not None:
            self._index.register_rows("link_table", slots)
        return slots

    # ----------------------------------------------------------------- prestress and support
    def apply_prestress(self, tension: float | None = None) -> None:
        """Set the rest lengths of the live springs so that the current rest positions are in
        equilibrium under a uniform membrane tension (``warp_cut.sim.prestress``).

        Args:
            tension: T [N/m]; default ``material.membrane_tension`` (sigma_r x thickness).
                0 gives every spring its current length. Call again after changing the
                stiffness: L0 = L - f / k depends on it.

        Raises:
            InputError: if the tension is too large for the springs (a rest length <= 0).
        """
        T = self.material.membrane_tension if tension is None else float(tension)
        mat = self.material
        self.rest_lengths = prestressed_rest_lengths(
            self.points, self.triangles, self.springs, self.stiffness, T,
            what=f"the membrane tension (youngs_modulus {mat.youngs_modulus:g} Pa x "
                 f"residual_strain {mat.residual_strain:g} x thickness {mat.thickness:g} m)")
        self.prestress_tension = T

    def add_hinges(self, hinges, positions) -> np.ndarray:
        """Hinges (h, 4) [a, b, k, l] made at ``positions`` (node positions [m], anything an index
        array turns into (k, 3)): their angle there is their rest angle, their stiffness from the
        material's bending rigidity and the triangles' shape there, capped by their nodes' masses
        (``mass_caps``, within ``bending_budget``). Returns their slots (h,)."""
        hinges = np.asarray(hinges, dtype=np.int64).reshape(-1, 4)
        x = positions
        rigidity = self.material.bending_rigidity
        caps = mass_caps(hinge_caps(x, hinges, rigidity), hinges, self.masses, self.bending_budget)
        slots = self.hinge_table.append(
            nodes=hinges, rest_angle=dihedral_angles(x, hinges),
            stiffness=hinge_stiffness(x, hinges, rigidity), cap=caps)
        if self._index is not None:
            self._index.register_rows("hinge_table", slots)
        return slots

    @property
    def hinges(self) -> np.ndarray:
        """Live hinges (h, 4) [a, b, k, l] (a copy)."""
        return self.hinge_table.live("nodes")

    @property
    def hinge_count(self) -> int:
        """Used hinge slots (dead ones included)."""
        return self.hinge_table.count

    @property
    def foundation_stiffness(self) -> float:
        """k_f [N/m^3] of the support under the sheet (``material.foundation_stiffness``; 0 = none)."""
        return float(self.material.foundation_stiffness)

    @property
    def node_areas(self) -> np.ndarray:
        """Lumped node areas [m^2], (node_count,): masses / (density x thickness), i.e. one third
        of the areas of a node's triangles when the masses are lumped (the default, and what a
        cut recomputes for the nodes it touches); with a uniform mass, the area whose mass the
        node carries."""
        return self.masses / self.material.areal_density
