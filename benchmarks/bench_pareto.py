"""Error against wall time for every integrator x substep x mesh spacing: a hanging sheet.

A 4 x 4 cm sheet (Table 1 density and thickness; material-derived stiffness and mass-
proportional damping D = 20 /s x m, so every spacing is the same sheet - the paper's per-node
D would damp a finer mesh more) pinned along its left edge is
released flat under gravity and falls for 0.25 s. The observable is the mean height of its
free (right) edge, sampled every 5 ms; the error of a run is the RMS difference of that curve
from the reference run (semi-implicit Euler at 0.1 x the stable step on the finest mesh), so
it holds both the time-stepping error and the mesh's. Wall time: the whole run.
"""

from __future__ import annotations

import time

import numpy as np
from common import RESULTS, markdown_table, write_csv, write_markdown

from warp_cut import Material, SimulationUnstable, Simulator, TissueModel
from warp_cut.sim.stability import stable_time_step
from warp_cut.sim.stiffness import material_stiffness

DURATION = 0.25
SAMPLE = 0.005
SPACINGS = (0.004, 0.002, 0.001)
FACTORS = {  # substep as a multiple of the explicit stable step (the element bound, sim/stability.py)
    "semi_implicit": (0.25, 0.5, 0.9),
    "implicit_euler": (4.0, 16.0, 64.0),
    "xpbd": (0.5, 1.0, 4.0, 16.0, 64.0),
}


def sheet(spacing):
    mat = Material()
    model = TissueModel.from_patch((0.04, 0.04), spacing, material=mat, pinned="none")
    model.damping = 20.0 * model.masses
    model.stiffness = material_stiffness(model.points, model.triangles, model.springs,
                                         mat.youngs_modulus, mat.thickness)
    model.pinned[:] = model.points[:, 0] < model.points[:, 0].min() + 1e-9
    return model


def edge_curve(model, integrator, h):
    """(times, mean z of the right edge) sampled every SAMPLE s, and the wall time [s]."""
    steps_per_sample = max(1, round(SAMPLE / h))
    h = SAMPLE / steps_per_sample
    sim = Simulator(model, dt=SAMPLE, substeps=steps_per_sample, integrator=integrator,
                    collision=False, residual_stress=False)
    right = model.points[:, 0] > model.points[:, 0].max() - 1e-9
    sim.step(1)  # compile and record outside the timing: the trade is per step, not start-up
    sim = Simulator(model, dt=SAMPLE, substeps=steps_per_sample, integrator=integrator,
                    collision=False, residual_stress=False)
    samples = round(DURATION / SAMPLE)
    z = np.empty(samples + 1)
    z[0] = 0.0
    start = time.perf_counter()
    for n in range(1, samples + 1):
        sim.step(1)
        z[n] = sim.state.positions.numpy()[: model.node_count][right, 2].mean()  # arrays span the capacity
    return z, time.perf_counter() - start, h


def run(quick: bool = False):
    spacings = SPACINGS[:2] if quick else SPACINGS
    finest = sheet(spacings[-1])
    h_ref = 0.1 * stable_time_step(finest).step
    z_ref, wall_ref, h_ref = edge_curve(finest, "semi_implicit", h_ref)
    rows = []
    for spacing in spacings:
        model = sheet(spacing)
        limit = stable_time_step(model).step
        for integrator, factors in FACTORS.items():
            seen = set()
            for factor in factors:
                steps_per_sample = max(1, round(SAMPLE / (factor * limit)))
                if steps_per_sample in seen:  # capped at one substep per sample: same run
                    continue
                seen.add(steps_per_sample)
                try:
                    z, wall, h = edge_curve(model, integrator, factor * limit)
                    error = float(np.sqrt(np.mean((z - z_ref) ** 2)))
                except SimulationUnstable:
                    z, wall, h, error = None, float("nan"), factor * limit, float("nan")
                rows.append({"integrator": integrator, "spacing_m": spacing,
                             "nodes": model.node_count, "substep_s": h,
                             "substep_over_limit": factor, "wall_s": wall,
                             "realtime_factor": DURATION / wall if wall == wall else float("nan"),
                             "rms_error_m": error,
                             "final_edge_z_m": float(z[-1]) if z is not None else float("nan")})
                print(f"  {integrator:15s} {spacing * 1e3:.0f} mm x{factor:<5g} wall {wall:7.3f} s "
                      f"error {error * 1e3:.3f} mm", flush=True)
    write_csv("pareto_hanging_sheet", rows)
    front = pareto_front(rows)
    text = (f"Reference: semi-implicit at h = {h_ref:.3g} s on the {spacings[-1] * 1e3:g} mm mesh "
            f"({wall_ref:.2f} s wall); its edge falls to z = {z_ref[-1] * 1e3:.2f} mm at "
            f"{DURATION} s. Error: RMS over time of the free edge's mean height against it.\n\n"
            "All runs:\n\n" + markdown_table(rows, ["integrator", "spacing_m", "nodes", "substep_s",
                                                     "substep_over_limit", "wall_s",
                                                     "realtime_factor", "rms_error_m"])
            + "\n\nPareto front (no run is both faster and more accurate):\n\n"
            + markdown_table(front, ["integrator", "spacing_m", "substep_s", "wall_s", "rms_error_m"]))
    write_markdown("pareto_hanging_sheet", "Error against wall time: hanging sheet", text)
    _plot(rows, front)
    return rows


def pareto_front(rows):
    ok = sorted((r for r in rows if r["rms_error_m"] == r["rms_error_m"]), key=lambda r: r["wall_s"])
    front, best = [], float("inf")
    for r in ok:
        if r["rms_error_m"] < best:
            front.append(r)
            best = r["rms_error_m"]
    return front


def _plot(rows, front):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.6))
    markers = {s: m for s, m in zip(SPACINGS, ("s", "o", "^"))}
    colors = {"semi_implicit": "C0", "implicit_euler": "C3", "xpbd": "C2"}
    for r in rows:
        if r["rms_error_m"] == r["rms_error_m"]:
            ax.loglog(r["wall_s"], r["rms_error_m"] * 1e3, markers[r["spacing_m"]],
                      color=colors[r["integrator"]], alpha=0.8)
    ax.loglog([r["wall_s"] for r in front], [r["rms_error_m"] * 1e3 for r in front], "k--",
              lw=1, label="Pareto front")
    for name, c in colors.items():
        ax.plot([], [], "o", color=c, label=name)
    for s, m in markers.items():
        ax.plot([], [], m, color="gray", label=f"{s * 1e3:g} mm")
    ax.set_xlabel(f"wall time for {DURATION} s simulated [s]")
    ax.set_ylabel("RMS error of the free edge height [mm]")
    ax.set_title("Hanging sheet: error against wall time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(RESULTS / "pareto_hanging_sheet.png", dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    run()
