"""What every solver shares: the tool pose and its statistics, spring order, launch replay.

The solver contract (the Simulator relies on it):

* ``Cls(device_model, gravity=None, residual_stress=True, collision=True,
  max_displacement=inf, links_expected=False, limits=None)``; the foundation is on when the
  model has one (``device_model.foundation_stiffness > 0``);
* ``step(state_in, state_out, tool, h)`` advances one substep h [s]; ``state_in.forces`` is zero
  on entry and left zero;
* ``clear_tool_stats()`` and the stats arrays ``tool_force`` (1,) vec3 [N], ``contact_count``
  (1,) int32, ``contact_position_sum`` (1,) vec3 [m], accumulated over substeps;
* the stability guard ``first_bad`` (1,) int32: the last node pass of every substep lowers it
  to the index of any active node whose new position is non-finite or farther than
  ``max_displacement`` [m] from rest (``kernels.diagnostics.report_runaway``; a non-finite
  velocity makes the position non-finite in the same pass); it stays at ``NO_BAD_NODE`` while
  all is well and is reset by ``readout.clear_bad_node()``;
* ``readout``: a ``StepReadout`` of ``first_bad`` and the tool statistics;
* ``notify_model_changed(change)`` after a topology edit (a ``ModelChange``) was mirrored on
  the device (in place, or into reallocated arrays the solver was remade on): the solver drops
  its recorded launches, re-derives what it keeps (spring order, valences) and follows its
  stable step (``limits``); ``prepare(state_in, state_out, h)`` records the launches ahead of
  the next ``step``;
* ``step_limit(model)`` (class method): the StepLimit the automatic step uses;
  ``limit_tracker(model)`` (class method): that limit, followed edit by edit
  (``warp_cut.solvers.limits``); ``limits.limit`` is the current one.

Recorded launches depend on the model's sizes (``_extent``: by default its used-slot counts, so
an edit records new launches; the semi-implicit solver spans the arrays' capacity instead, so an
edit within capacity records nothing).
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np
import warp as wp

from ..kernels.bending import hinge_forces
from ..kernels.collision import clear_tool_stats
from ..kernels.diagnostics import displacement_limit_sq
from ..sim.control import Tool
from ..sim.device_model import DeviceModel
from ..sim.model_change import ModelChange
from ..sim.stability import StepLimit, stable_time_step
from .launches import AUTO_CAPTURE_AFTER, LaunchSequence
from .limits import GivenLimit, RecomputedLimit, StepLimitTracker
from .readout import NO_BAD_NODE, StepReadout

__all__ = ["SolverBase", "CPU_CHUNK"]

CAPTURE_GAP = 8
"""Solver launches between two graph captures (each costs a few hundred microseconds on the
CPU): sequences that reach AUTO_CAPTURE_AFTER replays together are captured in different ticks."""
CPU_CHUNK = 4096
"""Items per thread on the CPU (Warp runs CPU threads in sequence; a thread costs a few ns)."""


class SolverBase:
    """Shared state of a solver; subclasses implement ``_record`` (and maybe ``_derive``).

    Args:
        model: the DeviceModel the solver is bound to.
        gravity: (3,) [m/s^2] or None (gravity code neither launched nor compiled).
        residual_stress: launch the residual-link forces when the model has links.
        collision: run the tool test and push-out when a tool is given.
        replay: how recorded launches are replayed, see ``launches.REPLAY_MODES``.
        max_displacement: the stability guard flags a node farther than this from rest [m]
            (inf: non-finite states only).
        links_expected: launch the residual links before the model has any (a cut will make
            them), where launches span the arrays' capacity (the semi-implicit solver), so the
            first link records nothing new.
        limits: the stable step's tracker to carry on with (a solver remade on reallocated
            arrays keeps its predecessor's); None builds one from the model.
    """

    def __init__(self, model: DeviceModel, *, gravity=None, residual_stress: bool = True,
                 collision: bool = True, replay: str = "auto", max_displacement: float = math.inf,
                 links_expected: bool = False, limits: StepLimitTracker | None = None):
        self.model = model
        self.gravity = None if gravity is None else wp.vec3(*np.asarray(gravity, dtype=np.float32))
        self.residual_stress = bool(residual_stress)
        self.links_expected = bool(links_expected)
        self.limits: StepLimitTracker = limits or self._new_limit_tracker()
        """The stable step (``limits.limit``), followed through edits."""
        self.collision = bool(collision)
        self.foundation_stiffness = float(model.foundation_stiffness)
        """k_f [N/m^3] of the model's support; 0: the foundation is neither launched nor compiled."""
        self.foundation = self.foundation_stiffness > 0.0
        self.bending = model.bending
        """Launch the hinge forces (the model's sheet resists bending, ``warp_cut.sim.bending``)."""
        self.replay = replay
        device = model.device
        self.device = device
        self.chunk = CPU_CHUNK if wp.get_device(device).is_cpu else 1
        self.tool_force = wp.zeros(1, dtype=wp.vec3, device=device)
        self.contact_count = wp.zeros(1, dtype=wp.int32, device=device)
        self.contact_position_sum = wp.zeros(1, dtype=wp.vec3, device=device)
        self.max_displacement = float(max_displacement)
        self.first_bad = wp.full(1, NO_BAD_NODE, dtype=wp.int32, device=device)
        self.readout = StepReadout(self.first_bad, self.tool_force, self.contact_count,
                                   self.contact_position_sum)
        self.tool_pose = wp.zeros(3, dtype=wp.vec3, device=device)
        """p0 [m], p1 [m], (radius [m], 0, 0) of the current tool; radius 0 = no tool."""
        self._tool_host = np.zeros((3, 3), dtype=np.float32)
        # on the CPU the array's memory is written through a numpy view (no copy call)
        self._tool_view = self.tool_pose.numpy() if wp.get_device(device).is_cpu else None
        self._last_tool: Tool | None = None
        self._clear_stats = None
        self._sequences: dict = {}
        self._launches, self._last_capture = 0, -CAPTURE_GAP
        self._sort_springs = True  # sort once here; a cut's small appended tail is left in place
        self.topology_changed()
        self._sort_springs = False

    # ------------------------------------------------------------------ contract
    @classmethod
    def step_limit(cls, model, links: bool = True) -> StepLimit:
        """The largest stable substep of this integrator for ``model`` (wherever its nodes are);
        ``links``: whether the residual links act (``residual_stress``: a solver without it never
        applies them, so they cannot limit its step)."""
        return stable_time_step(model, links=links)

    @classmethod
    def limit_tracker(cls, model, links: bool = True) -> StepLimitTracker:
        """``step_limit(model, links)``, followed edit by edit (by default worked out again each
        time)."""
        return RecomputedLimit(model, partial(cls.step_limit, links=links))

    def notify_model_changed(self, change: ModelChange) -> StepLimit:
        """Take a topology edit the device arrays now mirror: forget recorded launches,
        re-derive, follow the stable step (the one the change carries, if its maker worked it
        out). Returns the new limit."""
        self.topology_changed()
        if change.step_limit is not None:
            self.limits = GivenLimit(change.step_limit)
        elif isinstance(self.limits, GivenLimit):  # nothing followed the edits: start afresh
            self.limits = self._new_limit_tracker()
        else:
            self.limits.update(change)
        return self.limits.limit

    def _new_limit_tracker(self) -> StepLimitTracker:
        """A tracker of this integrator's stable step for the bound model, counting the residual
        links only if this solver applies them."""
        return type(self).limit_tracker(self.model.model, links=self.residual_stress)

    def _links_act(self) -> bool:
        """Whether this solver applies residual links now (residual stress on and the model has
        some)."""
        return self.residual_stress and self.model.link_count > 0

    def clear_tool_stats(self) -> None:
        """Zero the tool statistics (before the first substep of a step)."""
        if self.readout.views:  # host memory: zeroed in place, no launch
            self.readout.clear_tool_stats()
            return
        if self._clear_stats is None:
            self._clear_stats = wp.launch(
                clear_tool_stats, dim=1, device=self.device, record_cmd=True,
                inputs=[self.tool_force, self.contact_count, self.contact_position_sum])
        self._clear_stats.launch()

    def topology_changed(self) -> None:
        """Forget recorded launches and re-derive the solver's own arrays from the model."""
        self._last_tool = None
        self._derive()
        extent = self._extent_now = self._extent()  # what `_key` adds, until the next change
        self._sequences = {key: seq for key, seq in self._sequences.items() if key[3:] == extent}

    def step(self, state_in, state_out, tool: Tool | None, h: float) -> None:
        """Advance by one substep h [s]."""
        self._set_tool(tool)
        sequence = self._sequences.get(self._key(state_in, state_out, h))
        if sequence is None:
            sequence = self.prepare(state_in, state_out, h)
        sequence.launch()
        self._launches += 1
        if sequence.capturable and sequence.replays >= AUTO_CAPTURE_AFTER \
                and self._launches - self._last_capture >= CAPTURE_GAP:
            sequence.capture()
            self._last_capture = self._launches

    def prepare(self, state_in, state_out, h: float) -> LaunchSequence:
        """Record the launches of a substep from ``state_in`` to ``state_out`` now (``step``
        would on first use) and return them. The states ping-pong, so the swapped pair is
        recorded too: a new recording (the first step, a cut) lengthens one step, not two."""
        first = self._launches == 0  # the solver's first step (it loads the kernels): capture at once
        for a, b in ((state_out, state_in), (state_in, state_out)):
            key = self._key(a, b, h)
            if key not in self._sequences:
                sequence = LaunchSequence(self.device, self.replay)
                self._record(sequence, a, b, float(h))
                self._sequences[key] = sequence.finalize(capture_now=first)
        return self._sequences[self._key(state_in, state_out, h)]

    def launches_per_substep(self, state_in, state_out, h: float) -> int:
        """Kernel launches one substep of ``h`` [s] from ``state_in`` runs (recorded now if
        not yet)."""
        return len(self.prepare(state_in, state_out, h))

    def _key(self, state_in, state_out, h: float) -> tuple:
        """What a recorded sequence depends on: the state buffers, h and the model's sizes (as
        of the last ``topology_changed``: worked out there, not in every step)."""
        return (state_in.positions.ptr, state_out.positions.ptr, float(h)) + self._extent_now

    def _extent(self) -> tuple:
        """The model sizes baked into recorded launches (dims and count arguments): here the
        used-slot counts of nodes, springs and links and the spring arrays read."""
        m = self.model
        return (m.node_count, m.spring_count, m.link_count, self.spring_arrays()[0].ptr,
                m.hinge_indices.ptr)

    # ------------------------------------------------------------------ helpers
    def _record(self, seq: LaunchSequence, state_in, state_out, h: float) -> None:
        raise NotImplementedError

    def _derive(self) -> None:
        """Spring arrays in an order that touches node memory in sequence.

        Patch meshes already list springs by their first node; springs read from a file may
        not. Then the solver keeps a copy sorted by the smaller node index without deleted
        slots (the model's numbering is unchanged). That sort is O(springs), so it is done when
        the solver is made, not on ``topology_changed``: after a cut the solver reads the
        model's own arrays (dead slots skipped, the cut's few new springs at the end), and an
        edit costs what it touches.
        """
        m = self.model
        if not self._sort_springs:
            self.springs_sorted_copy, self._springs = False, None
            return
        count = m.spring_count
        idx = m.spring_indices.numpy()[: 2 * count].reshape(-1, 2)
        live = np.all(idx >= 0, axis=1)
        first = np.where(live, idx.min(axis=1), np.iinfo(np.int32).max)
        self.springs_sorted_copy = bool(count) and not bool(np.all(np.diff(first) >= 0))
        if not self.springs_sorted_copy:
            self._springs = None
            return
        order = np.argsort(first, kind="stable")
        order = order[live[order]]
        device = self.device
        self._springs = (
            wp.array(idx[order].astype(np.int32).ravel(), dtype=wp.int32, device=device),
            wp.array(m.spring_rest_length.numpy()[order], dtype=wp.float32, device=device),
            wp.array(m.spring_stiffness.numpy()[order], dtype=wp.float32, device=device),
            len(order),
        )

    def add_hinge_forces(self, seq: LaunchSequence, positions, forces) -> None:
        """Record the hinge forces at ``positions`` into ``forces`` when the sheet bends; the
        launch spans the hinge arrays' capacity (dead and spare slots are skipped), so an edit
        within capacity keeps it."""
        if not self.bending:
            return
        m = self.model
        count = m.hinge_stiffness.shape[0]
        seq.add(hinge_forces, self.threads(count),
                [positions, m.hinge_indices, m.hinge_rest_angle, m.hinge_stiffness, m.hinge_cap, self.chunk,
                 count, forces])

    def spring_arrays(self):
        """(indices, rest_length, stiffness, count) the spring kernels should read."""
        if self._springs is not None:
            return self._springs
        m = self.model
        return m.spring_indices, m.spring_rest_length, m.spring_stiffness, m.spring_count

    def threads(self, count: int) -> int:
        """Launch dim for ``count`` items at ``self.chunk`` items per thread."""
        return -(-int(count) // self.chunk)

    def guard_inputs(self, rest: bool = True) -> list:
        """The stability guard's arguments, appended to each integrator's last node pass:
        rest_positions (unless ``rest`` is False: the semi-implicit node pass has them
        already), max_displacement_sq [m^2], first_bad."""
        limit = [displacement_limit_sq(self.max_displacement), self.first_bad]
        return ([self.model.rest_positions] if rest else []) + limit

    def _set_tool(self, tool: Tool | None) -> None:
        if not self.collision or tool is self._last_tool:
            return
        self._last_tool = tool
        host = self._tool_host if self._tool_view is None else self._tool_view
        if tool is None:
            host[2, 0] = 0.0
        else:
            host[0], host[1] = tool.p0, tool.p1
            host[2, 0] = tool.radius
        if self._tool_view is None:
            self.tool_pose.assign(host)
