"""Cut fuzz: random meshes, random strokes, every invariant checked after every cut event.

Each case (``fuzz_cases.make_case``) builds a random skin mesh (flat grid, turned grid,
jittered Delaunay disk, dome, cylinder, saddle; spacing 1.5-3 mm), a Simulator as a user does
(``wc.Simulator(model, dt=1e-3, cutting=wc.CutSettings(interval=...), integrator=...,
gravity=...)``) and draws 2-4 strokes (lines, arcs, zigzags; tilt 30-75 deg, tool radius
0.2-2 spacings, 0.5-4 cm/s, 1-4 mm deep; later strokes cross earlier cuts), run one 1 ms
``sim.step(tool=pose)`` at a time (``warp_cut.verify.stroke_check.run_stroke``). After every
topology edit all invariants are checked (``warp_cut.verify.validity.cut_problems``); after each
stroke the cut is measured (``warp_cut.verify.stroke_quality``: coverage, split incisions, holes,
lip deviation, slivers as the skin lies and in the rest shape, latency); after a case's last
stroke the skin settles for ``SETTLE_S`` with the tool gone and is judged again (folded
triangles, the cut's smallest angle as it then lies). An exception ends its case (recorded
with a reproducer) and the run goes on with the next case.

    python benchmarks/fuzz_cut.py [--events 2500] [--seed 1] [--cases N] [--kind dome] [--quick]
                                  [--out benchmarks/results/fuzz.md]
    python benchmarks/fuzz_cut.py --case SEED [--strokes K]    # replay one case (its first K strokes)
    python benchmarks/fuzz_cut.py --named                      # the named cases (a)-(f)
    python benchmarks/fuzz_cut.py --bending --out /tmp/fuzz_bending.md   # the skin resists bending
    python benchmarks/fuzz_cut.py --no-strips --out /tmp/fuzz_no_strips.md  # no strip cut beside an opening

``--bending`` gives every case's material Table 1's bending rigidity (``physics.bending``,
``warp_cut.sim.bending``): the hinges are remade by every edit and checked with the rest.

Writes the markdown report at ``--out`` and ``<out>.csv`` with one row per stroke.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
from pathlib import Path

import numpy as np
import warp as wp

import warp_cut as wc
import warp_cut.cut.sweep.beside as beside
from warp_cut.mesh.geometry import triangle_min_angles
from warp_cut.scene import DEFAULT_FOUNDATION_STIFFNESS
from warp_cut.sim.bending import flexural_rigidity
from warp_cut.verify.cut_judge import against, surface_normal_at
from warp_cut.verify.stroke_check import run_stroke
from warp_cut.verify.stroke_quality import original_border

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fuzz_cases import KINDS, NAMED, SETTLE_S, build_stroke, build_surface, case_seed, make_case  # noqa: E402
from fuzz_report import write_report  # noqa: E402
from fuzz_scene import run_scene_case  # noqa: E402

HERE = Path(__file__).resolve().parent
DEFAULT_OUT = HERE / "results" / "fuzz.md"


def reproducer(case: dict, strokes: int) -> str:
    """The command that replays ``case`` up to (and including) stroke ``strokes`` - 1."""
    if case.get("named"):
        return f"python benchmarks/fuzz_cut.py --named {case['named']}"
    quick = " --quick" if case.get("quick") else ""
    bending = " --bending" if BENDING_RIGIDITY > 0 else ""
    return (f"python benchmarks/fuzz_cut.py --case {case['seed']} --kind {case['kind']}{quick} --strokes {strokes}"
            f"{bending}")


BENDING_RIGIDITY = 0.0
"""D [N m] every case's sheet gets (``--bending``: Table 1's skin, ``flexural_rigidity``)."""


def make_simulator(case: dict, surface):
    s = case["sim"]
    residual = s.get("residual", "links")
    material = wc.Material(foundation_stiffness=DEFAULT_FOUNDATION_STIFFNESS if s.get("foundation") else 0.0,
                           bending_rigidity=BENDING_RIGIDITY,
                           residual_stress_model="prestress" if residual == "prestress" else "links")
    model = wc.TissueModel.from_surface(surface, material=material)
    gravity = {} if s["gravity"] else {"gravity": None}  # the Simulator's default: standard gravity
    sim = wc.Simulator(model, dt=1e-3, cutting=wc.CutSettings(interval=s["interval"]),
                       integrator=s["integrator"], residual_stress=residual != "none", **gravity)
    return model, sim


def _stroke_row(case, index, spec, stroke, result, sim, surface, wall) -> dict:
    metrics = sim.cutter.metrics(sim.positions)
    lat = np.asarray(result.latency_ms)
    return {
        "case": case.get("named") or case["seed"], "stroke": index, "kind": case["kind"],
        "spacing_mm": 1e3 * surface.spacing, "nodes": len(surface.points),
        "integrator": case["sim"]["integrator"], "interval_ms": 1e3 * case["sim"]["interval"],
        "gravity": case["sim"]["gravity"], "foundation": case["sim"].get("foundation", False),
        "residual": case["sim"].get("residual", "links"),
        "path": spec["path"], "length_mm": 1e3 * stroke.length,
        "tilt_deg": spec["tilt_deg"], "radius_mm": 1e3 * spec["radius"], "depth_mm": 1e3 * spec["depth"],
        "speed_mm_s": 1e3 * spec["speed"], "events": result.events, "edits": result.edits,
        "incisions": result.incisions, "unfilled_holes": result.unfilled_holes,
        "coverage": result.coverage, "curve_coverage": result.curve_coverage,
        "lip_dev_max_mm": 1e3 * result.lip_deviation_max, "lip_dev_median_mm": 1e3 * result.lip_deviation_median,
        "lip_nodes": result.lip_nodes, "slivers": result.slivers, "min_new_angle_deg": result.min_new_angle_deg,
        "rest_slivers": result.rest_slivers, "min_new_rest_angle_deg": result.min_new_rest_angle_deg,
        "small_rest_triangles": result.small_rest_triangles, "min_new_rest_edge": result.min_new_rest_edge,
        "border_loops_added": result.border_loops_added,
        "latency_p50_ms": float(np.median(lat)) if len(lat) else float("nan"),
        "latency_max_ms": float(lat.max()) if len(lat) else float("nan"),
        "violations": ";".join(f"{k}x{v['events']}" for k, v in result.violations.items()),
        "first_violation": next(iter(result.violations.values()))["first"] if result.violations else "",
        "exception": result.exception or "", "traceback": result.traceback,
        "skipped": result.skipped, "total_incisions": metrics["cut"]["incisions"],
        "removed_fragments": metrics["cut"]["removed_fragments"], "cut_lip_nodes": metrics["cut"]["lip_nodes"],
        "incision_length_mm": 1e3 * metrics["incision"]["length_m"], "wall_s": wall,
        "reproducer": reproducer(case, index + 1), "_latency": result.latency_ms,
        "_violations": {k: v["first"] for k, v in result.violations.items()},
    }


def _refused(before: dict, after: dict) -> dict:
    """The stroke's refused cut events (``cutter.skipped`` counted before and after it): how
    many, and the commonest reason."""
    counts = {why: n - before.get(why, 0) for why, n in after.items() if n > before.get(why, 0)}
    return {"refused_events": sum(counts.values()),
            "refused_reason": max(counts, key=counts.get) if counts else ""}


def _case_failure(case, message, tb) -> dict:
    return {"case": case.get("named") or case["seed"], "stroke": -1, "kind": case["kind"],
            "exception": message, "traceback": tb, "reproducer": reproducer(case, 0), "events": 0,
            "skipped": "case set-up failed", "_latency": []}


def run_case(case: dict, *, strokes: int | None = None, log=print) -> list[dict]:
    """Run a case's strokes (the first ``strokes`` of them); one row per stroke."""
    try:
        surface = build_surface(case["surface"])
        model, sim = make_simulator(case, surface)
    except Exception as exc:  # recorded: a generator or set-up failure is a finding too
        row = _case_failure(case, f"{type(exc).__name__}: {exc}", traceback.format_exc(limit=-5))
        log(_progress(row))
        return [row]
    border = original_border(model)
    original_slots = model.triangle_table.count
    substeps_start = sim.substeps
    rows = []
    for index, spec in enumerate(case["strokes"][:strokes]):
        stroke = build_stroke(surface, spec)
        start = time.perf_counter()
        refused_before = dict(sim.cutter.skipped)
        result = run_stroke(sim, stroke, surface, border_keys=border)
        rows.append(_stroke_row(case, index, spec, stroke, result, sim, surface, time.perf_counter() - start))
        rows[-1].update(_refused(refused_before, sim.cutter.skipped))
        rows[-1].update({"substeps_start": substeps_start, "substeps": sim.substeps})
        log(_progress(rows[-1]))
        if result.exception:
            break  # the tissue is in an unknown state after an exception
    if rows and not rows[-1]["exception"]:
        rows[-1].update(settled(sim, surface, original_slots))
    return rows


