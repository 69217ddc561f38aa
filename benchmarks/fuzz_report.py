"""The cut fuzz's report: a markdown summary and a CSV with one row per stroke."""

from __future__ import annotations

import csv
import re
import sys
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

from warp_cut.cut.tolerances import MIN_ANGLE_DEG
from warp_cut.mesh.geometry import SLIVER_DEG
from warp_cut.verify.stroke_quality import SMALL_EDGE
from warp_cut.verify.validity import FOLD_CHECKS

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fuzz_cases import SETTLE_S  # noqa: E402

WOUND_WRONG = "tri_against_rest"
"""The check of triangles wound against the surface in the rest shape (where the cut decides)."""

ROOT = str(Path(__file__).resolve().parent.parent) + "/"
"""The repository root, stripped from file names in tracebacks."""

COVERED = 0.95
"""A stroke counts as covered when at least this fraction of its trace is open."""


def _ran(rows):
    return [r for r in rows if r["stroke"] >= 0 and not r.get("skipped")]


def _fmt(v, digits=3) -> str:
    if isinstance(v, float):
        return "-" if not np.isfinite(v) else f"{v:.{digits}g}"
    return str(v)


def _pct(values, q) -> float:
    v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
    return float(np.percentile(v, q)) if len(v) else float("nan")


def _message_key(message: str) -> str:
    """An exception message with numbers masked, to group the same failure."""
    return re.sub(r"-?\d+(\.\d+)?(e-?\d+)?", "#", message)[:160]


def _checks(row) -> list[str]:
    return list(row.get("_violations", {}))


def _stats(rows) -> dict:
    ran = _ran(rows)
    latency = [x for r in rows for x in r["_latency"]]
    cov = [r["coverage"] for r in ran if r["coverage"] == r["coverage"]]  # nan: no skin under the trace
    return {
        "strokes": len(ran), "events": sum(r["events"] for r in rows),
        "violating": sum(any(c not in FOLD_CHECKS + (WOUND_WRONG,) for c in _checks(r)) for r in ran),
        "wound_wrong": sum(WOUND_WRONG in _checks(r) for r in ran),
        "folded": sum(any(c in FOLD_CHECKS for c in _checks(r)) for r in ran),
        "exceptions": sum(bool(r["exception"]) for r in rows),
        "holes": sum(r["unfilled_holes"] > 0 for r in ran if not r["exception"]),
        "split": sum(r["incisions"] > 1 for r in ran),
        "none": sum(r["incisions"] == 0 for r in ran),
        "cov_median": _pct(cov, 50), "cov_min": _pct(cov, 0),
        "covered": sum(c >= COVERED for c in cov),
        "no_skin": len(ran) - len(cov),
        "slivers": sum(r.get("slivers", 0) > 0 for r in ran),
        "rest_slivers": sum(r.get("rest_slivers", 0) > 0 for r in ran),
        "min_rest_angle": _smallest_rest_angle(ran),
        "small_rest": sum(r.get("small_rest_triangles", 0) > 0 for r in ran),
        "min_rest_edge": min(((r["min_new_rest_edge"], r["reproducer"]) for r in ran
                              if np.isfinite(r.get("min_new_rest_edge", float("nan")))), default=(float("nan"), "")),
        "refused": sum(r.get("refused_events", 0) for r in ran),
        "refused_strokes": sum(r.get("refused_events", 0) > 0 for r in ran),
        "settled_cases": sum("settled_folded" in r for r in rows),
        "settled_folded_cases": sum(r.get("settled_folded", 0) > 0 for r in rows),
        "settled_folded": sum(r.get("settled_folded", 0) for r in rows),
        "settled_folded_cut": sum(r.get("settled_folded_cut", 0) for r in rows),
        "settled_slivers": sum(r.get("settled_min_cut_angle_deg", 180.0) < SLIVER_DEG for r in rows),
        "settle_exceptions": sum(bool(r.get("settle_exception")) for r in rows),
        "lat_p50": _pct(latency, 50), "lat_p99": _pct(latency, 99), "lat_max": _pct(latency, 100),
        "substep_growth": _substep_growth(ran),
    }


def _smallest_rest_angle(ran) -> tuple[float, str]:
    """(the smallest rest angle [deg] among the triangles the strokes made, that stroke's
    reproducer); nan and "" if no stroke made a live triangle."""
    angles = [(r["min_new_rest_angle_deg"], r["reproducer"]) for r in ran
              if np.isfinite(r.get("min_new_rest_angle_deg", float("nan")))]
    return min(angles) if angles else (float("nan"), "")


