"""Simulator: the user-facing loop binding a TissueModel, its State, a solver and the tool."""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial

import numpy as np
import warp as wp

from .cut.driver import CutDriver, make_cut_driver
from .cut.settings import CutSettings
from .errors import InputError, SimulationUnstable, ToolStartsInside
from .kernels.diagnostics import displacement_limit_sq, find_runaway_nodes, kinetic_energy
from .sim.ccd import ContinuousDetector
from .sim.collision import cylinder_contacts
from .sim.contacts import ToolContacts
from .sim.control import Tool, ToolPath
from .sim.device_model import DeviceModel, write_slots
from .sim.model import TissueModel
from .sim.model_change import ModelChange
from .sim.stability import StepLimit
from .sim.state import State
from .solvers import INTEGRATORS
from .solvers.readout import NO_BAD_NODE

__all__ = ["Simulator", "DEFAULT_GRAVITY", "choose_steps"]

DEFAULT_GRAVITY = (0.0, 0.0, -9.81)
"""Standard gravity [m/s^2], Z up."""

ToolInput = None | Tool | ToolPath | Callable[[float], Tool]


def choose_steps(limit: float, dt: float | str, substeps: int | str, safety: float) -> tuple[float, int]:
    """The step [s] and substeps for a stable step ``limit`` [s] (inf: nothing limits it).

    ``dt`` is a number of seconds or ``"auto"``: ``safety`` x the limit times the substeps
    (one unless ``substeps`` is a number). ``substeps`` is a number or ``"auto"``: the fewest
    that keep each substep within ``safety`` x the limit. Raises InputError for anything else.
    """
    if isinstance(dt, str):
        if dt != "auto":
            raise InputError(f"dt must be a positive number of seconds or 'auto', got {dt!r}")
        if not math.isfinite(limit):
            raise InputError("dt = 'auto' needs a model with springs (nothing limits the step)")
        dt = safety * limit * (1 if isinstance(substeps, str) else int(substeps))
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"dt must be a positive number of seconds, got {dt}")
    if isinstance(substeps, str):
        if substeps != "auto":
            raise InputError(f"substeps must be a positive integer or 'auto', got {substeps!r}")
        substeps = 1 if not math.isfinite(limit) else max(1, math.ceil(dt / (safety * limit)))
    substeps = int(substeps)
    if substeps < 1:
        raise InputError(f"substeps must be >= 1, got {substeps}")
    return dt, substeps


