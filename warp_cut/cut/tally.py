"""CutTally: what a Cutter counts and times, event by event (metrics.json's ``cut`` and
``latency_ms``).

Counts are of model elements (nodes, springs, links, triangles) and events; times are host wall
time per stage of an event [ms] (``STAGES``).
"""

from __future__ import annotations

import numpy as np

from .remesh.cut_piece import PieceCut
from .remesh.layout import Refusal
from .topology import EditReport

__all__ = ["CutTally", "STAGES", "TOTALS"]

STAGES = ("locate", "curve", "select_piece", "remesh", "links_and_islands", "device_update")
"""Names of the timed parts of a cut event (latency in metrics.json), in their order: the
blade's crossing and its material point; the incision curve's refit (Stage 2); the piece of
curve the event cuts; Stages 1 and 3's re-mesh (region, band, fill, writing it); the wound's
links, split nodes, islands and the edit's finish; the edit mirrored on the device."""

TOTALS = ("deleted_nodes", "deleted_springs", "residual_links", "carried_links", "lost_links", "lip_nodes",
          "inserted_nodes", "new_springs", "removed_fragments", "removed_islands", "removed_scraps", "removed_flaps",
          "region_growths", "unrefined_triangles", "delaunay_flips", "events", "skipped_events")
"""The counts of ``CutTally.totals`` (metrics.json's ``cut``)."""


class CutTally:
    """Running counts and stage times of a Cutter's events.

    Attributes:
        totals: Name (``TOTALS``) -> count over every event so far.
        skipped: Why events were left for the next one (the slit did not fit its region): the
            ``Refusal``'s message -> count.
        latency_ms: Stage (``STAGES``) -> each event's time in it [ms].
    """

    def __init__(self):
        self.totals = dict.fromkeys(TOTALS, 0)
        self.skipped: dict[str, int] = {}
        self.latency_ms: dict[str, list[float]] = {name: [] for name in STAGES}

    def edit(self, report: EditReport, cut: PieceCut) -> None:
        """Count one event's edit: its ``EditReport`` and its re-mesh's ``PieceCut``."""
        tot = self.totals
        tot["events"] += 1
        tot["deleted_nodes"] += len(cut.deleted)
        tot["deleted_springs"] += len(report.deleted_springs)
        tot["residual_links"] += len(report.residual_links)
        tot["carried_links"] += len(report.carried_links)
        tot["lip_nodes"] += len(cut.lips)
        tot["inserted_nodes"] += len(cut.inserted)
        tot["new_springs"] += len(report.new_springs)
        tot["removed_fragments"] += len(report.removed_fragments)
        tot["region_growths"] += cut.growth
        tot["unrefined_triangles"] += cut.unrefined

    def refused(self, reason: Refusal) -> None:
        """Count an event whose slit did not fit (nothing was edited)."""
        self.totals["skipped_events"] += 1
        self.skipped[reason.value] = self.skipped.get(reason.value, 0) + 1

    def times(self, marks: tuple) -> None:
        """Each stage's time [ms] from the perf_counter ``marks`` [s] (7,): the event's start,
        after locating, after the curve, before and after the re-mesh, after the links and
        islands, after mirroring the edit."""
        for name, start, end in zip(STAGES, marks[:-1], marks[1:]):
            self.latency_ms[name].append(1e3 * (end - start))

    def event_latency_ms(self) -> np.ndarray:
        """Each cut event's whole time [ms] (events,): the sum of its stages."""
        return np.sum([self.latency_ms[name] for name in STAGES], axis=0).reshape(-1)

    def latency_summary(self) -> dict:
        """p50 / p99 / max latency per stage [ms] over the events (None for a stage without any)."""
        out = {}
        for name, values in self.latency_ms.items():
            v = np.asarray(values)
            out[name] = ({"p50_ms": float(np.percentile(v, 50)), "p99_ms": float(np.percentile(v, 99)),
                          "max_ms": float(v.max()), "events": int(len(v))} if len(v) else None)
        return out
