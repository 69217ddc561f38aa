"""Command line: ``warp-cut run``, ``warp-cut validate``.

Exit codes: 0 success, 2 bad input (nothing written), 3 simulation unstable (nothing written).
"""

from __future__ import annotations

import argparse
import os
import sys

from .errors import InputError, SimulationUnstable

__all__ = ["main"]

EXIT_OK, EXIT_BAD_INPUT, EXIT_UNSTABLE = 0, 2, 3


def _quiet_warp() -> None:
    import warp as wp

    if hasattr(wp, "LOG_WARNING"):
        wp.config.log_level = wp.LOG_WARNING
    else:  # older Warp
        wp.config.quiet = True


def _cmd_run(args) -> int:
    from .runner import run_scene, write_outputs
    from .scene import load_scene

    scene = load_scene(args.scene, args.set)
    out = args.out or os.path.join("out", scene.name)
    if os.path.exists(out) and not os.path.isdir(out):
        raise InputError(f"--out {out}: exists and is not a directory")
    result = run_scene(scene, quiet=args.quiet)
    written = write_outputs(result, out)
    if not args.quiet:
        m = result.metrics
        print(f"{scene.name}: {m['nodes']} nodes, {m['springs']} springs, {m['steps']} steps of "
              f"{m['dt']:.3g} s x {m['substeps']} substeps, {m['wall_time_s']:.2f} s wall "
              f"({m['realtime_factor']:.2f}x real time)")
        for path in written:
            print(f"  wrote {path}")
    return EXIT_OK


def _cmd_validate(args) -> int:
    from .runner import prepare_simulation
    from .scene import load_scene

    scene = load_scene(args.scene, args.set)
    model, sim, _, steps_per_frame = prepare_simulation(scene)
    print(f"{scene.path}: ok ({model.node_count} nodes, {model.spring_count} springs, "
          f"{scene.frame_count} frames x {steps_per_frame} steps of {sim.dt:.3g} s, "
          f"{sim.substeps} substeps; stable step {sim.step_limit.step:.3g} s)")
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="warp-cut", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene and write metrics and time series")
    run.add_argument("scene", nargs="?", default=None,
                     help="scene file or bundled scene name (default: the default scene)")
    run.add_argument("--out", help="output directory (default: out/<scene name>)")
    run.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                     help="override a scene key (TOML value syntax); repeatable")
    run.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    run.set_defaults(func=_cmd_run)
    val = sub.add_parser("validate", help="check a scene without running it")
    val.add_argument("scene")
    val.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE")
    val.set_defaults(func=_cmd_validate)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    _quiet_warp()
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