def _substep_growth(ran) -> tuple[float, str, int]:
    """(the largest ratio of a stroke's substeps per step after it to its case's before any
    stroke, that stroke's reproducer, strokes above 4x): the cut's edits shortening the stable
    step (a hinge or a link on a light node) show here."""
    grown = [(r["substeps"] / max(r["substeps_start"], 1), r["reproducer"]) for r in ran if "substeps" in r]
    if not grown:
        return 1.0, "", 0
    ratio, where = max(grown)
    return ratio, where, sum(g > 4.0 for g, _ in grown)


def _totals(rows, wall) -> list[str]:
    s = _stats(rows)
    cases = len({r["case"] for r in rows})
    skipped = sum(bool(r.get("skipped")) for r in rows if r["stroke"] >= 0)
    return [
        f"- cases: {cases}, strokes run: {s['strokes']} (skipped: {skipped}), wall time {wall / 60:.1f} min",
        f"- cut events: **{s['events']}**, each followed by every invariant check",
        f"- strokes with a mesh invariant violated (check_mesh: indices, duplicates, degenerate "
        f"triangles, winding, manifold edges, springs = edges, masses; mass balance, links between live "
        f"nodes, device mirror, step budget, finite state; hinges with bending): **{s['violating']}**",
        f"- strokes in which the cut made a triangle wound against the surface ({WOUND_WRONG}): "
        f"**{s['wound_wrong']}**",
        f"- strokes after which triangles were folded over by the motion ({', '.join(FOLD_CHECKS)}; "
        f"not an edit error, see below): {s['folded']}",
        f"- exceptions: **{s['exceptions']}**",
        f"- strokes with a hole still open after the tool left: **{s['holes']}**",
        f"- strokes split into more than one incision: **{s['split']}**; strokes that made no incision: {s['none']}",
        f"- coverage: median {_fmt(s['cov_median'])}, min {_fmt(s['cov_min'])}; "
        f"strokes with coverage >= {COVERED}: {s['covered']} of {s['strokes']} "
        f"({s['no_skin']} with no skin under their trace)",
        f"- strokes leaving slivers (< {SLIVER_DEG:g} deg as the skin lies at the stroke's end) among the "
        f"triangles they made: {s['slivers']}",
        f"- strokes whose triangles go below {MIN_ANGLE_DEG:g} deg in the rest shape (the cut's promise; a re-mesh "
        f"defect, not the motion): **{s['rest_slivers']}**; the smallest rest angle of a triangle a stroke made: "
        f"{_fmt(s['min_rest_angle'][0])} deg" + (f" (`{s['min_rest_angle'][1]}`)" if s['min_rest_angle'][1] else ""),
        f"- strokes that made small triangles (a rest edge under {SMALL_EDGE:g} spacings: the angles may be good, "
        f"yet a small relative motion crushes them as the skin lies): {s['small_rest']}; the shortest rest edge: "
        f"{_fmt(s['min_rest_edge'][0])} spacings" + (f" (`{s['min_rest_edge'][1]}`)" if s['min_rest_edge'][1] else ""),
        f"- cut events refused (the slit did not fit; the next event tried again, `refused_reason` in the "
        f"CSV says why): {s['refused']}, in {s['refused_strokes']} strokes",
        f"- after a case's last stroke, the skin settled {SETTLE_S} s with the tool gone ({s['settled_cases']} "
        f"cases): cases with a triangle folded over **{s['settled_folded_cases']}** ({s['settled_folded']} "
        f"triangles, {s['settled_folded_cut']} of them made by the cut); cases with a triangle the cut made "
        f"under {SLIVER_DEG:g} deg as the skin lies: {s['settled_slivers']}; settles that went unstable: "
        f"{s['settle_exceptions']}",
        f"- host latency per cut event: p50 {_fmt(s['lat_p50'])} ms, p99 **{_fmt(s['lat_p99'])} ms**, "
        f"max {_fmt(s['lat_max'])} ms",
        f"- substeps per step after a stroke against its case's before the first: at most "
        f"{_fmt(s['substep_growth'][0])} times (`{s['substep_growth'][1]}`), more than 4 times after "
        f"{s['substep_growth'][2]} strokes",
    ]


