"""Node and spring classes of the cut (paper Fig. 2-3), kept for export and tests."""

from __future__ import annotations

from enum import IntEnum

__all__ = ["NodeClass", "SpringClass", "NODE_CLASS_COLORS"]


class NodeClass(IntEnum):
    """Class of a node, stored per node as int8 in ``TissueModel.node_class``."""

    NORMAL = 0
    """Untouched tissue."""
    GREY = 1
    """Surviving node on the border of the grey incision-generation area (Stage 1)."""
    YELLOW = 2
    """Border node joined to an end point of the incision curve (Stage 3)."""
    BLUE = 3
    """Border node joined to an interior lip node (Stage 3)."""
    LIP = 4
    """New node sampled on a lip of the incision (Stage 3)."""


class SpringClass(IntEnum):
    """Class of a spring, stored per spring as int8 in ``TissueModel.spring_class``."""

    NORMAL = 0
    RED = 1
    """Joins a border node to its nearest lip node (Stage 3)."""
    GREEN = 2
    """Shorter diagonal splitting a quad of two blue nodes and their lip nodes (Stage 3)."""
    LIP = 3
    """Joins two neighbouring lip nodes along one lip."""


NODE_CLASS_COLORS = {
    NodeClass.NORMAL: (0.93, 0.76, 0.66),
    NodeClass.GREY: (0.55, 0.55, 0.55),
    NodeClass.YELLOW: (0.95, 0.85, 0.10),
    NodeClass.BLUE: (0.15, 0.35, 0.90),
    NodeClass.LIP: (0.80, 0.10, 0.10),
}
"""Display colour (linear RGB in [0, 1]) of each node class, for USD and plots."""
