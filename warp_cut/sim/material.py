"""Tissue material constants, SI units. Defaults are the paper's Table 1 for skin."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..errors import InputError

__all__ = ["Material", "RESIDUAL_STRESS_MODELS"]

RESIDUAL_STRESS_MODELS = ("links", "prestress")
"""How the residual stress sigma_r = E eps_r acts: the paper's links across the cut (Eq. 4), or
an in-plane membrane tension the sheet carries from the start (``warp_cut.sim.prestress``)."""

_POSITIVE = ("thickness", "density")
"""Numeric fields that must be > 0 (the others >= 0)."""


@dataclass(frozen=True)
class Material:
    """Material of a tissue sheet.

    stiffness: spring constant K [N/m] (Table 1: 0.16 N/mm = 160 N/m).
    damping: per-node damping D [N s/m] (Table 1: 3).
    youngs_modulus: E [Pa] (Table 1: 20 kPa), used for the residual stress sigma_r = E eps_r.
    residual_strain: eps_r [-] (Table 1: 0.1).
    thickness: sheet thickness [m] (2 mm, typical skin), used for masses and link areas.
    density: [kg/m^3] (1100, typical soft tissue), used for lumped masses.
    residual_stress_model: one of ``RESIDUAL_STRESS_MODELS``: ``"links"`` (default, the paper's
        Eq. 4: a spring the cut deletes leaves a link pulling its two nodes together) or
        ``"prestress"`` (the sheet carries the membrane tension T = sigma_r t from the start and
        a cut releases it; the cut makes no links).
    foundation_stiffness: k_f [N/m^3] of the support under the sheet (subcutaneous tissue):
        each node is held to its rest position with stiffness k_f x its lumped area;
        0 (default) = no support.
    bending_rigidity: D [N m] of the sheet's bending (``warp_cut.sim.bending``: a hinge on every
        interior edge); 0 (default) = a membrane without bending stiffness.
    """

    stiffness: float = 160.0
    damping: float = 3.0
    youngs_modulus: float = 20.0e3
    residual_strain: float = 0.1
    thickness: float = 2.0e-3
    density: float = 1100.0
    residual_stress_model: str = "links"
    foundation_stiffness: float = 0.0
    bending_rigidity: float = 0.0

    def __post_init__(self):
        if self.residual_stress_model not in RESIDUAL_STRESS_MODELS:
            raise InputError(f"material.residual_stress_model must be one of "
                             f"{list(RESIDUAL_STRESS_MODELS)}, got {self.residual_stress_model!r}")
        for f in fields(self):
            if f.name == "residual_stress_model":
                continue
            value = getattr(self, f.name)
            if not np.isfinite(value):
                raise InputError(f"material.{f.name} must be finite, got {value}")
            low_ok = value > 0 if f.name in _POSITIVE else value >= 0
            if not low_ok:
                bound = "> 0" if f.name in _POSITIVE else ">= 0"
                raise InputError(f"material.{f.name} must be {bound}, got {value}")

    @property
    def residual_stress(self) -> float:
        """sigma_r = E eps_r [Pa] (paper Eq. 3)."""
        return self.youngs_modulus * self.residual_strain

    @property
    def membrane_tension(self) -> float:
        """T = sigma_r x thickness [N/m]: the in-plane tension of the prestressed sheet."""
        return self.residual_stress * self.thickness

    @property
    def areal_density(self) -> float:
        """density x thickness [kg/m^2]: lumped mass per unit area."""
        return self.density * self.thickness
