"""warp_cut/slots.py and device_model.py: in-place edits with spare capacity, mirrored slot by slot."""

import copy

import numpy as np
import pytest
from conftest import DEVICE
from hypothesis import given
from hypothesis import strategies as st

from warp_cut import TissueModel
from warp_cut.sim.device_model import DeviceModel
from warp_cut.sim.slots import SlotTable, member


@given(st.lists(st.integers(0, 5000), max_size=40), st.lists(st.integers(0, 5000), max_size=40))
def test_member_agrees_with_a_set(slots, among):
    mask = member(np.array(slots, dtype=np.int64).reshape(-1), among)
    assert mask.tolist() == [s in set(among) for s in slots]


def test_member_keeps_the_shape_and_refuses_negative_slots():
    pairs = np.array([[0, 7], [3, 4], [7, 9]])
    assert member(pairs, [7, 3]).tolist() == [[False, True], [True, False], [True, False]]
    assert member(np.zeros((0, 2), int), [1]).shape == (0, 2)
    with pytest.raises(ValueError, match="non-negative"):
        member([1, -1], [1])


def test_append_kill_and_dirty_slots():
    t = SlotTable({"pairs": np.array([[0, 1], [1, 2]]), "w": np.array([1.0, 2.0])}, key="pairs")
    assert t.capacity >= 2 + 256 and t.live_count == 2
    t.take_dirty()
    slots = t.append(pairs=[[2, 3]], w=[3.0])
    t.kill([0])
    assert slots.tolist() == [2] and t.live("pairs").tolist() == [[1, 2], [2, 3]]
    assert t.column("pairs")[0].tolist() == [-1, -1]  # dead slot marked for the kernels
    dirty, grown = t.take_dirty()
    assert dirty.tolist() == [0, 2] and not grown
    n = t.capacity  # spare room is used first, then the capacity grows
    t.append(pairs=np.zeros((n, 2), int), w=np.zeros(n))
    assert t.take_dirty()[1] and t.capacity >= n + 3 and t.live("w")[:2].tolist() == [2.0, 3.0]
    with pytest.raises(ValueError):
        t.append(pairs=[[1, 1]])


def test_device_mirror_follows_edits_and_growth():
    model = TissueModel.from_patch((0.01, 0.01), 0.002)
    dev = DeviceModel(model, DEVICE)
    table = model.spring_table
    table.kill([0])
    table.set("stiffness", [1], 7.0)
    assert dev.sync() is False
    assert dev.spring_indices.numpy()[:2].tolist() == [-1, -1]
    assert dev.spring_stiffness.numpy()[1] == pytest.approx(7.0)
    # growing beyond capacity reallocates, and the mirror equals the host afterwards
    n = table.capacity
    table.append(pairs=np.tile([[0, 1]], (n, 1)), rest_length=np.ones(n), stiffness=np.ones(n),
                 spring_class=np.zeros(n, np.int8))
    assert dev.sync() is True
    np.testing.assert_array_equal(dev.spring_indices.numpy()[: 2 * table.count],
                                  table.column("pairs").ravel())
    assert dev.spring_count == table.count
    # the used counts on the device (what launches over the capacity stop at) follow too
    assert dev.used_slots.numpy().tolist() == [model.node_table.count, table.count,
                                               model.link_table.count, model.hinge_table.count]


def test_changed_rows_replicate_a_table_edit_by_edit():
    """rows / put_rows carry every change (appends, kills, sets, growth) to a replica, and
    changed_slots leaves the changes for take_dirty."""
    t = SlotTable({"pairs": np.array([[0, 1], [1, 2], [2, 3]]), "w": np.array([1.0, 2.0, 3.0])}, key="pairs")
    replica = copy.deepcopy(t)
    t.take_dirty()
    for edit in range(3):
        t.kill([edit])
        t.set("w", [2], 10.0 + edit)
        n = t.capacity if edit == 1 else 2  # the second edit outgrows the capacity
        t.append(pairs=np.full((n, 2), edit), w=np.full(n, float(edit)))
        slots = t.changed_slots()
        replica.put_rows(slots, t.rows(slots), t.count)
        assert t.take_dirty()[0].tolist() == slots.tolist()
        assert replica.count == t.count and replica.capacity >= t.count
        np.testing.assert_array_equal(replica.alive, t.alive)
        for name in ("pairs", "w"):
            np.testing.assert_array_equal(replica.column(name), t.column(name))
    with pytest.raises(ValueError, match="put_rows needs"):
        replica.put_rows([0], {"w": np.zeros(1)}, replica.count)
