"""The worker side of a background cut (``warp_cut.cut.background``): what the loop and the
worker send each other, and the worker's loop.

At a due event the loop sends a ``WorkerEvent`` (the step's ``CutHost`` attributes and the tool
poses since the previous event), with the node positions in a ``SharedPositions`` buffer. The
worker (``serve``) loads them into its ``ReplicaHost`` (a replica of the model with its device
mirror), runs the Cutter's event on it and answers with the ``ModelEdit`` of every edit it made
(the changed rows of each slot table, the new nodes with their ``motion_anchors``) and a
``CutSummary`` of the cut. The loop writes the rows into its model and moves each new node as
its anchors moved since the event.
"""

from __future__ import annotations

import os
import signal
import time
import traceback
from dataclasses import dataclass, field
from multiprocessing import shared_memory

import numpy as np
import warp as wp

from ..errors import InputError
from ..sim.contacts import ToolContacts
from ..sim.control import Tool
from ..sim.device_model import DeviceModel, write_slots
from ..sim.model import TissueModel
from ..sim.model_change import ModelChange
from ..sim.state import State
from ..sim.topology_index import INDEXED_TABLES
from .cutter import Cutter
from .settings import CutSettings

__all__ = ["TableEdit", "ModelEdit", "CutSummary", "WorkerEvent", "SharedPositions", "ReplicaHost",
           "motion_anchors", "serve", "ANCHORS", "TABLES"]

TABLES = ("node_table", "spring_table", "triangle_table", "link_table", "hinge_table")
"""The model's slot tables an edit may change."""
ANCHORS = 3
"""Nodes whose motion carries a new node from the event to the step its edit applies at."""


@dataclass
class TableEdit:
    """The changed rows of one slot table: slots (k,), every column at them, the used count."""

    slots: np.ndarray
    rows: dict
    count: int


@dataclass
class ModelEdit:
    """One topology edit: the changed table rows and the ``ModelChange`` the loop's simulation
    takes (``Simulator.notify_model_changed``), its stable step worked out on the replica.

    Attributes:
        tables: Table name (``node_table``, ...) -> its TableEdit.
        change: What the edit changed, the new nodes where they were at the event.
        topology_version: The model's version after the edit.
        anchors: Per new node, the slots of its nearest nodes alive at the event, (k, ANCHORS).
        weights: Their weights (each row sums to 1), (k, ANCHORS).
    """

    tables: dict
    change: ModelChange
    topology_version: int
    anchors: np.ndarray = field(default_factory=lambda: np.zeros((0, ANCHORS), np.int64))
    weights: np.ndarray = field(default_factory=lambda: np.zeros((0, ANCHORS)))

    def positions_now(self, at_event: np.ndarray, now: np.ndarray) -> np.ndarray:
        """The new nodes' positions [m] (k, 3) moved as their anchors moved from ``at_event``
        to ``now`` (both (n, 3), indexed by slot)."""
        if not len(self.anchors):
            return self.change.new_positions
        moved = now[self.anchors].astype(np.float64) - at_event[self.anchors]  # (k, ANCHORS, 3)
        return self.change.new_positions + np.einsum("ka,kad->kd", self.weights, moved)

    def apply_to(self, model: TissueModel) -> None:
        """Write the changed rows into ``model`` (a replica of the one edited), keeping its
        topology index (if built) up to date."""
        index = model.index if model.has_index else None
        for name, edit in self.tables.items():
            table = getattr(model, name)
            if index is not None and name in INDEXED_TABLES:
                index.forget_rows(name, edit.slots[edit.slots < table.count])
            table.put_rows(edit.slots, edit.rows, edit.count)
            if index is not None and name in INDEXED_TABLES:
                index.register_rows(name, edit.slots)
        if index is not None:
            index.grow(model.node_table.count)
        model.topology_version = self.topology_version


@dataclass
class CutSummary:
    """What a loop reads of the cut between edits (frames, status lines), as of the latest edit
    it applied: sent with every edit, so reading it costs no round trip.

    Attributes:
        totals: The Cutter's counters (``Cutter.totals``).
        unfilled_holes: Holes left open (``Cutter.unfilled_holes``).
        pairs: Per incision, its paired lip nodes (k, 2) (``Incision.pairs``).
        controls: The latest incision's Bezier control points [m], (3 s + 1, 3), or None.
    """

    totals: dict = field(default_factory=dict)
    unfilled_holes: int = 0
    pairs: list = field(default_factory=list)
    controls: np.ndarray | None = None

    @classmethod
    def of(cls, cutter: Cutter) -> CutSummary:
        curves = [inc.curve for inc in cutter.incisions if inc.curve is not None]
        return cls(dict(cutter.totals), cutter.unfilled_holes, [inc.pairs() for inc in cutter.incisions],
                   curves[-1].control_points_flat() if curves else None)


