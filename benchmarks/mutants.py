"""Mutation testing of the cut's Stage 3: does the test suite notice when the re-mesh goes wrong?

Each mutant is one deliberate defect in the code that decides the mesh a cut leaves (the fill,
its coarsening, the flips, node matching, the slit's checks, islands): the fill choosing its
*worst* option instead of its best, a check skipped, a tolerance set to nothing. For each, the
package is copied, the defect written into the copy, and the tests run against the copy:

1. the unit tests of Stage 3's pieces (hand-built cases, seconds);
2. if they all pass, the stroke tests (whole incisions on varied meshes, minutes).

A mutant is *killed* when a test fails; the report names the first failing test. A mutant that
survives both tiers is a defect the suite cannot see: a test is missing. Writes
``benchmarks/results/mutants.md`` (+ .csv).

    python benchmarks/mutants.py [--only NAME ...] [--workers N]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from common import markdown_table, write_csv, write_markdown

ROOT = Path(__file__).resolve().parent.parent

UNIT_TESTS = ("test_fill.py", "test_coarsen.py", "test_remesh.py", "test_layout.py", "test_flips.py",
              "test_chart.py", "test_region.py", "test_event_band.py", "test_slit_band.py", "test_islands.py",
              "test_placement.py")
"""Tier 1: the unit tests of Stage 3's pieces."""
STROKE_TESTS = ("test_cutting.py", "test_cut_fuzz.py", "test_strokes.py", "test_incision_sets.py")
"""Tier 2: whole strokes, run only against the mutants tier 1 let through."""


@dataclass(frozen=True)
class Mutant:
    """One defect: in ``module`` (a path under warp_cut/), each ``old`` text (found exactly once)
    replaced by its ``new`` one."""

    name: str
    module: str
    edits: tuple[tuple[str, str], ...]
    defect: str