def settled(sim, surface, original_slots: int) -> dict:
    """After the case's last stroke, the skin left to settle ``SETTLE_S`` with the tool gone:
    triangles folded over (the current normal against the surface's, ``cut_judge.against``)
    among all and among those the cut made, and the smallest angle of the cut's triangles as
    the skin then lies."""
    try:
        sim.step(int(np.ceil(SETTLE_S / sim.dt)), tool=None)
    except Exception as exc:  # an unstable settle is a finding too
        return {"settle_exception": f"{type(exc).__name__}: {exc}"}
    model = sim.model
    triangles = model.triangles
    made = model.triangle_table.live_slots() >= original_slots
    folded = against(sim.positions, triangles, lambda c: surface_normal_at(surface, c))
    angles = triangle_min_angles(sim.positions, triangles[made]) if made.any() else np.array([180.0])
    return {"settled_folded": int(folded.sum()), "settled_folded_cut": int((folded & made).sum()),
            "settled_min_cut_angle_deg": float(angles.min())}


def _progress(row: dict) -> str:
    flags = " ".join(f for f in (row["exception"][:70], row.get("violations", "")[:60], row["skipped"]) if f)
    if row["stroke"] < 0:
        return f"case {row['case']} {row['kind']}: {flags}"
    return (f"case {row['case']} stroke {row['stroke']} {row['kind']:9s} {row['path']:6s} "
            f"events {row['events']:4d} incisions {row['incisions']} holes {row['unfilled_holes']} "
            f"coverage {row['coverage']:.2f} {row['wall_s']:.1f}s {flags}")


