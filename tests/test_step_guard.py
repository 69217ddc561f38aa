"""The stability guard folded into each integrator's node pass, and the per-step readout.

Compared against: the state a test writes (a NaN or a displacement planted at known nodes,
so the lowest bad node is known), the separate ``check_finite`` pass over the same state, and
batched stepping (``step(n)``) for single-step calls, which must take the same steps.
"""

import numpy as np
import pytest
import warp as wp
from conftest import DEVICE, chain_model

from warp_cut import SimulationUnstable, Simulator, TissueModel, Tool, ToolPath
from warp_cut.solvers import INTEGRATORS
from warp_cut.solvers.readout import NO_BAD_NODE, StepReadout

ALL = sorted(INTEGRATORS)


def plant(array: wp.array, nodes, value) -> None:
    """Write ``value`` (3,) into ``array`` at ``nodes`` (a download and upload on any device)."""
    host = array.numpy().copy()
    host[list(nodes)] = value
    array.assign(host)


def recording_sim(integrator, **options):
    model = chain_model(6, mass=0.01, stiffness=100.0, spacing=0.01, damping=0.1)
    sim = Simulator(model, dt=1e-3, substeps=1, integrator=integrator, device=DEVICE, **options)
    calls = []
    sim.post_step_hooks.append(lambda s: calls.append(s.time))
    return model, sim, calls


@pytest.mark.parametrize("integrator", ALL)
def test_nan_is_caught_in_the_step_that_makes_it_before_any_hook(integrator):
    model, sim, calls = recording_sim(integrator)
    sim.step(3)
    assert len(calls) == 3
    plant(sim.state.velocities, [5, 3], [np.nan, 0.0, 0.0])
    with pytest.raises(SimulationUnstable) as info:
        sim.step(5)
    err = info.value
    x, v = sim.state.positions.numpy(), sim.state.velocities.numpy()
    bad = np.flatnonzero(~(np.isfinite(x).all(axis=1) & np.isfinite(v).all(axis=1)))
    assert 3 in bad and err.node == bad[0]  # the lowest bad node of the step's state
    if integrator == "semi_implicit":  # forces come from the finite positions: only 3 and 5
        assert list(bad) == [3, 5]
    assert "non-finite" in str(err) and "stable step" in str(err)
    assert err.time == pytest.approx(4e-3) and err.step == pytest.approx(1e-3)
    assert len(calls) == 3  # the hooks never saw the bad step
    with pytest.raises(SimulationUnstable) as again:  # the separate pass agrees
        sim.check_finite()
    assert again.value.node == err.node


@pytest.mark.parametrize("integrator", ALL)
def test_runaway_beyond_max_displacement_is_caught(integrator):
    model, sim, _ = recording_sim(integrator, gravity=None, max_displacement=0.05)
    x = model.points.copy()
    x[[6, 4]] += [0.0, 0.2, 0.0]  # finite, but 0.2 m from rest
    sim.set_state(positions=x)
    with pytest.raises(SimulationUnstable) as info:
        sim.step()
    assert info.value.node == 4
    assert "moved more than 0.05 m from rest" in str(info.value)


@pytest.mark.parametrize("integrator", ALL)
def test_set_state_resets_the_guard(integrator):
    model, sim, calls = recording_sim(integrator)
    plant(sim.state.positions, [2], [np.inf, 0.0, 0.0])
    with pytest.raises(SimulationUnstable):
        sim.step()
    sim.set_state(positions=model.points, velocities=np.zeros((model.node_count, 3)))
    sim.step(4)
    assert len(calls) == 4 and np.all(np.isfinite(sim.positions))


def test_pinned_node_is_guarded_too():
    model, sim, _ = recording_sim("semi_implicit")
    plant(sim.state.positions, [0], [np.nan, np.nan, np.nan])  # node 0 is pinned
    with pytest.raises(SimulationUnstable) as info:
        sim.step()
    assert info.value.node == 0


