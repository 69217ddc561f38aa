"""Throughput against mesh size: the warp_cut step versus its spring kernel alone, a vectorised
numpy step and Newton's SolverSemiImplicit, plus the implicit Euler and XPBD substeps.

Every row is one mesh; times are medians over interleaved repeats (so machine load hits all
implementations alike), ratios are taken repeat by repeat (both timings from the same
repeat) and reported as median (min-max).
"""

from __future__ import annotations

import numpy as np
import warp as wp
from common import interleaved, markdown_table, patch_for_springs, spread, write_csv, write_markdown
from newton_step import NewtonSemiImplicit, available
from numpy_step import NumpySemiImplicit

from warp_cut import Simulator, TissueModel, Tool
from warp_cut.kernels.springs import spring_forces

SIZES = {"skin patch 2 mm": None, "10k springs": 10_000, "100k springs": 100_000,
         "1M springs": 1_000_000}


def build(label):
    if SIZES[label] is None:
        return TissueModel.from_patch((0.10, 0.06), 0.002)
    size, spacing = patch_for_springs(SIZES[label])
    return TissueModel.from_patch(size, spacing)


def agreement(model, h=1e-5, steps=20):
    """max |x_warp - x_numpy| [m] after a few steps of the same step (gravity, no tool)."""
    sim = Simulator(model, dt=h, substeps=1)
    ref = NumpySemiImplicit(model)
    sim.step(steps)
    for _ in range(steps):
        ref.step(h)
    return float(np.abs(sim.positions - ref.x).max())


def run(repeats: int = 5, quick: bool = False):
    newton_missing = available()
    rows = []
    labels = list(SIZES)[:2] if quick else list(SIZES)
    for label in labels:
        model = build(label)
        S, N = model.spring_count, model.node_count
        h = 1e-5
        tool = Tool([0, 0, 0.005], [0.03, 0, 0.02], 0.001)
        sims = {}
        for name, integrator, replay in (("warp", "semi_implicit", "graph"),
                                         ("warp_plain", "semi_implicit", "launch"),
                                         ("implicit_euler", "implicit_euler", "auto"),
                                         ("xpbd", "xpbd", "auto")):
            sim = Simulator(model, dt=h, substeps=1, integrator=integrator)
            sim.solver.replay = replay
            sim.solver.topology_changed()
            sims[name] = sim

        def substep(sim, tool=tool, h=h):
            st = [sim.state, sim._next]

            def go():
                sim.solver.step(st[0], st[1], tool, h)
                st.reverse()
            return go

        solver = sims["warp"].solver
        indices, rest, stiff, count = solver.spring_arrays()
        state = sims["warp"].state
        spring_cmd = wp.launch(spring_forces, dim=solver.threads(count),
                               inputs=[state.positions, indices, rest, stiff, solver.chunk,
                                       count, state.forces], record_cmd=True)

        fns = {name: substep(sim) for name, sim in sims.items()}
        fns["springs_alone"] = spring_cmd.launch
        ref = NumpySemiImplicit(model)
        fns["numpy"] = lambda ref=ref, h=h, tool=tool: ref.step(h, (tool.p0, tool.p1, tool.radius))
        if newton_missing is None:
            nt = NewtonSemiImplicit(model)
            fns["newton"] = lambda nt=nt, h=h: nt.step(h)
        calls = {name: max(3, int(2e5 // S)) for name in fns}
        calls["implicit_euler"] = max(2, calls["implicit_euler"] // 20)
        calls["numpy"] = max(2, calls["numpy"] // 10)
        calls["newton"] = calls["numpy"]
        times = interleaved(fns, calls, repeats)
        warp = times["warp"]
        row = {"mesh": label, "nodes": N, "springs": S}
        for name in ("warp", "xpbd", "implicit_euler"):
            stepper = sims[name]
            row[f"{name}_launches"] = stepper.solver.launches_per_substep(stepper.state, stepper._next, h)
        for name in ("warp", "springs_alone", "warp_plain", "implicit_euler", "xpbd", "numpy", "newton"):
            if name in times:
                row[f"{name}_us"] = float(np.median(times[name]) * 1e6)
                row[f"{name}_us_spread"] = spread(times[name] * 1e6)
        row["spring_updates_per_s"] = float(S / np.median(warp))
        row["node_steps_per_s"] = float(N / np.median(warp))
        row["springs_alone_over_step"] = spread(times["springs_alone"] / warp)
        row["numpy_over_warp"] = spread(times["numpy"] / warp)
        row["newton_over_warp"] = spread(times["newton"] / warp) if "newton" in times else "n/a"
        row["plain_over_replayed"] = spread(times["warp_plain"] / warp)
        row["max_dx_vs_numpy_m"] = agreement(model) if S < 200_000 else float("nan")
        rows.append(row)
        print(f"  {label}: step {row['warp_us']:.1f} us, springs alone {row['springs_alone_us']:.1f} us, "
              f"numpy x{row['numpy_over_warp']}, newton x{row['newton_over_warp']}", flush=True)
    write_csv("throughput", rows)
    cols = ["mesh", "nodes", "springs", "warp_launches", "warp_us_spread", "springs_alone_us_spread",
            "springs_alone_over_step", "numpy_over_warp", "newton_over_warp",
            "plain_over_replayed", "implicit_euler_launches", "implicit_euler_us_spread", "xpbd_launches",
            "xpbd_us_spread"]
    note = ("" if newton_missing is None else
            f"\n\nNewton could not be imported ({newton_missing}); its column is n/a.")
    write_markdown("throughput", "Throughput against mesh size (one CPU core)",
                   "Times per substep in microseconds, median (min-max) over interleaved repeats; "
                   "ratios repeat by repeat. `warp`: the semi-implicit substep (springs, gravity, "
                   "damping, tool test, integrate) replayed as a graph; `springs_alone`: its "
                   "spring-force kernel only; `warp_plain`: the same step with plain "
                   "`wp.launch` calls; `*_launches`: kernel launches per substep (one graph replay runs "
                   "them all).\n\n" + markdown_table(rows, cols) + note)
    _plot(rows)
    return rows


def _plot(rows):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from common import RESULTS

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    S = np.array([r["springs"] for r in rows])
    for name, label in (("warp", "warp_cut semi-implicit"), ("xpbd", "warp_cut XPBD"),
                        ("implicit_euler", "warp_cut implicit Euler"), ("newton", "Newton SolverSemiImplicit"),
                        ("numpy", "numpy (vectorised)")):
        if f"{name}_us" in rows[0]:
            ax.loglog(S, S / (np.array([r[f"{name}_us"] for r in rows]) * 1e-6), "o-", label=label)
    ax.set_xlabel("springs")
    ax.set_ylabel("spring updates per second")
    ax.set_title("Substep throughput, one CPU core")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(RESULTS / "throughput.png", dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    run()
