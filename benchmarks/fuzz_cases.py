"""Cases of the cut fuzz: a random mesh, random strokes on it and random simulation settings,
all drawn from one integer seed (so any case can be replayed alone), and the named cases.

A case is a plain dict (JSON-able): ``surface`` (generator name and arguments), ``sim``
(integrator, cut interval [s], gravity and support on/off, residual-stress model) and
``strokes`` (path kind and parameters in the surface's parameter plane, tilt [deg], tool
radius, depth, length [m], speed [m/s]).
"""

from __future__ import annotations

import math

import numpy as np

from warp_cut import InputError, TissueModel
from warp_cut.mesh import surfaces
from warp_cut.sim import strokes as paths

KINDS = ("flat", "rotated", "delaunay", "dome", "cylinder", "saddle")
"""Mesh kinds of the fuzz: flat grid, turned flat grid, jittered Delaunay disk, dome, cylinder, saddle."""

INTEGRATORS = (("semi_implicit", 0.7), ("implicit_euler", 0.15), ("xpbd", 0.15))

RESIDUAL_STRESS = (("links", 0.6), ("prestress", 0.2), ("none", 0.2))
"""How the residual stress acts (``material.residual_stress_model``, or ``physics.residual_stress
= false``) and how often; prestress only on a flat mesh or a supported one (a curved sheet
under tension without support flattens or bulges until its springs balance the tension)."""

START_MARGIN = 3e-3
"""Clearance [m] of the tool from the undeformed mesh at its start and end poses (earlier cuts
and the tool's push lift nodes a little above the surface)."""

SETTLE_S = 0.5
"""Time [s] the skin settles with the tool gone after a case's last stroke before it is judged
again (``fuzz_cut.settled``)."""


def case_seed(base_seed: int, index: int) -> int:
    """The seed of case ``index`` of a run started with ``base_seed``."""
    return int(np.random.SeedSequence([base_seed, index]).generate_state(1)[0])


def _surface_spec(kind: str, rng, quick: bool) -> dict:
    """Generator name and keyword arguments of a random mesh of ``kind`` (lengths [m])."""
    h = float(rng.uniform(1.5e-3, 3e-3))
    big = 0.7 if quick else 1.0
    if kind in ("flat", "rotated"):
        angle = 0.0 if kind == "flat" else float(rng.uniform(0.05, np.pi / 3 - 0.05))
        return {"make": "flat_grid", "size": big * float(rng.uniform(0.035, 0.05)), "spacing": h, "angle": angle}
    if kind == "delaunay":
        return {"make": "jittered_delaunay", "radius": big * float(rng.uniform(0.018, 0.026)),
                "spacing": h, "jitter": float(rng.uniform(0.1, 0.3)), "seed": int(rng.integers(2**31))}
    if kind == "dome":
        rc = float(rng.uniform(0.03, 0.06))
        base = big * min(0.9 * rc, float(rng.uniform(0.02, 0.028)))
        return {"make": "dome", "radius_of_curvature": rc, "base_radius": base,
                "spacing": h, "jitter": float(rng.choice([0.0, 0.2])), "seed": int(rng.integers(2**31))}
    if kind == "cylinder":
        radius = float(rng.uniform(0.012, 0.04))
        full = radius < 0.017 and rng.uniform() < 0.5
        arc = 2 * np.pi if full else min(float(rng.uniform(2.0, 4.2)), big * 0.09 / radius)
        return {"make": "cylinder", "radius": radius, "length": big * float(rng.uniform(0.04, 0.055)),
                "arc_angle": arc, "spacing": h, "jitter": float(rng.choice([0.0, 0.4])),
                "seed": int(rng.integers(2**31))}
    size = big * float(rng.uniform(0.035, 0.05))
    return {"make": "saddle", "size": size, "curvature": float(rng.choice([-1, 1]) * rng.uniform(10.0, 40.0)),
            "spacing": h, "jitter": float(rng.choice([0.0, 0.4])), "seed": int(rng.integers(2**31))}