def run_fuzz(args) -> list[dict]:
    rows, events, start = [], 0, time.perf_counter()
    index = 0
    while True:
        if args.cases is not None and index >= args.cases:
            break
        if events >= args.events or time.perf_counter() - start > 60 * args.max_minutes:
            break
        seed = case_seed(args.seed, index)
        case = make_case(seed, kind=args.kind, quick=args.quick)
        new = run_case(case)
        events += sum(r["events"] for r in new)
        rows += new
        index += 1
    return rows


def run_named(names) -> list[dict]:
    """The named cases (a)-(e) from ``fuzz_cases.NAMED`` and (f), the bundled scene."""
    rows = []
    for name in names:
        if name == "f_scene_no_damping":
            rows += run_scene_case(name, ["material.damping=0.0"], reproducer(
                {"named": name}, 1))
            continue
        spec = dict(NAMED[name], named=name, kind=NAMED[name]["surface"]["make"])
        rows += [dict(row, about=spec["about"]) for row in run_case(spec)]
    return rows


NAMED_ALL = list(NAMED) + ["f_scene_no_damping"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--events", type=int, default=2500, help="stop after this many cut events in total")
    ap.add_argument("--seed", type=int, default=1, help="base seed of the run")
    ap.add_argument("--cases", type=int, default=None, help="at most this many cases")
    ap.add_argument("--case", type=int, default=None, help="replay the case with this seed")
    ap.add_argument("--strokes", type=int, default=None, help="with --case: run only its first K strokes")
    ap.add_argument("--kind", choices=KINDS, default=None, help="only this mesh kind")
    ap.add_argument("--quick", action="store_true", help="smaller meshes, two short strokes per case")
    ap.add_argument("--max-minutes", type=float, default=30.0, help="stop starting new cases after this")
    ap.add_argument("--named", nargs="*", choices=NAMED_ALL, default=None,
                    help="run the named cases (all if none given)")
    ap.add_argument("--out", type=Path, default=None, help="markdown report (CSV beside it)")
    ap.add_argument("--bending", action="store_true", help="the skin resists bending (physics.bending)")
    ap.add_argument("--no-strips", action="store_true",
                    help="cut no strip of tissue beside an opening (cut/sweep/beside.py): the run to compare with")
    args = ap.parse_args(argv)
    if args.no_strips:
        beside.BESIDE_RUN = float("inf")
    if args.bending:
        global BENDING_RIGIDITY
        BENDING_RIGIDITY = flexural_rigidity(wc.Material().youngs_modulus, wc.Material().thickness)
    if hasattr(wp.config, "quiet"):
        wp.config.quiet = True
    start = time.perf_counter()
    if args.named is not None:
        rows = run_named(args.named or NAMED_ALL)
        out = args.out or HERE / "results" / "fuzz_named.md"
        title = "Named cut cases on the current code"
    elif args.case is not None:
        case = make_case(args.case, kind=args.kind, quick=args.quick)
        print(json.dumps(case, indent=1))
        rows = run_case(case, strokes=args.strokes)
        for row in rows:
            if row["traceback"]:
                print(row["traceback"])
        if "settled_folded" in rows[-1]:
            print(f"settled {SETTLE_S} s: {rows[-1]['settled_folded']} triangles folded over "
                  f"({rows[-1]['settled_folded_cut']} made by the cut), the cut's smallest angle "
                  f"{rows[-1]['settled_min_cut_angle_deg']:.1f} deg")
        return 0
    else:
        rows = run_fuzz(args)
        out = args.out or DEFAULT_OUT
        title = "Cut fuzz on the current code"
    command = "python benchmarks/fuzz_cut.py " + " ".join(sys.argv[1:] if argv is None else argv)
    write_report(rows, out, title=title, command=command, wall=time.perf_counter() - start,
                 named=args.named is not None)
    print(f"wrote {out} and {out.with_suffix('.csv')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
