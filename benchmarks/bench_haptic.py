"""Haptic rate: every 1 ms tick on time? The README's loop, one ``sim.step(tool=...)`` per tick.

    python benchmarks/bench_haptic.py [--quick] [--cpu N] [--repeats 3]

The loop of the README (10 x 6 cm patch, Table 1 material, a 60 degree scalpel going 8 mm in
along its axis over 0.2 s, then cutting at 2 cm/s for 2 s) on the straight incision and on the
curved one of ``scenes/curved_incision.toml`` (y = 8 mm sin(pi x / 2 cm)), at 2 mm and 1 mm
spacing, with and without cutting (in the step, or in a worker with the loop paced at 1x or
3x real time, or unpaced with a bounded edit lag). Each tick is timed around the ``step`` call alone (the Tool
is built outside, it is the caller's), in wall time and in the thread's CPU time (the
difference is time the machine gave other processes). The collector is frozen after set-up,
as ``docs/haptic.md`` advises for a haptic loop.

Then, without cutting, the per-call overhead: a loop of single-step calls with a new Tool per
call against one ``step(n, tool=...)`` call over the same poses, on two simulators advancing in
lockstep, samples interleaved; the ratio of the medians of the per-step times.

The process is pinned to one CPU (``--cpu``, default the last this process may use): Warp runs
CPU kernels on one thread, and the targets are for one core. Writes results/haptic.csv and
results/haptic.md; --quick: 2 mm only, shorter loops (a smoke run).
"""

from __future__ import annotations

import os
import time

import numpy as np
from common import markdown_table, pinned_cli, pinned_to, write_csv, write_markdown

import warp_cut as wc
from warp_cut.ticks import Pacer, TickLog, frozen_gc
from warp_cut.verify.stroke_quality import new_slivers

AXIS = np.array([-0.5, 0.0, 0.866])
"""The scalpel's axis from tip to handle: leaning back 60 degrees along -x."""
APPROACH_TICKS = 200
"""Ticks of the approach: 8 mm in along the axis."""
SPEED_TICK = 2e-5
"""Travel along x per 1 ms tick [m] (2 cm/s)."""
RADIUS = 0.001
UNPACED_LAG = 50
"""``max_lag`` [steps] of the unpaced background rows."""


def tip_at(k: int, curved: bool) -> np.ndarray:
    """The tool tip [m] at tick k: the README's path, or its S-curved variant."""
    depth = min(k, APPROACH_TICKS) / APPROACH_TICKS * 0.008
    travel = SPEED_TICK * max(k - APPROACH_TICKS, 0)
    tip = np.array([-0.02, 0.0, 0.004]) - depth / 0.866 * AXIS + [travel, 0.0, 0.0]
    if curved:
        x = -0.02 + travel  # along the curve's x, from -2 cm to +2 cm
        tip[1] = 0.008 * np.sin(np.pi * x / 0.02)
    return tip


def tools(ticks: int, curved: bool) -> list:
    return [wc.Tool(p0=tip, p1=tip + 0.04 * AXIS, radius=RADIUS)
            for tip in (tip_at(k, curved) for k in range(ticks))]


FAST_PACE = 3.0
"""Ticks per millisecond of wall time in the ``background, 3x pace`` rows (the target's 3x
real time)."""
CUTTING = {"no": (None, None), "in loop": (False, None), "background": (True, 1.0),
           "background, 3x pace": (True, FAST_PACE), f"background, lag {UNPACED_LAG}": (UNPACED_LAG, None)}
"""The rows' cut (None: no cut, False: in the step, True or a ``max_lag``: in a worker) and the loop's pace
(ticks per ms of wall time; None: as fast as it goes): none; in the step (the Cutter in the
loop); in a worker with the loop paced at 1 kHz as a device would pace it; the same paced at
FAST_PACE kHz, never waiting for an edit; and in a worker with the loop as fast as it goes,
waiting for an edit UNPACED_LAG steps after its event (``max_lag``)."""


