"""The wound against linear elastic fracture mechanics (SPEC section 1, "Prestress").

A straight cut of length 2a in a large sheet under a uniform membrane tension T [N/m] opens
into an ellipse (Griffith; plane stress):

    gap(x) = (4 T / E2D) sqrt(a^2 - x^2),      |x| < a, x from the cut's centre,

E2D [N/m] the sheet's in-plane Young's modulus x thickness: 2 k / sqrt(3) for a regular
triangle lattice of springs k (Poisson's ratio 1/3), E t for van Gelder's material springs.

Three comparisons, each a ``GapComparison``:

* ``slit_comparison``: the spring network's own static equilibrium (``warp_cut.sim.statics``)
  with an exact slit along a row of a prestressed lattice (``warp_cut.cut.wound.reference_slit``), the border
  either loaded by the prestress tractions (dead loads; a large plate) or pinned (clamped: the
  opening is lower);
* ``slot_comparison``: the nodes the scalpel's swept capsule deletes removed from a scene's
  prestressed patch, nothing re-meshed, static equilibrium (the opening of the swept slot);
* ``cutter_comparison``: the real three-stage cut: the gap between paired lip nodes
  (``Cutter.gap_profile``) minus the initial slit width 2 x ``lip_offset``, either after a
  dynamic run of the scene (at its end, and relaxed to static equilibrium) or after cut
  events driven without dynamics ("quasi-static") and a static solve.

``run_experiment`` writes ``wound.md``, ``wound_gap.csv`` and ``wound_gap.png``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..cut.topology import TopologyEditor
from ..cut.wound.reference_slit import open_slit
from ..io.files import atomic_path, write_csv
from ..io.plots import new_figure, save_figure
from ..runner import run_scene
from ..scene import Scene, load_scene
from ..sim.material import Material
from ..sim.model import TissueModel
from ..sim.statics import spring_network_forces, static_equilibrium
from ..sim.stiffness import material_stiffness, membrane_modulus
from ..simulator import Simulator

__all__ = ["griffith_gap", "GapComparison", "slit_comparison",
           "slot_comparison", "cutter_comparison", "quasi_static_cut", "scene_cut_comparisons", "run_experiment",
           "write_report", "MIDDLE_FRACTION"]

MIDDLE_FRACTION = 0.8
"""Errors are taken over the middle 80 % of the cut (|x| <= 0.8 a)."""


def griffith_gap(x, half_length: float, tension: float, modulus: float) -> np.ndarray:
    """Opening (k,) [m] of a straight cut of half-length a [m] at x (k,) [m] from its centre in
    a sheet under membrane tension T [N/m] with in-plane modulus E2D [N/m]; 0 outside |x| < a."""
    x = np.asarray(x, dtype=np.float64)
    return 4.0 * tension / modulus * np.sqrt(np.maximum(half_length ** 2 - x ** 2, 0.0))


@dataclass(frozen=True)
class GapComparison:
    """A measured opening against the closed form.

    label: what was measured. x (k,) [m] from the cut's centre; gap (k,) [m] measured;
    half_length a [m]; tension T [N/m]; modulus E2D [N/m]; setup: the set-up in words.
    """

    label: str
    x: np.ndarray
    gap: np.ndarray
    half_length: float
    tension: float
    modulus: float
    setup: str = ""

    @property
    def closed_form(self) -> np.ndarray:
        return griffith_gap(self.x, self.half_length, self.tension, self.modulus)

    def middle(self, fraction: float = MIDDLE_FRACTION) -> np.ndarray:
        return np.abs(self.x) <= fraction * self.half_length + 1e-12

    def max_error(self, fraction: float = MIDDLE_FRACTION) -> float:
        """Largest |gap / closed form - 1| over |x| <= fraction x a."""
        k = self.middle(fraction)
        return float(np.max(np.abs(self.gap[k] / self.closed_form[k] - 1.0))) if k.any() else math.nan

    def median_ratio(self, fraction: float = MIDDLE_FRACTION) -> float:
        """Median of gap / closed form over |x| <= fraction x a."""
        k = self.middle(fraction)
        return float(np.median(self.gap[k] / self.closed_form[k])) if k.any() else math.nan

    def centre_ratio(self) -> float:
        """Measured over closed form at the station nearest the centre."""
        k = int(np.argmin(np.abs(self.x)))
        return float(self.gap[k] / self.closed_form[k])


# ------------------------------------------------------------------ exact slit in a lattice
def _lattice(rows: int, columns: int, spacing: float, material: Material, stiffness_model: str):
    """A prestressed patch of ``columns`` x ``rows`` near-equilateral triangles with a node row
    at y = 0 (rows even), border pinned."""
    size = (columns * spacing, rows * spacing * math.sqrt(3.0) / 2.0)
    model = TissueModel.from_patch(size, spacing, material=material, pinned="border")
    if stiffness_model == "material":
        model.stiffness_model = "material"
        model.stiffness = material_stiffness(model.points, model.triangles, model.springs,
                                             material.youngs_modulus, material.thickness,
                                             fallback=material.stiffness)
        model.apply_prestress()
    return model


def _traction_border(model) -> np.ndarray:
    """Unpin the border and return the dead loads (node_count, 3) [N] the pins carried, so the
    prestressed sheet stays in equilibrium with its border free (a plate under the tension);
    the border node farthest along +-x and +-y on each axis stays pinned against rigid motion."""
    forces = spring_network_forces(model.points, model.springs, model.rest_lengths, model.stiffness)
    loads = -forces * model.pinned[:, None]
    x = model.points
    keep = np.zeros(model.node_count, dtype=bool)
    for axis in (0, 1):
        near_axis = model.pinned & (np.abs(x[:, 1 - axis]) <= 0.5 * np.ptp(x[:, 1 - axis]) / 50)
        candidates = np.flatnonzero(near_axis)
        for sign in (-1.0, 1.0):
            keep[candidates[np.argmax(sign * x[candidates, axis])]] = True
    model.pinned = keep
    return loads


def slit_comparison(*, stiffness_model: str = "constant", border: str = "traction",
                    rows: int = 80, columns: int = 80, half_length: int = 10,
                    spacing: float = 1e-3, residual_strain: float = 0.002) -> GapComparison:
    """Static opening of an exact slit of 2 ``half_length`` spacings along the middle row of a
    prestressed lattice (Table 1 material but for ``residual_strain``), against the closed form.

    Args:
        stiffness_model: "constant" (E2D = 2 K / sqrt(3)) or "material" (E2D = E t).
        border: "traction" (dead loads; a large plate) or "pinned" (clamped).
        rows, columns: Lattice size in rows (even) and columns of triangles.
        half_length: a in spacings.
        spacing: Edge length [m].
        residual_strain: eps_r (small: the comparison is linear elasticity).
    """
    material = Material(residual_strain=residual_strain, residual_stress_model="prestress")
    model = _lattice(rows, columns, spacing, material, stiffness_model)
    loads = _traction_border(model) if border == "traction" else None
    x = model.points
    row = np.flatnonzero(np.abs(x[:, 1]) < 1e-9 * spacing + 1e-12)
    centre = x[row[np.argmin(np.abs(x[row, 0]))], 0]
    a = half_length * spacing
    slit = open_slit(model, [centre - a, 0.0, 0.0], [centre + a, 0.0, 0.0])
    if loads is not None:
        loads = np.concatenate([loads, np.zeros((model.node_count - len(loads), 3))])
    result = static_equilibrium(model, external=loads, force_tolerance=1e-7, cg_tolerance=1e-6)
    X = result.positions
    gap = X[slit.upper, 1] - X[slit.lower, 1]
    size = f"{columns * spacing * 1e3:.0f} x {rows * spacing * math.sqrt(3) / 2 * 1e3:.1f} mm"
    setup = (f"{stiffness_model} springs, {size} lattice at {spacing * 1e3:g} mm, slit 2a = "
             f"{2 * a * 1e3:g} mm, T = {material.membrane_tension:.3g} N/m, {border} border")
    return GapComparison(f"exact slit, {stiffness_model} springs, {border} border",
                         slit.arc - slit.length / 2, gap, slit.length / 2,
                         material.membrane_tension, membrane_modulus(material, stiffness_model), setup)


# ------------------------------------------------------------------ the scene's cut
def _cut_line(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Where the scene's tool crosses z = 0 at its first and last keyframe in the skin: the
    straight cut's end points [m]."""
    frames = [k for k in scene.tool.keyframes if k.p0[2] < 0 < k.p1[2]]
    ends = []
    for k in (frames[0], frames[-1]):
        s = k.p0[2] / (k.p0[2] - k.p1[2])
        ends.append(k.p0 + s * (k.p1 - k.p0))
    return ends[0], ends[1]


