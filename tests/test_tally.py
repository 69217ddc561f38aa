"""warp_cut/cut/tally.py: a Cutter's counts and stage times, on hand-made events."""

from __future__ import annotations

import pytest

from warp_cut.cut.remesh.cut_piece import PieceCut
from warp_cut.cut.remesh.layout import Refusal
from warp_cut.cut.tally import STAGES, TOTALS, CutTally
from warp_cut.cut.topology import EditReport


def test_each_stage_takes_the_time_between_its_two_marks():
    """Marks at 0, 1, 3, 6, 10, 15, 21 ms give stages of 1-6 ms; a second event adds its own;
    an event's whole time is the sum of its stages."""
    tally = CutTally()
    tally.times(tuple(1e-3 * t for t in (0, 1, 3, 6, 10, 15, 21)))
    tally.times(tuple(1e-3 * t for t in (100, 100, 100, 100, 102, 102, 102)))
    assert [tally.latency_ms[name] for name in STAGES] == [pytest.approx([1, 0]), pytest.approx([2, 0]),
                                                           pytest.approx([3, 0]), pytest.approx([4, 2]),
                                                           pytest.approx([5, 0]), pytest.approx([6, 0])]
    assert tally.event_latency_ms() == pytest.approx([21.0, 2.0])
    summary = tally.latency_summary()
    assert summary["remesh"] == {"p50_ms": pytest.approx(3.0), "p99_ms": pytest.approx(3.98),
                                 "max_ms": pytest.approx(4.0), "events": 2}


def test_no_event_times_nothing():
    tally = CutTally()
    assert len(tally.event_latency_ms()) == 0
    assert tally.latency_summary() == dict.fromkeys(STAGES)


def test_an_edit_and_a_refusal_are_counted_where_metrics_read_them():
    """One edit's report and re-mesh add their sizes; a refusal counts an event skipped and its
    reason; nothing else moves."""
    tally = CutTally()
    report = EditReport(deleted_springs=[1, 2, 3], residual_links=[4], carried_links=[5, 6], new_springs=[7] * 9,
                        removed_fragments=[8])
    cut = PieceCut(deleted=[1, 2], lips=[3, 4, 5], inserted=[6], growth=2, unrefined=1)
    tally.edit(report, cut)
    tally.refused(Refusal.UNDER_ANGLE)
    tally.refused(Refusal.UNDER_ANGLE)
    expected = dict.fromkeys(TOTALS, 0) | {"events": 1, "deleted_nodes": 2, "deleted_springs": 3, "residual_links": 1,
                                           "carried_links": 2, "lip_nodes": 3, "inserted_nodes": 1, "new_springs": 9,
                                           "removed_fragments": 1, "region_growths": 2, "unrefined_triangles": 1,
                                           "skipped_events": 2}
    assert tally.totals == expected
    assert tally.skipped == {Refusal.UNDER_ANGLE.value: 2}
