"""A fixed-rate 1 kHz haptic loop on warp_cut: read the device pose, step once, send the force.

    python examples/haptic_loop.py [--ticks N] [--trace FILE] [--no-cut | --cut-in-loop]
                                   [--max-lag N] [--write-trace FILE]

A haptic device reports its stylus pose every millisecond and wants a force back before the
next tick. This loop stands in for the device with a trace of poses: a CSV file recorded from
a device (``--trace``), or the scripted README cut (the default: 0.2 s going 8 mm into the
skin along the blade's axis, then 2 cm/s along x). Each tick it

1. turns the pose (tip position and orientation quaternion) into a ``wc.Tool``,
2. calls ``sim.step(tool=...)`` once (one 1 ms step),
3. takes ``sim.tool_force``, the tissue's reaction on the tool: what it would send,
4. sleeps, then spins, until the tick's deadline.

The cut runs in a worker process (``Simulator(cutting=CutSettings(worker=True))``): a cut event's host
work (milliseconds) would otherwise land in one tick; ``--cut-in-loop`` runs it in the step, to
compare; ``--max-lag N`` makes a tick wait for an edit N steps after its event (1: the edits
land on the same ticks every run, whatever the machine's load, at the price of late ticks). A
tick that ends after its deadline is a missed deadline (the device would have held the last
force): it is printed with its duration and force, and the schedule moves on to the next tick
boundary. The summary gives the tick percentiles and the largest tick-to-tick force change.

Trace CSV: a header, then one row per tick: ``t`` [s], ``x, y, z`` tip position [m], ``qw, qx,
qy, qz`` the stylus orientation (unit quaternion rotating the stylus frame into the world; the
blade's axis from tip to handle is the stylus +z). ``--write-trace FILE`` writes the scripted
trace in this format as a starting point.
"""

from __future__ import annotations

import argparse
import csv
import gc
import sys
import time
from pathlib import Path

import numpy as np

import warp_cut as wc
from warp_cut.ticks import wait_until

PERIOD = 1e-3
"""The haptic tick [s]: one step of dt = 1 ms per tick."""
BLADE_LENGTH = 0.04
"""Tool length from the tip along its axis [m]."""
BLADE_RADIUS = 0.001
"""Tool radius [m]."""
SPIN = 2e-4
"""Time before a deadline [s] spent spinning instead of sleeping (sleep wakes up late)."""
COLUMNS = ["t", "x", "y", "z", "qw", "qx", "qy", "qz"]


def axis_quaternion(axis) -> np.ndarray:
    """The unit quaternion (w, x, y, z) turning +z onto ``axis``."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    z = np.array([0.0, 0.0, 1.0])
    q = np.concatenate([[1.0 + a @ z], np.cross(z, a)])
    if q[0] < 1e-12:  # axis = -z: half a turn about x
        return np.array([0.0, 1.0, 0.0, 0.0])
    return q / np.linalg.norm(q)


def rotate_z(q) -> np.ndarray:
    """The stylus +z axis in world coordinates for the unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])


def scripted_trace(ticks: int) -> np.ndarray:
    """The README's cut as a device trace, (ticks, 8): t, tip x y z [m], quaternion."""
    axis = np.array([-0.5, 0.0, 0.866])  # the blade leaning back 60 degrees
    q = axis_quaternion(axis)
    rows = np.empty((ticks, 8))
    for k in range(ticks):
        depth = min(k, 200) / 200 * 0.008
        tip = np.array([-0.02, 0.0, 0.004]) - depth / 0.866 * axis + [2e-5 * max(k - 200, 0), 0, 0]
        rows[k] = [(k + 1) * PERIOD, *tip, *q]
    return rows