@dataclass
class WorkerEvent:
    """What the worker needs of one step of the loop (the ``CutHost`` attributes)."""

    time: float
    dt: float
    collision: bool
    poses: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    """Tool poses of the steps since the previous event, the current one last, (k, 7): p0 [m],
    p1 [m], radius [m] (k = 0: no tool)."""

    contacts: ToolContacts = field(default_factory=ToolContacts.none)
    """The loop's tool contacts as of the event's step."""
    node_count: int = 0
    """Node slots whose positions [m] at the event are in the shared buffer."""
    buffer: str = ""
    """Name of the shared buffer of positions, (capacity, 3) float32."""
    capacity: int = 0
    settings: CutSettings | None = None
    """New cutting parameters, taken before the event (None: unchanged)."""

    def tools(self) -> list[Tool]:
        """The poses as Tools, oldest first."""
        return [Tool(p0=row[0:3], p1=row[3:6], radius=row[6]) for row in self.poses]


class SharedPositions:
    """Node positions in shared memory, (capacity, 3) float32: the loop writes them at an
    event, the worker reads them (the loop writes only while the worker is idle)."""

    def __init__(self, capacity: int, name: str | None = None):
        self.capacity = int(capacity)
        self.memory = shared_memory.SharedMemory(name=name, create=name is None,
                                                 size=max(1, self.capacity) * 12)
        self.array = np.ndarray((self.capacity, 3), np.float32, buffer=self.memory.buf)

    @property
    def name(self) -> str:
        return self.memory.name

    def release(self, unlink: bool) -> None:
        """Unmap (and, by its creator, remove) the buffer."""
        del self.array
        self.memory.close()
        if unlink:
            self.memory.unlink()


class ReplicaHost:
    """The worker's CutHost: the replica model's device mirror and a state that holds the
    positions each event brings; it records every edit the Cutter makes instead of stepping,
    and follows the stable step with the simulation's own integrator's tracker
    (``limit_tracker(model)``; None: the loop's solver works it out)."""

    def __init__(self, model: TissueModel, limit_tracker=None):
        self.model = model
        self.device_model = DeviceModel(model, "cpu")
        self.state = State(model.node_table.buffer("points"), device="cpu")
        self.limits = None if limit_tracker is None else limit_tracker(model)
        self.edits: list[ModelEdit] = []
        self.tool_pose: Tool | None = None
        self.contacts = ToolContacts.none()
        self.shared: SharedPositions | None = None

    def load(self, event: WorkerEvent) -> None:
        """Take the loop's step: its time, tool and positions."""
        self.time, self.dt, self.collision = event.time, event.dt, event.collision
        self.tool_pose = event.tools()[-1] if len(event.poses) else None
        self.contacts = event.contacts
        if self.shared is None or self.shared.name != event.buffer:
            if self.shared is not None:
                self.shared.release(unlink=False)
            self.shared = SharedPositions(event.capacity, event.buffer)
        n = event.node_count
        self.state.positions.numpy()[:n] = self.shared.array[:n]
        self.at_event = self.shared.array[:n].astype(np.float64)
        self.alive_at_event = np.flatnonzero(self.model.active[:n])

    def notify_model_changed(self, change: ModelChange) -> None:
        """Record the edit (the changed rows of every table, the change with its stable step),
        then mirror it here."""
        tables = {}
        for name in TABLES:
            table = getattr(self.model, name)
            slots = table.changed_slots()
            if len(slots):
                tables[name] = TableEdit(slots, table.rows(slots), table.count)
        if self.limits is not None:
            change = change.with_limit(self.limits.update(change))
        anchors, weights = motion_anchors(self.at_event, self.alive_at_event, change.new_positions)
        self.edits.append(ModelEdit(tables, change, self.model.topology_version, anchors, weights))
        self.device_model.sync()
        capacity = self.model.node_table.capacity
        if self.state.node_count < capacity:
            self.state = self.state.grown(capacity)
        write_slots(self.state.positions, change.new_nodes, change.new_positions)