def tick_run(spacing: float, curved: bool, cutting: str, ticks: int) -> dict:
    """The README's loop for ``ticks`` ticks; one table row for a ``CUTTING`` key."""
    model = wc.TissueModel.from_patch(size=(0.10, 0.06), spacing=spacing)
    nodes, triangles = model.node_count, model.triangle_table.count
    mode, pace = CUTTING[cutting]
    background = mode not in (None, False)
    made = time.perf_counter()
    settings = None if mode is None else wc.CutSettings(
        worker=background, max_lag=mode if background and mode is not True else None)
    sim = wc.Simulator(model, dt=1e-3, cutting=settings)
    setup_s = time.perf_counter() - made  # with a background cut, the worker's start
    poses = tools(ticks, curved)
    log = TickLog(ticks, budget=sim.dt, cpu_time=True)
    try:
        with frozen_gc():
            pacer = Pacer(sim.dt / (pace or 1.0))
            for k, tool in enumerate(poses):
                log.step(sim, tool)
                if pace:
                    pacer.wait(k)
            wall = time.perf_counter() - pacer.start
        if background:
            sim.cutter.flush(sim)
            cut = sim.cutter.metrics(sim.positions)
            worker = {"worker_event_p50_ms": float(np.median(sim.cutter.worker_ms)),
                      "edit_lag_p50_steps": float(np.median(sim.cutter.lag_steps)),
                      "edit_lag_max_steps": int(np.max(sim.cutter.lag_steps)),
                      **{f"loop_{part}_p99_ms": float(np.percentile(ms, 99))
                         for part, ms in sim.cutter.loop_ms.items()}}
    finally:
        sim.close()
    t, cpu, jump = log.tick_metrics(), log.tick_metrics(cpu=True), log.force_jump_metrics()
    return {"path": "curved" if curved else "straight", "spacing_mm": spacing * 1e3,
            "nodes": nodes, "nodes_end": model.active_node_count, "substeps": sim.substeps,
            "cutting": cutting, "setup_s": setup_s, "ticks": t["ticks"], "tick_first_ms": t["first_ms"],
            "tick_p50_ms": t["p50"], "tick_p99_ms": t["p99"], "tick_max_ms": t["max"],
            "ticks_over_1ms": t["over_budget"], "cpu_p99_ms": cpu["p99"], "cpu_max_ms": cpu["max"],
            "cpu_over_1ms": cpu["over_budget"], "realtime_factor": ticks * sim.dt / wall,
            "force_jump_max_n": jump["max"], "force_jump_p99_n": jump["p99"],
            "force_jump_after_cut_n": jump["max_after_cut"] if jump["max_after_cut"] is not None else "",
            "cut_ticks": jump["cut_ticks"],
            **cut_quality(cut if background else sim.cutter.metrics(sim.positions) if cutting != "no" else None,
                          sim, triangles),
            **(worker if background else dict.fromkeys(WORKER_COLUMNS, ""))}


def _timed(fn, *args) -> tuple[float, float]:
    """(wall, CPU) seconds of ``fn(*args)``."""
    wall, cpu = time.perf_counter(), time.thread_time()
    fn(*args)
    return time.perf_counter() - wall, time.thread_time() - cpu


def _single_calls(sim, poses) -> None:
    for tool in poses:
        sim.step(tool=tool)


def call_overhead(spacing: float, chunk: int, repeats: int) -> dict:
    """Per-step time of single-step calls over that of batched calls, no cutting.

    Two simulators step the same poses in lockstep; in each repeat one makes ``chunk``
    single-step calls (a new Tool each) and the other one ``step(chunk, tool=...)`` call with
    a callable handing out the same Tools (the cheapest way to give a batched call a new pose
    per step: a ToolPath's interpolation costs ~10 us a step more). The roles swap every
    repeat, so neither simulator's memory placement favours one side.
    """
    model = wc.TissueModel.from_patch(size=(0.10, 0.06), spacing=spacing)
    warm = APPROACH_TICKS + 50  # past first contact: the steady cutting-speed regime
    poses = tools(warm + repeats * chunk + 1, curved=False)
    sims = [wc.Simulator(model, dt=1e-3), wc.Simulator(model, dt=1e-3)]

    def pose(t):  # the pose for the end of the step ending at t [s]
        return poses[max(round(t * 1e3) - 1, 0)]

    for sim in sims:
        sim.step(warm, tool=pose)
    samples = {"single": [], "batched": []}
    with frozen_gc():
        for r in range(repeats):
            single, batched = sims[r % 2], sims[1 - r % 2]
            k = warm + r * chunk
            samples["single"].append(_timed(_single_calls, single, poses[k:k + chunk]))
            samples["batched"].append(_timed(batched.step, chunk, pose))
    s, b = (np.array(samples[k]) / chunk for k in ("single", "batched"))
    assert np.allclose(sims[0].positions, sims[1].positions, atol=1e-7), "the two loops diverged"
    return {"spacing_mm": spacing * 1e3, "nodes": model.node_count, "steps_per_sample": chunk,
            "repeats": repeats, "per_call_ms": float(np.median(s[:, 0]) * 1e3),
            "batched_ms": float(np.median(b[:, 0]) * 1e3),
            "ratio_wall": float(np.median(s[:, 0]) / np.median(b[:, 0])),
            "ratio_cpu": float(np.median(s[:, 1]) / np.median(b[:, 1])),
            "per_call_cpu_ms": float(np.median(s[:, 1]) * 1e3),
            "batched_cpu_ms": float(np.median(b[:, 1]) * 1e3)}