def slot_comparison(scene: Scene) -> GapComparison:
    """The scene's prestressed patch with the nodes of the scalpel's swept capsule removed
    (nothing re-meshed): static opening of the slot's border rows against the closed form of a
    cut of the same length."""
    model = scene.build_model()
    start, end = _cut_line(scene)
    r = scene.cutting.sweep_radius or scene.tool.radius
    x = model.points
    t = (end - start) / np.linalg.norm(end - start)
    s = np.clip((x - start) @ t, 0.0, np.linalg.norm(end - start))
    doomed = np.flatnonzero(np.linalg.norm(x - start - np.outer(s, t), axis=1) < r)
    editor = TopologyEditor(model)
    editor.begin()
    editor.delete_nodes(doomed)
    editor.finish()
    X = static_equilibrium(model, planar=True).positions
    a = 0.5 * float(np.linalg.norm(end - start))
    mid = 0.5 * (start + end)
    y = x[:, 1]
    live = model.active & (np.abs(x[:, 0] - mid[0]) < a)
    face = np.min(np.abs(y[live & (np.abs(y) > r)]))
    upper = np.flatnonzero(live & (np.abs(y - face) < 1e-6))
    lower = np.flatnonzero(live & (np.abs(y + face) < 1e-6))
    upper, lower = upper[np.argsort(x[upper, 0])], lower[np.argsort(x[lower, 0])]
    xu = x[upper, 0] - mid[0]
    opening = (X[upper, 1] - x[upper, 1]) - np.interp(x[upper, 0], x[lower, 0],
                                                       X[lower, 1] - x[lower, 1])
    return GapComparison("swept slot, no re-mesh (static)", xu, opening, a,
                         scene.material.membrane_tension,
                         membrane_modulus(scene.material, scene.stiffness_model),
                         f"opening of the slot's border rows (y = +-{face * 1e3:.2f} mm)")


