"""MaterialPolicy: how the springs an edit changes get their stiffness and rest length.

A topology edit (a cut) makes and deletes triangles; the springs on their edges must then carry
what the sheet's material says. Which rule applies is fixed by the model when the cut is set
up, so it is chosen once (``material_policy(model)``) instead of being asked at every edit:

* ``ConstantSprings``: the paper's constant K. New springs get K and the rest length they are
  made with; nothing is refreshed.
* ``VanGelderSprings`` (``stiffness_model = "material"``): every changed spring gets van Gelder's
  stiffness E t sum|T| / |e|^2 from the triangles it borders now (``warp_cut.sim.stiffness``).
* ``PrestressedSprings`` (a sheet that carries the membrane tension, ``apply_prestress``): as
  one of the two above for the stiffness, measured in the rest shape, then the rest lengths that
  carry the tension (``warp_cut.sim.prestress``); the cut releases the tension across it
  instead of leaving residual links, and a finished cut's springs take the sheet's modulus
  (``settle``).

Each policy also says whether a spring the cut separates leaves a residual-stress link (the
paper's Eq. 4 model, ``makes_links``) and whether the rest shape carries tension
(``prestressed``), which is all the cut needs to know of the material.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .prestress import prestressed_rest_lengths
from .stiffness import membrane_modulus, van_gelder_stiffness

__all__ = ["MaterialPolicy", "ConstantSprings", "VanGelderSprings", "PrestressedSprings",
           "material_policy", "MAX_PRESTRAIN"]

MAX_PRESTRAIN = 0.5
"""Largest |f / (k L)| a spring an edit makes or changes in a prestressed sheet is given
(``PrestressedSprings``)."""


class MaterialPolicy:
    """The refresh of the springs an edit changed (base: the paper's constant K, nothing to do).

    Attributes:
        makes_links: A spring a cut separates leaves a residual-stress link (the paper's model).
        prestressed: The rest lengths carry a membrane tension (``model.prestress_tension``).
    """

    prestressed = False

    def __init__(self, model):
        self.model = model
        self.makes_links = model.material.residual_stress_model == "links"

    def refresh(self, changed: Callable[[], list[int]], settling: list[int]) -> None:
        """Give the springs an edit changed (``changed()``: their slots, worked out only if the
        policy needs them) and the springs named to ``settle`` (live slots) what the material
        says."""
        if settling:
            self.stiffen(settling, self._lengths(settling))

    def stiffen(self, slots: list[int], lengths: np.ndarray) -> None:
        """Give springs ``slots`` van Gelder's stiffness from the triangles they now border and
        their ``lengths`` [m] (k,), for the sheet's modulus (``membrane_modulus``: E t with
        material springs, 2 K / sqrt(3) with the paper's constant K, K itself on an equilateral
        pair); one of length 0 keeps its own."""
        model = self.model
        index = model.index
        areas, pairs = model.triangle_table.column("area"), model.spring_table.column("pairs")
        keep = np.asarray(lengths) > 0
        slots, lengths = [slot for slot, ok in zip(slots, keep) if ok], np.asarray(lengths)[keep]
        if slots:
            area_sums = [sum(areas[t] for t in index.triangles_with_edge(*(int(v) for v in pairs[slot])))
                         for slot in slots]
            modulus = membrane_modulus(model.material, model.stiffness_model)
            model.spring_table.set("stiffness", slots, van_gelder_stiffness(modulus, np.array(area_sums),
                                                                              lengths ** 2))

    def _lengths(self, slots: list[int]) -> np.ndarray:
        """The lengths [m] (k,) van Gelder's stiffness takes: the springs' rest lengths."""
        return self.model.spring_table.column("rest_length")[slots]


class ConstantSprings(MaterialPolicy):
    """The paper's constant K: new springs keep K; only springs named to settle are refreshed."""


class VanGelderSprings(MaterialPolicy):
    """Material springs: every changed spring gets van Gelder's stiffness."""

    def refresh(self, changed: Callable[[], list[int]], settling: list[int]) -> None:
        slots = sorted(set(changed()) | set(settling))
        if slots:
            self.stiffen(slots, self._lengths(slots))


class PrestressedSprings(MaterialPolicy):
    """A sheet under membrane tension: the stiffness rule of ``van_gelder`` (else constant K),
    measured in the rest shape, then rest lengths that carry the tension.

    Args:
        model: The tissue.
        van_gelder: Changed springs get van Gelder's stiffness (material springs); else only the
            springs named to settle do.
    """

    prestressed = True

    def __init__(self, model, van_gelder: bool):
        super().__init__(model)
        self.van_gelder = van_gelder

    def refresh(self, changed: Callable[[], list[int]], settling: list[int]) -> None:
        changed_slots = set(changed())
        stiffened = sorted((changed_slots if self.van_gelder else set()) | set(settling))
        if stiffened:
            self.stiffen(stiffened, self._lengths(stiffened))
        self.carry_tension(sorted(changed_slots | set(settling)))

    def _lengths(self, slots: list[int]) -> np.ndarray:
        """Lengths [m] (k,) of springs ``slots`` between their nodes' rest positions."""
        pairs = self.model.spring_table.column("pairs")[slots]
        points = self.model.points
        return np.linalg.norm(points[pairs[:, 1]] - points[pairs[:, 0]], axis=1)

    def carry_tension(self, slots: list[int]) -> None:
        """Rest lengths of the springs ``slots`` that carry the model's membrane tension in the
        rest shape, as ``apply_prestress`` gives the original springs
        (``warp_cut.sim.prestress.prestressed_rest_lengths``, from the nodes' rest positions and
        the triangles each spring borders now). So a new spring carries the tension its
        neighbours carry, and an edge a cut left on one triangle carries its side's share only
        (the traction across the cut is released). f / (k L) is kept within
        +-``MAX_PRESTRAIN``: a triangle nearly flat in the rest shape would otherwise give a
        rest length near 0, or a long one."""
        if not slots:
            return
        model = self.model
        index = model.index
        pairs = model.spring_table.column("pairs")[slots]
        triangles = sorted({t for i, j in pairs for t in index.triangles_with_edge(int(i), int(j))})
        corners = model.triangle_table.column("corners")[triangles].reshape(-1, 3)
        rest = prestressed_rest_lengths(model.points, corners, pairs, model.spring_table.column("stiffness")[slots],
                                        model.prestress_tension, max_ratio=MAX_PRESTRAIN)
        model.spring_table.set("rest_length", slots, rest)


def material_policy(model) -> MaterialPolicy:
    """The policy of ``model`` as it is now (its stiffness model and prestress)."""
    van_gelder = model.stiffness_model == "material"
    if model.prestress_tension:
        return PrestressedSprings(model, van_gelder)
    return VanGelderSprings(model) if van_gelder else ConstantSprings(model)
