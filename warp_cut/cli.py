"""Command line: ``warp-cut run``, ``warp-cut validate``, ``warp-cut batch``, ``warp-cut live``, ...

Exit codes: 0 success, 1 a check found problems (``usd-check``) or a batch scenario failed,
was unstable or was lost, 2 bad input (nothing written), 3 simulation unstable (nothing
written), 130 a batch was interrupted (finished scenarios kept).
"""

from __future__ import annotations

import argparse
import os
import sys

from .batch.pool import run_batch
from .batch.report import plot_results
from .batch.sweep import load_sweep
from .errors import InputError, SimulationUnstable
from .experiments import mean_abs_error_pct, run_experiment, write_report
from .experiments import wound as fracture
from .io.usd_check import check_usd, validate_usd
from .io.usd_export import DEFAULT_CHUNK_FRAMES, flatten_usd
from .live.app import LiveApp, PlayerApp, serve
from .live.engine import LiveCut
from .live.playback import RunPlayback
from .live.server import check_port, import_viser
from .runner import prepare_simulation, run_to_directory
from .scene import load_scene
from .sim.warp_config import quiet_warp

__all__ = ["main"]

EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_UNSTABLE = 0, 1, 2, 3
EXIT_SOME_FAILED, EXIT_INTERRUPTED = 1, 130


def _cmd_run(args) -> int:
    """``warp-cut run``: run a scene; write metrics, time series, pictures and (unless --no-usd) USD."""
    scene = load_scene(args.scene, args.set)
    out = args.out or os.path.join("out", scene.name)
    result, written = run_to_directory(scene, out, usd=not args.no_usd, usd_path=args.usd,
                                       usd_chunk=args.usd_chunk, quiet=args.quiet,
                                       cut_in_background=args.cut_in_background, pace=args.pace,
                                       max_lag=args.max_lag)
    if not args.quiet:
        m = result.metrics
        print(f"{scene.name}: {m['nodes']} nodes, {m['springs']} springs, {m['steps']} steps of "
              f"{m['dt']:.3g} s x {m['substeps']} substeps, {m['wall_time_s']:.2f} s wall "
              f"({m['realtime_factor']:.2f}x real time)")
        ticks = m.get("tick_ms")
        if ticks and ticks["p50"] is not None:
            print(f"  ticks: p50 {ticks['p50']:.3f} ms, p99 {ticks['p99']:.3f} ms, max {ticks['max']:.3f} ms, "
                  f"{ticks['over_budget']} of {ticks['ticks']} over the {ticks['budget_ms']:.3g} ms budget")
        for path in written:
            print(f"  wrote {path}")
    return EXIT_OK


def _cmd_validate(args) -> int:
    """``warp-cut validate``: load a scene and set it up without running it."""
    scene = load_scene(args.scene, args.set)
    model, sim, _, steps_per_frame = prepare_simulation(scene)
    print(f"{scene.path}: ok ({model.node_count} nodes, {model.spring_count} springs, "
          f"{scene.frame_count} frames x {steps_per_frame} steps of {sim.dt:.3g} s, "
          f"{sim.substeps} substeps; stable step {sim.step_limit.step:.3g} s)")
    return EXIT_OK


def _cmd_usd_check(args) -> int:
    """``warp-cut usd-check``: check USD files; exit 1 if any has a problem."""
    bad = 0
    for path in args.paths:
        if not os.path.isfile(path):
            raise InputError(f"{path}: file not found")
        problems = check_usd(path) + [f"{path}: {m}" for m in validate_usd(path)]
        for p in problems:
            print(p)
        if not problems:
            print(f"{path}: ok")
        bad += bool(problems)
    return EXIT_CHECK_FAILED if bad else EXIT_OK


def _cmd_usd_flatten(args) -> int:
    """``warp-cut usd-flatten``: resolve an export's chunk files into one USD file."""
    print(f"wrote {flatten_usd(args.source, args.target)}")
    return EXIT_OK


