"""The cut on random curved and irregular skin: a short property-based version of
benchmarks/fuzz_cut.py (``make fuzz`` runs the long one).

Each example draws a small mesh (flat, turned grid, jittered Delaunay, dome, cylinder, saddle),
one stroke (line, arc or zigzag; tilt, tool radius, depth, speed) and the simulation settings,
and cuts the stroke with ``sim.step(tool=pose)`` every 1 ms, as a user does
(``warp_cut.verify.stroke_check.run_stroke``). The mesh invariants after every cut event
(``warp_cut.verify.validity.cut_problems``: indices, duplicates, degenerate triangles, winding,
manifold edges, springs = edges, masses and their balance, links between live nodes, the device
mirror, finite state) are hard assertions, and so are the cut's own properties: no exception,
one incision per stroke, no hole (border loops beyond one per incision, counted on the mesh)
once the tool has left, no triangle wound against the surface in the rest shape, every triangle
the stroke made at least 20 deg in the rest shape. One is an
expected failure (``xfail``, naming the cases that
fail): coverage >= 0.95. (``make fuzz`` runs thousands of events, several strokes per mesh, crossing earlier cuts;
its report says where the cut still falls short.)
"""

import math

import numpy as np
import pytest
from conftest import DEVICE
from hypothesis import HealthCheck, Phase, given, seed, settings
from hypothesis import strategies as st

import warp_cut as wc
from warp_cut.mesh import surfaces as S
from warp_cut.sim import strokes as K
from warp_cut.verify.stroke_check import run_stroke
from warp_cut.verify.validity import FOLD_CHECKS

KINDS = ("flat", "rotated", "delaunay", "dome", "cylinder", "saddle")
EXAMPLES = 10
FLIPS = FOLD_CHECKS


@st.composite
def cut_cases(draw):
    """A mesh about 26 mm across, one 6-10 mm stroke through its middle, the settings."""
    kind = draw(st.sampled_from(KINDS))
    h = draw(st.floats(1.8e-3, 3e-3))
    mesh = {"kind": kind, "spacing": h, "angle": draw(st.floats(0.05, 1.0)),
            "curvature": draw(st.floats(20.0, 40.0)) * draw(st.sampled_from([-1, 1])),
            "radius": draw(st.floats(0.015, 0.03)), "seed": draw(st.integers(0, 2**16))}
    stroke = {"path": draw(st.sampled_from(["line", "line", "arc", "zigzag"])),
              "heading": draw(st.floats(0.0, 2 * math.pi)), "length": draw(st.floats(0.006, 0.01)),
              "offset": draw(st.tuples(st.floats(-0.002, 0.002), st.floats(-0.002, 0.002))),
              "tilt": math.radians(draw(st.floats(30.0, 75.0))), "radius": h * draw(st.floats(0.3, 2.0)),
              "depth": draw(st.floats(0.001, 0.003)), "speed": draw(st.floats(0.02, 0.04))}
    sim = {"integrator": draw(st.sampled_from(["semi_implicit"] * 4 + ["implicit_euler", "xpbd"])),
           "interval": draw(st.sampled_from([0.0, 1.0 / 120, 1.0 / 60, 1.0 / 30])),
           "gravity": draw(st.booleans()),
           "residual": draw(st.sampled_from(["links"] * 3 + ["prestress", "none"]))}
    if sim["residual"] == "prestress" and kind not in ("flat", "rotated", "delaunay"):
        sim["residual"] = "links"  # unsupported, a curved sheet under tension changes its shape
    return {"mesh": mesh, "stroke": stroke, "sim": sim}


def make_surface(m):
    h = m["spacing"]
    if m["kind"] in ("flat", "rotated"):
        return S.flat_grid(0.026, h, angle=m["angle"] if m["kind"] == "rotated" else 0.0)
    if m["kind"] == "delaunay":
        return S.jittered_delaunay(0.013, h, 0.25, seed=m["seed"])
    if m["kind"] == "dome":
        return S.dome(m["radius"], 0.013, h)
    if m["kind"] == "cylinder":
        return S.cylinder(m["radius"], 0.026, 0.026 / m["radius"], h)
    return S.saddle(0.026, m["curvature"], h)


def make_stroke(surf, s):
    d = np.array([math.cos(s["heading"]), math.sin(s["heading"])])
    start = np.array(s["offset"]) - 0.5 * s["length"] * d
    if s["path"] == "line":
        path = K.line(start, s["heading"], s["length"])
    elif s["path"] == "arc":
        path = K.arc(start, s["heading"], s["length"], 0.015)
    else:
        path = K.zigzag(start, s["heading"], s["length"], 1.5 * surf.spacing, 6 * surf.spacing)
    return K.Stroke(surf, path, tilt=s["tilt"], radius=s["radius"], depth=s["depth"],
                    speed=s["speed"], margin=2e-3)