def build_surface(spec: dict):
    """The Surface of a ``surface`` spec (``make`` names the generator, or "patch" for
    ``TissueModel.from_patch``'s flat patch)."""
    args = {k: v for k, v in spec.items() if k != "make"}
    if spec["make"] == "patch":
        model = TissueModel.from_patch(tuple(args["size"]), args["spacing"])
        return surfaces.on_plane(model.points, model.triangles, args["spacing"])
    return getattr(surfaces, spec["make"])(**args)


def build_path(surface, s: dict) -> paths.ParamPath:
    """The parameter path of a stroke spec."""
    start, heading = s["start"], s["heading"]
    if s["path"] == "line":
        return paths.line(start, heading, s["length"])
    if s["path"] == "arc":
        return paths.arc(start, heading, s["length"], s["turn_radius"])
    return paths.zigzag(start, heading, s["length"], s["amplitude"], s["wavelength"])


def build_stroke(surface, s: dict) -> paths.Stroke:
    """The Stroke of a stroke spec (tilt in degrees)."""
    return paths.Stroke(surface, build_path(surface, s), tilt=math.radians(s["tilt_deg"]),
                        radius=s["radius"], depth=s["depth"], speed=s["speed"],
                        tool_length=s["tool_length"], margin=START_MARGIN)


def _tool(rng, h: float, quick: bool) -> dict:
    kind = str(rng.choice(["line", "arc", "zigzag"], p=[0.5, 0.25, 0.25]))
    spec = {"path": kind, "length": float(rng.uniform(0.008, 0.015) if quick else rng.uniform(0.01, 0.03)),
            "tilt_deg": float(rng.uniform(30.0, 75.0)), "radius": float(rng.uniform(0.2, 2.0) * h),
            "depth": float(rng.uniform(0.001, 0.004)), "speed": float(rng.uniform(0.005, 0.04)),
            "tool_length": float(rng.uniform(0.03, 0.05))}
    if kind == "arc":
        spec["turn_radius"] = float(rng.choice([-1, 1]) * rng.uniform(0.008, 0.03))
    elif kind == "zigzag":
        spec["amplitude"] = float(rng.uniform(1.0, 3.0) * h)
        spec["wavelength"] = float(rng.uniform(6.0, 12.0) * h)
    return spec


def _start(surface, rng, spec: dict, earlier: list) -> None:
    """Start point and heading: random for the first stroke; later ones cross an earlier path
    at 30-90 deg near its middle."""
    if not earlier:
        uv = surface.uv
        spec["start"] = [float(v) for v in uv[rng.integers(len(uv))]]
        spec["heading"] = float(rng.uniform(0, 2 * np.pi))
        return
    other = earlier[rng.integers(len(earlier))]
    k = int(rng.uniform(0.25, 0.75) * (len(other.uv) - 1))
    d = other.uv[min(k + 1, len(other.uv) - 1)] - other.uv[max(k - 1, 0)]
    heading = math.atan2(d[1], d[0]) + float(rng.choice([-1, 1]) * rng.uniform(np.pi / 6, np.pi / 2))
    spec["heading"] = heading
    back = 0.5 * spec["length"] * np.array([math.cos(heading), math.sin(heading)])
    spec["start"] = [float(v) for v in other.uv[k] - back]


def _plan_strokes(surface, rng, count: int, quick: bool) -> list[dict]:
    """Up to ``count`` stroke specs whose paths keep r + 3 spacings from the mesh border."""
    h, specs, planned = surface.spacing, [], []
    for _ in range(count):
        for _attempt in range(60):
            spec = _tool(rng, h, quick)
            _start(surface, rng, spec, planned)
            try:
                path = build_path(surface, spec)
                if surface.depth(path.uv).min() < spec["radius"] + 3 * h:
                    continue
                build_stroke(surface, spec)
            except InputError:
                continue
            specs.append(spec)
            planned.append(path)
            break
    return specs