def read_trace(path: Path) -> np.ndarray:
    """A trace CSV (see the module doc) as an array (rows, 8). Raises ValueError naming the
    file and what is wrong."""
    try:
        with open(path, newline="") as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader, [])]
            if header != COLUMNS:
                raise ValueError(f"the header must be {','.join(COLUMNS)}, got {','.join(header) or 'nothing'}")
            rows = np.array([[float(v) for v in row] for row in reader if row], dtype=float)
    except OSError as error:
        raise ValueError(f"--trace {path}: {error.strerror}") from error
    except ValueError as error:
        raise ValueError(f"--trace {path}: {error}") from error
    if rows.ndim != 2 or rows.shape[1] != 8 or not np.all(np.isfinite(rows)):
        raise ValueError(f"--trace {path}: need one or more rows of 8 finite numbers ({','.join(COLUMNS)})")
    bad = np.flatnonzero(np.abs(np.linalg.norm(rows[:, 4:], axis=1) - 1.0) > 1e-3)
    if len(bad):
        raise ValueError(f"--trace {path}: data row {bad[0] + 1}: qw, qx, qy, qz is not a unit quaternion")
    return rows


def write_trace(path: Path, rows: np.ndarray) -> None:
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(COLUMNS)
        writer.writerows([f"{v:.9g}" for v in row] for row in rows)


def tool_from_pose(row: np.ndarray) -> wc.Tool:
    """The cylinder tool of one trace row: from the tip along the stylus +z."""
    tip = row[1:4]
    return wc.Tool(p0=tip, p1=tip + BLADE_LENGTH * rotate_z(row[4:]), radius=BLADE_RADIUS)


def report_miss(k: int, late: float, start_late: float, step: float, force: np.ndarray) -> None:
    """Print a missed deadline: by how much [s], how late the tick started (time the machine
    gave to other work, or a sleep that woke late) and how long the step took."""
    print(f"tick {k}: missed the deadline by {late * 1e3:.2f} ms (started {max(start_late, 0.0) * 1e3:.2f} ms "
          f"late, step {step * 1e3:.2f} ms), force {np.round(force, 4).tolist()} N")


def haptic_loop(sim: wc.Simulator, trace: np.ndarray, print_every: int, miss_lines: int = 50) -> dict:
    """Run one tick per trace row at 1 kHz. Returns the step times [s], forces [N] and the
    count of missed deadlines; prints the first ``miss_lines`` misses."""
    ticks = len(trace)
    step_s, forces, missed = np.zeros(ticks), np.zeros((ticks, 3)), 0
    start = time.perf_counter()
    deadline = start + PERIOD
    for k in range(ticks):
        tool = tool_from_pose(trace[k])  # in a real loop: read the device here
        begin = time.perf_counter()
        sim.step(tool=tool)
        force = sim.tool_force  # ... and send this force to the device here
        done = time.perf_counter()
        step_s[k], forces[k] = done - begin, force
        if done > deadline:
            missed += 1
            if missed <= miss_lines:
                report_miss(k, done - deadline, begin - (deadline - PERIOD), step_s[k], force)
            deadline += PERIOD * np.ceil((done - deadline) / PERIOD)  # the next tick boundary
        if print_every and k % print_every == 0:
            print(f"tick {k}: t = {sim.time:.3f} s, force {np.round(force, 4).tolist()} N")
        wait_until(deadline, SPIN)
        deadline += PERIOD
    if missed > miss_lines:
        print(f"... {missed - miss_lines} more missed deadlines not printed")
    return {"step_s": step_s, "forces": forces, "missed": missed,
            "wall_s": time.perf_counter() - start}


