"""warp_cut/batch (pool, store, report) and ``warp-cut batch``: the process pool and a
real Dask cluster give the same results, an interrupted batch resumes without losing or
repeating work, and failing scenarios do not stop the others."""

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from matplotlib.image import imread

from warp_cut.batch import pool as batch
from warp_cut.batch.pool import run_batch
from warp_cut.batch.store import BatchStore
from warp_cut.batch.sweep import load_sweep
from warp_cut.cli import main

TINY = """base = "skin_press"
[set]
"tissue.size" = [0.02, 0.02]
duration = 0.3
"""
WALL_FIELDS = {"wall_time_s", "realtime_factor", "usd_write_time_s", "tick_ms"}
"""Metrics that measure the machine, not the simulation."""
WALL_COLUMNS = {"tick_max_ms"}
"""Time series columns that measure the machine."""


def _write(tmp_path, text, name="sweep.toml") -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def _rows(out) -> list[dict]:
    with open(Path(out) / "results.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _metrics(run_dir: Path) -> dict:
    """metrics.json without wall times, checking that the USD it names is in ``run_dir``."""
    metrics = json.loads((run_dir / "metrics.json").read_text())
    if "usd_file" in metrics:
        assert Path(metrics.pop("usd_file")) == run_dir / "skin_press.usdc"
    return {k: v for k, v in metrics.items() if k not in WALL_FIELDS}


def _content(path: Path):
    """A file's bytes; for timeseries.csv its rows as text without the wall-time columns (the
    simulated values still compared character for character)."""
    if path.name != "timeseries.csv":
        return path.read_bytes()
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    keep = [i for i, name in enumerate(rows[0]) if name not in WALL_COLUMNS]
    return [[row[i] for i in keep] for row in rows]


def _files(run_dir: Path) -> set:
    """Every file under run_dir, as relative paths."""
    return {p.relative_to(run_dir).as_posix() for p in run_dir.rglob("*") if p.is_file()}


def _entries(out) -> set:
    return {p.name for p in (Path(out) / "runs").iterdir()}


@pytest.fixture(scope="module")
def pool_run(tmp_path_factory):
    """A 2 x 2 sweep run once on a local pool of two processes."""
    tmp = tmp_path_factory.mktemp("pool")
    sweep = _write(tmp, TINY + '[grid]\n"material.stiffness" = [80.0, 160.0]\n'
                                 '"tool.radius" = [0.0005, 0.001]\n')
    summary = run_batch(load_sweep(sweep), tmp / "out", workers=2)
    return sweep, tmp / "out", summary


def test_pool_runs_every_scenario_as_warp_cut_run_does(pool_run, tmp_path):
    sweep_path, out, summary = pool_run
    sweep = load_sweep(sweep_path)
    assert summary.all_ok and summary.counts["ok"] == 4 and summary.skipped == 0
    rows = _rows(out)
    assert [r["id"] for r in rows] == [s.id for s in sweep.scenarios]
    assert {r["status"] for r in rows} == {"ok"} and {r["message"] for r in rows} == {""}
    assert [float(r["material.stiffness"]) for r in rows] == [80, 80, 160, 160]
    assert _entries(out) == {s.id for s in sweep.scenarios}
    # the last scenario, run on its own by warp-cut run with the recorded overrides
    scenario = sweep.scenarios[-1]
    record = json.loads((out / "runs" / scenario.id / "scenario.json").read_text())
    assert record["status"] == "ok" and record["overrides"] == sweep.overrides(scenario)
    args = ["run", "skin_press", "--out", str(tmp_path / "single"), "--quiet"]
    for item in record["overrides"]:
        args += ["--set", item]
    assert main(args) == 0
    ours, theirs = out / "runs" / scenario.id, tmp_path / "single"
    assert _metrics(ours) == _metrics(theirs)
    assert _files(ours) == _files(theirs) | {"scenario.json"}
    for name in _files(theirs) - {"metrics.json"}:  # time series, final mesh: byte for byte
        assert _content(ours / name) == _content(theirs / name)
    # the csv carries the metrics of metrics.json
    row = rows[-1]
    m = _metrics(out / "runs" / scenario.id)
    assert float(row["max_tool_force_n"]) == pytest.approx(m["max_tool_force_n"], rel=1e-8)
    assert int(row["steps"]) == m["steps"] and m["max_tool_force_n"] > 0


def _gated_worker(gate: Path, proc) -> tuple[int, str]:
    """(pid, task key) of the first worker whose scenario reached the gate (tests/dask_gate.py)."""
    deadline = time.monotonic() + 300
    while not (started := sorted(gate.glob("started-*"))):
        assert proc.poll() is None, f"the batch ended before a scenario started: {proc.communicate()}"
        assert time.monotonic() < deadline, "no scenario reached the gate"
        time.sleep(0.02)
    return int(started[0].name.split("-")[1]), started[0].read_text()


def test_dask_cluster_gives_identical_metrics_after_losing_a_worker(pool_run, tmp_path):
    distributed = pytest.importorskip("distributed")
    import dask_gate

    sweep, pool_out, _ = pool_run
    out, gate = tmp_path / "dask", tmp_path / "gate"
    gate.mkdir()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        with distributed.Client(cluster.scheduler_address) as client:
            client.wait_for_workers(2)
            client.run(dask_gate.install, str(gate))  # scenarios wait for the test's word
            proc = subprocess.Popen([sys.executable, "-m", "warp_cut.cli", "batch", sweep, "--out",
                                     str(out), "--scheduler", cluster.scheduler_address, "--quiet"],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            try:
                # a worker killed while its scenario is certainly unfinished (held at the gate):
                # the scheduler gives the scenario to another worker
                pid, key = _gated_worker(gate, proc)
                os.kill(pid, signal.SIGKILL)
                (gate / "open").touch()
                stdout, stderr = proc.communicate(timeout=300)
            finally:
                if proc.poll() is None:
                    proc.kill()
            story = client.story(key)  # scheduler events: ("scheduler", key, from, to, ...)
            assert sum(1 for e in story if e[0] == "scheduler" and e[3] == "processing") >= 2, story
    assert proc.returncode == 0, stderr
    assert "4 scenarios (0 already done): 4 ok" in stdout and "lost" not in stdout + stderr
    assert _entries(out) == _entries(pool_out)
    for name in _entries(out):
        ours, theirs = out / "runs" / name, pool_out / "runs" / name
        assert _metrics(ours) == _metrics(theirs)
        assert _files(ours) == _files(theirs)
        for file in _files(ours) - {"metrics.json", "scenario.json"}:
            assert _content(ours / file) == _content(theirs / file)
    def drop(row):
        return {k: v for k, v in row.items()  # flattened: tick_ms.p50, ...
                if k.split(".")[0] not in WALL_FIELDS | {"worker_time_s", "usd_file"}}
    assert [drop(r) for r in _rows(out)] == [drop(r) for r in _rows(pool_out)]


DRIVER = Path(__file__).with_name("batch_driver.py")
"""Runs warp-cut with a kill at a chosen point (see its docstring)."""


def _driven(action, arg, args) -> subprocess.Popen:
    """``warp-cut ARGS`` under the driver, in its own session (so its process group is its
    own: a kill of the group leaves pytest alone)."""
    return subprocess.Popen([sys.executable, str(DRIVER), action, str(arg)] + args,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def _finished(out) -> set:
    """Run directories present (complete ones: temporaries are hidden)."""
    return {n for n in _entries(out) if not n.startswith(".")} if (Path(out) / "runs").is_dir() else set()


def _assert_whole(out, names) -> dict:
    """Every run directory of ``names`` is complete; returns their (inode, mtime) stamps."""
    stamps = {}
    for name in names:
        run = Path(out) / "runs" / name
        assert {"metrics.json", "timeseries.csv", "scenario.json"} <= _files(run)
        assert not [n for n in _files(run) if n.startswith(".")]
        stamps[name] = (run.stat().st_ino, (run / "metrics.json").stat().st_mtime_ns)
    return stamps


def test_killed_batch_resumes_with_one_row_per_scenario(tmp_path, capsys):
    sweep = _write(tmp_path, TINY + '[grid]\n"material.stiffness" = [60.0, 80.0, 120.0, 160.0]\n')
    ids = [s.id for s in load_sweep(sweep).scenarios]
    out = tmp_path / "out"
    # kill -9 of the batch and its pool worker right after the 2nd scenario is committed
    proc = _driven("kill-batch", 2, ["batch", sweep, "--out", str(out), "--workers", "1",
                                     "--quiet", "--no-usd"])
    try:
        while proc.poll() is None:
            # results.csv is always whole, and never ahead of the run directories (read it first)
            rows = _rows(out) if (out / "results.csv").exists() else []
            assert {r["id"] for r in rows} <= _finished(out)
            time.sleep(0.01)
        proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == -signal.SIGKILL
    finished = _finished(out)
    assert finished == set(ids[:2])  # one worker: the scenarios finish in sweep order
    before = _assert_whole(out, finished)

    assert main(["batch", sweep, "--out", str(out), "--workers", "2", "--quiet", "--no-usd"]) == 0
    assert "(2 already done)" in capsys.readouterr().out
    rows = _rows(out)
    assert [r["id"] for r in rows] == ids and {r["status"] for r in rows} == {"ok"}
    assert _entries(out) == set(ids)  # no temporaries left behind
    for name, stamp in before.items():  # what had finished was not run again
        run = out / "runs" / name
        assert (run.stat().st_ino, (run / "metrics.json").stat().st_mtime_ns) == stamp
    assert main(["batch", sweep, "--out", str(out), "--quiet"]) == 0
    assert f"({len(ids)} already done)" in capsys.readouterr().out


def test_a_killed_pool_worker_is_replaced_and_its_scenario_rerun(tmp_path):
    sweep = _write(tmp_path, TINY + '[grid]\n"material.stiffness" = [60.0, 80.0, 120.0]\n')
    ids = [s.id for s in load_sweep(sweep).scenarios]
    out = tmp_path / "out"
    # the worker is killed while it runs the 2nd scenario (right after the 1st is committed)
    proc = _driven("kill-worker", 1, ["batch", sweep, "--out", str(out), "--workers", "1",
                                      "--no-usd"])
    stdout, stderr = proc.communicate(timeout=300)
    assert "batch_driver: killing worker" in stderr
    assert proc.returncode == 0, stderr
    assert "3 scenarios (0 already done): 3 ok, 0 failed, 0 unstable -> " in stdout
    assert "lost" not in stdout + stderr
    rows = _rows(out)
    assert [r["id"] for r in rows] == ids and {r["status"] for r in rows} == {"ok"}
    assert _entries(out) == set(ids)
    _assert_whole(out, ids)


def test_a_scenario_that_kills_its_worker_is_lost_alone(tmp_path, capsys):
    sweep = _write(tmp_path, TINY + '[grid]\n"material.stiffness" = [60.0, 80.0, 120.0]\n')
    ids = [s.id for s in load_sweep(sweep).scenarios]
    out = tmp_path / "out"
    # the worker running stiffness 80 dies every time: the pool breaks (failing the others it
    # held), the suspects run again one at a time, and only that one is lost
    proc = _driven("poison", "material.stiffness=80.0", ["batch", sweep, "--out", str(out),
                                                         "--workers", "2", "--no-usd"])
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 1, stderr
    assert "3 scenarios (0 already done): 2 ok, 0 failed, 0 unstable, 1 lost (rerun to retry)" in stdout
    assert "lost material.stiffness=80.0: BrokenProcessPool" in stderr
    assert [r["id"] for r in _rows(out)] == [ids[0], ids[2]]
    assert _finished(out) == {ids[0], ids[2]} and _entries(out) == _finished(out)
    # the next call runs the lost one only (here its worker survives)
    assert main(["batch", sweep, "--out", str(out), "--workers", "1", "--quiet", "--no-usd"]) == 0
    assert "(2 already done)" in capsys.readouterr().out
    assert [r["status"] for r in _rows(out)] == ["ok"] * 3


@pytest.mark.parametrize("target", ["process", "group"])
def test_ctrl_c_exits_130_at_once_and_keeps_what_finished(tmp_path, target):
    # Ctrl-C in a terminal signals the whole process group; kill -INT the batch process only.
    # The second scenario would run for many minutes (100 s take ~15 s here): the batch must
    # stop it, not wait for it
    sweep_path = _write(tmp_path, TINY + '[[cases]]\nduration = 0.05\n[[cases]]\nduration = 5000.0\n')
    sweep = load_sweep(sweep_path)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "warp_cut.cli", "batch", sweep_path, "--out",
                             str(out), "--workers", "1", "--no-usd"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        while proc.poll() is None and not _finished(out):
            time.sleep(0.01)
        assert proc.poll() is None, proc.communicate()
        (os.killpg if target == "group" else os.kill)(proc.pid, signal.SIGINT)
        _, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, stderr
    assert "interrupted; finished scenarios are kept in" in stderr and "Traceback" not in stderr
    first, second = (s.id for s in sweep.scenarios)
    assert _finished(out) == {first} and _entries(out) == {first}  # no temporary left
    _assert_whole(out, [first])
    assert {r["id"] for r in _rows(out)} <= {first}
    # the lock is free and the next call would run the second scenario only
    with BatchStore(out, sweep) as store:
        assert [s.id for s in store.load_finished()] == [second]


def test_bad_and_unstable_scenarios_do_not_stop_the_others(tmp_path, capsys):
    sweep = _write(tmp_path, TINY + """
[[cases]]
"material.damping" = 1.0
[[cases]]
"material.stiffness" = -1.0
[[cases]]
"physics.collision" = false
"material.damping" = 0.0
"solver.substeps" = 1
"solver.dt" = 0.01
duration = 0.5
[[cases]]
"material.stiffness" = 80.0
""")
    out = tmp_path / "out"
    assert main(["batch", sweep, "--out", str(out), "--workers", "2", "--no-usd"]) == 1
    captured = capsys.readouterr()
    assert "4 scenarios (0 already done): 2 ok, 1 failed, 1 unstable" in captured.out
    assert "done 4, failed 2, remaining 0" in captured.err  # progress lines off a terminal
    rows = {r["id"]: r for r in _rows(out)}
    assert [r["status"] for r in rows.values()] == ["ok", "failed", "unstable", "ok"]
    bad = rows["material.stiffness=-1.0"]
    assert "skin_press.toml: [material.stiffness] must be in [0, 1000000000.0], got -1.0" in bad["message"]
    assert bad["max_tool_force_n"] == "" and float(bad["material.stiffness"]) == -1.0
    unstable = rows[next(i for i in rows if i.startswith("physics.collision=false"))]
    assert "simulation unstable" in unstable["message"] and "stable step" in unstable["message"]
    assert rows["material.damping=1.0"]["message"] == "" and rows["material.stiffness=80.0"]["steps"]
    assert {p.name for p in (out / "runs" / "material.stiffness=-1.0").iterdir()} == {"scenario.json"}

    stamps = {i: (out / "runs" / i).stat().st_ino for i in rows}
    assert main(["batch", sweep, "--out", str(out), "--quiet"]) == 1  # nothing left to run
    assert "(4 already done)" in capsys.readouterr().out
    assert {i: (out / "runs" / i).stat().st_ino for i in rows} == stamps
    assert main(["batch", sweep, "--out", str(out), "--quiet", "--retry-failed"]) == 1
    assert "(2 already done)" in capsys.readouterr().out
    after = {i: (out / "runs" / i).stat().st_ino for i in rows}
    assert [after[i] == stamps[i] for i in rows] == [True, False, False, True]
    assert [r["status"] for r in _rows(out)] == ["ok", "failed", "unstable", "ok"]


def test_changed_base_scene_reruns_its_scenarios(tmp_path, capsys):
    sweep = _write(tmp_path, 'base = "skin_press"\n[set]\n"tissue.size" = [0.02, 0.02]\n'
                             'duration = 0.05\n[grid]\n"material.stiffness" = [80.0]\n')
    out = tmp_path / "out"
    assert main(["batch", sweep, "--out", str(out), "--workers", "1", "--quiet", "--no-usd"]) == 0
    capsys.readouterr()
    sweep_text = Path(sweep).read_text().replace("duration = 0.05", "duration = 0.1")
    Path(sweep).write_text(sweep_text)
    assert main(["batch", sweep, "--out", str(out), "--workers", "1", "--quiet", "--no-usd"]) == 0
    assert "(0 already done)" in capsys.readouterr().out
    assert float(_rows(out)[0]["sim_time_s"]) == pytest.approx(0.1)
    assert _entries(out) == {"material.stiffness=80.0"}


def test_worker_without_the_scene_file_runs_the_text_it_was_sent():
    from warp_cut.scene import bundled_scene_path

    text = bundled_scene_path("skin_press").read_text()
    outcome = batch.run_scenario({
        "scene_text": text, "scene_path": "/nonexistent/elsewhere/skin_press.toml",
        "overrides": ["tissue.size=[0.02, 0.02]", "duration=0.05"], "usd": False})
    assert outcome["status"] == "ok", outcome["message"]
    metrics = json.loads(outcome["files"]["metrics.json"])
    assert metrics["name"] == "skin_press" and metrics["sim_time_s"] == pytest.approx(0.05)
    assert "timeseries.csv" in outcome["files"] and not any(f.endswith(".usdc") for f in outcome["files"])


def test_bad_input_exit_2_and_nothing_written(tmp_path, capsys, monkeypatch):
    out = tmp_path / "never"
    bad = _write(tmp_path, 'base = "skin_press"\n[grid]\n"material.stiffness" = 80.0\n')
    assert main(["batch", bad, "--out", str(out)]) == 2
    assert 'sweep.toml: [grid."material.stiffness"]' in capsys.readouterr().err
    good = _write(tmp_path, TINY, "good.toml")
    assert main(["batch", good, "--out", str(out), "--workers", "0"]) == 2
    assert main(["batch", good, "--out", str(out), "--workers", "1",
                 "--scheduler", "tcp://127.0.0.1:9"]) == 2
    monkeypatch.setattr(batch, "CONNECT_TIMEOUT_S", 0.5)
    assert main(["batch", good, "--out", str(out), "--scheduler", "tcp://127.0.0.1:9"]) == 2
    assert "cannot connect" in capsys.readouterr().err
    assert not out.exists()
    (tmp_path / "file").write_text("")
    assert main(["batch", good, "--out", str(tmp_path / "file")]) == 2


def test_one_batch_at_a_time_per_directory(tmp_path, capsys):
    sweep = load_sweep(_write(tmp_path, TINY))
    with BatchStore(tmp_path / "out", sweep):
        with pytest.raises(Exception, match="another warp-cut batch is writing there"):
            run_batch(sweep, tmp_path / "out", workers=1)


def test_report_draws_metrics_against_parameters(pool_run, tmp_path, capsys):
    _, out, _ = pool_run
    assert main(["report", str(out)]) == 0
    plots = sorted(p.name for p in (out / "plots").iterdir())
    assert plots == ["material.stiffness.png", "tool.radius.png"]
    for name in plots:
        assert (out / "plots" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        img = imread(out / "plots" / name)
        # panels of 4.4 x 3.3 in at 100 dpi, up to three a row; drawn on (a blank page has std 0)
        assert img.shape[1] in (440, 880, 1320) and img.shape[0] % 330 == 0
        assert img[:, :, :3].std() > 0.05
    assert main(["report", str(tmp_path)]) == 2
    assert "batch.json: not found" in capsys.readouterr().err


def test_ctrl_c_is_raised_only_where_the_batch_checks_for_it():
    # a KeyboardInterrupt at any bytecode could land inside concurrent.futures holding a
    # future's lock (the batch then hung at exit) or half-way through writing a result
    before = signal.getsignal(signal.SIGINT)
    with batch._DeferredInterrupt() as interrupt:
        interrupt.check()  # nothing yet
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)  # the handler runs; no KeyboardInterrupt here
        with pytest.raises(KeyboardInterrupt):
            interrupt.check()
    assert signal.getsignal(signal.SIGINT) is before
