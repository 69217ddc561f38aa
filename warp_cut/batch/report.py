"""Plots of a batch: each metric against each swept parameter, one PNG per parameter.

``plot_results(DIR)`` reads ``DIR/results.csv`` and ``DIR/batch.json`` (written by
``warp-cut batch``) and writes ``DIR/plots/<parameter>.png``: one panel per metric that varies
across the successful scenarios, a line per combination of the other swept parameters
(repeats averaged), and red crosses on the x axis where scenarios failed or were unstable.
"""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

from matplotlib.figure import Figure

from ..errors import InputError
from ..io.files import atomic_path
from .store import MANIFEST_FILE, RESULTS_FILE

__all__ = ["plot_results", "read_results", "KEY_METRICS"]

KEY_METRICS = ("width_curve.plateau_m", "width_curve.peak_m", "incision.width_m",
               "incision.max_deviation_m", "cut.residual_links", "mesh.slivers",
               "first_contact_time_s", "first_contact_time_exact_s", "first_contact_point.0",
               "first_contact_point.1", "max_tool_force_n", "stable_step_s", "realtime_factor",
               "wall_time_s")
"""Metrics drawn first when present (others that vary follow, up to MAX_PANELS in all)."""
MAX_PANELS = 12
"""Panels per parameter plot at most."""
_MAX_LEGEND = 8
_NOT_METRICS = {"id", "status", "rep", "message", "worker_time_s"}


def _number(cell: str):
    """A results.csv cell as a finite float, or None."""
    try:
        value = float(cell)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def read_results(out_dir) -> tuple[list[str], list[dict]]:
    """Read the results of a batch.

    Parameters whose values are lists or tables (tool keyframes, say) are not drawn; a
    ``tag.*`` parameter beside them labels what they encode.

    Args:
        out_dir: The ``--out`` directory of ``warp-cut batch``.

    Returns:
        The swept parameters with scalar values, and the rows of results.csv as dicts of
        strings.

    Raises:
        InputError: batch.json or results.csv is missing or unreadable.
    """
    root = Path(out_dir)
    manifest, results = root / MANIFEST_FILE, root / RESULTS_FILE
    for path in (manifest, results):
        if not path.is_file():
            raise InputError(f"{path}: not found (is {root} the --out directory of warp-cut batch?)")
    try:
        parameters = json.loads(manifest.read_text(encoding="utf-8"))["scalar_parameters"]
    except (ValueError, KeyError) as exc:
        raise InputError(f"{manifest}: [scalar_parameters] unreadable ({exc})") from exc
    with open(results, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    return parameters, rows


def _metrics(rows: list[dict], parameters: list[str]) -> list[str]:
    """Key metrics with a numeric value, then the other numeric metrics that vary across rows."""
    names = [c for c in (rows[0] if rows else {}) if c not in _NOT_METRICS and c not in parameters]
    values = {name: {_number(r[name]) for r in rows} - {None} for name in names}
    key = [m for m in KEY_METRICS if values.get(m)]
    varying = [m for m in names if m not in KEY_METRICS and len(values[m]) > 1]
    return (key + varying)[:MAX_PANELS]


def _x_positions(values: list[str]):
    """Numeric x values, or positions and tick labels for categories."""
    numbers = [_number(v) for v in values]
    if all(n is not None for n in numbers):
        return numbers, None
    labels = list(dict.fromkeys(values))
    return [float(labels.index(v)) for v in values], labels


def _plot_parameter(param: str, parameters: list[str], rows: list[dict], metrics: list[str]):
    """The figure of ``metrics`` against ``param``: a line per combination of the other varying
    parameters (repeats averaged), failures as red crosses on the x axis."""
    others = [p for p in parameters if p != param and len({r[p] for r in rows}) > 1]
    xs, labels = _x_positions([r[param] for r in rows])
    ok = [i for i, r in enumerate(rows) if r["status"] == "ok"]
    bad = [i for i, r in enumerate(rows) if r["status"] != "ok"]
    groups: dict[tuple, list[int]] = {}
    for i in ok:
        groups.setdefault(tuple(rows[i][p] for p in others), []).append(i)
    cols = min(3, len(metrics))
    nrows = math.ceil(len(metrics) / cols)
    fig = Figure(figsize=(4.4 * cols, 3.3 * nrows), layout="constrained")
    for n, metric in enumerate(metrics):
        ax = fig.add_subplot(nrows, cols, n + 1)
        for key, members in groups.items():
            by_x: dict[float, list[float]] = {}
            for i in members:
                if (y := _number(rows[i][metric])) is not None:
                    by_x.setdefault(xs[i], []).append(y)
            px = sorted(by_x)
            label = ", ".join(f"{p}={v}" for p, v in zip(others, key)) or None
            ax.plot(px, [sum(by_x[x]) / len(by_x[x]) for x in px], "o-", ms=4,
                    label=label if len(groups) <= _MAX_LEGEND else None)
        if bad:
            ax.plot([xs[i] for i in bad], [0.0] * len(bad), "x", color="red", ms=8,
                    transform=ax.get_xaxis_transform(), clip_on=False, label="failed/unstable")
        if labels is not None:
            ax.set_xticks(range(len(labels)), labels, rotation=30, ha="right")
        ax.set_xlabel(param)
        ax.set_ylabel(metric)
        ax.grid(alpha=0.3)
        if n == 0 and (bad or 1 < len(groups) <= _MAX_LEGEND):
            ax.legend(fontsize="x-small")
    fig.suptitle(f"{param}: {len(ok)} ok, {len(bad)} failed or unstable")
    return fig


def plot_results(out_dir) -> list[Path]:
    """Draw every varying metric against every swept parameter, into ``DIR/plots/``.

    Args:
        out_dir: The ``--out`` directory of ``warp-cut batch``.

    Returns:
        The PNG files written (none for a parameter without two successful values).

    Raises:
        InputError: batch.json or results.csv is missing or unreadable.
    """
    parameters, rows = read_results(out_dir)
    ok_rows = [r for r in rows if r["status"] == "ok"]
    metrics = _metrics(ok_rows, parameters)
    written = []
    for param in parameters:
        if len({r[param] for r in ok_rows}) < 2 or not metrics:
            continue  # no successful scenarios to compare along this parameter
        fig = _plot_parameter(param, parameters, rows, metrics)
        path = Path(out_dir) / "plots" / (re.sub(r"[^A-Za-z0-9._-]", "-", param) + ".png")
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png", dpi=100)
        written.append(path)
    return written