def cut_quality(metrics: dict | None, sim, first_new_triangle: int) -> dict:
    """Cut events, incisions, holes left open, coverage and the lips' largest in-plane
    deviation from the cut's metrics; slivers (< 10 deg) among the triangles the cut made."""
    if metrics is None:
        return dict.fromkeys(QUALITY_COLUMNS, "") | {"cut_events": 0}
    slivers, _ = new_slivers(sim.model, sim.positions, first_new_triangle)
    return {"cut_events": metrics["cut"]["events"], "incisions": metrics["cut"]["incisions"],
            "unfilled_holes": metrics["cut"]["unfilled_holes"], "coverage": metrics["incision"]["coverage"],
            "lip_deviation_mm": 1e3 * metrics["incision"]["max_deviation_m"], "slivers": slivers}


QUALITY_COLUMNS = ["cut_events", "incisions", "unfilled_holes", "coverage", "lip_deviation_mm", "slivers"]


WORKER_COLUMNS = ["worker_event_p50_ms", "edit_lag_p50_steps", "edit_lag_max_steps",
                  "loop_send_p99_ms", "loop_receive_p99_ms", "loop_apply_p99_ms"]
"""Background rows: the worker's time per event, the steps from an event to its edit, and
the loop's share of an event (send, receive, apply: one step each)."""
TICK_COLUMNS = ["path", "spacing_mm", "nodes", "nodes_end", "cutting", "setup_s", "substeps", "tick_first_ms",
                "tick_p50_ms", "tick_p99_ms", "tick_max_ms", "ticks_over_1ms", "cpu_p99_ms", "cpu_max_ms",
                "cpu_over_1ms", "realtime_factor", "force_jump_max_n", "force_jump_p99_n",
                "force_jump_after_cut_n", "cut_ticks", *QUALITY_COLUMNS, *WORKER_COLUMNS,
                "tick_p99_range_ms", "repeats"]


def run(quick: bool = False, cpu: int | None = None, repeats: int = 3):
    with pinned_to(cpu) as pinned:
        return _run(quick, pinned, 1 if quick else repeats)


UNPINNED_CUTTING = ("no", "background")
"""The rows of the unpinned run: the loop alone, and with the cut in a worker at 1 kHz."""


def run_unpinned(quick: bool = False, repeats: int = 3):
    """The loop with the cut in a worker, paced at 1 kHz, not pinned: the loop's thread and the
    worker go wherever the operating system puts them (results/haptic_unpinned.md)."""
    return _run(quick, None, 1 if quick else repeats, cuttings=UNPINNED_CUTTING, name="haptic_unpinned")


def median_row(runs: list[dict]) -> dict:
    """The median of each numeric column over repeated runs of one configuration, and the
    range of the tick p99 (`tick_p99_range_ms`)."""
    row = dict(runs[0])
    for key, value in row.items():
        values = [r[key] for r in runs]
        if isinstance(value, (int, float)) and not isinstance(value, bool) and all(
                isinstance(v, (int, float)) for v in values):
            row[key] = float(np.median(values))
    p99 = [r["tick_p99_ms"] for r in runs]
    row["tick_p99_range_ms"] = f"{min(p99):.3g}-{max(p99):.3g}"
    row["repeats"] = len(runs)
    return row


