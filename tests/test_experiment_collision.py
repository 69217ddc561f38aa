"""The collision experiment: closed-form contact checked independently, detection against it."""

import csv
import math

import numpy as np
import pytest

from warp_cut.cli import main
from warp_cut.experiments import analytic_first_contact, run_case
from warp_cut.mesh.patch import skin_patch_mesh


def _first_inside_by_sampling(points, tip0, a, speed, length, radius, t_max, samples=20001):
    """Independent check: the paper's test in float64 on a dense time grid; returns the first
    sample time with a node inside and the mean of the nodes inside then."""
    for t in np.array_split(np.linspace(0.0, t_max, samples), 40):
        q = points[None, :, :] - (tip0 - speed * t[:, None] * a)[:, None, :]  # (times, nodes, 3)
        s = q @ a
        inside = (s >= 0) & (s <= length) & (np.einsum("tij,tij->ti", q, q) - s * s < radius**2)
        hit = np.flatnonzero(inside.any(axis=1))
        if len(hit):
            k = hit[0]
            return t[k], points[inside[k]].mean(axis=0)
    return None, None


@pytest.mark.parametrize("angle", [30, 45, 70])
def test_closed_form_matches_an_independent_search(angle):
    pts, _ = skin_patch_mesh((0.03, 0.03), 0.002)
    speed, t0, r, L = 0.01, 0.5, 0.001, 0.04
    tip0, a, point = analytic_first_contact(pts, angle, speed, t0, r)
    assert a == pytest.approx([math.cos(math.radians(angle)), 0, math.sin(math.radians(angle))])
    t, p = _first_inside_by_sampling(pts, tip0, a, speed, L, r, 2 * t0)
    step = 2 * t0 / 20000
    assert t0 <= t <= t0 + step and p == pytest.approx(point)


@pytest.mark.parametrize("t0", [0.05, 0.0504])
def test_detection_against_the_analytic_contact(t0):
    case = run_case(40.0, 0.01, t0=t0, rate=1000.0, size=(0.02, 0.02))
    assert case.t_analytic == t0
    # the per-step test: the end of the first step at or after the contact
    assert case.t_discrete == pytest.approx(math.ceil(t0 * 1000 - 1e-9) / 1000, abs=1e-12)
    assert 0 <= case.relative_error_pct("discrete") < 100 * 1e-3 / t0
    # continuous detection: the exact time, up to the float32 node coordinates (~1e-9 m / v)
    assert case.t_ccd == pytest.approx(t0, abs=1e-7)
    assert case.point_ccd == pytest.approx(case.point_analytic, abs=1e-9)
    assert case.point_discrete == pytest.approx(case.point_analytic, abs=1e-9)


def test_cli_writes_table_csv_and_picture(tmp_path, capsys):
    out = tmp_path / "col"
    assert main(["experiment", "collision", "--out", str(out), "--angles", "30,70",
                 "--speeds", "0.01,0.02", "--t0", "0.0304"]) == 0
    assert "paper: 0.05 %" in capsys.readouterr().out
    rows = list(csv.DictReader((out / "collision.csv").open()))
    assert [(float(r["angle_deg"]), float(r["speed_m_s"])) for r in rows] == [
        (30, 0.01), (70, 0.01), (30, 0.02), (70, 0.02)]
    for r in rows:
        assert float(r["t_discrete_s"]) == pytest.approx(0.031, abs=1e-12)
        # node coordinates are float32 on the device: half an ulp (~1e-9 m at 2 cm) over the
        # speed bounds the continuous time's error
        assert abs(float(r["t_ccd_s"]) - 0.0304) < 1e-9 / float(r["speed_m_s"])
    md = (out / "collision.md").read_text()
    assert "| 30 deg | 70 deg |" in md and "0.05 |" in md and "Continuous detection" in md
    assert (out / "collision_points.png").stat().st_size > 10_000


@pytest.mark.parametrize("args", [["--angles", "95"], ["--speeds", "0"], ["--t0", "-1"],
                                  ["--angles", "a,b"]])
def test_bad_options_exit_2_and_write_nothing(tmp_path, args):
    out = tmp_path / "never"
    try:
        code = main(["experiment", "collision", "--out", str(out)] + args)
    except SystemExit as exc:  # argparse refuses malformed numbers itself
        code = exc.code
    assert code == 2 and not out.exists()
