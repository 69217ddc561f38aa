"""warp_cut/cut/tolerances.py: the margins the tolerances' docstrings promise.

Checked: the refinement's chart angle (REFINE_ANGLE_DEG) leaves every triangle at least
MIN_ANGLE_DEG once the chart's fill is lifted onto a curved rest surface of the size the chart's
docstring names (a region 8 mm across on skin of 4 cm radius, and on 2 cm), with the 3D angles
computed here from the lifted points; and the height the CLEARANCE docstring quotes for a
thin triangle.
"""

import numpy as np
import pytest

from warp_cut.cut.chart import PiecewiseLinearMap, RegionChart
from warp_cut.cut.remesh.fill import fill_region
from warp_cut.cut.tolerances import CLEARANCE, MIN_ANGLE_DEG, REFINE_ANGLE_DEG


def sphere_cap(radius: float, half: float, n: int = 17):
    """A grid of (2 half) x (2 half) [m] lifted onto a sphere of ``radius`` [m] touching z = 0
    at the origin: (points (n^2, 3), triangles), counter-clockwise from +z."""
    g = np.linspace(-half, half, n)
    xy = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    points = np.column_stack([xy, np.sqrt(radius**2 - (xy**2).sum(axis=1)) - radius])
    tri = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            tri += [[a, b, e], [a, e, d]]
    return points, np.array(tri)


def smallest_angles_3d(points, triangles) -> np.ndarray:
    c = points[triangles]
    out = np.full(len(triangles), 180.0)
    for k in range(3):
        u, v = c[:, (k + 1) % 3] - c[:, k], c[:, (k + 2) % 3] - c[:, k]
        cos = (u * v).sum(axis=1) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
        out = np.minimum(out, np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return out


@pytest.mark.parametrize("radius", [0.04, 0.02])
def test_a_fill_at_the_refine_angle_keeps_the_least_angle_on_curved_skin(radius):
    """A disk of 8 mm diameter filled in the chart of a sphere cap at REFINE_ANGLE_DEG, its
    points lifted onto the cap's triangles: every 3D angle is still at least MIN_ANGLE_DEG
    (the reason REFINE_ANGLE_DEG is set above it)."""
    assert REFINE_ANGLE_DEG > MIN_ANGLE_DEG
    points, tri = sphere_cap(radius, 0.005)
    corners = points[tri]
    chart = RegionChart.of_triangles(corners)
    k = 24
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)
    disk = np.stack([0.004 * np.cos(t), 0.004 * np.sin(t)], axis=1)
    fill = fill_region(disk, [(i, (i + 1) % k) for i in range(k)], min_angle_deg=REFINE_ANGLE_DEG, min_edge=2e-5)
    assert fill.unrefined == 0
    lifted = PiecewiseLinearMap(chart.to2d(corners), corners)(fill.points)[0]
    on_sphere = np.linalg.norm(lifted - [0, 0, -radius], axis=1)
    assert np.all(on_sphere <= radius + 1e-12) and np.all(on_sphere >= radius - 1e-5)  # on the cap's facets
    assert smallest_angles_3d(lifted, fill.triangles).min() >= MIN_ANGLE_DEG


def test_the_thin_triangle_height_quoted_for_the_clearance():
    """An isosceles triangle of MIN_ANGLE_DEG base angles on a base s is tan(20 deg)/2 = 0.18 s
    high, as the CLEARANCE docstring says; the clearance kept beside a lip line is more."""
    height = np.tan(np.radians(MIN_ANGLE_DEG)) / 2
    assert height == pytest.approx(0.18, abs=0.005)
    assert CLEARANCE > height