def _cmd_experiment_collision(args) -> int:
    """``warp-cut experiment collision``: the paper's collision experiment (Table 2, Fig. 7)."""
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise InputError(f"--out {args.out}: exists and is not a directory")
    cases = run_experiment(args.angles, args.speeds, t0=args.t0, rate=args.rate)
    written = write_report(args.out, cases, args.rate)
    if not args.quiet:
        for speed in sorted({c.speed_m_s for c in cases}):
            group = [c for c in cases if c.speed_m_s == speed]
            print(f"speed {speed:g} m/s: mean relative error of the first-contact time "
                  f"{mean_abs_error_pct(group, 'discrete'):.3g} % per step at {args.rate:g} Hz, "
                  f"{mean_abs_error_pct(group, 'ccd'):.3g} % continuous (paper: 0.05 %)")
        for path in written:
            print(f"  wrote {path}")
    return EXIT_OK


def _cmd_experiment_wound(args) -> int:
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise InputError(f"--out {args.out}: exists and is not a directory")
    scene = load_scene(args.scene, args.set)  # a bad scene is refused before the long part
    comparisons = fracture.run_experiment(scene, quick=args.quick)
    written = fracture.write_report(args.out, comparisons)
    if not args.quiet:
        for c in comparisons:
            print(f"{c.label}: centre {c.centre_ratio():.3f} x closed form, max error "
                  f"{100 * c.max_error():.1f} % over the middle 80 % ({c.setup})")
        for path in written:
            print(f"  wrote {path}")
    return EXIT_OK


def _cmd_batch(args) -> int:
    """``warp-cut batch``: run a sweep; exit 1 if a scenario failed, 130 if interrupted."""
    if args.workers is not None and args.scheduler:
        raise InputError("--workers sizes the local pool; with --scheduler the cluster's "
                         "workers run the scenarios: give one of the two")
    sweep = load_sweep(args.sweep)
    out = args.out or os.path.join("out", sweep.path.stem)
    try:
        summary = run_batch(sweep, out, workers=args.workers, scheduler=args.scheduler,
                            retry_failed=args.retry_failed, progress=not args.quiet,
                            usd=not args.no_usd)
    except KeyboardInterrupt:
        print(f"warp-cut: interrupted; finished scenarios are kept in {out}; run the same "
              "command again to run the rest", file=sys.stderr)
        return EXIT_INTERRUPTED
    print(f"{summary.line()} -> {os.path.join(out, 'results.csv')}")
    for scenario_id, message in summary.lost:
        print(f"  lost {scenario_id}: {message}", file=sys.stderr)
    if args.plot:
        _cmd_report(argparse.Namespace(dir=out))
    return EXIT_OK if summary.all_ok else EXIT_SOME_FAILED


def _cmd_report(args) -> int:
    """``warp-cut report``: plots of a batch directory."""
    for path in plot_results(args.dir):
        print(f"  wrote {path}")
    return EXIT_OK


def _cmd_live(args) -> int:
    """Cut live in a browser page until Ctrl-C."""
    import_viser()
    check_port(args.host, args.port)  # before the simulation is built
    live = LiveCut(args.scene, args.set, speed=1e-3 * args.speed,
                   cut_in_background=args.cut_in_background)
    try:
        app = LiveApp(live, host=args.host, port=args.port, out_dir=args.out)
        serve(app, f"live cutting of {live.scene.name}")
    finally:
        live.close()
    return EXIT_OK


def _cmd_view(args) -> int:
    """Replay a finished run in a browser page until Ctrl-C."""
    import_viser()
    check_port(args.host, args.port)
    playback = RunPlayback(args.run)
    serve(PlayerApp(playback, host=args.host, port=args.port),
          f"replay of {playback.path} ({playback.frame_count} frames)")
    return EXIT_OK


def _add_overrides(parser) -> None:
    """The ``--set SECTION.KEY=VALUE`` option (``load_scene``'s overrides)."""
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a scene key (TOML value syntax); repeatable")


def _add_server_options(parser) -> None:
    parser.add_argument("--port", type=int, default=0,
                        help="port of the page (default 0: any free port; a taken port is an error)")
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to listen on (default 127.0.0.1, this machine only)")


