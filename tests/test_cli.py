"""warp_cut/cli.py: outputs, exit codes, and nothing written on bad input or instability."""

import csv
import json
import subprocess
import sys

import pytest

from warp_cut.cli import main
from warp_cut.runner import TIMESERIES_COLUMNS

FAST = ["--set", "duration=0.1", "--set", "tissue.size=[0.03,0.02]"]


def test_run_default_scene_writes_metrics_and_timeseries(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--out", str(out), "--quiet"] + FAST) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    for key in ("name", "nodes", "springs", "triangles", "steps", "dt", "substeps", "sim_time_s",
                "wall_time_s", "realtime_factor", "first_contact_time_s", "first_contact_point",
                "max_tool_force_n", "finite"):
        assert key in metrics
    assert metrics["finite"] is True and metrics["sim_time_s"] == pytest.approx(0.1)
    assert metrics["steps"] * metrics["dt"] == pytest.approx(0.1)
    rows = list(csv.reader((out / "timeseries.csv").open()))
    assert rows[0] == TIMESERIES_COLUMNS + ["incision_width_m"]  # the default scene cuts
    assert len(rows) == 1 + 1 + round(0.1 * 60)
    assert (out / "final_mesh.ply").is_file()
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary left


def test_press_scene_makes_contact_and_force(tmp_path):
    out = tmp_path / "press"
    assert main(["run", "skin_press", "--out", str(out), "--quiet", "--set", "duration=0.5"]) == 0
    m = json.loads((out / "metrics.json").read_text())
    # the tip moves from z = 5 mm to z = -4 mm over 0.5 s; it reaches the sheet (which sags
    # slightly under gravity) shortly after 0.5 * 5/9 s
    assert 0.25 < m["first_contact_time_s"] < 0.35
    assert m["max_tool_force_n"] > 0.01


def test_bad_input_exit_2_and_nothing_written(tmp_path, capsys):
    out = tmp_path / "never"
    assert main(["run", "--out", str(out), "--set", "tool.radius=-0.001"]) == 2
    assert "tool.radius" in capsys.readouterr().err
    assert not out.exists()
    assert main(["run", str(tmp_path / "missing.toml"), "--out", str(out)]) == 2
    assert not out.exists()


def test_unstable_exit_3_and_nothing_written(tmp_path, capsys):
    out = tmp_path / "boom"
    code = main(["run", "skin_press", "--out", str(out), "--quiet", "--set", "physics.collision=false",
                 "--set", "material.damping=0", "--set", "solver.substeps=1",
                 "--set", "solver.dt=0.01", "--set", "duration=0.5"] + FAST[2:])
    assert code == 3
    err = capsys.readouterr().err
    assert "unstable" in err and "stable step" in err
    assert not out.exists()


def test_validate_checks_without_running(tmp_path):
    assert main(["validate", "skin_press"]) == 0
    bad = tmp_path / "bad.toml"
    bad.write_text("name = 'x'\n[tissue]\nspacing = -1\n")
    assert main(["validate", str(bad)]) == 2


def test_console_script_exit_code(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("this is = = not toml")
    proc = subprocess.run([sys.executable, "-m", "warp_cut.cli", "validate", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "bad.toml" in proc.stderr
