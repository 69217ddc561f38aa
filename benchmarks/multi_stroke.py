"""Multi-stroke incisions on regular, curved and real meshes, judged stroke by stroke.

Every incision set of ``warp_cut.verify.incision_sets`` (T, X, elliptical excision, recut,
tight arc) is cut into each mesh: a flat grid, a jittered Delaunay disk, a cylinder of 3 cm
radius, a dome, and the top of an MNI152 brain envelope (``tests/data/mni152_brain_top.obj``,
irregular, made by ``benchmarks/make_brain_mesh.py``); 2 mm spacing (the brain mesh: its own,
2.3 mm median). The tool: 1 mm radius, 60 deg tilt, 2 cm/s, 3 mm deep, entering along its
axis; on the flat grid also a 0.5 mm tool and the 1 mm tool lowered straight down onto each
stroke's start (``warp_cut.verify.lowered_entry``). A Simulator as a user makes it
(``wc.Simulator(model, dt=1e-3, cutting=wc.CutSettings())``, semi-implicit, gravity, the
border pinned) is stepped one 1 ms ``sim.step(tool=pose)`` at a time
(``warp_cut.verify.stroke_check.run_stroke``, every invariant checked after every edit), and
after each stroke the cut is judged from the model's arrays (``warp_cut.verify.cut_judge``).
An exception ends its case (recorded) and the run goes on.

    python benchmarks/multi_stroke.py [--quick] [--only MESH/SET] [--out PATH] [--no-check]

``--only`` takes shell patterns (``flat*/x``, ``brain/*``); ``--quick`` runs the flat grid and
the brain mesh only, without the invariant checks. A full run writes
``benchmarks/results/multi_stroke.md`` and ``.csv`` (one row per stroke); a partial one prints
its table and writes only with ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import fnmatch
import math
import subprocess
import sys
import time
import traceback
from pathlib import Path

import warp_cut as wc
from warp_cut.mesh import surfaces
from warp_cut.sim.warp_config import quiet_warp
from warp_cut.verify.cut_judge import Judgement, baseline, judge
from warp_cut.verify.incision_sets import SET_BUILDERS, ToolSpec, build_set
from warp_cut.verify.mesh_surface import load_mesh_surface
from warp_cut.verify.stroke_check import run_stroke
from warp_cut.verify.stroke_quality import original_border

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DEFAULT_OUT = HERE / "results" / "multi_stroke.md"
BRAIN_OBJ = ROOT / "tests" / "data" / "mni152_brain_top.obj"

SURFACES = {
    "flat": lambda: surfaces.flat_grid(0.05, 0.002),
    "delaunay": lambda: surfaces.jittered_delaunay(0.025, 0.002, jitter=0.25, seed=3),
    "cylinder": lambda: surfaces.cylinder(0.03, 0.06, math.radians(150.0), 0.002),
    "dome": lambda: surfaces.dome(0.04, 0.028, 0.002),
    "brain": lambda: load_mesh_surface(BRAIN_OBJ, name="brain_top"),
}
"""Mesh name -> Surface maker (lengths [m])."""

DEFAULT_TOOL = ToolSpec(radius=1e-3, tilt=math.radians(60.0), speed=0.02, depth=3e-3)
MESHES = {
    "flat": ("flat", DEFAULT_TOOL, 0.3),
    "flat_thin": ("flat", ToolSpec(radius=5e-4), 0.3),
    "flat_lowered": ("flat", ToolSpec(entry="lowered"), 0.3),
    "delaunay": ("delaunay", DEFAULT_TOOL, 0.3),
    "cylinder": ("cylinder", DEFAULT_TOOL, 0.0),
    "dome": ("dome", DEFAULT_TOOL, 0.3),
    "brain": ("brain", DEFAULT_TOOL, 0.3),
}
"""Row name -> (surface, tool, heading [rad] of the first stroke). The flat meshes' strokes
are turned off the lattice rows; the cylinder's first strokes run along its axis."""

QUICK = ("flat", "brain")

COLUMNS = ["mesh", "set", "stroke", "coverage", "min_rest_angle_deg", "min_current_angle_deg", "wound_against",
           "folded", "holes", "open_area_mm2", "components", "exception"]
"""The report's per-stroke table."""


def make_case(mesh: str, set_name: str):
    """(surface, incision set, Simulator, baseline, original border keys) of one case."""
    surface_name, tool, heading = MESHES[mesh]
    surface = SURFACES[surface_name]()
    incisions = build_set(set_name, surface, tool, (0.0, 0.0), heading)
    model = wc.TissueModel.from_surface(surface)
    sim = wc.Simulator(model, dt=1e-3, cutting=wc.CutSettings(), integrator="semi_implicit")
    return surface, incisions, sim, baseline(model, surface), original_border(model)


