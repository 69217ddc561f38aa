"""BackgroundCutter: the cut's host work in a second process, so a 1 kHz loop keeps its ticks.

A cut event (Stages 1-3, ``warp_cut.cut.cutter``) is milliseconds of Python. In the stepping
thread it makes its tick late; a thread beside the loop does not help, as the interpreter lock
makes every tick wait for it (``benchmarks/bench_edit_thread.py``). Here a worker process
holds a replica of the model and runs the Cutter on it (``warp_cut.cut.cut_worker``):

1. at a due event the loop copies the node positions into memory shared with the worker and
   sends it the tool poses since the previous event (a small pipe write), and steps on;
2. the worker runs the event on its replica and sends back the edit: the changed rows of the
   model's slot tables, the new nodes' positions and the explicit step's new limit;
3. the loop receives it at the first step after it arrives and applies it at the next
   (``SlotTable.put_rows`` and ``Simulator.notify_model_changed``, the stable step worked out
   by the worker with the simulation's own integrator: a few hundred microseconds, nothing
   that grows with the mesh or the cut). Sending, receiving and applying each take a step of
   their own.

While an edit is in flight no event is sent; the next is due one interval after the previous
one was sent, or at once when the tool has left the tissue (the end of an incision). The edit
applies to the tissue some steps after the positions it was computed from (the worker's time
for the event, 10-20 ms on the bundled patches): the nodes have moved by what they move in
that time (a tool at 2 cm/s, 0.2-0.4 mm). Each new node therefore comes with anchors, the
nearest nodes alive at the event, and the loop moves it by their mean motion since the event
(inverse-distance weights) when it applies the edit: the new nodes land where the tissue they
were made in is now.

The worker runs on the CPU whatever the simulation's device. What the Cutter reports is asked
of the worker (``metrics(sim)``, or ``call(sim, name, *args)`` for any other method or
attribute, e.g. ``"incisions"`` or ``"gap_profile"``) after the edit in flight has been
applied.
"""

from __future__ import annotations

import multiprocessing
import os
import time
import weakref

import numpy as np
import warp as wp

from ..errors import CutWorkerError, InputError
from ..sim.collision import pushed_out
from ..sim.model import TissueModel
from .cut_worker import CutSummary, ModelEdit, SharedPositions, WorkerEvent, serve
from .events import EventClock
from .host import CutHost
from .settings import CutSettings
from .wound.measures import incision_width

__all__ = ["BackgroundCutter", "arrival_positions"]

_START_TIMEOUT_S = 120.0
"""How long the worker may take to start (import Warp, load the cut's kernels) [s]."""
ANSWER_TIMEOUT_S = 60.0
"""How long the loop waits for an answer it needs now (an edit it must apply, a query) before
it takes the worker for hung [s]: an event takes it milliseconds."""


class _LipPairs:
    """An incision as the loop sees it between edits: its paired lip nodes (what
    ``warp_cut.cut.wound.measures.incision_width`` reads)."""

    def __init__(self, pairs: np.ndarray):
        self._pairs = pairs

    def pairs(self) -> np.ndarray:
        return self._pairs


class _Resources:
    """What outlives a BackgroundCutter unless released: the worker, its pipe, the shared
    buffer (kept apart from the BackgroundCutter so that a finalizer can release them)."""

    def __init__(self, process, conn):
        self.process, self.conn = process, conn
        self.shared: SharedPositions | None = None
        self.hung = False
        """The worker stopped answering: it is killed, not asked to stop."""

    def release(self) -> None:
        """Stop the worker (asked first, unless it has hung), close the pipe, free the buffer."""
        if self.process.is_alive() and not self.hung:
            try:
                self.conn.send(("stop", None))
                self.process.join(timeout=5.0)
            except (BrokenPipeError, OSError):
                pass
        if self.process.is_alive():
            self.process.kill()  # a hung (even a stopped) process ends only so
            self.process.join(timeout=5.0)
        self.conn.close()
        if self.shared is not None:
            self.shared.release(unlink=True)
            self.shared = None


def _worker_cpus() -> set[int] | None:
    """The CPUs the loop's process is not pinned to, or None (not pinned, or no affinity)."""
    if not hasattr(os, "sched_getaffinity"):
        return None
    others = set(range(os.cpu_count() or 1)) - os.sched_getaffinity(0)
    return others or None


