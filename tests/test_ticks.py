"""warp_cut/ticks.py and the run loop's tick metrics: planted tick times and forces give the
percentiles, budget counts and force jumps numpy computes from the same numbers; a run's
metrics.json and timeseries.csv agree with each other and with the step count."""

import csv
import gc
import json
import time

import numpy as np
import pytest

from warp_cut.cli import main
from warp_cut.ticks import TickLog, frozen_gc, wait_until


class _Model:
    topology_version = 0


class ScriptedSim:
    """Stands in for a Simulator: each step sets the next scripted force and, on the listed
    steps, bumps the topology version as a cut event does."""

    def __init__(self, forces, edits=()):
        self.model = _Model()
        self._forces = iter(np.asarray(forces, dtype=float))
        self._edits = set(edits)
        self._k = 0
        self.tool_force = np.zeros(3)

    def step(self, n=1, tool=None):
        assert n == 1
        self.tool_force = next(self._forces)
        if self._k in self._edits:
            self.model.topology_version += 1
        self._k += 1


def test_tick_metrics_of_planted_times():
    log = TickLog(4, budget=1e-3)  # grows past its capacity
    ms = np.concatenate([[40.0], np.full(97, 0.2), [0.9, 1.5, 7.0]])  # the first tick compiles
    sim = ScriptedSim(np.zeros((len(ms), 3)))
    for _ in ms:
        log.step(sim)
    log.seconds[: log.count] = ms * 1e-3  # replace the measured times by planted ones
    t = log.tick_metrics()
    assert t["ticks"] == 101 and t["first_ms"] == pytest.approx(40.0)
    assert t["over_budget"] == 2 and t["budget_ms"] == pytest.approx(1.0)
    assert t["p50"] == pytest.approx(0.2) and t["max"] == pytest.approx(7.0)
    assert t["p99"] == pytest.approx(np.percentile(ms[1:], 99))


def test_force_jumps_and_the_ticks_after_a_cut_event():
    forces = np.zeros((10, 3))
    forces[:, 2] = np.linspace(0.0, 0.09, 10)  # a smooth ramp: jumps of 0.01 N
    forces[6:, 0] = 0.5                       # a 0.5 N step into tick 6
    sim = ScriptedSim(forces, edits=[5])      # the edit is made during tick 5
    log = TickLog(10, budget=1e-3)
    for _ in range(10):
        log.step(sim)
    assert list(np.flatnonzero(log.after_edit[: log.count])) == [6]
    jumps = log.force_jumps()
    np.testing.assert_allclose(jumps, np.linalg.norm(np.diff(forces, axis=0), axis=1))
    j = log.force_jump_metrics()
    assert j["max"] == pytest.approx(np.hypot(0.5, 0.01)) and j["max_at_tick"] == 6
    assert j["max_after_cut"] == pytest.approx(np.hypot(0.5, 0.01)) and j["cut_ticks"] == 1
    no_cut = TickLog(10, budget=1e-3)
    smooth = ScriptedSim(np.column_stack([np.zeros(10), np.zeros(10), forces[:, 2]]))
    for _ in range(10):
        no_cut.step(smooth)
    assert no_cut.force_jump_metrics()["max_after_cut"] is None
    assert no_cut.force_jump_metrics()["max"] == pytest.approx(0.01)


def test_frame_max_covers_the_ticks_since_the_last_frame():
    log = TickLog(6, budget=1e-3)
    sim = ScriptedSim(np.zeros((6, 3)))
    for _ in range(3):
        log.step(sim)
    assert log.frame_max_ms() == pytest.approx(log.seconds[:3].max() * 1e3)
    for _ in range(3):
        log.step(sim)
    assert log.frame_max_ms() == pytest.approx(log.seconds[3:6].max() * 1e3)
    assert log.frame_max_ms() == 0.0  # no tick since


def test_frozen_gc_restores_the_collector():
    with frozen_gc():
        assert gc.get_freeze_count() > 0
    assert gc.get_freeze_count() == 0


def test_run_reports_ticks_in_metrics_and_timeseries(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "skin_press", "--out", str(out), "--quiet", "--no-usd",
                 "--set", "duration=0.1", "--set", "tissue.size=[0.03,0.02]"]) == 0
    m = json.loads((out / "metrics.json").read_text())
    t, j = m["tick_ms"], m["tool_force_jump_n"]
    assert t["ticks"] == m["steps"] and t["budget_ms"] == pytest.approx(m["dt"] * 1e3)
    assert 0 < t["p50"] <= t["p99"] <= t["max"] and 0 <= t["over_budget"] <= t["ticks"]
    assert j["max_after_cut"] is None and j["cut_ticks"] == 0  # skin_press does not cut
    rows = list(csv.DictReader((out / "timeseries.csv").open()))
    per_frame = np.array([float(r["tick_max_ms"]) for r in rows])
    assert per_frame[0] == 0.0 and np.all(per_frame[1:] > 0)  # frame 0 is the initial state
    digits = 1e-8  # timeseries.csv keeps 9 significant digits, metrics.json all of them
    assert per_frame[1] >= t["first_ms"] * (1 - digits)  # frame 1 holds the first tick
    assert per_frame[2:].max() <= t["max"] * (1 + digits)
    assert max(per_frame.max(), t["first_ms"]) == pytest.approx(max(t["max"], t["first_ms"]))
    forces = np.array([[float(r[c]) for c in ("tool_fx", "tool_fy", "tool_fz")] for r in rows])
    # the frames sample the ticks: their changes are no larger than the sum of the ticks'
    assert np.linalg.norm(np.diff(forces, axis=0), axis=1).max() <= j["max"] * (m["steps"] / 6) + 1e-12


def test_wait_until_returns_at_the_deadline_not_before():
    """``wait_until`` (the pacing of ``Pacer``, ``run --cut-in-background`` and the haptic
    example): never returns before its deadline, whether it sleeps (far) or spins (near), and
    a deadline already past returns at once without sleeping."""
    for ahead, spin in ((0.01, 2e-3), (0.003, 2e-4), (0.001, 2e-3)):
        deadline = time.perf_counter() + ahead
        wait_until(deadline, spin)
        assert time.perf_counter() >= deadline
    past = time.perf_counter() - 1.0
    wait_until(past)
    assert time.perf_counter() - past < 1.0 + 0.5  # no second of sleep