def slit_area_mm2(incisions, index: int, tool: ToolSpec) -> float:
    """Area [mm^2] an ideal slit along strokes 0..index leaves open at rest: two lip offsets
    (0.25 tool radius each, the CutSettings default) times the length of the distinct paths
    (a path cut again adds none)."""
    seen, length = set(), 0.0
    for stroke, path in zip(incisions.strokes[: index + 1], incisions.paths[: index + 1]):
        if id(path) not in seen:
            seen.add(id(path))
            length += stroke.length
    return 1e6 * 0.5 * tool.radius * length


def _row(mesh, set_name, index, surface, tool, result, judgement, wall, slit) -> dict:
    return {
        "mesh": mesh, "set": set_name, "stroke": index, "coverage": result.coverage,
        **judgement.as_row(), "slit_area_mm2": slit,
        "exception": result.exception or "", "incisions": result.incisions,
        "unfilled_holes": result.unfilled_holes, "events": result.events,
        "violations": ";".join(f"{k}x{v['events']}" for k, v in result.violations.items()),
        "skipped": result.skipped, "nodes": len(surface.points), "spacing_mm": 1e3 * surface.spacing,
        "radius_mm": 1e3 * tool.radius, "entry": tool.entry, "wall_s": wall,
        "reproducer": f"python benchmarks/multi_stroke.py --only {mesh}/{set_name}",
        "traceback": result.traceback,
    }


def run_case(mesh: str, set_name: str, *, check: bool = True, log=print) -> list[dict]:
    """Cut one incision set into one mesh; one row per stroke (one row if set-up failed)."""
    tool = MESHES[mesh][1]
    try:
        surface, incisions, sim, base, border = make_case(mesh, set_name)
    except Exception as exc:  # recorded: a set-up failure is a finding too
        row = {"mesh": mesh, "set": set_name, "stroke": -1, "exception": f"{type(exc).__name__}: {exc}",
               "traceback": traceback.format_exc(limit=-4), "skipped": "set-up failed"}
        log(f"{mesh}/{set_name}: set-up failed: {row['exception']}")
        return [row]
    rows = []
    for index, stroke in enumerate(incisions.strokes):
        start = time.perf_counter()
        result = run_stroke(sim, stroke, surface, border_keys=border, check=check)
        try:
            judgement = judge(sim.model, sim.positions, surface, base, wounds=incisions.wounds[index],
                              outline=incisions.island_outline if index == len(incisions.strokes) - 1 else None)
        except Exception as exc:  # the tissue may be broken after an exception
            judgement = None
            result.exception = result.exception or f"judge {type(exc).__name__}: {exc}"
        rows.append(_row(mesh, set_name, index, surface, tool, result, judgement or Judgement(),
                         time.perf_counter() - start, slit_area_mm2(incisions, index, tool)))
        log(_progress(rows[-1]))
        if result.exception or result.skipped:
            break  # the tissue is in an unknown state after an exception
    return rows


def _progress(row: dict) -> str:
    return (f"{row['mesh']:12s} {row['set']:9s} stroke {row['stroke']} coverage {row['coverage']:.3f} "
            f"angles {row['min_rest_angle_deg']:.1f}/{row['min_current_angle_deg']:.1f} "
            f"against {row['wound_against']} folded {row['folded']} holes {row['holes']} "
            f"open {row['open_area_mm2']:.0f}/{row['slit_area_mm2']:.0f} mm2 unfilled {row['unfilled_holes']} "
            f"components {row['components']} {row['island']} {row['wall_s']:.1f}s "
            f"{row['exception'][:80]} {row['skipped']}")


def cases(only: str | None, quick: bool) -> list[tuple[str, str]]:
    """(mesh, set) pairs to run, in report order."""
    meshes = QUICK if quick else tuple(MESHES)
    pairs = [(m, s) for m in meshes for s in SET_BUILDERS]
    if only:
        pairs = [(m, s) for m, s in pairs if fnmatch.fnmatch(f"{m}/{s}", only)]
    return pairs


def _fmt(value) -> str:
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.3g}"
    return str(value)


def table(rows: list[dict], columns: list[str]) -> str:
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        lines.append("| " + " | ".join(_fmt(row.get(c, "")).replace("|", "/") for c in columns) + " |")
    return "\n".join(lines)


def summary(rows: list[dict]) -> list[dict]:
    """One row per mesh x set: the smallest coverage over its strokes, the state after its last."""
    out = {}
    for row in rows:
        key = (row["mesh"], row["set"])
        entry = out.setdefault(key, {"mesh": row["mesh"], "set": row["set"], "strokes": 0,
                                     "min_coverage": float("nan"), "unfilled_holes": 0, "exception": ""})
        if row["stroke"] < 0:
            entry["exception"] = row["exception"]
            continue
        entry["strokes"] += 1
        entry["unfilled_holes"] += row["unfilled_holes"]
        cov = row["coverage"]
        if not math.isnan(cov):
            entry["min_coverage"] = cov if math.isnan(entry["min_coverage"]) else min(entry["min_coverage"], cov)
        for name in ("min_rest_angle_deg", "min_current_angle_deg", "rest_slivers", "wound_against", "folded",
                     "border_loops", "expected_loops", "holes", "open_area_mm2", "slit_area_mm2", "components",
                     "island"):
            entry[name] = row[name]
        entry["exception"] = entry["exception"] or row["exception"] or row["skipped"]
    return list(out.values())


