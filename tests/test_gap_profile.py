"""Cutter.gap_profile and the run's incision_profile.csv / incision.max_gap_m.

Compared against: the paired lip nodes themselves (distances recomputed from the final mesh),
the incision width (the median of the same pairs), and the incision's stations.
"""

import csv
import json

import numpy as np
import pytest

from warp_cut.cli import main
from warp_cut.runner import PROFILE_COLUMNS, run_scene
from warp_cut.scene import load_scene

QUICK = ["tissue.size=[0.04,0.03]", "duration=0.8"]


def test_run_writes_the_opening_profile(tmp_path):
    out = tmp_path / "run"
    args = ["run", "paper_width_curve", "--out", str(out), "--quiet", "--no-usd"]
    assert main(args + [a for s in QUICK for a in ("--set", s)]) == 0
    rows = list(csv.reader((out / "incision_profile.csv").open()))
    assert rows[0] == PROFILE_COLUMNS
    data = np.array(rows[1:], dtype=float)
    assert len(data) >= 5
    metrics = json.loads((out / "metrics.json").read_text())
    incision = metrics["incision"]
    assert incision["max_gap_m"] == pytest.approx(data[:, 2].max(), rel=1e-8)
    assert incision["width_m"] == pytest.approx(np.median(data[:, 2]), rel=1e-8)
    u = data[:, 1]
    assert np.all(np.diff(u) > 0) and 0 < u[0] and u[-1] < incision["length_m"]


def test_gap_profile_is_the_distance_between_paired_lips():
    keep = {}

    class Grab:
        def on_frame(self, sim, frame):
            keep["sim"] = sim

        def finish(self, metrics):
            pass

    run_scene(load_scene("paper_width_curve", QUICK), observers=[Grab()])
    sim = keep["sim"]
    inc = sim.cutter.incisions[0]
    profile = sim.cutter.gap_profile(sim.positions)
    pairs = inc.pairs()
    x = sim.positions
    np.testing.assert_allclose(profile["gap_m"], np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1))
    stations = [u for u, a, b in zip(inc.station_u, inc.left, inc.right) if a >= 0 and b >= 0]
    np.testing.assert_allclose(profile["arc_length_m"], stations)
    assert np.all(profile["incision"] == 0)
