"""Cut events by the blade's travel: the trade between how often the cut runs and its quality.

Each incision scene is run with the cut in the step (reproducible), its events on the scene's
clock (``cutting.interval`` 1/60 s, one per rendered frame) and by travel (``cutting.travel``:
one event each time the tool's tip has moved that fraction of the lip spacing). Per run: cut
events; the real-time factor (``warp-cut run``'s, over the loop's wall time: median of
``repeats``, all runs interleaved, so the machine's load hits every setting alike); coverage,
the lips' largest deviation from the path, slivers, the mesh's smallest angle, holes, and the
width curve's peak and plateau. The cut's outcome is deterministic: only the timing differs
between repeats.

Writes results/event_travel.csv, results/event_travel.md and results/event_travel.png.
"""

from __future__ import annotations

import argparse
import dataclasses
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from common import RESULTS, markdown_table, write_csv, write_markdown  # noqa: E402

from warp_cut.cut.settings import DEFAULT_TRAVEL  # noqa: E402
from warp_cut.runner import run_scene  # noqa: E402
from warp_cut.scene import load_scene  # noqa: E402

CASES = {"straight_incision, 2 mm": ("straight_incision", []),
         "straight_incision, 1 mm": ("straight_incision", ["tissue.spacing=0.001"]),
         "curved_incision, 2 mm": ("curved_incision", [])}
"""Row label -> (scene, overrides)."""
CLOCK = 1.0 / 60.0
"""The clock's interval [s]: one event per rendered frame (the scenes' rule before travel)."""
TRAVELS = (None, 0.25, 0.5, 1.0, 1.5, 2.0)
"""None: on the clock (``CLOCK``); else ``cutting.travel`` [lip spacings]."""
COLUMNS = ["case", "events_by", "travel_mm", "cut_events", "realtime_factor", "coverage", "lip_deviation_mm",
           "slivers", "min_angle_deg", "unfilled_holes", "width_peak_mm", "width_plateau_mm", "valid"]


def scene_with(case: str, travel: float | None):
    """The case's scene with its events on the clock (``travel`` None) or by ``travel``."""
    name, overrides = CASES[case]
    scene = load_scene(name, overrides)
    rule = {"interval": CLOCK, "travel": None} if travel is None else {"interval": None, "travel": travel}
    return dataclasses.replace(scene, cutting=dataclasses.replace(scene.cutting, **rule))


def one_run(case: str, travel: float | None) -> tuple[dict, float]:
    """(metrics, real-time factor) of one run of ``case``: simulated time over the wall time of
    its loop, as ``warp-cut run`` reports it (metrics.json ``realtime_factor``)."""
    metrics = run_scene(scene_with(case, travel)).metrics
    return metrics, metrics["realtime_factor"]


def row_of(case: str, travel: float | None, metrics: dict, factors: list[float], spacing: float) -> dict:
    inc, cut, curve, mesh = metrics["incision"], metrics["cut"], metrics["width_curve"], metrics["mesh"]
    return {"case": case, "events_by": "clock (1/60 s)" if travel is None else f"travel {travel:g}",
            "travel_mm": "" if travel is None else 1e3 * travel * spacing,
            "cut_events": cut["events"], "realtime_factor": float(np.median(factors)),
            "coverage": inc["coverage"], "lip_deviation_mm": 1e3 * inc["max_deviation_m"],
            "slivers": mesh["slivers"], "min_angle_deg": mesh["min_angle_deg"],
            "unfilled_holes": cut["unfilled_holes"], "width_peak_mm": 1e3 * curve["peak_m"],
            "width_plateau_mm": 1e3 * curve["plateau_m"], "valid": mesh["valid"]}


def run(quick: bool = False, repeats: int = 3) -> list[dict]:
    cases = list(CASES)[:1] if quick else list(CASES)
    travels = (None, DEFAULT_TRAVEL) if quick else TRAVELS
    repeats = 1 if quick else repeats
    load_before = os.getloadavg()
    metrics, factors = {}, {}
    for _ in range(repeats):  # interleaved: a busy spell of the machine hits every setting
        for case in cases:
            for travel in travels:
                m, f = one_run(case, travel)
                metrics[case, travel] = m
                factors.setdefault((case, travel), []).append(f)
    rows = []
    for case in cases:
        spacing = scene_with(case, None).tissue.spacing
        for travel in travels:
            rows.append(row_of(case, travel, metrics[case, travel], factors[case, travel], spacing))
            r = rows[-1]
            print(f"  {case}, {r['events_by']}: {r['cut_events']} events, {r['realtime_factor']:.2f}x real time, "
                  f"coverage {r['coverage']:.3f}, lips {r['lip_deviation_mm']:.3g} mm, {r['slivers']} slivers, "
                  f"width peak {r['width_peak_mm']:.3g} mm plateau {r['width_plateau_mm']:.3g} mm", flush=True)
    write_csv("event_travel", rows)
    plot(rows)
    write_markdown("event_travel", "Cut events by the blade's travel", report(rows, repeats, load_before))
    return rows


def plot(rows: list[dict]) -> None:
    """results/event_travel.png: per case, each measure against the travel per event (the
    clock's value as a dashed line)."""
    measures = [("cut_events", "cut events"), ("realtime_factor", "x real time"),
                ("lip_deviation_mm", "lip deviation [mm]"), ("width_peak_mm", "width peak [mm]"),
                ("width_plateau_mm", "width plateau [mm]"), ("coverage", "coverage")]
    fig, axes = plt.subplots(2, 3, figsize=(12, 6.5))
    for ax, (key, label) in zip(axes.flat, measures):
        for case in dict.fromkeys(r["case"] for r in rows):
            mine = [r for r in rows if r["case"] == case]
            by_travel = [r for r in mine if r["travel_mm"] != ""]
            line, = ax.plot([float(r["events_by"].split()[1]) for r in by_travel], [r[key] for r in by_travel],
                            "o-", label=case)
            for r in mine:
                if r["travel_mm"] == "":
                    ax.axhline(r[key], ls="--", color=line.get_color(), lw=0.8)
        ax.set_xlabel("travel per event [lip spacings]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=7, title="dashed: clock (1/60 s)", title_fontsize=7)
    fig.tight_layout()
    fig.savefig(RESULTS / "event_travel.png", dpi=110)
    plt.close(fig)


def report(rows: list[dict], repeats: int, load_before) -> str:
    return "\n\n".join([
        "Each case run with the cut in the step (reproducible), its cut events on a clock "
        "(one per rendered frame, 1/60 s) and by the blade's travel (`cutting.travel`, in lip spacings; "
        "`travel_mm` is that travel in millimetres). `realtime_factor` is the median of "
        f"{repeats} runs, all settings interleaved; the other columns are the run's metrics.json "
        "(deterministic): `lip_deviation_mm` is `incision.max_deviation_m`, `slivers` the triangles "
        "the cut made under 10 degrees, `min_angle_deg` the mesh's smallest angle, `width_*` "
        f"the width curve. The default travel is {DEFAULT_TRAVEL:g} x the lip spacing "
        "(`warp_cut.cut.settings.DEFAULT_TRAVEL`).",
        f"Load average (1, 5, 15 min) before: {', '.join(f'{v:.2f}' for v in load_before)}.",
        markdown_table(rows, COLUMNS),
        "![measures against travel](event_travel.png)",
        "Command: `python benchmarks/bench_event_travel.py` (part of `make bench`)."])


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="the 2 mm straight incision, clock and default only")
    parser.add_argument("--repeats", type=int, default=3, help="runs per setting (timing)")
    args = parser.parse_args()
    run(quick=args.quick, repeats=args.repeats)