def _numbers(text: str) -> list[float]:
    """Comma-separated numbers of an option, e.g. ``--angles 30,40``."""
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None
    if not values:
        raise argparse.ArgumentTypeError("expected at least one number")
    return values


def _add_run(sub) -> None:
    """The ``run`` and ``validate`` commands."""
    run = sub.add_parser("run", help="run a scene and write metrics and time series")
    run.add_argument("scene", nargs="?", default=None,
                     help="scene file or bundled scene name (default: the default scene)")
    run.add_argument("--out", help="output directory (default: out/<scene name>)")
    _add_overrides(run)
    run.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    usd = run.add_mutually_exclusive_group()
    usd.add_argument("--usd", metavar="PATH",
                     help="USD playback file (.usdc, or .usda for small debug runs; "
                          "default: OUT/<scene name>.usdc)")
    usd.add_argument("--no-usd", action="store_true", help="do not write USD")
    run.add_argument("--usd-chunk", type=int, default=DEFAULT_CHUNK_FRAMES, metavar="FRAMES",
                     help="frames per USD chunk file: memory held, and the most a killed run "
                          f"loses (default {DEFAULT_CHUNK_FRAMES})")
    run.add_argument("--cut-in-background", action="store_true",
                     help="cut in a worker process with the run paced at real time, as a live "
                          "1 kHz loop runs it (the cut then trails the tool by the worker's time; "
                          "without it the cut runs in the step and the run is reproducible)")
    run.add_argument("--pace", type=float, default=1.0, metavar="X",
                     help="with --cut-in-background: run X times faster than real time, every "
                          "step in 1/X of its dt of wall time (0 < X <= 1000; default 1)")
    run.add_argument("--max-lag", type=int, default=None, metavar="N",
                     help="with --cut-in-background: wait for a cut event's edit once it is N steps "
                          "in flight (N >= 1; default: never wait); 1 makes the run's wound the same "
                          "every time")
    run.set_defaults(func=_cmd_run)
    val = sub.add_parser("validate", help="check a scene without running it")
    val.add_argument("scene")
    _add_overrides(val)
    val.set_defaults(func=_cmd_validate)


def _add_usd(sub) -> None:
    """The ``usd-check`` and ``usd-flatten`` commands."""
    chk = sub.add_parser("usd-check", help="check exported USD files time sample by time sample "
                                           "(exit 1 if a problem is found)")
    chk.add_argument("paths", nargs="+", metavar="FILE")
    chk.set_defaults(func=_cmd_usd_check)
    flat = sub.add_parser("usd-flatten", help="resolve an export's chunk files into one USD file")
    flat.add_argument("source")
    flat.add_argument("target")
    flat.set_defaults(func=_cmd_usd_flatten)


def _add_experiment(sub) -> None:
    """The ``experiment collision`` command."""
    exp = sub.add_parser("experiment", help="run one of the paper's experiments")
    exps = exp.add_subparsers(dest="experiment", required=True)
    col = exps.add_parser("collision", help="first-contact time and point at several cutting "
                                            "angles (paper Table 2, Fig. 7)")
    col.add_argument("--out", default=os.path.join("out", "collision"),
                     help="output directory (default: out/collision)")
    col.add_argument("--angles", type=_numbers, default=[30.0, 40.0, 50.0, 60.0, 70.0],
                     help="cutting angles in (0, 90] deg, comma-separated (default 30,40,50,60,70)")
    col.add_argument("--speeds", type=_numbers, default=[0.01],
                     help="approach speeds in (0, 100] m/s, comma-separated (default 0.01)")
    col.add_argument("--t0", type=float, default=2.0,
                     help="analytic first-contact time [s] (default 2.0, as in the paper)")
    col.add_argument("--rate", type=float, default=1000.0,
                     help="simulation steps per second, the per-step test's rate (default 1000)")
    col.add_argument("--quiet", action="store_true", help="no summary")
    col.set_defaults(func=_cmd_experiment_collision)
    wnd = exps.add_parser("wound", help="the opening of a cut in a prestressed sheet against linear "
                                        "elastic fracture mechanics (docs/wound.md)")
    wnd.add_argument("--out", default=os.path.join("out", "wound"),
                     help="output directory (default: out/wound)")
    wnd.add_argument("--scene", default="wound_gape",
                     help="the scene whose straight cut is compared (default: wound_gape)")
    _add_overrides(wnd)
    wnd.add_argument("--quick", action="store_true",
                     help="only the exact-slit checks (no run of the scene)")
    wnd.add_argument("--quiet", action="store_true", help="no summary")
    wnd.set_defaults(func=_cmd_experiment_wound)


