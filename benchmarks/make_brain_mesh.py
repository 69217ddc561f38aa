"""One-off: the irregular test mesh tests/data/mni152_brain_top.obj from a real MRI template.

Source: the ICBM 2009a nonlinear symmetric T1 template (MNI152, 1 mm voxels) that nilearn ships
inside its wheel (``nilearn/datasets/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz``).
nilearn's copy is skull-stripped: the outermost tissue in it is the brain, so the surface is the
brain's envelope (the surface a dura or the inner skull lies on), not the scalp.

Steps (lengths in mm until the last step):

1. voxels brighter than 10 (of 255) are the brain; a morphological closing of radius 7 mm (by
   distance transforms) bridges the sulci and most of the fissure between the hemispheres, and
   a Gaussian of 1 voxel smooths the staircase; marching cubes (scikit-image) at 0.5 gives the
   envelope, wound outward.
2. the top of the head: the faces facing up within 45 mm (horizontally) of (x, y) = (0, -20), the
   largest connected piece: a disk-like cap of about 7100 mm^2.
3. node sites: quadric decimation (trimesh + fast-simplification) of the cap to edges of about
   ``--spacing`` mm gives sites dense where the envelope bends, sparse where it is flat; the
   cap's border loop is resampled every ``--spacing`` mm of its length and the sites nearer the
   border than 0.6 spacings are dropped.
4. the sites are Delaunay-triangulated in the horizontal plane (the cap is a height field over
   it), triangles outside the border polygon dropped, interior sites relaxed halfway towards
   their neighbours' mean twice (the decimation leaves slivers), and every interior site lifted
   onto the envelope by casting a vertical ray onto the dense cap.
5. centred on the cap's top-centre point, scaled to metres, written as OBJ with its source and
   licence in the header.

The packages it needs (nilearn, nibabel, scikit-image, scipy, trimesh, fast-simplification,
rtree) are not the project's: run with any Python 3.11+, the script makes its own virtualenv in
the temporary directory (``--env`` to choose it) and runs itself there:

    python3 benchmarks/make_brain_mesh.py [--out tests/data/mni152_brain_top.obj] [--spacing 2.3]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFAULT_OUT = HERE.parent / "tests" / "data" / "mni152_brain_top.obj"
REQUIREMENTS = ["nilearn==0.14.1", "nibabel==5.4.2", "scikit-image==0.26.0", "scipy>=1.13",
                "trimesh==5.2.0", "fast-simplification==0.2.0", "rtree==1.4.1", "numpy>=2"]

THRESHOLD = 10.0
"""Template intensity (of 255) above which a voxel is brain."""
CLOSING_MM = 7.0
"""Radius [mm] of the morphological closing that bridges sulci."""
CENTRE_XY = (0.0, -20.0)
"""Centre [mm] (MNI x, y) of the cap cut from the top of the head."""
CAP_RADIUS_MM = 45.0
"""Horizontal radius [mm] of the cap."""
RELAX_STEPS = 2
"""Halfway relaxations of the interior sites towards their neighbours' mean."""

LICENCE = """\
# Surface derived from the ICBM 2009a Nonlinear Symmetric T1 template (MNI152), as shipped
# in nilearn 0.14.1 (nilearn/datasets/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz).
# Copyright (C) 1993-2009 Louis Collins, McConnell Brain Imaging Centre, Montreal Neurological
# Institute, McGill University. Permission to use, copy, modify, and distribute this software and
# its documentation for any purpose and without fee is hereby granted, provided that the above
# copyright notice appear in all copies. The authors and McGill University make no
# representations about the suitability of this software for any purpose. It is provided "as is"
# without express or implied warranty.
# References: Fonov et al., NeuroImage 47 S102 (2009); Fonov et al., NeuroImage 54 313-327 (2011).
# Made by benchmarks/make_brain_mesh.py: brain envelope (closing 7 mm), top cap 45 mm around
# MNI (0, -20), re-triangulated; metres, centred on the cap's top-centre point, normals outward.
"""


