"""Tissue material constants, SI units. Defaults are the paper's Table 1 for skin."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..errors import InputError

__all__ = ["Material"]


@dataclass(frozen=True)
class Material:
    """Material of a tissue sheet.

    stiffness: spring constant K [N/m] (Table 1: 0.16 N/mm = 160 N/m).
    damping: per-node damping D [N s/m] (Table 1: 3).
    youngs_modulus: E [Pa] (Table 1: 20 kPa), used for the residual stress sigma_r = E eps_r.
    residual_strain: eps_r [-] (Table 1: 0.1).
    thickness: sheet thickness [m] (2 mm, typical skin), used for masses and link areas.
    density: [kg/m^3] (1100, typical soft tissue), used for lumped masses.
    """

    stiffness: float = 160.0
    damping: float = 3.0
    youngs_modulus: float = 20.0e3
    residual_strain: float = 0.1
    thickness: float = 2.0e-3
    density: float = 1100.0

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if not np.isfinite(value):
                raise InputError(f"material.{f.name} must be finite, got {value}")
            low_ok = value > 0 if f.name in ("thickness", "density") else value >= 0
            if not low_ok:
                bound = "> 0" if f.name in ("thickness", "density") else ">= 0"
                raise InputError(f"material.{f.name} must be {bound}, got {value}")

    @property
    def residual_stress(self) -> float:
        """sigma_r = E eps_r [Pa] (paper Eq. 3)."""
        return self.youngs_modulus * self.residual_strain