def cutter_comparison(label: str, cutter, positions, scene: Scene, setup: str = "") -> GapComparison:
    """The gap between paired lip nodes (``Cutter.gap_profile``) minus the initial slit width
    2 x lip_offset, at x = u - L/2 along the incision of length L, against a cut of half-length
    L/2."""
    profile = cutter.gap_profile(positions)
    inc = cutter.incisions[0]
    half = inc.length / 2.0
    gap = profile["gap_m"] - 2.0 * inc.lip_offset
    return GapComparison(label, profile["arc_length_m"] - half, gap, half,
                         scene.material.membrane_tension,
                         membrane_modulus(scene.material, scene.stiffness_model), setup)


def quasi_static_cut(scene: Scene, events: int = 114):
    """The scene's cut made by the Cutter without dynamics between events (straight, from the
    tool's entry to its exit point at z = 0, ``events`` events), then the static equilibrium
    with the border loaded (``_loaded_border``). Returns (cutter, positions (node_count, 3) [m])."""
    model = scene.build_model()
    sim = Simulator(model, dt=1e-3, gravity=None, device=scene.device, cutting=scene.cutting)
    start, end = _cut_line(scene)
    r = scene.cutting.sweep_radius or scene.tool.radius
    sim.cutter.start_incision(sim, start, np.array([0.0, 0.0, 1.0]), r)
    for point in np.linspace(start, end, events + 1)[1:]:
        sim.cutter.extend_incision(sim, point)
    sim.cutter.end_incision(sim)
    return sim.cutter, _settled(model, sim.positions, _loaded_border(model, scene)).positions


# ------------------------------------------------------------------ report
def run_experiment(scene_source="wound_gape", *, quick: bool = False) -> list[GapComparison]:
    """Every comparison: the exact slit (constant and material springs, traction border; the
    constant one also pinned), the swept slot, the quasi-static and the dynamic cut of the
    scene (a name, path or ``Scene``). ``quick``: the slit checks only."""
    out = [slit_comparison(stiffness_model="constant"),
           slit_comparison(stiffness_model="material"),
           slit_comparison(stiffness_model="constant", border="pinned")]
    if quick:
        return out
    scene = scene_source if isinstance(scene_source, Scene) else load_scene(scene_source)
    out.append(slot_comparison(scene))
    cutter, x = quasi_static_cut(scene)
    out.append(cutter_comparison("cutter, quasi-static (no dynamics), static solve, loaded border", cutter, x,
                                 scene, "cut events without time steps between them"))
    out += scene_cut_comparisons(scene)
    return out