def _ensure_env(env_dir: Path) -> None:
    """Re-run this script in a virtualenv holding REQUIREMENTS (made on first use)."""
    if os.environ.get("WARP_CUT_MESH_ENV") == "1":
        return
    python = env_dir / "bin" / "python"
    if not python.exists():
        subprocess.run([sys.executable, "-m", "venv", str(env_dir)], check=True)
        subprocess.run([str(python), "-m", "pip", "install", "--quiet", *REQUIREMENTS], check=True)
    env = dict(os.environ, WARP_CUT_MESH_ENV="1")
    sys.exit(subprocess.run([str(python), __file__, *sys.argv[1:]], env=env).returncode)


def envelope():
    """The brain envelope as a trimesh (mm, MNI coordinates, wound outward)."""
    import nibabel as nib
    import numpy as np
    import trimesh
    from nilearn.datasets.struct import MNI152_FILE_PATH
    from scipy import ndimage
    from skimage.measure import marching_cubes

    img = nib.load(str(MNI152_FILE_PATH))
    pad = int(CLOSING_MM) + 8
    brain = np.pad(img.get_fdata() > THRESHOLD, pad)
    grown = ndimage.distance_transform_edt(~brain) <= CLOSING_MM
    closed = ndimage.binary_fill_holes(ndimage.distance_transform_edt(grown) > CLOSING_MM)
    field = ndimage.gaussian_filter(closed.astype(np.float64), 1.0)
    verts, faces, _, _ = marching_cubes(field, 0.5)
    mesh = trimesh.Trimesh(nib.affines.apply_affine(img.affine, verts - pad), faces)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def top_cap(mesh):
    """The faces facing up within CAP_RADIUS_MM of CENTRE_XY: the largest connected piece."""
    import numpy as np

    centre = np.asarray(CENTRE_XY)
    near = np.linalg.norm(mesh.vertices[:, :2] - centre, axis=1) < CAP_RADIUS_MM
    keep = near[mesh.faces].all(axis=1) & (mesh.face_normals[:, 2] > 0.0)
    cap = mesh.submesh([np.flatnonzero(keep)], append=True)
    return max(cap.split(only_watertight=False), key=lambda piece: piece.area)


def border_sites(cap, spacing: float):
    """Points (b, 3) [mm] every ``spacing`` along the cap's border loop (its longest one)."""
    import numpy as np
    import trimesh

    edges = cap.edges_sorted[trimesh.grouping.group_rows(cap.edges_sorted, require_count=1)]
    loops = trimesh.graph.connected_components(edges, min_len=3)
    graph = {}
    for a, b in edges:
        graph.setdefault(a, []).append(b)
        graph.setdefault(b, []).append(a)
    start = max(loops, key=len)[0]
    order, previous = [start], None
    while True:
        nxt = [n for n in graph[order[-1]] if n != previous]
        if nxt[0] == start:
            break
        previous = order[-1]
        order.append(nxt[0])
    loop = cap.vertices[order + [start]]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(loop, axis=0), axis=1))])
    count = int(round(s[-1] / spacing))
    t = np.arange(count) * (s[-1] / count)
    return np.column_stack([np.interp(t, s, loop[:, k]) for k in range(3)])


def lift(cap, xy):
    """Points (n, 3) [mm]: vertical rays through ``xy`` (n, 2) [mm] cast onto the cap."""
    import numpy as np

    top = cap.bounds[1, 2] + 10.0
    origins = np.column_stack([xy, np.full(len(xy), top)])
    directions = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
    hits, rays, _ = cap.ray.intersects_location(origins, directions, multiple_hits=False)
    z = np.full(len(xy), np.nan)
    z[rays] = hits[:, 2]
    if np.isnan(z).any():
        raise RuntimeError(f"{int(np.isnan(z).sum())} sites miss the cap")
    return np.column_stack([xy, z])


def inside_polygon(points, polygon):
    """Mask (m,) of points (m, 2) inside the closed polygon (k, 2) (even-odd crossings)."""
    import numpy as np

    a, b = polygon, np.roll(polygon, -1, axis=0)
    x, y = points[:, None, 0], points[:, None, 1]
    straddle = (a[None, :, 1] > y) != (b[None, :, 1] > y)
    t = (y - a[None, :, 1]) / np.where(straddle, b[None, :, 1] - a[None, :, 1], 1.0)
    cross = straddle & (x < a[None, :, 0] + t * (b[None, :, 0] - a[None, :, 0]))
    return cross.sum(axis=1) % 2 == 1