DEFINITIONS = """\
One row per stroke; the state columns are measured after that stroke (the wound so far).

- coverage: fraction of the stroke's ideal in-skin trace at which an opening the stroke made
  lies within 0.5 spacing + 0.25 tool radius across the trace (parameter plane, rest
  positions; samples over an opening an earlier stroke made are left out;
  `verify/stroke_quality.py`).
- min_rest_angle_deg / min_current_angle_deg: smallest angle of the live triangles the cut
  made (slot >= the original triangle count) in the rest shape (`model.points`) and as the skin
  lies (`sim.positions`); rest_slivers: those below 10 deg at rest.
- wound_against: cut-made triangles whose rest normal points against the surface normal at
  their rest centroid (analytic surfaces: the analytic normal; the brain mesh: the normal of
  the original triangle the centroid projects into).
- folded: cut-made triangles whose current normal points against the surface normal where
  their current centroid lies (folded_tissue: the same for original triangles).
- holes: border loops - (original loops + one per separate wound + one for a freed island);
  unfilled_holes: holes the Cutter itself reports left open after the tool left.
- open_area_mm2: parameter-plane area the original triangles covered at rest that no live
  triangle covers now (slits, open holes, channels left without lips, skin deleted); against
  slit_area_mm2, what an ideal slit leaves (2 x 0.25 tool radius x the distinct path length).
  A channel without lips is one border loop like a slit: only this column shows it.
- components: connected pieces of the live triangles (through shared nodes); island (excision,
  after its last stroke): free / attached / removed (`verify/cut_judge.py`).
- coverage of a recut's second stroke: its trace lies over the first stroke's slit (an
  opening at rest), whose samples are left out, so it is nan or measured on a few samples.
- violations: invariant checks failed after an edit (`verify/validity.py`; tri_flipped_* are
  the folds the motion made, see docs/cutting.md).
"""


def write_report(rows: list[dict], out: Path, *, command: str, wall: float) -> None:
    """The markdown report at ``out`` and the CSV beside it."""
    out.parent.mkdir(parents=True, exist_ok=True)
    strokes = [r for r in rows if r["stroke"] >= 0]
    failed = [r for r in rows if r["exception"]]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    text = [f"# Multi-stroke incisions on the current code ({commit})", "",
            f"Command: `{command}`; wall time {wall / 60:.1f} min.", "", DEFINITIONS,
            "## Per mesh and set (coverage: the smallest over the set's strokes; the rest after its last stroke)",
            "", table(summary(rows), ["mesh", "set", "strokes", "min_coverage", "min_rest_angle_deg",
                                      "min_current_angle_deg", "rest_slivers", "wound_against", "folded",
                                      "border_loops", "expected_loops", "holes", "unfilled_holes",
                                      "open_area_mm2", "slit_area_mm2", "components", "island", "exception"]),
            "", "## Per stroke", "",
            table(strokes, COLUMNS + ["slit_area_mm2", "island", "incisions", "unfilled_holes", "events",
                                      "violations"])]
    if failed:
        text += ["", "## Exceptions", ""]
        for row in failed:
            text += [f"### {row['mesh']}/{row['set']} stroke {row['stroke']}: {row['exception']}", "",
                     f"Reproduce: `{row.get('reproducer', '')}`", "", "```", row["traceback"].rstrip(), "```", ""]
    out.write_text("\n".join(text) + "\n")
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with open(out.with_suffix(".csv"), "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="the flat grid and the brain mesh, no invariant checks")
    ap.add_argument("--only", default=None, help="MESH/SET shell pattern, e.g. flat_thin/x or 'brain/*'")
    ap.add_argument("--out", type=Path, default=None, help="markdown report (CSV beside it)")
    ap.add_argument("--no-check", action="store_true", help="skip the invariant checks after every edit")
    args = ap.parse_args(argv)
    quiet_warp()
    todo = cases(args.only, args.quick)
    if not todo:
        ap.error(f"no case matches {args.only!r}; meshes {list(MESHES)}, sets {list(SET_BUILDERS)}")
    start, rows = time.perf_counter(), []
    for mesh, set_name in todo:
        rows += run_case(mesh, set_name, check=not (args.no_check or args.quick))
    wall = time.perf_counter() - start
    out = args.out or (DEFAULT_OUT if not (args.only or args.quick) else None)
    command = "python benchmarks/multi_stroke.py " + " ".join(sys.argv[1:] if argv is None else argv)
    if out is None:
        print(table([r for r in rows if r["stroke"] >= 0], COLUMNS + ["island"]))
    else:
        write_report(rows, out, command=command.strip(), wall=wall)
        print(f"wrote {out} and {out.with_suffix('.csv')}")
    print(f"{len(todo)} cases, {wall / 60:.1f} min")
    return 0


if __name__ == "__main__":
    sys.exit(main())