def scene_cut_comparisons(scene: Scene) -> list[GapComparison]:
    """The scene run as it is (the cut made with dynamics) compared at its end, then the same
    cut sheet at static equilibrium, with the scene's pinned border and with the border loaded
    by the forces its pins carried before the cut (dead loads, four nodes on the axes pinned
    against rigid motion: a large plate, as the closed form assumes). The sheet is heavily
    overdamped (Table 1's damping): a long wound keeps creeping open for tens of seconds after
    the tool has gone, and the closed form is the equilibrium's answer."""
    keep = {}

    class _Grab:
        def on_frame(self, sim, frame):
            keep["sim"] = sim

        def finish(self, metrics):
            pass

    run_scene(scene, observers=[_Grab()])
    sim = keep["sim"]
    model, label = sim.model, f"scene {scene.name}"
    out = [cutter_comparison(f"cutter, dynamic run to t = {sim.time:.3g} s", sim.cutter, sim.positions, scene,
                             label)]
    for border in ("pinned", "loaded"):
        loads = _loaded_border(model, scene) if border == "loaded" else None
        static = _settled(model, sim.positions, loads)
        out.append(cutter_comparison(f"cutter, that run's cut sheet at static equilibrium, {border} border",
                                     sim.cutter, static.positions, scene,
                                     f"{label}, largest net force {static.residual:.1e} N"))
    return out


def _settled(model, positions, loads=None):
    """The cut sheet's static equilibrium from ``positions`` (node_count, 3) [m], in its plane,
    to ``STATIC_TOLERANCE``, with dead ``loads`` (node_count, 3) [N] on its border if given
    (``_loaded_border``, which unpins it); a ``StaticResult``."""
    return static_equilibrium(model, positions=positions, external=loads, force_tolerance=STATIC_TOLERANCE,
                              planar=True)


def _loaded_border(model, scene: Scene) -> np.ndarray:
    """Unpin the cut ``model``'s border and return the dead loads (node_count, 3) [N] its pins
    carried in the scene's uncut prestressed sheet (``_traction_border``; the cut is far from
    the border, whose springs it leaves as they were)."""
    uncut = scene.build_model()
    loads = np.zeros((model.node_count, 3))
    loads[:uncut.node_count] = _traction_border(uncut)
    model.pinned = np.concatenate([uncut.pinned, np.zeros(model.node_count - uncut.node_count, dtype=bool)])
    return loads


STATIC_TOLERANCE = 1e-6
"""Static solves of a cut scene stop once the largest net force on a free node is below this
fraction of the largest spring force at the start. They hold the flat sheet in its plane
(``planar``): the cut's compressed springs would otherwise let the membrane (no bending
stiffness) buckle out of it, which the plane-stress closed form leaves out."""


def write_report(out_dir, comparisons: list[GapComparison]) -> list[Path]:
    """``wound.md`` (the table), ``wound_gap.csv`` (every point) and ``wound_gap.png``."""
    out = Path(out_dir)
    rows = [(c.label, float(x), float(g), float(f)) for c in comparisons
            for x, g, f in zip(c.x, c.gap, c.closed_form)]
    write_csv(out / "wound_gap.csv", ["comparison", "x_m", "gap_m", "closed_form_m"], rows)
    lines = ["| comparison | set-up | a [mm] | T [N/m] | E2D [N/m] | centre: measured / closed form "
             f"| median ratio, middle {MIDDLE_FRACTION:.0%} | max error, middle {MIDDLE_FRACTION:.0%} |",
             "|---|---|---|---|---|---|---|---|"]
    for c in comparisons:
        lines.append(f"| {c.label} | {c.setup} | {c.half_length * 1e3:.2f} | {c.tension:.3g} | "
                     f"{c.modulus:.4g} | {c.centre_ratio():.3f} | {c.median_ratio():.3f} | "
                     f"{100 * c.max_error():.1f} % |")
    with atomic_path(out / "wound.md") as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return [out / "wound_gap.csv", out / "wound.md", _plot(out / "wound_gap.png", comparisons)]


def _plot(path: Path, comparisons: list[GapComparison]) -> Path:
    fig = new_figure(12.0, 4.8)
    axes = fig.subplots(1, 2)
    for ax, group in zip(axes, (comparisons[:3], comparisons[3:])):
        markers = iter("osD^vx")
        for c in group:
            u = c.x / c.half_length
            ax.plot(u, c.gap / (c.tension / c.modulus * c.half_length), next(markers), ms=4, mfc="none",
                            label=f"{c.label} ({100 * c.max_error():.0f} %)")
        s = np.linspace(-1, 1, 201)
        ax.plot(s, 4 * np.sqrt(1 - s * s), "k-", lw=1.2, label="closed form 4 sqrt(1 - (x/a)^2)")
        ax.axvspan(-MIDDLE_FRACTION, MIDDLE_FRACTION, color="0.92", zorder=0)
        ax.set_xlabel("x / a")
        ax.set_ylabel("gap / (a T / E2D)")
        ax.legend(fontsize=7, loc="lower center")
        ax.set_xlim(-1.05, 1.05)
        ax.set_ylim(0, 4.8)
    axes[0].set_title("exact slit, static (lattice)")
    axes[1].set_title("the scene's cut")
    return save_figure(fig, path)