MUTANTS = (
    Mutant("fill_unrefined", "cut/remesh/fill.py",
           (("cdt.deg_to_rad(min_angle_deg),\n                               erase, min_edge)",
             "cdt.deg_to_rad(0.0),\n                               erase, min_edge)"),),
           "the fill keeps the constrained Delaunay triangulation unrefined (no smallest angle)"),
    Mutant("fill_clockwise", "cut/remesh/fill.py",
           (("flip = chart_signed_areas(points, triangles) < 0", "flip = chart_signed_areas(points, triangles) > 0"),),
           "the fill's triangles wound clockwise in the chart"),
    Mutant("fill_worst_choice", "cut/remesh/coarsen.py",
           (("if chart_min_angles(points, made).min() < min_angle_deg or",
             "if chart_min_angles(points, made).min() < 0.0 or"),),
           "the coarsening takes a point out whatever angles the triangles made without it keep"),
    Mutant("coarsen_outline_corner", "cut/remesh/coarsen.py",
           (("not closed and not _in_line(points[ring[-1]], points[v], points[ring[0]])", "False"),),
           "the coarsening takes out points at corners of the outline (the outline changes)"),
    Mutant("flip_away_from_delaunay", "cut/remesh/flips.py",
           (("bad = np.flatnonzero(total > 180.0 + DELAUNAY_TOLERANCE_DEG)",
             "bad = np.flatnonzero(total < 180.0 - DELAUNAY_TOLERANCE_DEG)"),
            ("if angles[0, 2] + angles[1, 2] <= 180.0 + DELAUNAY_TOLERANCE_DEG:",
             "if angles[0, 2] + angles[1, 2] >= 180.0 - DELAUNAY_TOLERANCE_DEG:")),
           "the flips choose the worse diagonal (away from Delaunay)"),
    Mutant("no_bend_matching", "cut/remesh/cut_piece.py",
           (("_match_bend_lips(band, inc, model, LIP_MATCH * s)", "_match_bend_lips(band, inc, model, 0.0 * s)"),),
           "no node matching round a bend (lips a sliver apart on its inside)"),
    Mutant("match_either_side", "cut/remesh/cut_piece.py",
           (("or side is not None and p.side != side:", ":"),),
           "bend matching takes lips of the other side too (across a thin slit)"),
    Mutant("slit_unchecked", "cut/remesh/cut_piece.py",
           (("    _check_slit(layout, band)\n    return layout, growth", "    return layout, growth"),),
           "a fill that does not lay the whole slit (a lip missing or doubled) is written"),
    Mutant("no_angle_refusal", "cut/remesh/cut_piece.py",
           (("if layout.fill.unrefined and _smallest_angle(layout.fill) < MIN_ANGLE_DEG:", "if False:"),),
           "a fill left under the smallest angle however far its region grew is written"),
    Mutant("no_region_growth", "cut/remesh/cut_piece.py",
           (("        region.grow(refused)\n", ""),),
           "the region does not grow where the refinement would split its fixed outline"),
    Mutant("split_outline_unreported", "cut/remesh/fill.py",
           (("split = {tuple(sorted((e.v1, e.v2))) for originals in tri.piece_to_originals.values() "
             "for e in originals}", "split = set()"),),
           "the fill does not report the outline edges it split (T-junctions with the mesh outside)"),
    Mutant("new_nodes_at_rest", "cut/remesh/cut_piece.py",
           (("rest_new, current_new = lift(fill.points[new_rows])",
             "rest_new, current_new = lift(fill.points[new_rows])[0], lift(fill.points[new_rows])[0]"),),
           "new nodes placed at their rest positions instead of where the tissue lies now"),
    Mutant("folded_new_triangles_kept", "cut/remesh/placement.py",
           (("folded = folded_against(x, touching, maps)", "folded = np.zeros(len(touching), dtype=bool)"),),
           "new nodes of a triangle born folded over in the tool's dent are left there"),
    Mutant("tool_nodes_in_tissue_map", "cut/remesh/placement.py",
           (("sources = old & ~held_by(x, tool)", "sources = old"),),
           "the nodes the tool pushes count as the tissue round a new node"),
    Mutant("inner_nodes_on_outline", "cut/remesh/layout.py",
           (("away = np.all([shapely.distance(piece.boundary, points) > clear for piece in pieces], axis=0)",
             "away = xy[:, 0] == xy[:, 0]"),),
           "the fill keeps region nodes however near the new outline they lie"),
    Mutant("no_node_matching", "cut/remesh/layout.py",
           (("loops, points, matched = _loops(pieces, table, MERGE * inc.spacing)",
             "loops, points, matched = _loops(pieces, table, 0.0)"),),
           "new outline points a hair from a node are kept beside it (no node matching)"),
    Mutant("sharp_corners_kept", "cut/remesh/layout.py",
           (("if v in protected or corner_angle(chart, turn) >= REFINE_ANGLE_DEG:", "if True:"),),
           "sharp corners of the new outline are neither taken in nor cut off"),
    Mutant("rest_angles_unchecked", "cut/remesh/cut_piece.py",
           (("    if len(triangles) and triangle_min_angles(rest, triangles).min() < MIN_ANGLE_DEG:",
             "    if False:"),),
           "a fill lifted onto a curved rest surface may leave triangles under the smallest angle"),
    Mutant("flaps_kept", "cut/wound/islands.py",
           (("        flaps = self.remove_flaps(near, keep | slit) if slit else self._remove_flaps_near(keep)\n",
             "        flaps = 0\n"),),
           "pieces of tissue an edit leaves hanging by one edge stay, and fold over"),
    Mutant("islands_not_searched", "cut/wound/islands.py",
           (("        islands = islands_from(editor.model, editor.report.new_triangles)\n",
             "        islands = []\n"),),
           "pieces of skin an edit cuts free are left floating in the wound"),
)


def apply(mutant: Mutant, package: Path) -> None:
    """Write ``mutant``'s defect into the package copy at ``package`` (its warp_cut/ folder).

    Raises:
        SystemExit: An ``old`` text is not found exactly once (the code moved on: update the mutant).
    """
    path = package / mutant.module
    text = path.read_text()
    for old, new in mutant.edits:
        count = text.count(old)
        if count != 1:
            raise SystemExit(f"mutant {mutant.name}: {mutant.module} holds the text to replace {count} times "
                             f"(needs exactly 1): {old[:60]!r}")
        text = text.replace(old, new)
    path.write_text(text)


