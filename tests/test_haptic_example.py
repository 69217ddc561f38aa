"""examples/haptic_loop.py: runs a few hundred ticks and prints its summary; its trace file
round-trips; a bad trace is exit code 2 with the file named; the stylus quaternion maps +z
onto the axis it was made from."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "haptic_loop.py"


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location("haptic_loop", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_runs_a_few_hundred_ticks_as_a_script():
    # The script goes in for 200 ticks, then draws at 2 cm/s. The slit's tip stays
    # r / sin 60 deg + s / 4 = 1.65 mm behind the blade while it cuts, and from its start the
    # slit opens once it holds its first lip pair (FIRST_STATION + LAST_STATION = 1.15 spacings
    # = 2.3 mm): the first edit comes once the blade has drawn 3.95 mm (tick 398), at the next
    # event that extends the incision (every other one of an event every 1/60 s, the blade
    # drawing 1/3 mm between two: by tick 432). --max-lag 1: each edit lands two ticks after
    # its event, however long the worker takes on a loaded machine, so the edits of these 500
    # ticks arrive within them every run
    done = subprocess.run([sys.executable, str(EXAMPLE), "--ticks", "500", "--print-every", "100",
                           "--max-lag", "1"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert "summary: 500 ticks" in out and "missed deadlines" in out and "step per tick: p50" in out
    assert "tick 100: t = 0.102 s, force" in out  # one untimed tick first, then 0, 1, ...
    assert "cutting in a worker process" in out
    edits = [line for line in out.splitlines() if "topology edits" in line]
    assert edits and int(edits[0].split("cut: ")[1].split()[0]) > 0  # the worker's edits arrived


def test_no_cut_and_a_written_trace_give_the_same_forces(example, tmp_path, capsys):
    trace = tmp_path / "trace.csv"
    assert example.main(["--write-trace", str(trace), "--ticks", "250"]) == 0
    rows = example.read_trace(trace)
    np.testing.assert_allclose(rows, example.scripted_trace(250), rtol=0, atol=1e-9)
    assert example.main(["--trace", str(trace), "--no-cut", "--print-every", "0"]) == 0
    from_file = capsys.readouterr().out
    assert example.main(["--ticks", "249", "--no-cut", "--print-every", "0"]) == 0
    scripted = capsys.readouterr().out
    assert "cutting off: one untimed tick, then 249 at 1 kHz" in from_file
    force_line = [line for line in from_file.splitlines() if "tool force: max" in line]
    assert force_line and force_line == [line for line in scripted.splitlines() if "tool force: max" in line]


def test_a_bad_trace_is_exit_2_naming_the_file(example, tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x,y,z,qw,qx,qy,qz\n0.001,0,0,0.01,2,0,0,0\n")
    assert example.main(["--trace", str(bad)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "unit quaternion" in err
    bad.write_text("time,x,y,z\n")
    assert example.main(["--trace", str(bad)]) == 2
    assert "header" in capsys.readouterr().err
    assert example.main(["--trace", str(tmp_path / "missing.csv")]) == 2
    assert "missing.csv" in capsys.readouterr().err


def test_the_stylus_quaternion_turns_z_onto_the_axis(example, rng):
    for axis in list(rng.normal(size=(20, 3))) + [np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 2.0])]:
        q = example.axis_quaternion(axis)
        assert np.linalg.norm(q) == pytest.approx(1.0)
        np.testing.assert_allclose(example.rotate_z(q), axis / np.linalg.norm(axis), atol=1e-12)