def _run(quick: bool, pinned: int | None, repeats: int, cuttings=tuple(CUTTING), name: str = "haptic"):
    load_before = os.getloadavg()
    spacings = (0.002,) if quick else (0.002, 0.001)
    ticks = 600 if quick else 2200
    rows = []
    for spacing in spacings:
        for curved in (False, True):
            for cutting in cuttings:
                row = median_row([tick_run(spacing, curved, cutting, ticks) for _ in range(repeats)])
                rows.append(row)
                print(f"  {row['path']} {row['spacing_mm']:g} mm cutting={row['cutting']}: tick p50 "
                      f"{row['tick_p50_ms']:.3f} p99 {row['tick_p99_ms']:.2f} max {row['tick_max_ms']:.1f} ms, "
                      f"{row['ticks_over_1ms']} over 1 ms (cpu p99 {row['cpu_p99_ms']:.2f}), "
                      f"force jump {row['force_jump_max_n']:.3g} N", flush=True)
    overhead = [call_overhead(s, chunk=100 if quick else 150, repeats=5 if quick else 11)
                for s in spacings] if name == "haptic" else []
    for o in overhead:
        print(f"  per-call / batched at {o['spacing_mm']:g} mm: {o['ratio_wall']:.3f} wall, "
              f"{o['ratio_cpu']:.3f} cpu ({o['per_call_ms']:.3f} vs {o['batched_ms']:.3f} ms)", flush=True)
    load_after = os.getloadavg()
    write_csv(name, rows)
    if overhead:
        write_csv("haptic_call_overhead", overhead)
    title = "Haptic rate: the README's 1 kHz loop" + ("" if pinned is not None else ", not pinned")
    write_markdown(name, title, _report(rows, overhead, pinned, load_before, load_after))
    return rows, overhead


def _report(rows, overhead, pinned, load_before, load_after) -> str:
    where = (f"Pinned to CPU {pinned} of {os.cpu_count()}" if pinned is not None else
             f"Not pinned: the loop's thread and the worker run wherever the system puts them on its "
             f"{os.cpu_count()} CPUs")
    load = (f"{where}; load average (1, 5, 15 min) "
            f"{', '.join(f'{v:.2f}' for v in load_before)} before and "
            f"{', '.join(f'{v:.2f}' for v in load_after)} after: a load above 1 per core means "
            "other processes shared the CPU, which shows as wall time above CPU time.")
    return "\n\n".join([
        "Medians over `repeats` runs of each row (`tick_p99_range_ms`: the p99's range). "
        "One `sim.step(tool=wc.Tool(...))` per 1 ms tick, timed around the call (wall time, and the "
        "thread's CPU time `cpu_*`); budget 1 ms. Percentiles, max and counts over the ticks after "
        "the first (`tick_first_ms`: it loads the kernels and records the launches). 200 ticks "
        "going 8 mm in, then 2 cm/s along x (straight, or on y = 8 mm sin(pi x / 2 cm)); "
        "collector frozen after set-up (`setup_s`: making the Simulator, with a background cut "
        "the worker's start). "
        "`force_jump_*`: tick-to-tick change of the tool force [N]; `_after_cut`: into the tick "
        "that follows a topology edit. `cutting`: no; in loop (the cut event runs inside the "
        "step of its tick); background (`Simulator(cutting=CutSettings(worker=True))`: a worker process "
        "runs the event, the loop only sends positions and applies the edit; the loop is paced "
        "at 1 kHz, so `realtime_factor` is at most 1; background, 3x pace: the same paced at 3 kHz "
        "(3 ticks per ms of wall time: 3x real time), never waiting for an edit; background, "
        "lag 50: the same with the loop as fast as it goes, waiting for an edit 50 steps after "
        "its event; `worker_event_p50_ms`: the worker's time "
        "per event; `edit_lag_*_steps`: steps from the event to its edit's application; `loop_*_p99_ms`: "
        "the loop's share of an event, sending it, receiving and applying its edit, each in a "
        "tick of its own).", load,
        markdown_table(rows, TICK_COLUMNS),
        *(["## Per-call overhead, no cutting\n\nSingle-step calls with a new Tool each against one "
           "`step(n, tool=callable)` call handing out the same Tools (two simulators in lockstep, "
           "past first contact, roles swapped every sample), median per-step time [ms] of "
           "interleaved samples, wall and CPU; target ratio <= 1.2.",
           markdown_table(overhead)] if overhead else []),
        "Command: `python benchmarks/bench_haptic.py" + (" --unpinned`." if pinned is None else
                                                          "` (part of `make bench`).")])


if __name__ == "__main__":
    args = pinned_cli(__doc__, "2 mm only, shorter loops", "runs per row; the table gives medians",
                      "the loop alone and with the cut in a worker, not pinned (results/haptic_unpinned.md)")
    if args.unpinned:
        run_unpinned(quick=args.quick, repeats=args.repeats)
    else:
        run(quick=args.quick, cpu=args.cpu, repeats=args.repeats)