def make_case(seed: int, *, kind: str | None = None, quick: bool = False) -> dict:
    """The random case of ``seed`` (``kind`` forces the mesh kind; the draws stay the same)."""
    rng = np.random.default_rng(seed)
    drawn = str(rng.choice(KINDS))
    kind = kind or drawn
    surface_spec = _surface_spec(kind, rng, quick)
    names, weights = zip(*INTEGRATORS)
    sim = {"integrator": str(rng.choice(names, p=weights)),
           "interval": 0.0 if rng.uniform() < 0.2 else float(rng.uniform(0.0, 1.0 / 30.0)),
           "gravity": bool(rng.uniform() < 0.8)}
    # Under gravity the skin lies on its support (physics.foundation, as in the body): an
    # unsupported sheet sags about 1 cm, and strokes planned on the undeformed surface after
    # the first would pass above it.
    sim["foundation"] = sim["gravity"]
    sim["residual"] = _residual_stress(seed, kind, sim["foundation"])
    count = 2 if quick else int(rng.integers(2, 5))
    surface = build_surface(surface_spec)
    return {"seed": int(seed), "kind": kind, "quick": quick, "surface": surface_spec, "sim": sim,
            "strokes": _plan_strokes(surface, rng, count, quick)}


def _residual_stress(seed: int, kind: str, supported: bool) -> str:
    """The residual-stress model of case ``seed`` (``RESIDUAL_STRESS``), from a stream of its own
    so that the draws of cases made before it existed stay the same."""
    names, weights = zip(*RESIDUAL_STRESS)
    drawn = str(np.random.default_rng([seed, 1]).choice(names, p=weights))
    if drawn == "prestress" and not (supported or kind in ("flat", "rotated", "delaunay")):
        return "links"
    return drawn


def _line(start, heading_deg, length, *, tilt, radius, depth, speed, tool_length=0.04) -> dict:
    return {"path": "line", "start": list(start), "heading": math.radians(heading_deg), "length": length,
            "tilt_deg": tilt, "radius": radius, "depth": depth, "speed": speed, "tool_length": tool_length}


SEMI = {"integrator": "semi_implicit", "interval": 1.0 / 60.0, "gravity": True}

NAMED = {
    "a_cylinder_around": {
        "about": "around a cylinder of radius 3 cm (150 deg of arc), tool at 60 deg following the "
                 "surface, 47 mm stroke across the crest",
        "surface": {"make": "cylinder", "radius": 0.03, "length": 0.06, "arc_angle": math.radians(150),
                    "spacing": 0.002},
        "sim": SEMI,
        "strokes": [_line([0.0, -0.0235], 90.0, 0.047, tilt=60.0, radius=0.001, depth=0.003, speed=0.02)]},
    "b_dome_across": {
        "about": "across a dome of radius of curvature 4 cm (rim radius 3 cm) through its apex, 40 mm",
        "surface": {"make": "dome", "radius_of_curvature": 0.04, "base_radius": 0.03, "spacing": 0.002},
        "sim": SEMI,
        "strokes": [_line([-0.02, 0.0], 0.0, 0.04, tilt=60.0, radius=0.001, depth=0.003, speed=0.02)]},
    "c_cylinder_slope": {
        "about": "along the slope of the cylinder: parallel to its axis, 40 deg off the crest, 40 mm",
        "surface": {"make": "cylinder", "radius": 0.03, "length": 0.06, "arc_angle": math.radians(150),
                    "spacing": 0.002},
        "sim": SEMI,
        "strokes": [_line([-0.02, 0.03 * math.radians(40.0)], 0.0, 0.04, tilt=60.0, radius=0.001,
                          depth=0.003, speed=0.02)]},
    "d_vertical_thin_delaunay": {
        "about": "a vertical 0.5 mm-radius tool entering a jittered Delaunay 2 mm mesh, 20 mm stroke",
        "surface": {"make": "jittered_delaunay", "radius": 0.025, "spacing": 0.002, "jitter": 0.25, "seed": 7},
        "sim": SEMI,
        "strokes": [_line([-0.01, 0.0013], 0.0, 0.02, tilt=90.0, radius=0.0005, depth=0.003, speed=0.01)]},
    "e_flat_patch_16mm": {
        "about": "a straight 16 mm stroke on the flat 2 mm patch (tilt 41 deg, r 1.3 mm, 8 mm/s)",
        "surface": {"make": "patch", "size": [0.06, 0.04], "spacing": 0.002},
        "sim": SEMI,
        "strokes": [_line([-0.008, 0.0], 0.0, 0.016, tilt=41.0, radius=0.0013, depth=0.003, speed=0.008)]},
}
"""Named cases (a)-(e); (f), the bundled scene, is run by the driver through the scene loader."""