def _add_batch(sub) -> None:
    """The ``batch`` and ``report`` commands."""
    bat = sub.add_parser("batch", help="run the scenarios of a sweep file; write results.csv")
    bat.add_argument("sweep", help="sweep file (TOML) or bundled sweep name")
    bat.add_argument("--out", help="output directory (default: out/<sweep name>)")
    bat.add_argument("--workers", type=int, help="local processes (default: number of cores)")
    bat.add_argument("--scheduler", metavar="ADDRESS",
                     help="Dask scheduler, e.g. tcp://host:8786 (needs warp-cut[cluster])")
    bat.add_argument("--retry-failed", action="store_true",
                     help="run failed and unstable scenarios again (finished ones are kept)")
    bat.add_argument("--no-usd", action="store_true", help="runs write no USD (warp-cut run --no-usd)")
    bat.add_argument("--plot", action="store_true", help="draw metrics against parameters")
    bat.add_argument("--quiet", action="store_true", help="no progress output")
    bat.set_defaults(func=_cmd_batch)
    live = sub.add_parser("live", help="cut live in a browser page: drag the scalpel, watch the "
                                       "wound open, save the run (needs the live extra)")
    live.add_argument("scene", nargs="?", default=None,
                      help="scene file or bundled scene name with a [tool] (default: the default scene)")
    _add_overrides(live)
    live.add_argument("--out", help="default directory of the page's save button "
                                    "(default: out/<scene name>_live)")
    live.add_argument("--cut-in-background", action="store_true",
                      help="run each cut event in a worker process, so that it does not stall "
                           "the real-time loop (see docs/haptic.md)")
    live.add_argument("--speed", type=float, default=20.0,
                      help="largest scalpel tip speed [mm/s] (default 20)")
    _add_server_options(live)
    live.set_defaults(func=_cmd_live)
    view = sub.add_parser("view", help="replay a finished run (its USD) in a browser page "
                                       "(needs the live extra)")
    view.add_argument("run", metavar="OUT_DIR", help="output directory of warp-cut run (or a USD file)")
    _add_server_options(view)
    view.set_defaults(func=_cmd_view)
    rep = sub.add_parser("report", help="draw a batch's metrics against its parameters (PNG)")
    rep.add_argument("dir", help="batch output directory (holds results.csv)")
    rep.set_defaults(func=_cmd_report)


def build_parser() -> argparse.ArgumentParser:
    """The ``warp-cut`` argument parser with every command."""
    parser = argparse.ArgumentParser(prog="warp-cut", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for add in (_add_run, _add_usd, _add_experiment, _add_batch):
        add(sub)
    return parser


def main(argv=None) -> int:
    """Run the ``warp-cut`` command line.

    Args:
        argv: The arguments (default ``sys.argv[1:]``).

    Returns:
        The exit code: 0 success, 1 a check found problems or a batch scenario failed, 2 bad
        input, 3 simulation unstable, 130 a batch was interrupted.
    """
    args = build_parser().parse_args(argv)
    quiet_warp()
    try:
        return args.func(args)
    except InputError as exc:
        print(f"warp-cut: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except SimulationUnstable as exc:
        print(f"warp-cut: {exc}", file=sys.stderr)
        return EXIT_UNSTABLE


if __name__ == "__main__":
    sys.exit(main())