class Simulator:
    """Advance a tissue in time.

    Args:
        model: the TissueModel (kept by reference: the single topology store).
        dt: time of one ``step()`` [s] (default 1 ms, a haptic loop's period), or ``"auto"``
            for ``safety`` x the stable step (times ``substeps`` if that is a number).
        substeps: integration substeps per step, or ``"auto"``: the fewest that keep each
            substep within ``safety`` x the stable step.
        integrator: one of ``INTEGRATORS``: ``"semi_implicit"`` (default), ``"implicit_euler"``,
            ``"xpbd"`` (see README, Speed and accuracy).
        gravity: (3,) [m/s^2] or None to leave gravity out (neither launched nor compiled).
        residual_stress, collision: enable the residual links and the tool test.
        safety: fraction of the computed stable step used by the automatic choices.
        max_displacement: a node farther than this from its rest position [m] is a runaway
            (default 1000 x the model's bounding-box diagonal, at least 1 m).
        device: Warp device, ``"cpu"`` or ``"cuda:0"``.
        cutting: None for no cutting, or the ``CutSettings`` of a cut that follows the tool;
            its driver is then ``self.cutter`` (``warp_cut.cut.driver``): the cut in the step,
            or with ``CutSettings(worker=True)`` in a worker process, so a cut event no longer
            lands in one step (a fixed-rate loop; call ``close()`` when done).
    """

    def __init__(self, model: TissueModel, dt: float | str = 1.0e-3, *,
                 integrator: str = "semi_implicit", gravity=DEFAULT_GRAVITY,
                 device: str = "cpu", substeps: int | str = "auto",
                 residual_stress: bool = True, collision: bool = True,
                 safety: float = 0.5, max_displacement: float | None = None,
                 cutting: CutSettings | None = None):
        if integrator not in INTEGRATORS:
            raise InputError(f"integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
        if not (0 < safety <= 1):
            raise InputError(f"safety must be in (0, 1], got {safety}")
        if cutting is not None and not isinstance(cutting, CutSettings):
            raise InputError(f"cutting must be None or a CutSettings, got {type(cutting).__name__}")
        wp.init()
        self.model = model
        self.device = device
        self.integrator = integrator
        self.safety = float(safety)
        self.gravity = None if gravity is None else np.asarray(gravity, dtype=np.float64)
        if self.gravity is not None and (self.gravity.shape != (3,) or not np.all(np.isfinite(self.gravity))):
            raise InputError(f"gravity must be three finite numbers [m/s^2], got {gravity!r}")
        self.residual_stress = residual_stress
        self.collision = collision
        self._cutting = cutting is not None
        extent = np.ptp(model.points[model.active], axis=0) if model.active.any() else np.zeros(3)
        self.max_displacement = float(max_displacement or max(1.0, 1000.0 * np.linalg.norm(extent)))
        self._dt_request, self._substeps_request = dt, substeps
        self._state = State(model.node_table.buffer("points"), device=device)
        self._next = State(model.node_table.buffer("points"), device=device)
        self._step_count = 0
        self._time_offset = 0.0
        self._tool_checked = False
        self.contacts = ToolContacts.none()
        """The tool's contacts: over the last step (force, count, centroid) and the run so far
        (largest force, first contact discrete and exact)."""
        self.tool_pose: Tool | None = None
        """The tool pose of the last step (its end), or None before the first step with a tool."""
        self._ccd = None
        self._energy = None  # the kinetic energy's one-element sum, made at its first read
        self.device_model = DeviceModel(self.model, self.device)
        self.solver = self._make_solver()
        self._choose_steps()
        self.post_step_hooks: list[Callable[[Simulator], None]] = []
        """Called with the simulator after every step, in order (e.g. the cut's ``after_step``)."""
        self.cutter: CutDriver | None = None
        """The cut driver (``warp_cut.cut.driver.CutDriver``) when the simulator was made with
        ``cutting``, else None."""
        if cutting is not None:
            self.cutter = make_cut_driver(model, cutting, device,
                                          partial(INTEGRATORS[integrator].limit_tracker, links=residual_stress))
            self.post_step_hooks.append(self.cutter.after_step)

    def close(self) -> None:
        """Release what outlives a step: the cut's worker process, if any."""
        if self.cutter is not None:
            self.cutter.close()

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # --------------------------------------------------------------- set-up
    def _make_solver(self, limits=None):
        """The integrator bound to the device mirror; ``limits``: a step-limit tracker to carry
        on with (after a reallocation), else one made from the model."""
        return INTEGRATORS[self.integrator](
            self.device_model, gravity=self.gravity, residual_stress=self.residual_stress,
            collision=self.collision, max_displacement=self.max_displacement,
            links_expected=self._cutting, limits=limits)

    def _choose_steps(self) -> None:
        dt, substeps = choose_steps(self.step_limit.step, self._dt_request, self._substeps_request, self.safety)
        if self._step_count:
            # keep the clock exact across a change of dt (after a topology edit)
            self._time_offset = self.time
            self._step_count = 0
        self.dt = dt
        self.substeps = substeps

    def fit_to_frame(self, frame_dt: float) -> int:
        """Shorten the step so that a whole number of steps makes ``frame_dt`` [s] (the run
        loop's output frames), keeping the substep choice; returns the steps per frame."""
        steps = max(1, math.ceil(frame_dt / self.dt - 1e-9))
        self._dt_request = frame_dt / steps
        self._choose_steps()
        return steps

    @property
    def step_limit(self) -> StepLimit:
        """The integrator's stable (sub)step for the model as it is now (inf: no limit)."""
        return self.solver.limits.limit

    @property
    def tool_force(self) -> np.ndarray:
        """Reaction of the tissue on the tool over the last step [N], (3,) (``contacts.force``)."""
        return self.contacts.force

    # --------------------------------------------------------------- properties
    @property
    def time(self) -> float:
        """Simulated time [s]."""
        return self._time_offset + self._step_count * self.dt

    @property
    def substep(self) -> float:
        """Integration step h = dt / substeps [s]."""
        return self.dt / self.substeps

    @property
    def positions(self) -> np.ndarray:
        """Node positions [m], (node_count, 3) float64 (a copy; deleted node slots included)."""
        return self._state.positions.numpy()[: self.model.node_count].astype(np.float64)

    @property
    def velocities(self) -> np.ndarray:
        """Node velocities [m/s], (node_count, 3) float64 (a copy; deleted node slots included)."""
        return self._state.velocities.numpy()[: self.model.node_count].astype(np.float64)

    @property
    def incision_controls(self) -> np.ndarray | None:
        """Control points [m] of the incision's cubic Bezier chain, (3 s + 1, 3) for s segments
        (end points shared), or None while there is no incision (the latest incision's when a
        cut has been restarted; with a worker, as of the latest edit applied)."""
        return None if self.cutter is None else self.cutter.incision_controls

    @property
    def state(self) -> State:
        """The current device state (positions and velocities as Warp arrays)."""
        return self._state

    def set_state(self, positions=None, velocities=None) -> None:
        """Overwrite node positions [m] and/or velocities [m/s], each (node_count, 3)."""
        n = self.model.node_count
        for name, value, target in (("positions", positions, self._state.positions),
                                    ("velocities", velocities, self._state.velocities)):
            if value is None:
                continue
            arr = np.asarray(value, dtype=np.float64)
            if arr.shape != (n, 3) or not np.all(np.isfinite(arr)):
                raise InputError(f"{name} must be finite with shape ({n}, 3), got {arr.shape}")
            full = target.numpy()
            full[:n] = arr
            target.assign(full)
        self.solver.readout.clear_bad_node()

    def kinetic_energy(self) -> float:
        """Sum of 0.5 m |v|^2 over the nodes [J]."""

        if self._energy is None:
            self._energy = wp.zeros(1, dtype=wp.float32, device=self.device)
        out = self._energy
        out.zero_()
        m = self.device_model
        wp.launch(kinetic_energy, dim=m.node_count, device=self.device,
                  inputs=[self._state.velocities, m.node_mass, m.node_flags, out])
        return float(out.numpy()[0])

    # --------------------------------------------------------------- stepping
    def _resolve_tool(self, tool: ToolInput, t: float) -> Tool | None:
        if tool is None or isinstance(tool, Tool):
            return tool
        if isinstance(tool, ToolPath):
            return tool.pose_at(t)
        if callable(tool):
            return tool(t)
        raise InputError(f"tool must be a Tool, a ToolPath or a callable t -> Tool, got {type(tool)}")

    def check_tool_outside(self, tool: Tool) -> None:
        """Raise ToolStartsInside unless ``tool`` touches no node (the paper's premise:
        the tool starts outside the tissue). ``step`` checks the first pose it is given."""
        self._tool_checked = True
        inside = cylinder_contacts(self.positions, tool.p0, tool.p1, tool.radius, self.device)
        if inside.any():
            first = int(np.flatnonzero(inside)[0])
            raise ToolStartsInside(
                f"the tool starts inside the tissue: {int(inside.sum())} nodes (first: node {first}) "
                f"lie within the cylinder p0={tool.p0.tolist()} p1={tool.p1.tolist()} "
                f"r={tool.radius}; start it outside (the paper's premise)")

    def step(self, n: int = 1, tool: ToolInput = None) -> None:
        """Advance n steps of dt. ``tool``: a fixed Tool pose, a ToolPath evaluated at the end
        of each step, a callable t -> Tool, or None. Raises SimulationUnstable before any
        non-finite value can be read back: after every step, before the post-step hooks."""
        if n < 0:
            raise InputError(f"n must be >= 0, got {n}")
        for _ in range(int(n)):
            self._step_once(tool)

    def _step_once(self, tool: ToolInput) -> None:
        """One step: the tool pose at its end, the substeps, the guard, the statistics, the hooks."""
        pose = self._resolve_tool(tool, self.time + self.dt)
        use_tool = pose is not None and self.collision
        if use_tool:
            self._before_contact(tool, pose)
            self.solver.clear_tool_stats()
        self.tool_pose = pose
        h = self.substep
        solver = self.solver
        for _ in range(self.substeps):
            solver.step(self._state, self._next, pose, h)
            self._state, self._next = self._next, self._state
        self._step_count += 1
        solver.readout.fetch(tool_stats=use_tool)
        if solver.readout.first_bad != NO_BAD_NODE:
            self._raise_unstable(solver.readout.first_bad)
        if use_tool:
            force, count, position_sum = solver.readout.tool_stats()
            self.contacts.record_step(force, count, position_sum, self.substeps, self.time)
        else:
            self.contacts.no_tool()
        for hook in self.post_step_hooks:
            hook(self)

    def _before_contact(self, tool: ToolInput, pose: Tool) -> None:
        """Until the first contact is known: check the first pose is outside the tissue, and
        run the continuous first-contact detection over the coming step."""
        if self.contacts.first_known:
            return
        if not self._tool_checked:
            self.check_tool_outside(self._resolve_tool(tool, self.time))
        self._continuous_first_contact(self.tool_pose or self._resolve_tool(tool, self.time), pose)

    def _continuous_first_contact(self, start: Tool, end: Tool) -> None:
        """Continuous detection over the coming step: the tool's end points move linearly from
        ``start`` to ``end``, the nodes with their current velocity. Evaluated each step until
        a first contact is known (one extra per-node launch per step before contact)."""
        if self._ccd is None:
            self._ccd = ContinuousDetector(self.device)
        hit = self._ccd.first_contact(self._state.positions, self._state.velocities,
                                      self.device_model.node_flags, start, end,
                                      t_start=self.time, interval=self.dt, overlap=1e-3)
        if hit is not None:
            self.contacts.record_exact(hit.time, hit.point)

    def notify_model_changed(self, change: ModelChange) -> None:
        """Take a topology edit of the model (``ModelChange``): mirror its changed slots on the
        device (arrays are reallocated only when a table outgrew its capacity), place its new
        nodes at rest where it says, let the solver re-derive and follow its stable step, and
        choose the substeps again. The launches of the next step are recorded now, in the step
        that made the edit."""
        reallocated = self.device_model.sync()
        capacity = self.model.node_table.capacity
        if self._state.node_count < capacity:
            self._state, self._next = self._state.grown(capacity), self._next.grown(capacity)
            reallocated = True
        idx = np.asarray(change.new_nodes, np.int64)
        for state in (self._state, self._next):
            write_slots(state.positions, idx, change.new_positions)
            write_slots(state.velocities, idx, np.zeros((len(idx), 3)))
        if reallocated:
            self.solver = self._make_solver(limits=self.solver.limits)
        self.solver.notify_model_changed(change)
        self._choose_steps()
        self.solver.prepare(self._state, self._next, self.substep)

    def check_finite(self) -> None:
        """Raise SimulationUnstable if any active node is non-finite or has run away.

        ``step`` needs no call to this: every integrator's last node pass runs the same test
        on the state it writes, and ``step`` reads its one-int result after every step."""

        m = self.device_model
        first_bad = wp.array([NO_BAD_NODE], dtype=wp.int32, device=self.device)
        wp.launch(find_runaway_nodes, dim=m.node_count, device=self.device,
                  inputs=[self._state.positions, self._state.velocities, m.rest_positions,
                          m.node_flags, displacement_limit_sq(self.max_displacement), first_bad])
        node = int(first_bad.numpy()[0])
        if node != NO_BAD_NODE:
            self._raise_unstable(node)

    def _raise_unstable(self, node: int) -> None:
        """Raise SimulationUnstable for ``node``, saying whether it is non-finite or ran away."""
        x = self._state.positions.numpy()[node]
        v = self._state.velocities.numpy()[node]
        finite = np.all(np.isfinite(x)) and np.all(np.isfinite(v))
        reason = ("has a non-finite position or velocity" if not finite
                  else f"moved more than {self.max_displacement:.3g} m from rest")
        raise SimulationUnstable(node, self.time, self.substep, self.step_limit.step, reason)
