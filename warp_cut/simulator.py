"""Simulator: the user-facing loop binding a TissueModel, its State, a solver and the tool."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import warp as wp

from .cut.background import DEFAULT_MAX_LAG, BackgroundCutter
from .cut.cutter import CutSettings, Cutter
from .errors import InputError, SimulationUnstable, ToolStartsInside
from .kernels.diagnostics import displacement_limit_sq, find_runaway_nodes, kinetic_energy
from .sim.ccd import ContinuousDetector
from .sim.collision import cylinder_contacts
from .sim.control import Tool, ToolPath
from .sim.device_model import DeviceModel, write_slots
from .sim.model import TissueModel
from .sim.stability import StepLimit
from .sim.state import State
from .solvers import INTEGRATORS
from .solvers.readout import NO_BAD_NODE

__all__ = ["Simulator", "DEFAULT_GRAVITY"]

DEFAULT_GRAVITY = (0.0, 0.0, -9.81)
"""Standard gravity [m/s^2], Z up."""

ToolInput = None | Tool | ToolPath | Callable[[float], Tool]


class Simulator:
    """Advance a tissue in time.

    Args:
        model: the TissueModel (kept by reference: the single topology store).
        dt: time of one ``step()`` [s] (default 1 ms, a haptic loop's period), or ``"auto"``
            for ``safety`` x the stable step with one substep.
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
        cutting: None/False for no cutting, True or a ``CutSettings`` to cut the tissue where
            the tool goes (see ``warp_cut.cut.cutter``); the Cutter is then ``self.cutter``.
        cut_in_background: run the cut's host work in a worker process (a
            ``warp_cut.cut.background.BackgroundCutter`` is then ``self.cutter``): a cut event
            no longer lands in one step, for a fixed-rate loop; call ``close()`` when done.
            True (never wait for the worker), or the ``max_lag`` in steps an edit may take
            before the loop waits for it.
    """

    def __init__(self, model: TissueModel, dt: float | str = 1.0e-3, *,
                 integrator: str = "semi_implicit", gravity=DEFAULT_GRAVITY,
                 device: str = "cpu", substeps: int | str = "auto",
                 residual_stress: bool = True, collision: bool = True,
                 safety: float = 0.5, max_displacement: float | None = None,
                 cutting=None, cut_in_background: bool | int = False):
        if integrator not in INTEGRATORS:
            raise InputError(f"integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
        if not (0 < safety <= 1):
            raise InputError(f"safety must be in (0, 1], got {safety}")
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
        self._cutting = bool(cutting)
        extent = np.ptp(model.points[model.active], axis=0) if model.active.any() else np.zeros(3)
        self.max_displacement = float(max_displacement or max(1.0, 1000.0 * np.linalg.norm(extent)))
        self._dt_request, self._substeps_request = dt, substeps
        self._state = State(model.node_table.buffer("points"), device=device)
        self._next = State(model.node_table.buffer("points"), device=device)
        self._step_count = 0
        self._time_offset = 0.0
        self._tool_checked = False
        self.tool_force = np.zeros(3)
        """Reaction of the tissue on the tool over the last step [N], (3,)."""
        self.contact_count = 0.0
        """Mean number of nodes in contact per substep over the last step."""
        self.first_contact_time: float | None = None
        """Time [s] at the end of the first step with a contact, or None."""
        self.first_contact_point: np.ndarray | None = None
        """Mean position [m] of the nodes in contact during that step, or None."""
        self.max_tool_force = 0.0
        """Largest |tool_force| of any step so far [N]."""
        self.tool_pose: Tool | None = None
        """The tool pose of the last step (its end), or None before the first step with a tool."""
        self.first_contact_time_exact: float | None = None
        """Exact first-contact time [s] of the swept tool (continuous detection), or None."""
        self.first_contact_point_exact: np.ndarray | None = None
        """Mean position [m] of the nodes the swept tool reaches first, or None."""
        self._ccd = None
        self.contact_centroid: np.ndarray | None = None
        """Mean position [m] of the nodes in contact during the last step, or None."""
        self._rebuild()
        self.post_step_hooks: list[Callable[[Simulator], None]] = []
        """Called with the simulator after every step, in order (e.g. ``Cutter.after_step``)."""
        self.cutter: Cutter | BackgroundCutter | None = None
        """The Cutter (or BackgroundCutter) when the simulator was made with ``cutting``."""
        if cutting:
            settings = cutting if isinstance(cutting, CutSettings) else None
            if cut_in_background:
                lag = DEFAULT_MAX_LAG if cut_in_background is True else int(cut_in_background)
                self.cutter = BackgroundCutter(model, settings, max_lag=lag)
            else:
                self.cutter = Cutter(model, settings, device)
            self.post_step_hooks.append(self.cutter.after_step)

    def close(self) -> None:
        """Release what outlives a step: the background cut's worker process, if any."""
        if isinstance(self.cutter, BackgroundCutter):
            self.cutter.close()

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # --------------------------------------------------------------- set-up
    def _rebuild(self) -> None:
        """Derive device arrays, solver, stable step and substeps from the model."""
        self.device_model = DeviceModel(self.model, self.device)
        self.solver = self._make_solver()
        # per-integrator limit: infinite for the unconditionally stable integrators
        self.step_limit: StepLimit = INTEGRATORS[self.integrator].step_limit(self.model)
        self._choose_steps()

    def _make_solver(self):
        solver = INTEGRATORS[self.integrator](
            self.device_model, gravity=self.gravity, residual_stress=self.residual_stress,
            collision=self.collision, max_displacement=self.max_displacement)
        # a cut makes links: launch them from the start, so their first ones record nothing
        solver.links_expected = self._cutting
        return solver

    def _choose_steps(self) -> None:
        limit = self.step_limit.step
        dt, substeps = self._dt_request, self._substeps_request
        if isinstance(dt, str):
            if dt != "auto":
                raise InputError(f"dt must be a positive number of seconds or 'auto', got {dt!r}")
            if not math.isfinite(limit):
                raise InputError("dt = 'auto' needs a model with springs (nothing limits the step)")
            dt, substeps = self.safety * limit, 1
        dt = float(dt)
        if not (math.isfinite(dt) and dt > 0):
            raise InputError(f"dt must be a positive number of seconds, got {dt}")
        if isinstance(substeps, str):
            if substeps != "auto":
                raise InputError(f"substeps must be a positive integer or 'auto', got {substeps!r}")
            substeps = 1 if not math.isfinite(limit) else max(1, math.ceil(dt / (self.safety * limit)))
        substeps = int(substeps)
        if substeps < 1:
            raise InputError(f"substeps must be >= 1, got {substeps}")
        if self._step_count:
            # keep the clock exact across a change of dt (after a topology edit)
            self._time_offset = self.time
            self._step_count = 0
        self.dt = dt
        self.substeps = substeps

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
        cut has been restarted)."""
        if self.cutter is None:
            return None
        if isinstance(self.cutter, BackgroundCutter):  # as of the latest edit applied
            return self.cutter.incision_controls
        curves = [inc.curve for inc in self.cutter.incisions if inc.curve is not None]
        return curves[-1].control_points_flat() if curves else None

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

        out = wp.zeros(1, dtype=wp.float32, device=self.device)
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
            self._read_tool_stats()
        else:
            self.tool_force = np.zeros(3)
            self.contact_count = 0.0
            self.contact_centroid = None
        for hook in self.post_step_hooks:
            hook(self)

    def _before_contact(self, tool: ToolInput, pose: Tool) -> None:
        """Until the first contact is known: check the first pose is outside the tissue, and
        run the continuous first-contact detection over the coming step."""
        if self.first_contact_time_exact is not None or self.first_contact_time is not None:
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
            self.first_contact_time_exact = hit.time
            self.first_contact_point_exact = hit.point

    def _read_tool_stats(self) -> None:
        force, count, position_sum = self.solver.readout.tool_stats()
        force /= self.substeps
        self.tool_force = force
        self.contact_count = count / self.substeps
        self.max_tool_force = max(self.max_tool_force, math.sqrt(force.dot(force)))
        self.contact_centroid = position_sum / count if count else None
        if count and self.first_contact_time is None:
            self.first_contact_time = self.time
            self.first_contact_point = self.contact_centroid

    def apply_topology_edit(self, new_nodes: np.ndarray, new_positions: np.ndarray,
                            explicit_limit: StepLimit | None = None) -> None:
        """Mirror the model's latest edit on the device and update the stable step.

        Changed slots are copied (arrays are reallocated only when a table outgrew its
        capacity) and new nodes start at rest.

        Args:
            new_nodes: Slots of the nodes the edit created, shape (k,).
            new_positions: Their positions [m], shape (k, 3).
            explicit_limit: The semi-implicit step's limit after the edit, when the caller
                keeps it up to date (the Cutter does, node by node); other integrators, or
                None, compute theirs from the model.
        """
        reallocated = self.device_model.sync()
        capacity = self.model.node_table.capacity
        if self._state.node_count < capacity:
            self._state, self._next = self._state.grown(capacity), self._next.grown(capacity)
            reallocated = True
        idx = np.asarray(new_nodes, np.int64)
        for state in (self._state, self._next):
            write_slots(state.positions, idx, np.asarray(new_positions).reshape(-1, 3))
            write_slots(state.velocities, idx, np.zeros((len(idx), 3)))
        if reallocated:
            self.solver = self._make_solver()
        else:
            self.solver.topology_changed()
        self.update_step_limit(explicit_limit if self.integrator == "semi_implicit" else None)
        # record the new launches now, in the step that made the edit, not in the next one
        self.solver.prepare(self._state, self._next, self.substep)

    def update_step_limit(self, limit: StepLimit | None = None) -> None:
        """Set the stable step (recomputed from the model if not given) and the substeps."""
        self.step_limit = limit or INTEGRATORS[self.integrator].step_limit(self.model)
        self._choose_steps()

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