def run_tests(package_parent: Path, files: tuple[str, ...], workers: int) -> tuple[str, str]:
    """Run ``files`` (under tests/) against the package copy under ``package_parent``: (outcome
    "killed" / "survived" / "error", the first failing test or the error's last line)."""
    env = dict(os.environ, PYTHONPATH=str(package_parent), PYTHONDONTWRITEBYTECODE="1")
    args = [sys.executable, "-m", "pytest", "-q", "-x", "-rf", "-p", "no:cacheprovider", "-p", "no:randomly"]
    if workers > 1:
        args += ["-n", str(workers)]
    args += [str(ROOT / "tests" / f) for f in files]
    proc = subprocess.run(args, cwd=package_parent, env=env, capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    failed = re.findall(r"^FAILED (\S+)", out, flags=re.MULTILINE)
    if proc.returncode == 0:
        return "survived", ""
    if proc.returncode in (1, 2) and failed:  # 2: xdist's workers stopped at the first failure (-x)
        return "killed", "tests/" + failed[0].split("tests/", 1)[-1]
    lines = [line for line in out.splitlines() if line.strip()]
    return "error", lines[-1] if lines else f"pytest exit code {proc.returncode}"


def imported_from(package_parent: Path) -> str:
    """Where ``import warp_cut`` resolves with the copy first on the path (it must be the copy)."""
    env = dict(os.environ, PYTHONPATH=str(package_parent))
    return subprocess.run([sys.executable, "-c", "import warp_cut; print(warp_cut.__file__)"], cwd=package_parent,
                          env=env,
                          capture_output=True, text=True, check=True).stdout.strip()


def try_mutant(mutant: Mutant, workers: int) -> dict:
    """Copy the package, write the defect, run tier 1 then (if it survives) tier 2."""
    with tempfile.TemporaryDirectory(prefix=f"mutant-{mutant.name}-") as tmp:
        parent = Path(tmp)
        shutil.copytree(ROOT / "warp_cut", parent / "warp_cut", ignore=shutil.ignore_patterns("__pycache__"))
        apply(mutant, parent / "warp_cut")
        where = imported_from(parent)
        if not where.startswith(str(parent)):
            raise SystemExit(f"the tests would import warp_cut from {where}, not the mutated copy in {parent}")
        start = time.perf_counter()
        outcome, test = run_tests(parent, UNIT_TESTS, 1)
        tier = "unit"
        if outcome == "survived":
            outcome, test = run_tests(parent, STROKE_TESTS, workers)
            tier = "strokes"
        return {"mutant": mutant.name, "module": mutant.module, "defect": mutant.defect, "outcome": outcome,
                "tier": tier if outcome != "survived" else "", "caught_by": test,
                "seconds": round(time.perf_counter() - start, 1)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", help="mutant names to run (default: all)")
    parser.add_argument("--workers", type=int, default=1, help="pytest-xdist workers for the stroke tests")
    args = parser.parse_args(argv)
    names = {m.name for m in MUTANTS}
    unknown = set(args.only or ()) - names
    if unknown:
        print(f"--only: unknown mutants {sorted(unknown)}; known: {sorted(names)}", file=sys.stderr)
        return 2
    chosen = [m for m in MUTANTS if not args.only or m.name in args.only]
    rows = []
    for mutant in chosen:
        rows.append(try_mutant(mutant, args.workers))
        row = rows[-1]
        print(f"{row['mutant']:26s} {row['outcome']:9s} {row['tier']:8s} {row['seconds']:7.1f}s {row['caught_by']}",
              flush=True)
    if not args.only:
        write_csv("mutants", rows)
        write_report(rows)
    return 0 if all(r["outcome"] == "killed" for r in rows) else 1


def write_report(rows: list[dict]) -> None:
    """benchmarks/results/mutants.md from the rows of a whole run."""
    killed = sum(r["outcome"] == "killed" for r in rows)
    missed = [r["mutant"] for r in rows if r["outcome"] != "killed"]
    about = "\n\n".join(__doc__.split("\n\n")[1:4])  # what a mutant is, the two tiers, what killed means
    text = (f"{about}\n\nKilled: **{killed} of {len(rows)}**" + (f"; not killed: {', '.join(missed)}" if missed else "")
            + ".\n\n" + markdown_table(rows, ["mutant", "module", "defect", "outcome", "tier", "caught_by", "seconds"])
            + "\n\nCommand: `python benchmarks/mutants.py` (`make mutants`).\n")
    write_markdown("mutants", "Mutation testing of the cut's Stage 3", text)


if __name__ == "__main__":
    sys.exit(main())