def _by_kind(rows) -> list[str]:
    kinds = sorted({r["kind"] for r in rows})
    head = ("| kind | strokes | events | invariant violated | wound wrong | folded | exceptions | holes | "
            "split | no incision | coverage median | coverage min | covered | p99 latency [ms] |")
    out = [head, "|" + "---|" * 14]
    for k in kinds:
        s = _stats([r for r in rows if r["kind"] == k])
        out.append(f"| {k} | {s['strokes']} | {s['events']} | {s['violating']} | {s['wound_wrong']} | "
                   f"{s['folded']} | {s['exceptions']} | "
                   f"{s['holes']} | {s['split']} | {s['none']} | {_fmt(s['cov_median'])} | "
                   f"{_fmt(s['cov_min'])} | {s['covered']} | {_fmt(s['lat_p99'])} |")
    return out


def _breakdown(rows) -> list[str]:
    """Coverage, splits, holes and slivers by tool radius / spacing, by first vs crossing
    stroke, by integrator: where the current cut loses the stroke."""
    ran = _ran(rows)
    groups = {
        "tool radius < 0.5 spacing": lambda r: r["radius_mm"] < 0.5 * r["spacing_mm"],
        "tool radius 0.5-1 spacing": lambda r: 0.5 * r["spacing_mm"] <= r["radius_mm"] < r["spacing_mm"],
        "tool radius >= 1 spacing": lambda r: r["radius_mm"] >= r["spacing_mm"],
        "tilt < 45 deg": lambda r: r["tilt_deg"] < 45.0,
        "tilt >= 45 deg": lambda r: r["tilt_deg"] >= 45.0,
        "first stroke of a case": lambda r: r["stroke"] == 0,
        "later stroke (crosses an earlier cut)": lambda r: r["stroke"] > 0,
    }
    for name in sorted({r["integrator"] for r in ran}):
        groups[f"integrator {name}"] = lambda r, name=name: r["integrator"] == name
    for name in sorted({r.get("residual", "links") for r in ran}):
        groups[f"residual stress: {name}"] = lambda r, name=name: r.get("residual", "links") == name
    out = [f"| strokes | n | coverage median | covered | split | holes | no incision | slivers (< {SLIVER_DEG:g} deg "
           "as the skin lies) |", "|---|---|---|---|---|---|---|---|"]
    for label, test in groups.items():
        part = [r for r in ran if test(r)]
        if part:
            s = _stats(part)
            out.append(f"| {label} | {s['strokes']} | {_fmt(s['cov_median'])} | {s['covered']} | "
                       f"{s['split']} | {s['holes']} | {s['none']} | {s['slivers']} |")
    return out


SETTLE_TOOL_BINS = (0.0, 0.5, 1.0, 1.5, float("inf"))
"""Edges of the bins of a case's thickest tool (radius / spacing) in ``_settled_by_tool``."""


def _settled_by_tool(rows) -> list[str]:
    """Cases with a triangle folded over after the settle, by the case's thickest tool (radius /
    mesh spacing): a tool thicker than the mesh is fine pushes whole triangles onto its
    cylinder, where they are crushed or turned over, and a membrane is slow to turn them back."""
    thickest, settled = {}, {}
    for r in _ran(rows):
        thickest[r["case"]] = max(thickest.get(r["case"], 0.0), r["radius_mm"] / r["spacing_mm"])
    for r in rows:
        if "settled_folded" in r:
            settled[r["case"]] = r["settled_folded"] > 0
    out = ["| thickest tool (radius / spacing) | cases | with a fold after the settle |", "|---|---|---|"]
    for lo, hi in zip(SETTLE_TOOL_BINS, SETTLE_TOOL_BINS[1:]):
        cases = [c for c in settled if lo <= thickest.get(c, 0.0) < hi]
        if cases:
            label = f"{lo:g} - {hi:g}" if np.isfinite(hi) else f">= {lo:g}"
            out.append(f"| {label} | {len(cases)} | {sum(settled[c] for c in cases)} |")
    return out


def _violations(rows) -> list[str]:
    strokes, events, example = Counter(), Counter(), {}
    for r in _ran(rows):
        for item in filter(None, (r.get("violations") or "").split(";")):
            name, count = item.rsplit("x", 1)
            strokes[name] += 1
            events[name] += int(count)
            example.setdefault(name, (r["_violations"].get(name, ""), r["reproducer"]))
    if not strokes:
        return ["None."]
    out = ["Checks named tri_flipped_cut / tri_flipped_tissue count triangles made by an earlier edit / "
           "of the original mesh that the motion turned over (the tool pushes the nodes inside it "
           "out radially, lips included, and a mass-spring sheet has no resistance to folding); "
           "tri_flipped_new counts triangles an edit made inside tissue the tool had folded (their "
           "current positions come from the folded tissue's); tri_against_rest counts triangles "
           "wound against the surface in the rest shape, where the cut is decided.", "",
           "| check | strokes | checks failed | first message | reproducer |", "|---|---|---|---|---|"]
    for name, n in strokes.most_common():
        msg, rep = example[name]
        out.append(f"| {name} | {n} | {events[name]} | {msg[:140]} | `{rep}` |")
    return out


