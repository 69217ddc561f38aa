"""warp_cut/cut/curve/incision.py: an incision's path before anything is cut - turned back (a tool
lowered with its axis tilted) and its start moved (into an earlier wound the blade reaches)."""

from __future__ import annotations

import numpy as np
import pytest

from warp_cut.cut.curve.incision import Incision, polyline_distance
from warp_cut.cut.tolerances import STATION_GAP, STATION_TURN_DEG
from warp_cut.errors import InputError

SPACING = 2e-3


def straight_incision(points) -> Incision:
    """An uncut incision through ``points`` (k, 3) [m] on the plane z = 0."""
    inc = Incision(np.asarray(points[0], dtype=float), [0.0, 0.0, 1.0], spacing=SPACING, lip_offset=2.5e-4,
                   tolerance=0.1 * SPACING)
    for p in points[1:]:
        inc.extend(np.asarray(p, dtype=float), 0.0)
    return inc


def test_turn_back_reverses_the_path_and_the_curve_follows():
    """Turned back, the path runs the other way and the fitted curve starts at its new start
    and ends at its old one, with the same length (a straight path: exactly)."""
    points = [[0.001 * k, 0.0, 0.0] for k in range(6)]
    inc = straight_incision(points)
    length = inc.length
    inc.turn_back()
    np.testing.assert_allclose(np.array(inc.path), np.array(points[::-1]))
    np.testing.assert_allclose(inc.point_at(np.array([0.0, inc.length])), [points[-1], points[0]], atol=1e-12)
    assert inc.length == pytest.approx(length, rel=1e-9)


def test_start_at_moves_the_start_and_refits_the_curve():
    """``start_at``: the path's first point is the new one, the curve starts there, and its
    length is the new path's chord length (a straight path, extended back along itself by 1 mm)."""
    inc = straight_incision([[0.001 * k, 0.0, 0.0] for k in range(6)])
    inc.start_at([-0.001, 0.0, 0.0])
    np.testing.assert_allclose(inc.path[0], [-0.001, 0.0, 0.0])
    np.testing.assert_allclose(inc.point_at(np.array([0.0]))[0], [-0.001, 0.0, 0.0], atol=1e-12)
    assert inc.length == pytest.approx(0.006, rel=1e-6)


def test_restart_at_drops_the_points_near_the_new_start():
    """``restart_at``: a path from 3 mm back to 0 and on to 5 mm (a hairpin at its first point),
    restarted at 0.1 mm with a 0.5 mm step, keeps the points at least 0.5 mm from the new start
    (1 ... 5 mm; the start's own normal and contact rows stay with it) and the curve runs from
    the new start to the path's end, its length the new chord length."""
    points = [[0.003, 0.0, 0.0], [0.0, 0.0, 0.0]] + [[0.001 * k, 0.0, 0.0] for k in range(1, 6)]
    inc = straight_incision(points)
    inc.restart_at([0.0001, 0.0, 0.0], 0.0005)
    np.testing.assert_allclose(np.array(inc.path)[:, 0], [0.0001, 0.001, 0.002, 0.003, 0.004, 0.005])
    assert len(inc.normals) == len(inc.contact_path) == len(inc.contact_normals) == len(inc.path)
    np.testing.assert_allclose(inc.point_at(np.array([0.0, inc.length])), [[0.0001, 0, 0], [0.005, 0, 0]],
                               atol=1e-12)
    assert inc.length == pytest.approx(0.0049, rel=1e-6)


def test_a_cut_incision_neither_turns_back_nor_moves_its_start():
    """Once some of it is cut (a cut point, a station or a slit node), the path is fixed."""
    inc = straight_incision([[0.001 * k, 0.0, 0.0] for k in range(6)])
    inc.cut_point = np.array([0.002, 0.0, 0.0])
    assert not inc.uncut
    with pytest.raises(InputError, match="before any of it is cut"):
        inc.turn_back()
    with pytest.raises(InputError, match="before any of it is cut"):
        inc.start_at([-0.001, 0.0, 0.0])
    with pytest.raises(InputError, match="before any of it is cut"):
        inc.restart_at([-0.001, 0.0, 0.0], 0.0005)


def test_the_curve_stays_near_crossings_a_spacing_apart_on_tight_arcs():
    """Crossings a spacing apart on half circles of 5-10 spacings' radius, each jittered across
    by up to half the tolerance, added one at a time (as events by travel add them): after every
    extension the curve lies within 1.1 tolerances of the polyline through the crossings, also
    where the refitted tail joins the part frozen before (a joining handle too long for the new
    piece once bulged the curve out by up to 1.85 tolerances between two crossings)."""
    spacing, tol = 2e-3, 2e-4
    for seed in range(30):
        rng = np.random.default_rng(seed)
        radius = rng.uniform(5.0, 10.0) * spacing
        angles = np.arange(0.0, np.pi, spacing / radius)
        r = radius + rng.uniform(-0.5, 0.5, len(angles)) * tol
        points = np.column_stack([r * np.sin(angles), radius - r * np.cos(angles), np.zeros_like(angles)])
        inc = Incision(points[0], [0, 0, 1], spacing=spacing, lip_offset=2.5e-4, tolerance=tol)
        for k, p in enumerate(points[1:], start=2):
            assert inc.extend(p, 0.0)
            dense = inc.point_at(np.linspace(0.0, inc.length, 400))
            off = polyline_distance(dense, points[:k]).max()
            assert off <= 1.1 * tol, f"seed {seed}, {k} crossings: the curve {off / tol:.2f} tolerances off"


def test_stations_are_a_spacing_apart_on_a_straight_cut():
    """Along a straight path each station follows the one before by exactly a spacing."""
    inc = straight_incision([[0.001 * k, 0.0, 0.0] for k in range(13)])
    stations = inc.stations_from(0.0013, 0.011)
    np.testing.assert_allclose(np.diff(stations), SPACING, rtol=1e-9)
    assert stations[0] == pytest.approx(0.0013) and stations[-1] <= 0.011


@pytest.mark.parametrize("turn_deg", [90.0, 135.0])
def test_a_station_comes_sooner_round_a_sharp_corner(turn_deg):
    """A path 6 mm along x, then 6 mm on turned by ``turn_deg``: from a station 0.8 spacings
    before the corner the next one lies where the curve's tangent has turned
    ``STATION_TURN_DEG`` (checked on the fitted curve itself), no nearer than ``STATION_GAP``
    spacings and sooner than a spacing; along the straight legs stations stay a spacing apart."""
    a = np.radians(turn_deg)
    leg = [[0.0005 * k, 0.0, 0.0] for k in range(13)]
    corner = np.array(leg[-1])
    leg2 = [corner + 0.0005 * k * np.array([np.cos(a), np.sin(a), 0.0]) for k in range(1, 13)]
    inc = straight_incision(leg + leg2)
    u_corner = float(inc.project(corner[None])[0][0])
    u0 = u_corner - 0.8 * SPACING
    u1 = inc.next_station_after(u0)
    assert u0 + STATION_GAP * SPACING - 1e-12 <= u1 < u0 + SPACING
    turned = np.degrees(np.arccos(np.clip(inc.tangent_at([u1])[0] @ inc.tangent_at([u0])[0], -1.0, 1.0)))
    assert turned >= STATION_TURN_DEG
    assert inc.next_station_after(0.0005) == pytest.approx(0.0005 + SPACING)  # the straight first leg