def summary(sim: wc.Simulator, run: dict) -> str:
    ms = run["step_s"] * 1e3
    jumps = np.linalg.norm(np.diff(run["forces"], axis=0), axis=1)
    lines = [f"{len(ms)} ticks in {run['wall_s']:.3f} s wall for {sim.time:.3f} s simulated; "
             f"{run['missed']} missed deadlines",
             f"step per tick: p50 {np.percentile(ms, 50):.3f} ms, p99 {np.percentile(ms, 99):.3f} ms, "
             f"max {ms.max():.3f} ms; {int(np.count_nonzero(ms > PERIOD * 1e3))} steps over {PERIOD * 1e3:g} ms",
             f"tool force: max {np.linalg.norm(run['forces'], axis=1).max():.4f} N, largest tick-to-tick "
             f"change {jumps.max() if len(jumps) else 0.0:.4f} N"]
    if sim.cutter is not None:
        lines.append(f"cut: {sim.model.topology_version} topology edits")
    return "summary: " + "\n         ".join(lines)


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description="A 1 kHz haptic loop on warp_cut, driven by a device trace.")
    parser.add_argument("--ticks", type=int, default=None,
                        help="timed ticks to run (default: the whole trace; the scripted one has 2200)")
    parser.add_argument("--trace", type=Path, default=None, help="trace CSV (default: the scripted README cut)")
    parser.add_argument("--no-cut", action="store_true", help="touch and press without cutting")
    parser.add_argument("--cut-in-loop", action="store_true",
                        help="run each cut event inside the step of its tick (default: in a worker process)")
    parser.add_argument("--max-lag", type=int, default=None, metavar="N",
                        help="with the cut in a worker: wait for an event's edit once it is N steps in flight "
                             "(default: never; 1: the same edits on the same ticks every run)")
    parser.add_argument("--write-trace", type=Path, default=None,
                        help="write the scripted trace to this CSV and exit")
    parser.add_argument("--print-every", type=int, default=250, help="print the force every N ticks (0: never)")
    parser.add_argument("--miss-lines", type=int, default=50, help="print at most this many missed deadlines")
    parser.add_argument("--spacing", type=float, default=0.002, help="mesh spacing [m] (default 0.002)")
    args = parser.parse_args(argv)
    if args.ticks is not None and args.ticks < 1:
        parser.error(f"--ticks must be >= 1, got {args.ticks}")
    if args.no_cut and args.cut_in_loop:
        parser.error("--no-cut and --cut-in-loop exclude each other")
    if args.max_lag is not None and (args.no_cut or args.cut_in_loop or args.max_lag < 1):
        parser.error(f"--max-lag must be >= 1 and needs the cut in a worker, got {args.max_lag}")
    if not 0.0005 <= args.spacing <= 0.01:
        parser.error(f"--spacing must be in [0.0005, 0.01] m, got {args.spacing}")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    if args.write_trace is not None:
        write_trace(args.write_trace, scripted_trace(args.ticks or 2200))
        print(f"wrote {args.write_trace}")
        return 0
    try:
        # one row more than --ticks: the first tick runs before the clock starts
        trace = read_trace(args.trace) if args.trace is not None else scripted_trace((args.ticks or 2199) + 1)
        trace = trace[: args.ticks + 1] if args.ticks else trace
        model = wc.TissueModel.from_patch(size=(0.10, 0.06), spacing=args.spacing)
        cutting = None if args.no_cut else wc.CutSettings(worker=not args.cut_in_loop, max_lag=args.max_lag)
        sim = wc.Simulator(model, dt=PERIOD, cutting=cutting)
    except (ValueError, wc.InputError) as error:  # a bad trace
        print(f"error: {error}", file=sys.stderr)
        return 2
    try:
        return run_ticks(sim, trace, args)
    finally:
        sim.close()  # stops the cut's worker process


def run_ticks(sim: wc.Simulator, trace: np.ndarray, args) -> int:
    """The untimed first tick, then the loop and its summary; exit code."""
    try:
        sim.step(tool=tool_from_pose(trace[0]))  # compile and record before the clock starts
    except wc.InputError as error:  # a trace starting inside the skin
        print(f"error: {error}", file=sys.stderr)
        return 2
    # A full garbage collection walks every object and takes tens of ms: collect now and
    # keep the set-up's objects out of later collections.
    gc.collect()
    gc.freeze()
    where = "off" if args.no_cut else ("in the loop" if args.cut_in_loop else "in a worker process")
    print(f"{sim.model.node_count} nodes, {sim.substeps} substep(s) per 1 ms tick, "
          f"cutting {where}: one untimed tick, then {len(trace) - 1} at 1 kHz")
    run = haptic_loop(sim, trace[1:], args.print_every, args.miss_lines)
    print(summary(sim, run))
    return 0


if __name__ == "__main__":
    sys.exit(main())