_RUNS = {}


def cut(case):
    """(surface, stroke result) of a case, run once per test session."""
    key = repr(case)
    if key not in _RUNS:
        surf = make_surface(case["mesh"])
        stroke = make_stroke(surf, case["stroke"])
        s = case["sim"]
        material = wc.Material(residual_stress_model="prestress" if s["residual"] == "prestress" else "links")
        sim = wc.Simulator(wc.TissueModel.from_surface(surf, material=material), dt=1e-3, device=DEVICE,
                           integrator=s["integrator"], cutting=wc.CutSettings(interval=s["interval"]),
                           residual_stress=s["residual"] != "none",
                           **({} if s["gravity"] and s["integrator"] != "xpbd" else {"gravity": None}))
        _RUNS[key] = (surf, run_stroke(sim, stroke, surf))
    return _RUNS[key]


def fuzz(test):
    """Same examples for every property (one seed, no shrinking: each example is a simulation)."""
    return seed(20240607)(settings(max_examples=EXAMPLES, deadline=None, database=None,
                                   phases=[Phase.generate],
                                   suppress_health_check=list(HealthCheck))(given(cut_cases())(test)))


@fuzz
def test_mesh_invariants_hold_after_every_cut_event(case):
    _, result = cut(case)
    broken = {name: v["first"] for name, v in result.violations.items() if name not in FLIPS}
    assert not broken, broken
    assert result.edits >= result.events


@fuzz
def test_no_exception(case):
    _, result = cut(case)
    assert result.exception is None, result.traceback


@fuzz
def test_one_incision_per_stroke(case):
    _, result = cut(case)
    assert result.incisions == 1


@fuzz
def test_no_hole_open_after_the_stroke(case):
    _, result = cut(case)
    assert result.unfilled_holes == 0


@pytest.mark.xfail(strict=False, reason="a 6 mm line of a 0.54 mm tool on a 1.8 mm dome mesh (lip offset "
                                        "0.14 mm) opens 0.81 of its path (0.63 before the material-space cut's "
                                        "rules for slit ends): its incision ends 0.6 mm short of the trace's "
                                        "end, its last lip pair 2.5 mm before that (the tip's wedge), much of "
                                        "so short a stroke; a zigzag on a cylinder opens 0.90")
@fuzz
def test_the_cut_opens_the_whole_stroke(case):
    _, result = cut(case)
    assert result.coverage >= 0.95


@fuzz
def test_no_triangle_is_wound_against_the_surface_in_the_rest_shape(case):
    """The cut is decided in the rest shape: no edit leaves a triangle wound against the
    analytic normal there, whatever the tool did to the current positions."""
    _, result = cut(case)
    assert "tri_against_rest" not in result.violations


@fuzz
def test_every_triangle_the_stroke_made_keeps_the_smallest_angle_at_rest(case):
    """The cut promises every triangle it makes at least ``MIN_ANGLE_DEG`` (20 deg) in the rest
    shape (``stroke_quality.new_rest_slivers``); as the skin lies, the motion may crush them."""
    _, result = cut(case)
    assert result.rest_slivers == 0, f"smallest rest angle {result.min_new_rest_angle_deg:.2f} deg"


def test_the_checks_catch_a_broken_tissue():
    """Negative control: the invariants the fuzz asserts do fail on a broken tissue."""
    from warp_cut.verify.validity import cut_problems

    surf = S.flat_grid(0.012, 0.002)
    sim = wc.Simulator(wc.TissueModel.from_surface(surf), dt=1e-3, gravity=None, device=DEVICE,
                       cutting=wc.CutSettings())
    model = sim.model
    assert cut_problems(sim, surf) == []

    def names():
        return {p.split(":")[0] for p in cut_problems(sim, surf)}

    corners = model.triangle_table.column("corners")
    original = corners[3].copy()
    corners[3] = original[[0, 2, 1]]  # wound the other way
    assert {"winding_inconsistent", "tri_flipped_tissue"} <= names()
    corners[3] = original
    mass = model.masses[5]
    model.node_table.set("masses", [5], 2.0 * mass)
    assert "mass_total" in names()
    model.node_table.set("masses", [5], mass)
    mirror = sim.device_model.spring_indices.numpy()  # a view of the CPU array
    mirror[0], keep = mirror[0] + 1, mirror[0]
    assert "device_springs" in names()
    mirror[0] = keep
    assert cut_problems(sim, surf) == []