def patch_path(steps, dt):
    """A tool pressing into a small patch: keyframes at the end of every step."""
    t = np.arange(1, steps + 1) * dt
    depth = np.minimum(t / (steps * dt), 1.0) * 0.004
    p0 = np.column_stack([np.zeros(steps), np.zeros(steps), 0.003 - depth])
    return ToolPath(t, p0, p0 + [0.0, 0.0, 0.02], 0.001)


@pytest.mark.parametrize("integrator", ALL)
def test_single_step_calls_take_the_same_steps_as_one_batched_call(integrator):
    model = TissueModel.from_patch((0.02, 0.02), 0.002)
    steps, dt = 60, 1e-3
    path = patch_path(steps, dt)
    batched = Simulator(model, dt=dt, integrator=integrator, device=DEVICE)
    single = Simulator(model, dt=dt, integrator=integrator, device=DEVICE)
    batched.step(steps, tool=path)
    forces = []
    for _ in range(steps):
        p0, p1 = path.endpoints_at(single.time + dt)  # the time step() evaluates a path at
        single.step(tool=Tool(p0, p1, path.radius))
        forces.append(single.tool_force)
    assert single.contacts.first_time is not None  # the tool did press in
    # the same launches on the same data: equal on the CPU, to float32 rounding where atomic
    # sums may be ordered differently from run to run (CUDA)
    np.testing.assert_allclose(single.positions, batched.positions, rtol=0, atol=1e-8)
    np.testing.assert_allclose(single.tool_force, batched.tool_force, rtol=1e-5, atol=1e-9)
    assert single.contacts.max_force == pytest.approx(batched.contacts.max_force, rel=1e-5)
    assert single.contacts.max_force == pytest.approx(max(np.linalg.norm(f) for f in forces))
    assert single.contacts.first_time_exact == pytest.approx(batched.contacts.first_time_exact, rel=1e-9)


def test_readout_copies_match_the_views():
    first_bad = wp.full(1, NO_BAD_NODE, dtype=wp.int32, device=DEVICE)
    force = wp.array([[1.5, -2.0, 0.25]], dtype=wp.vec3, device=DEVICE)
    count = wp.array([7], dtype=wp.int32, device=DEVICE)
    position_sum = wp.array([[0.07, 0.0, -0.014]], dtype=wp.vec3, device=DEVICE)
    copies = StepReadout(first_bad, force, count, position_sum, views=False)
    copies.fetch(tool_stats=True)
    f, n, s = copies.tool_stats()
    np.testing.assert_array_equal(f, np.float32([1.5, -2.0, 0.25]))
    assert n == 7 and copies.first_bad == NO_BAD_NODE
    np.testing.assert_array_equal(s, np.float32([0.07, 0.0, -0.014]))
    first_bad.fill_(3)
    copies.fetch(tool_stats=False)
    assert copies.first_bad == 3
    copies.clear_bad_node()
    copies.fetch(tool_stats=False)
    assert copies.first_bad == NO_BAD_NODE


@pytest.mark.cpu_only(reason="views exist only where device memory is host memory")
def test_readout_views_see_the_device_arrays_without_a_fetch():
    arrays = (wp.full(1, NO_BAD_NODE, dtype=wp.int32, device="cpu"),
              wp.zeros(1, dtype=wp.vec3, device="cpu"), wp.zeros(1, dtype=wp.int32, device="cpu"),
              wp.zeros(1, dtype=wp.vec3, device="cpu"))
    views = StepReadout(*arrays)
    assert views.views
    arrays[1].assign(np.float32([[0.0, 0.0, 3.0]]))
    arrays[2].fill_(2)
    f, n, _ = views.tool_stats()
    assert f[2] == 3.0 and n == 2
    views.clear_tool_stats()
    assert not arrays[1].numpy().any() and arrays[2].numpy()[0] == 0