_ON_NODE = 1e-12
"""A target nearer a node than this [m] is on it: the floor of the inverse-distance weights. At
1e-9 m a neighbour 0.1 mm away still took 1e-5 of the weight of a target on a node."""


def motion_anchors(points: np.ndarray, alive: np.ndarray, targets: np.ndarray,
                   k: int = ANCHORS) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` nodes of ``alive`` (slots into ``points`` (n, 3) [m]) nearest each target
    (m, 3) [m], with inverse-distance weights: ((m, k) slots, (m, k) weights summing to 1).
    Fewer than ``k`` alive nodes repeat the nearest."""
    m = len(targets)
    if not m or not len(alive):
        return np.zeros((m, k), np.int64), np.zeros((m, k))
    candidates, d2 = _nearest_around(points, alive, targets, k)
    take = min(k, len(candidates))
    order = np.argsort(d2, axis=1)[:, :take]
    order = np.concatenate([order, np.repeat(order[:, :1], k - take, axis=1)], axis=1)
    weights = 1.0 / np.maximum(np.sqrt(np.take_along_axis(d2, order, axis=1)), _ON_NODE)
    return candidates[order], weights / weights.sum(axis=1, keepdims=True)


def _nearest_around(points: np.ndarray, alive: np.ndarray, targets: np.ndarray, k: int):
    """The slots of ``alive`` in a box around the targets and their squared distances to each
    target ((c,), (m, c)): the box grows from 1 mm of margin until each target's ``k`` nearest
    in it are nearer than the margin, so they are its ``k`` nearest of all."""
    lo, hi = targets.min(axis=0), targets.max(axis=0)
    p = points[alive]
    margin = 1e-3
    while True:
        inside = np.all((p >= lo - margin) & (p <= hi + margin), axis=1)
        d2 = ((targets[:, None, :] - p[inside][None, :, :]) ** 2).sum(axis=2)
        if inside.all() or (inside.sum() >= k and np.partition(d2, k - 1, axis=1)[:, k - 1].max() <= margin**2):
            return alive[inside], d2
        margin *= 2.0


def serve(conn, settings: CutSettings, cpus: set[int] | None, log_level: int, limit_tracker=None) -> None:
    """The worker's loop: receive the model, build the Cutter, then answer events and calls
    until told to stop; each answer carries the seconds the worker spent on it. Ctrl-C reaches
    the loop's whole process group: the worker leaves it to the loop, which stops it (or it ends
    when the pipe closes). Warp logs at the loop's level (``log_level``: a quiet CLI stays
    quiet); ``limit_tracker`` follows the stable step on the replica (``ReplicaHost``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    wp.config.log_level = log_level
    if cpus:
        os.sched_setaffinity(0, cpus)
    try:
        model = conn.recv()
    except EOFError:  # the loop has gone
        return
    try:
        host = ReplicaHost(model, limit_tracker)
        cutter = Cutter(model, settings, "cpu")
    except InputError as err:
        conn.send(("input_error", str(err)))
        return
    except Exception:  # noqa: BLE001 - reported to the loop, which raises it there
        conn.send(("error", traceback.format_exc()))
        return
    conn.send(("ready", None))
    while True:
        try:
            kind, payload = conn.recv()
        except EOFError:  # the loop has gone
            return
        if kind == "stop":
            if host.shared is not None:
                host.shared.release(unlink=False)
            conn.send(("stopped", None))
            return
        try:
            start = time.perf_counter()
            answer = _answer(cutter, host, kind, payload)
            conn.send(("done", (answer, time.perf_counter() - start)))
        except Exception:  # noqa: BLE001 - reported to the loop, which raises it there
            conn.send(("error", traceback.format_exc()))


def _answer(cutter: Cutter, host: ReplicaHost, kind: str, payload):
    """An event: run it and return the edits it made. A call: (name, args) of the Cutter."""
    if kind == "event":
        host.load(payload)
        if payload.settings is not None:
            cutter.settings = payload.settings
        cutter.catch_up(payload.tools()[:-1])
        host.edits = []
        cutter.after_step(host)
        return host.edits, CutSummary.of(cutter)
    name, args = payload
    value = getattr(cutter, name)
    return value(*args) if callable(value) else value