def arrival_positions(edits, at_event: np.ndarray, now: np.ndarray, tool) -> list[np.ndarray]:
    """Where each edit's new nodes land [m] ((k, 3) per edit): moved as their anchors moved from
    ``at_event`` to ``now`` (node positions (n, 3) by slot), then, with a ``tool`` (its pose
    now; None: no tool), put on its surface where they would lie inside it: it has moved on
    since the event, and a node inside it would be pushed out in one step (a force spike)."""
    arrived = [edit.positions_now(at_event, now) for edit in edits]
    return arrived if tool is None else [pushed_out(x, tool) for x in arrived]


class BackgroundCutter:
    """A Cutter in a worker process, driven by the loop's ``after_step`` like a Cutter.

    Args:
        model: The tissue the simulation steps (edited by the worker's edits as they arrive).
        settings: Cutting parameters (default ``CutSettings(worker=True)``). ``max_lag``: the
            steps an event may stay in flight; at the next step the loop waits for the
            worker's answer. None (default): never wait, the edit lands when it is ready (an
            event takes the worker 10-25 ms, more where holes are re-tried). A loop faster than
            real time may set it, so that the cut does not fall behind the tool by more than
            this; 1: every edit lands two steps after its event (reproducible run to run).
        cpus: CPUs the worker may run on (default: when the loop's process is pinned to some
            of the machine's CPUs, the others; else the same as the loop's).
        limit_tracker: The simulation's integrator's step-limit tracker
            (``SolverBase.limit_tracker``): the worker follows the stable step with it on its
            replica and sends it with every edit (None: the loop's solver works it out).

    Raises:
        InputError: The mesh cannot be cut (the worker's Cutter refused it).
        CutWorkerError: The worker did not start.
    """

    def __init__(self, model: TissueModel, settings: CutSettings | None = None,
                 cpus: set[int] | None = None, limit_tracker=None):
        self.model = model
        self._settings = settings or CutSettings(worker=True)
        self._settings_due: CutSettings | None = None
        self.summary = CutSummary()
        """What the loop reads of the cut between edits, as of the latest edit applied."""
        self.cpus = _worker_cpus() if cpus is None else set(cpus)
        """CPUs the worker runs on (None: wherever the loop's process may run)."""
        context = multiprocessing.get_context("spawn")  # no copy of Warp's state, on every OS
        self._conn, child = context.Pipe()
        # the model goes through the pipe, not the process's arguments: a worker that dies while
        # starting would leave a large argument's write blocked for ever
        self._process = context.Process(
            target=serve, args=(child, self.settings, self.cpus, wp.config.log_level, limit_tracker),
            name="warp_cut-cutter", daemon=True)
        self._process.start()
        child.close()
        self._resources = _Resources(self._process, self._conn)
        self._finalizer = weakref.finalize(self, self._resources.release)
        self._busy = False
        self._failed: str | None = None
        self._in_flight = 0
        self._received: list[ModelEdit] | None = None
        self._poses = np.zeros((64, 7))
        self._pose_count = 0
        self._clock = EventClock()
        self.spacing = self._settings.lip_spacing(model.rest_lengths)
        """The lip station spacing [m] (the worker's Cutter's), which events by travel count in."""
        self._tool_in = False
        self._end_due = False
        self.edits_applied = 0
        """Edits received from the worker and applied to the model."""
        self.worker_ms: list[float] = []
        """The worker's time for each event [ms] (its Stages 1-3 and edit recording)."""
        self.lag_steps: list[int] = []
        """For each event, the steps from the one that sent it to the one that applied its edit."""
        self.loop_ms: dict[str, list[float]] = {"send": [], "receive": [], "apply": []}
        """The loop's share of each event [ms]: sending it, receiving its edit, applying it
        (each in a step of its own)."""
        self.answer_timeout = ANSWER_TIMEOUT_S
        """How long the loop waits for an answer it needs now before it gives the worker up [s]."""
        self._start()

    def _start(self) -> None:
        """Wait for the worker's "ready"; a worker that dies first is most often a script
        that makes the Simulator at its top level (the spawned worker imports the script)."""
        try:
            try:
                self._conn.send(self.model)
            except OSError as err:  # the worker died before it read the model
                self._process.join(timeout=1.0)
                raise CutWorkerError(f"the cut's worker process died (exit code {self._process.exitcode})") from err
            self._expect("ready", timeout=_START_TIMEOUT_S)
        except CutWorkerError as err:
            self.close()
            raise CutWorkerError(
                f"{err}. The worker is a new Python process that imports the main script: a script "
                "that makes a Simulator that cuts in a worker (CutSettings(worker=True)) must do so under "
                "'if __name__ == \"__main__\":' (see the worker's own error above)") from err

    # ----------------------------------------------------------------- the loop's side
    @property
    def max_lag(self) -> int | None:
        """Steps an event may stay in flight before the loop waits for it (``settings.max_lag``)."""
        return self._settings.max_lag

    def after_step(self, sim: CutHost) -> None:
        """After every step, one of: receive the worker's edit, apply the edit received at the
        previous step, send a due event (each costs up to a few hundred microseconds: one per
        tick keeps every tick short)."""
        if self._failed is not None:
            raise CutWorkerError(self._failed)
        self._record_pose(sim)
        start = time.perf_counter()
        if self._received is not None:
            self._apply(sim)
            self.loop_ms["apply"].append(1e3 * (time.perf_counter() - start))
            return
        if self._busy:
            self._in_flight += 1
            late = self.max_lag is not None and self._in_flight >= self.max_lag
            if late or self._conn.poll():
                self._receive()
                self.loop_ms["receive"].append(1e3 * (time.perf_counter() - start))
            return
        due = self._event_due(sim)
        if self._end_due:  # before any pose of a new stroke
            self._end_due = False
            self._send(sim, np.zeros((0, 7)))
        elif due:
            poses, self._pose_count = self._poses[: self._pose_count].copy(), 0
            self._send(sim, poses)

    def _event_due(self, sim: CutHost) -> bool:
        """Whether an event is due (``EventClock``; then this step's is the last): the
        worker's Cutter keeps the same clock, with the same tool poses."""
        tool = sim.tool_pose if sim.collision else None
        tip = tool.p0 if tool is not None and tool.radius > 0 else None
        return self._clock.due(sim.time, sim.dt, tip, *self.settings.event_rule(self.spacing))

    def _record_pose(self, sim) -> None:
        """Keep the step's tool pose, or note that the tool has left (the worker ends the
        incision at its next event)."""
        tool = sim.tool_pose if sim.collision else None
        if tool is None or tool.radius <= 0:
            if self._tool_in:
                self._pose_count, self._tool_in, self._end_due = 0, False, True
            return
        if self._pose_count == len(self._poses):
            self._poses = np.concatenate([self._poses, np.zeros_like(self._poses)])
        row = self._poses[self._pose_count]
        row[0:3], row[3:6], row[6] = tool.p0, tool.p1, tool.radius
        self._pose_count += 1
        self._tool_in = True

    def _send(self, sim, poses: np.ndarray) -> None:
        """Send the worker the event of this step with ``poses`` (k, 7) (the tool's since the
        last event)."""
        start = time.perf_counter()
        n = self.model.node_count
        shared = self._resources.shared
        if shared is None or shared.capacity < n:
            if shared is not None:  # the worker is idle: it has read the old one
                shared.release(unlink=True)
            shared = self._resources.shared = SharedPositions(self.model.node_table.capacity)
        shared.array[:n] = sim.state.positions.numpy()[:n]
        event = WorkerEvent(sim.time, sim.dt, sim.collision, poses, sim.contacts,
                            n, shared.name, shared.capacity, self._settings_due)
        self._settings_due = None
        self._post(("event", event))
        self._busy, self._in_flight = True, 0
        self.loop_ms["send"].append(1e3 * (time.perf_counter() - start))

    def flush(self, sim) -> None:
        """Wait for the edit in flight, if any, and apply it."""
        if self._busy:
            self._receive()
        if self._received is not None:
            self._apply(sim)

    def _receive(self) -> None:
        try:
            answer, seconds = self._expect("done", timeout=self.answer_timeout)
        except CutWorkerError as err:  # the replica is unknown now: the cut stops here
            self._failed = str(err)
            raise
        self._busy = False
        self._received = answer
        self.worker_ms.append(1e3 * seconds)

    def _apply(self, sim) -> None:
        """Apply the edits received; one that fails leaves the loop's model neither the
        replica's nor what it was, so the cut stops for good (every later step raises)."""
        (edits, summary), self._received = self._received, None
        self.lag_steps.append(self._in_flight + 1)
        try:
            arrived = arrival_positions(edits, self._resources.shared.array, sim.state.positions.numpy(),
                                        sim.tool_pose if sim.collision else None)  # before any slot is reused
            for edit, positions in zip(edits, arrived):
                edit.apply_to(self.model)
                sim.notify_model_changed(edit.change.with_positions(positions))
                self.edits_applied += 1
        except Exception as err:  # noqa: BLE001 - the tissue is unknown now: reported, for good
            self._failed = f"applying the cut worker's edit failed: {type(err).__name__}: {err}"
            raise CutWorkerError(self._failed) from err
        self.summary = summary

    # ----------------------------------------------------------------- the Cutter's answers
    @property
    def settings(self) -> CutSettings:
        """The cutting parameters; a new value reaches the worker with the next event."""
        return self._settings

    @settings.setter
    def settings(self, value: CutSettings) -> None:
        self._settings = self._settings_due = value

    @property
    def totals(self) -> dict:
        """The Cutter's counters as of the latest edit applied (``Cutter.totals``)."""
        return self.summary.totals

    @property
    def unfilled_holes(self) -> int:
        """Holes left open as of the latest edit applied."""
        return self.summary.unfilled_holes

    @property
    def incisions(self) -> list[_LipPairs]:
        """The incisions as of the latest edit applied, as their paired lip nodes (``pairs()``);
        the worker's Incision objects are ``call(sim, "incisions")``."""
        return [_LipPairs(p) for p in self.summary.pairs]

    @property
    def incision_controls(self) -> np.ndarray | None:
        """The latest incision's Bezier control points [m], (3 s + 1, 3), or None."""
        return self.summary.controls

    def incision_width(self, positions: np.ndarray) -> float:
        """``Cutter.incision_width`` as of the latest edit applied (no round trip)."""
        return incision_width(self.incisions, self.model, positions)

    def end_incision(self, sim) -> None:
        """End the incision in progress now (``Cutter.end_incision``): waits for the edit in
        flight, then for the end's own edit, and applies both."""
        self.flush(sim)
        self._event_due(sim)
        self._send(sim, np.zeros((0, 7)))
        self._pose_count, self._tool_in, self._end_due = 0, False, False
        self.flush(sim)

    def call(self, sim, name: str, *args):
        """The worker Cutter's ``name(*args)`` (or attribute ``name``), after the edit in
        flight has been applied."""
        self.flush(sim)
        return self._query(name, *args)

    def _query(self, name: str, *args):
        """The worker Cutter's ``name(*args)``; no edit may be in flight (its answer comes
        first, and the positions passed would not match the worker's tissue)."""
        if self._busy or self._received is not None:
            raise InputError(f"BackgroundCutter.{name}: an edit is in flight; call "
                             "sim.cutter.flush(sim) first, then read sim.positions")
        self._post(("call", (name, args)))
        return self._expect("done", timeout=self.answer_timeout)[0]

    def metrics(self, positions: np.ndarray) -> dict:
        """``Cutter.metrics``, computed by the worker (after ``flush(sim)``)."""
        return self._query("metrics", positions)

    def gap_profile(self, positions: np.ndarray) -> dict:
        """``Cutter.gap_profile``, computed by the worker (after ``flush(sim)``)."""
        return self._query("gap_profile", positions)

    def live_new_triangles(self) -> np.ndarray:
        """``Cutter.live_new_triangles``, computed by the worker (after ``flush(sim)``)."""
        return self._query("live_new_triangles")

    def latency_summary(self) -> dict:
        """``Cutter.latency_summary`` of the worker's events (after ``flush(sim)``)."""
        return self._query("latency_summary")

    # ----------------------------------------------------------------- life cycle
    def close(self) -> None:
        """Stop the worker and free the shared buffer (idempotent; also done when the
        BackgroundCutter is collected or the interpreter exits)."""
        self._finalizer()

    def __enter__(self) -> BackgroundCutter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _post(self, message) -> None:
        """Send the worker a message; a worker that has gone is a CutWorkerError."""
        try:
            self._conn.send(message)
        except (BrokenPipeError, OSError) as err:
            raise CutWorkerError(f"the cut's worker process died (exit code {self._process.exitcode})") from err

    def _expect(self, kind: str, timeout: float | None = None):
        """The worker's next answer, which must be ``kind``; its failures raised here."""
        if timeout is not None and not self._conn.poll(timeout):
            self._resources.hung = True
            self.close()
            raise CutWorkerError(f"the cut's worker process did not answer within {timeout:g} s (hung); it was stopped")
        try:
            got, payload = self._conn.recv()
        except (EOFError, OSError) as err:
            self._process.join(timeout=1.0)
            raise CutWorkerError(f"the cut's worker process died (exit code {self._process.exitcode})") from err
        if got == "input_error":
            self.close()
            raise InputError(payload)
        if got == "error":
            raise CutWorkerError("the cut's worker process failed:\n" + payload)
        if got != kind:
            raise CutWorkerError(f"the cut's worker process answered {got!r}, expected {kind!r}")
        return payload
