"""USD export cost: size on disk, write time and memory of a 10k-node, 600-frame export.

The exporter is driven directly by a deforming patch (a travelling bump, the tool gliding
over it, a mid-run topology edit and class change), so the numbers measure USD writing alone.
Results: benchmarks/results/usd_export.json and .md. Usage:

    python benchmarks/bench_usd.py [--nodes 10000] [--frames 600] [--chunk 100]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from warp_cut import Material, TissueModel, Tool
from warp_cut.cut.classes import NodeClass
from warp_cut.io.files import atomic_path
from warp_cut.io.usd_check import check_usd, validate_usd
from warp_cut.io.usd_export import UsdRecorder

RESULTS = Path(__file__).parent / "results"


def _rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _patch(nodes: int) -> SimpleNamespace:
    """The attributes the exporter reads, as plain arrays the benchmark edits."""
    side = 0.002 * math.sqrt(nodes / 1.15)  # the patch generator's node density at 2 mm
    patch = TissueModel.from_patch((side, side), 0.002, material=Material())
    n = patch.node_count
    return SimpleNamespace(points=patch.points.copy(), triangles=patch.triangles.copy(),
                           active=np.ones(n, bool), node_class=np.zeros(n, np.int8),
                           node_count=n, topology_version=0)


def run(nodes: int, frames: int, chunk: int, fps: float = 60.0) -> dict:
    import pxr.Usd  # noqa: F401 - a one-off import cost, not part of writing

    model = _patch(nodes)
    rest = model.points.astype(np.float32)
    tmp = Path(tempfile.mkdtemp(prefix="bench_usd_"))
    path = tmp / "bench.usdc"
    rec = UsdRecorder(path, fps=fps, tool_radius=0.001, chunk_frames=chunk)
    rss, start = [], time.perf_counter()
    for frame in range(frames):
        t = frame / fps
        x = rest.copy()
        centre = np.array([0.02 * math.sin(t), 0.0], np.float32)
        x[:, 2] = -0.003 * np.exp(-np.sum((x[:, :2] - centre) ** 2, axis=1) / 1e-4)
        if frame == frames // 2:  # a topology edit: drop a strip of triangles, classes change
            strip = np.abs(model.points[model.triangles].mean(axis=1)[:, 1]) < 0.002
            model.triangles = model.triangles[~strip]
            model.node_class[np.unique(model.triangles)[:50]] = NodeClass.GREY
            model.topology_version += 1
        tool = Tool([centre[0], 0, 0.001], [centre[0] + 0.03, 0, 0.02], 0.001)
        sim = SimpleNamespace(model=model, state=SimpleNamespace(positions=SimpleNamespace(numpy=lambda x=x: x)),
                              time=t, incision_controls=None, tool_pose=tool, substep=1e-3,
                              step_limit=SimpleNamespace(step=1e-3))
        rec.on_frame(sim, frame)
        if frame % chunk == chunk - 1:
            rss.append(_rss_mb())
    rec.finish()
    wall = time.perf_counter() - start
    files = [path] + sorted(rec.clip_dir.iterdir())
    size = sum(f.stat().st_size for f in files)
    t0 = time.perf_counter()
    problems = check_usd(path) + validate_usd(path)
    check_time = time.perf_counter() - t0
    for f in files:
        f.unlink()
    rec.clip_dir.rmdir()
    tmp.rmdir()
    return {"nodes": model.node_count, "frames": frames,
            "chunk_frames": chunk, "files": len(files), "bytes": size,
            "mb": size / 2**20, "bytes_per_node_frame": size / (model.node_count * frames),
            "write_time_s": rec.write_time, "loop_time_s": wall,
            "write_ms_per_frame": 1e3 * rec.write_time / frames,
            "rss_mb_after_each_chunk": [round(v, 1) for v in rss],
            "check_and_validate_time_s": check_time, "problems": problems}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, default=10_000)
    p.add_argument("--frames", type=int, default=600)
    p.add_argument("--chunk", type=int, default=100)
    args = p.parse_args(argv)
    result = run(args.nodes, args.frames, args.chunk)
    from pxr import Usd

    result["machine"] = {"python": sys.version.split()[0], "platform": platform.platform(),
                         "processor": platform.processor() or platform.machine(),
                         "usd": "{1}.{2}".format(*Usd.GetVersion())}
    with atomic_path(RESULTS / "usd_export.json") as tmp:
        tmp.write_text(json.dumps(result, indent=2) + "\n")
    rss = result["rss_mb_after_each_chunk"]
    md = (f"# USD export: {result['nodes']} nodes x {result['frames']} frames\n\n"
          f"| quantity | value |\n|---|---|\n"
          f"| files (top-level + manifest + chunks of {result['chunk_frames']} frames) | {result['files']} |\n"
          f"| size on disk | {result['mb']:.1f} MiB ({result['bytes_per_node_frame']:.1f} bytes per node and frame) |\n"
          f"| write time | {result['write_time_s']:.2f} s ({result['write_ms_per_frame']:.2f} ms per frame) |\n"
          f"| resident memory after each chunk | {rss[0]:.0f} ... {rss[-1]:.0f} MiB |\n"
          f"| usd-check + UsdValidation | {result['check_and_validate_time_s']:.1f} s, "
          f"{len(result['problems'])} problems |\n\n"
          f"Command: `python benchmarks/bench_usd.py --nodes {args.nodes} --frames {args.frames} "
          f"--chunk {args.chunk}`; {result['machine']['platform']}, usd-core {result['machine']['usd']}.\n")
    with atomic_path(RESULTS / "usd_export.md") as tmp:
        tmp.write_text(md)
    print(md)
    return 0 if not result["problems"] else 1


if __name__ == "__main__":
    sys.exit(main())