def _exceptions(rows) -> list[str]:
    groups = defaultdict(list)
    for r in rows:
        if r["exception"]:
            groups[_message_key(r["exception"])].append(r)
    if not groups:
        return ["None."]
    out = []
    for _key, items in sorted(groups.items(), key=lambda kv: -len(kv[1])):
        first = items[0]
        where = first["traceback"].strip().splitlines()
        frames = [ln.strip().replace(ROOT, "") for ln in where if ln.strip().startswith("File ")][-2:]
        out.append(f"- **{len(items)}x** `{first['exception'][:200]}`  ")
        out.append(f"  at {' <- '.join(reversed(frames))}  " if frames else "  ")
        out.append("  reproducers: " + ", ".join(f"`{r['reproducer']}`" for r in items[:3]))
    return out


def _failures(rows, what, test, limit=8) -> list[str]:
    bad = [r for r in _ran(rows) if test(r) and not r["exception"]]
    if not bad:
        return [f"- {what}: none"]
    return [f"- {what} ({len(bad)}): " + ", ".join(
        f"`{r['reproducer']}` ({r['kind']}, {r['path']})" for r in bad[:limit])]


def _named(rows) -> list[str]:
    cols = ["case", "events", "incisions", "unfilled_holes", "coverage", "curve_coverage",
            "lip_dev_max_mm", "slivers", "rest_slivers", "violations", "exception"]
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        out.append("| " + " | ".join(_fmt(r.get(c, "")) if c != "exception" else (r[c][:120] or "-")
                                     for c in cols) + " |")
    return out


def write_csv(rows, path: Path) -> None:
    keys = [k for k in rows[0] if not k.startswith("_")] if rows else []
    for r in rows:
        keys += [k for k in r if k not in keys and not k.startswith("_")]
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (r.get(k, "").replace("\n", " | ") if isinstance(r.get(k), str) else r.get(k, ""))
                        for k in keys})


def write_report(rows, out: Path, *, title: str, command: str, wall: float, named: bool) -> None:
    """Write ``out`` (markdown) and ``out`` with suffix .csv."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"# {title}", "", f"Command: `{command}`", "",
             "Coverage: fraction of the stroke's ideal in-skin trace at which an opening the stroke made "
             "lies within 0.5 spacing + 0.25 tool radius across the trace (parameter plane, rest positions; "
             "samples over an opening earlier strokes made are left out, a stroke whose whole trace is over one "
             "has none; see warp_cut/verify/stroke_quality.py). Holes: border loops a stroke added "
             "beyond one per incision, counted on the mesh after the tool left. "
             "Split: the stroke started more than one incision. Latency: host time of each cut event "
             "(`sim.cutter.latency_ms`, all stages) on the machine that ran the report; other load on it "
             "inflates the tail.", "", "## Totals", ""]
    lines += _totals(rows, wall)
    if named:
        lines += ["", "## Cases", ""] + [f"- **{r['case']}**: {r.get('about', '')}" for r in rows]
        lines += ["", ""] + _named(rows)
    else:
        lines += ["", "## By mesh kind", ""] + _by_kind(rows)
        lines += ["", "## By stroke", ""] + _breakdown(rows)
        lines += ["", "## Folds after the settle, by tool", ""] + _settled_by_tool(rows)
    lines += ["", "## Checks that failed", ""] + _violations(rows)
    lines += ["", "## Exceptions (grouped by message, numbers masked)", ""] + _exceptions(rows)
    lines += ["", "## Other failing strokes (reproducers)", ""]
    lines += _failures(rows, "holes open after the stroke", lambda r: r["unfilled_holes"] > 0)
    lines += _failures(rows, "split into several incisions", lambda r: r["incisions"] > 1)
    lines += _failures(rows, "no incision", lambda r: r["incisions"] == 0)
    lines += _failures(rows, f"coverage below {COVERED}", lambda r: r["coverage"] < COVERED)
    lines += _failures(rows, f"triangles under {MIN_ANGLE_DEG:g} deg in the rest shape",
                       lambda r: r.get("rest_slivers", 0) > 0)
    out.write_text("\n".join(lines) + "\n")
    write_csv(rows, out.with_suffix(".csv"))
