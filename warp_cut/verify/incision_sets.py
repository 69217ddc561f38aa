"""Multi-stroke incisions: several strokes cut one after the other into the same skin.

Each builder draws its strokes (``warp_cut.sim.strokes.Stroke``, or ``LoweredStroke`` for a
tool lowered onto its start) on any Surface (``warp_cut.mesh.surfaces`` or
``warp_cut.verify.mesh_surface``), about a ``centre`` (2,) [m] in the parameter plane, turned
by ``heading`` [rad] (the direction of the first stroke, from +u):

* ``t_set`` - a straight stroke, then a second that starts inside the first wound (at its
  midpoint) and runs perpendicular away from it: a T.
* ``x_set`` - two strokes of equal length crossing at their midpoints at right angles.
* ``excision_set`` - an elliptical (fusiform) excision, ``length`` x ``width``: two circular
  arcs from the same end point, the upper one then the lower one, meeting again at the other
  end; together they enclose an island of skin that should come free.
* ``recut_set`` - the same straight line cut twice.
* ``tight_arc_set`` - one half-circle arc whose radius of curvature is about 5 mesh spacings.

Every set says how many separate wounds it should leave after each stroke (the strokes of
all of these join into one) and, for the excision, the island's outline in the parameter plane.
Lengths [m], angles [rad].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..sim.strokes import ParamPath, Stroke, arc, line
from .lowered_entry import lowered

__all__ = ["ToolSpec", "IncisionSet", "make_stroke", "t_set", "x_set", "excision_set", "recut_set",
           "tight_arc_set", "SET_BUILDERS", "build_set", "lens_arcs"]

ENTRIES = ("axis", "lowered")
"""How the tool enters: along its own axis (``Stroke``) or lowered along the normal (``LoweredStroke``)."""


@dataclass(frozen=True)
class ToolSpec:
    """The scalpel and how it is driven: radius, depth below the surface and tool length [m],
    tilt of its axis from the tangent plane [rad], speed [m/s], clearance from every node at
    the start and end poses [m], and the entry (``ENTRIES``)."""

    radius: float = 1e-3
    tilt: float = math.radians(60.0)
    speed: float = 0.02
    depth: float = 3e-3
    tool_length: float = 0.04
    margin: float = 3e-3
    entry: str = "axis"

    def __post_init__(self):
        if self.entry not in ENTRIES:
            raise InputError(f"tool entry must be one of {ENTRIES}, got {self.entry!r}")


@dataclass
class IncisionSet:
    """Strokes to cut in order and what they should leave.

    name: the builder ("t", "x", "excision", "recut", "tight_arc").
    strokes: Stroke (or LoweredStroke) objects, in cutting order.
    wounds: separate wounds expected after each stroke (len(strokes),).
    island_outline: (k, 2) [m] polygon in the parameter plane enclosing the skin the set should
        free, or None.
    about: one line saying what the set is.
    """

    name: str
    strokes: list
    wounds: list[int]
    island_outline: np.ndarray | None = None
    about: str = ""
    paths: list = field(default_factory=list)
    """The parameter paths (``ParamPath``) of the strokes."""

    @property
    def islands(self) -> int:
        """Islands of skin the set should free (0 or 1)."""
        return 0 if self.island_outline is None else 1


def _direction(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def make_stroke(surface, path: ParamPath, tool: ToolSpec):
    """The Stroke drawing ``path`` on ``surface`` with ``tool`` (lowered onto its start when
    ``tool.entry == "lowered"``)."""
    stroke = Stroke(surface, path, tilt=tool.tilt, radius=tool.radius, depth=tool.depth, speed=tool.speed,
                    tool_length=tool.tool_length, margin=tool.margin)
    return lowered(stroke, tool.margin) if tool.entry == "lowered" else stroke


def _centred_line(centre, heading: float, length: float) -> ParamPath:
    """A straight path of ``length`` [m] whose midpoint is ``centre`` (2,) [m]."""
    start = np.asarray(centre, np.float64) - 0.5 * length * _direction(heading)
    return line(start, heading, length)


def _finish(name, surface, paths, tool, wounds, about, outline=None) -> IncisionSet:
    return IncisionSet(name, [make_stroke(surface, p, tool) for p in paths], wounds, outline, about, paths)


def t_set(surface, tool: ToolSpec = ToolSpec(), centre=(0.0, 0.0), heading: float = 0.0,
          length: float = 0.02, stem: float = 0.012) -> IncisionSet:
    """A T: a ``length`` [m] stroke through ``centre``, then a ``stem`` [m] stroke from its
    midpoint, perpendicular to it (turned left)."""
    first = _centred_line(centre, heading, length)
    second = line(np.asarray(centre, np.float64), heading + math.pi / 2, stem)
    return _finish("t", surface, [first, second], tool, [1, 1],
                   f"{1e3 * length:.0f} mm line, then a {1e3 * stem:.0f} mm line from its midpoint, perpendicular")


def x_set(surface, tool: ToolSpec = ToolSpec(), centre=(0.0, 0.0), heading: float = 0.0,
          length: float = 0.02) -> IncisionSet:
    """An X: two ``length`` [m] strokes through ``centre`` at right angles."""
    paths = [_centred_line(centre, heading, length), _centred_line(centre, heading + math.pi / 2, length)]
    return _finish("x", surface, paths, tool, [1, 1], f"two {1e3 * length:.0f} mm lines crossing at their midpoints")


def lens_arcs(centre, heading: float, length: float, width: float) -> tuple[ParamPath, ParamPath]:
    """The two circular arcs of a lens ``length`` x ``width`` [m] about ``centre``, both from the
    end point behind ``centre`` (along -heading) to the one ahead: the arc on the left of the
    heading first. Each arc has radius R = (c^2 + s^2) / (2 s) (c = length / 2, s = width / 2)
    and leaves the end point at asin(c / R) from the heading."""
    if not (0 < width < length):
        raise InputError(f"a lens needs 0 < width < length, got {width} x {length} m")
    c, s = 0.5 * length, 0.5 * width
    radius = (c * c + s * s) / (2.0 * s)
    half = math.asin(c / radius)
    start = np.asarray(centre, np.float64) - c * _direction(heading)
    upper = arc(start, heading + half, 2.0 * half * radius, -radius)
    lower = arc(start, heading - half, 2.0 * half * radius, radius)
    return upper, lower


def excision_set(surface, tool: ToolSpec = ToolSpec(), centre=(0.0, 0.0), heading: float = 0.0,
                 length: float = 0.03, width: float = 0.01) -> IncisionSet:
    """An elliptical excision ``length`` x ``width`` [m] (``lens_arcs``): upper arc, then lower
    arc; the island between them should come free."""
    upper, lower = lens_arcs(centre, heading, length, width)
    outline = np.vstack([upper.uv, lower.uv[::-1][1:-1]])
    return _finish("excision", surface, [upper, lower], tool, [1, 1],
                   f"{1e3 * length:.0f} x {1e3 * width:.0f} mm elliptical excision: upper arc, then lower arc",
                   outline)


def recut_set(surface, tool: ToolSpec = ToolSpec(), centre=(0.0, 0.0), heading: float = 0.0,
              length: float = 0.02) -> IncisionSet:
    """The same ``length`` [m] line through ``centre`` cut twice."""
    path = _centred_line(centre, heading, length)
    return _finish("recut", surface, [path, path], tool, [1, 1], f"one {1e3 * length:.0f} mm line cut twice")


def tight_arc_set(surface, tool: ToolSpec = ToolSpec(), centre=(0.0, 0.0), heading: float = 0.0,
                  spacings: float = 5.0) -> IncisionSet:
    """A half circle of radius ``spacings`` x the mesh spacing [m], its bounding box centred
    on ``centre``: from behind the centre (along -heading), bulging to the left, to ahead of it."""
    radius = spacings * surface.spacing
    along, across = _direction(heading), _direction(heading + math.pi / 2)
    start = np.asarray(centre, np.float64) - radius * along - 0.5 * radius * across
    path = arc(start, heading + math.pi / 2, math.pi * radius, -radius)
    return _finish("tight_arc", surface, [path], tool, [1],
                   f"half circle of radius {1e3 * radius:.0f} mm ({spacings:g} spacings)")


SET_BUILDERS = {"t": t_set, "x": x_set, "excision": excision_set, "recut": recut_set, "tight_arc": tight_arc_set}
"""Set name -> builder (surface, tool, centre, heading, ...)."""


def build_set(name: str, surface, tool: ToolSpec = ToolSpec(), centre=(0.0, 0.0), heading: float = 0.0,
              **sizes) -> IncisionSet:
    """The incision set ``name`` (a key of ``SET_BUILDERS``) on ``surface``."""
    if name not in SET_BUILDERS:
        raise InputError(f"unknown incision set {name!r}; known: {sorted(SET_BUILDERS)}")
    return SET_BUILDERS[name](surface, tool, centre, heading, **sizes)