def triangulate(sites_xy, border_count: int, border_xy):
    """Delaunay triangles (t, 3) of ``sites_xy`` (n, 2) whose first ``border_count`` rows are
    the border loop; triangles whose centroid lies outside the loop's polygon are dropped."""
    from scipy.spatial import Delaunay

    tri = Delaunay(sites_xy).simplices
    inside = inside_polygon(sites_xy[tri].mean(axis=1), border_xy)
    tri = tri[inside]
    a, b, c = (sites_xy[tri[:, k]] for k in range(3))
    ccw = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0] > 0
    tri[~ccw] = tri[~ccw][:, [0, 2, 1]]
    return tri


def relax(sites_xy, tri, border_count: int):
    """Interior sites moved halfway to the mean of their neighbours (n, 2) [mm]."""
    import numpy as np

    n = len(sites_xy)
    pairs = np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    pairs = np.unique(np.sort(pairs, axis=1), axis=0)
    total, count = np.zeros((n, 2)), np.zeros(n)
    for i, j in ((0, 1), (1, 0)):
        np.add.at(total, pairs[:, i], sites_xy[pairs[:, j]])
        np.add.at(count, pairs[:, i], 1.0)
    moved = sites_xy.copy()
    interior = np.arange(n) >= border_count
    moved[interior] = 0.5 * (sites_xy[interior] + total[interior] / count[interior, None])
    return moved


def build(spacing: float):
    """(points (n, 3) [m], triangles (t, 3)) of the cap, centred, wound outward (+z)."""
    import numpy as np
    import trimesh

    cap = top_cap(envelope())
    faces = int(cap.area / (np.sqrt(3.0) / 4.0 * spacing ** 2))
    decimated = cap.simplify_quadric_decimation(face_count=faces)
    border = border_sites(cap, spacing)
    inner = decimated.vertices[:, :2]
    gap = np.min(np.linalg.norm(inner[:, None, :] - border[None, :, :2], axis=2), axis=1)
    sites = np.vstack([border[:, :2], inner[gap > 0.6 * spacing]])
    tri = triangulate(sites, len(border), border[:, :2])
    for _ in range(RELAX_STEPS):
        sites = relax(sites, tri, len(border))
        tri = triangulate(sites, len(border), border[:, :2])
    points = np.vstack([border, lift(cap, sites[len(border):])])  # the border sites lie on the cap
    mesh = trimesh.Trimesh(points, tri, process=False)
    mesh.remove_unreferenced_vertices()
    centre = np.asarray([*CENTRE_XY, 0.0])
    centre[2] = lift(cap, centre[None, :2])[0, 2]
    return (np.asarray(mesh.vertices) - centre) * 1e-3, np.asarray(mesh.faces)


def write_obj(path: Path, points, triangles) -> None:
    """OBJ with the licence header; coordinates [m] with 7 decimals (0.1 um)."""
    lines = [LICENCE.rstrip("\n")]
    lines += [f"v {x:.7f} {y:.7f} {z:.7f}" for x, y, z in points]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in triangles]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")


def report(points, triangles) -> str:
    """Node, triangle, edge-length and angle summary of the mesh."""
    import numpy as np
    import trimesh
    from trimesh.triangles import angles

    mesh = trimesh.Trimesh(points, triangles, process=False)
    edges = mesh.edges_unique_length * 1e3
    smallest = np.degrees(angles(mesh.triangles)).min(axis=1)
    return (f"{len(points)} nodes, {len(triangles)} triangles, edges p5/p50/p95 "
            f"{np.percentile(edges, 5):.2f}/{np.median(edges):.2f}/{np.percentile(edges, 95):.2f} mm, "
            f"smallest angle {smallest.min():.1f} deg ({int((smallest < 20).sum())} below 20 deg), "
            f"winding consistent {mesh.is_winding_consistent}, euler {mesh.euler_number}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--spacing", type=float, default=2.3, help="target edge length [mm]")
    ap.add_argument("--env", type=Path, default=Path(tempfile.gettempdir()) / "warp_cut_mesh_env",
                    help="virtualenv for the packages the script needs")
    args = ap.parse_args(argv)
    _ensure_env(args.env)
    points, triangles = build(args.spacing)
    write_obj(args.out, points, triangles)
    print(f"{args.out}: {report(points, triangles)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
