"""warp_cut/solvers: a scene pays only for the physics it enables (modules neither launched
nor compiled: gravity, the tool, residual links, the foundation), checked in a fresh interpreter
for every integrator; recorded and replayed
launches give the same states as plain launches."""

import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import DEVICE

from warp_cut import CutSettings, Material, Simulator, TissueModel, Tool
from warp_cut.sim.model_change import ModelChange
from warp_cut.solvers import INTEGRATORS
from warp_cut.solvers.base import CAPTURE_GAP
from warp_cut.solvers.launches import AUTO_CAPTURE_AFTER

SCRIPT = r"""
import json, sys
from warp_cut.sim.warp_config import quiet_warp
quiet_warp()
from warp_cut import Material, Simulator, TissueModel, Tool
from warp._src.context import user_modules
integrator = sys.argv[1]
gravity, collision, residual, foundation = (a == "1" for a in sys.argv[2:6])
device = sys.argv[6]
model = TissueModel.from_patch((0.01, 0.01), 0.002,
                               material=Material(foundation_stiffness=1e5 if foundation else 0.0))
model.add_residual_links([[0, 1]], [0.002])
sim = Simulator(model, integrator=integrator, gravity=(0, 0, -9.81) if gravity else None,
                collision=collision, residual_stress=residual, device=device)
sim.step(3, tool=Tool([0, 0, 0.01], [0, 0, 0.05], 0.001))
print(json.dumps([name for name, mod in user_modules.items()
                  if name.startswith("warp_cut.kernels") and mod.execs]))
"""

PHYSICS = ("gravity", "collision", "residual", "foundation")


