"""Output files written atomically: to a temporary name beside the target, then renamed."""

from __future__ import annotations

import contextlib
import csv
import json
import os
import tempfile
from pathlib import Path

import numpy as np
import trimesh

__all__ = ["atomic_path", "write_json", "write_csv", "write_ply"]

_UMASK = os.umask(0o022)
os.umask(_UMASK)
_FILE_MODE = 0o666 & ~_UMASK
"""Mode of a finished output file: what open() would give (mkstemp makes 0600)."""


@contextlib.contextmanager
def atomic_path(path, suffix: str = ".tmp"):
    """Yield a temporary path next to ``path``; rename it onto ``path`` only on success.

    Args:
        path: The final file.
        suffix: End of the temporary name (writers that pick a format by extension need it).

    Yields:
        The temporary path to write; it is removed if the block raises.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, _FILE_MODE)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _plain(value):
    """``value`` with numpy arrays and scalars as Python lists and numbers, non-finite floats as None."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None  # JSON has no NaN/inf; an absent measurement is null
    return value


def write_json(path, data: dict) -> None:
    """Write ``data`` as indented JSON, atomically.

    Args:
        path: The JSON file.
        data: Values may be numpy arrays and scalars; non-finite floats are written as null.
    """
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(_plain(data), indent=2) + "\n", encoding="utf-8")


def write_csv(path, header: list[str], rows) -> None:
    """Write rows as CSV, atomically.

    Args:
        path: The CSV file.
        header: Column names.
        rows: Iterables matching ``header``; a NaN float (no value, e.g. no incision yet) is
            written as an empty cell, other floats with 9 significant digits.
    """

    def cell(v):
        if isinstance(v, float):
            return "" if np.isnan(v) else f"{v:.9g}"
        return v

    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        for row in rows:
            writer.writerow([cell(v) for v in row])


def write_ply(path, points, triangles, node_class=None) -> None:
    """Write a triangle surface as binary PLY through trimesh, atomically.

    Args:
        path: The PLY file.
        points: Vertex positions [m], shape (k, 3).
        triangles: Vertex indices, shape (t, 3).
        node_class: Optional ``NodeClass`` per vertex, shape (k,), written as the vertex
            property ``node_class`` (int8).
    """

    mesh = trimesh.Trimesh(np.asarray(points), np.asarray(triangles), process=False)
    if node_class is not None:
        mesh.vertex_attributes["node_class"] = np.asarray(node_class, dtype=np.int8)
    with atomic_path(path) as tmp:
        mesh.export(tmp, file_type="ply")