def loaded(integrator, gravity, collision, residual, foundation):
    out = subprocess.run([sys.executable, "-c", SCRIPT, integrator, str(int(gravity)),
                          str(int(collision)), str(int(residual)), str(int(foundation)), DEVICE],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("integrator", sorted(INTEGRATORS))
def test_only_enabled_physics_is_compiled(integrator):
    for enabled in ((False, False, False, False), (True, True, True, True),
                    (False, False, False, True)):
        names = loaded(integrator, *enabled)
        assert any("springs" in n or "implicit" in n or "xpbd" in n for n in names), names
        for physics, on in zip(PHYSICS, enabled):
            compiled = [n for n in names if physics in n]
            if on:
                assert compiled, f"{physics} enabled but no module with it was compiled: {names}"
            else:
                assert not compiled, f"{physics} disabled but compiled: {compiled}"


@pytest.mark.parametrize("links, bending", [(False, False), (True, False), (True, True)])
def test_a_semi_implicit_substep_is_one_launch_per_force_family_and_one_per_node(links, bending):
    """The semi-implicit substep launches the spring forces, the residual links' forces (when
    there are links), the hinges' bending forces (with bending) and one node kernel (gravity,
    damping, tool, foundation and integration fused): ``launches_per_substep`` counts them."""
    model = TissueModel.from_patch((0.01, 0.01), 0.002, material=Material(bending_rigidity=1e-6 if bending else 0.0))
    if links:
        model.add_residual_links([[0, 1]], [0.002])
    sim = Simulator(model, dt=1e-3, device=DEVICE)
    assert sim.solver.launches_per_substep(sim.state, sim._next, sim.substep) == 2 + links + bending


def run_positions(integrator, replay, steps=40):
    model = TissueModel.from_patch((0.02, 0.012), 0.002)
    model.add_residual_links([[0, 5]], [0.002])
    sim = Simulator(model, dt=1e-3, integrator=integrator, device=DEVICE)
    sim.solver.replay = replay
    sim.solver.topology_changed()
    def depth(t):
        return max(0.002 - 0.2 * t, -0.002)
    def tool(t):
        return Tool([0, 0, depth(t)], [0.02, 0, 0.02 + depth(t)], 0.001)
    sim.step(steps, tool=tool)
    return sim.positions, sim.tool_force


@pytest.mark.cpu_only(reason="bitwise equality needs the CPU's serial threads: on CUDA the "
                      "order of float atomic adds, and so the last bits, varies from run to run")
@pytest.mark.parametrize("integrator", sorted(INTEGRATORS))
def test_replayed_launches_match_plain_launches(integrator):
    x_plain, f_plain = run_positions(integrator, "launch")
    assert np.abs(f_plain).max() > 0  # the tool touched the sheet
    for replay in ("commands", "auto"):
        x, f = run_positions(integrator, replay)
        np.testing.assert_array_equal(x, x_plain)
        np.testing.assert_array_equal(f, f_plain)


@pytest.mark.parametrize("integrator", sorted(INTEGRATORS))
def test_a_later_recording_is_captured_after_its_replays_one_capture_at_a_time(integrator):
    """The first recording is captured at once; one made later (here: a new substep, as after
    a cut) replays as commands until AUTO_CAPTURE_AFTER replays, the swapped pair is captured
    at least CAPTURE_GAP launches later (one capture per tick), and the states stay equal to
    those of commands alone."""
    tool = Tool([0, 0, 0.0005], [0.02, 0, 0.02], 0.001)
    sims = {}
    for replay in ("auto", "commands"):
        model = TissueModel.from_patch((0.02, 0.012), 0.002)
        sims[replay] = sim = Simulator(model, dt=1e-3, integrator=integrator, device=DEVICE)
        sim.solver.replay = replay
        sim.solver.topology_changed()
        sim.step(2, tool=tool)
    solver = sims["auto"].solver
    assert {seq.kind for seq in solver._sequences.values()} == {"graph"}
    h = 0.5 * sims["auto"].substep
    pairs = {name: [sim.state, sim._next] for name, sim in sims.items()}
    captured = {}
    for launch in range(2 * AUTO_CAPTURE_AFTER + 2 * CAPTURE_GAP):
        for name, sim in sims.items():
            a, b = pairs[name]
            sim.solver.step(a, b, tool, h)
            pairs[name].reverse()
        for key, seq in solver._sequences.items():
            if key[2] == h and seq.kind == "graph":
                captured.setdefault(key, (launch, seq.replays))
    assert len(captured) == 2, captured
    (first, replays_a), (second, replays_b) = sorted(captured.values())
    assert min(replays_a, replays_b) >= AUTO_CAPTURE_AFTER
    assert second - first >= CAPTURE_GAP
    final = {name: pairs[name][0].positions.numpy() for name in sims}
    np.testing.assert_array_equal(final["auto"], final["commands"])


@pytest.mark.parametrize("integrator", sorted(INTEGRATORS))
def test_an_edited_simulator_steps_like_one_built_from_the_edited_model(integrator):
    """A cut edits the device arrays in place (and the semi-implicit solver keeps its recorded
    launches, which span the arrays' capacity): the next steps must equal those of a
    simulator made from scratch from the edited model, in the same state."""
    model = TissueModel.from_patch((0.03, 0.02), 0.002)
    sim = Simulator(model, dt=1e-3, integrator=integrator, device=DEVICE, cutting=CutSettings())
    tool = Tool([0.0, 3e-4, 0.0005], [0.0, 3e-4, 0.02], 0.001)
    sim.step(5, tool=tool)
    recorded = dict(sim.solver._sequences)
    version = model.topology_version
    # between two rows of nodes, narrower than the spacing: the springs across are cut
    sim.cutter.start_incision(sim, [-0.006, 1e-3, 0.0], [0, 0, 1], 3e-4)
    sim.cutter.extend_incision(sim, [0.006, 1e-3, 0.0])
    sim.cutter.end_incision(sim)
    # one event cuts the whole slit, its lips and its links in one edit
    assert len(model.links) and model.topology_version > version
    if integrator == "semi_implicit":  # nothing recorded again: the same launch objects
        assert all(sim.solver._sequences.get(key) is seq for key, seq in recorded.items())
    fresh = Simulator(model, dt=sim.dt, substeps=sim.substeps, integrator=integrator, device=DEVICE)
    fresh.set_state(sim.positions, sim.velocities)
    sim.step(20, tool=tool)
    fresh.step(20, tool=tool)
    np.testing.assert_allclose(sim.positions, fresh.positions, rtol=0, atol=1e-7)
    np.testing.assert_allclose(sim.tool_force, fresh.tool_force, rtol=1e-4, atol=1e-7)


def test_a_node_table_that_outgrows_its_capacity_keeps_the_state():
    """More new nodes than the spare slots: both states grow to the new capacity keeping every
    old position and velocity; the new nodes start where given, at rest; stepping goes on."""
    model = TissueModel.from_patch((0.01, 0.01), 0.002)
    sim = Simulator(model, dt=1e-3, device=DEVICE, gravity=(0.0, 0.0, -9.81))
    sim.step(3)
    x, v = sim.positions, sim.velocities
    table = model.node_table
    n = table.capacity - table.count + 5  # five past the spare room
    far = np.tile([0.5, 0.5, 0.5], (n, 1)) + np.arange(n)[:, None] * 1e-3
    slots = table.append(points=far, masses=np.full(n, 1e-6), damping=np.zeros(n),
                         pinned=np.ones(n, bool), node_class=np.zeros(n, np.int8))
    sim.notify_model_changed(ModelChange.of(new_nodes=slots, new_positions=far, touched_nodes=slots))
    assert sim.state.node_count >= table.capacity > len(x) + n - 5
    np.testing.assert_array_equal(sim.positions[: len(x)], x.astype(np.float32))
    np.testing.assert_array_equal(sim.velocities[: len(v)], v.astype(np.float32))
    np.testing.assert_allclose(sim.positions[slots], far, atol=1e-7)
    assert not sim.velocities[slots].any()
    sim.step(2)
    assert np.isfinite(sim.positions).all() and sim.positions[: len(x), 2].min() < x[:, 2].min()
