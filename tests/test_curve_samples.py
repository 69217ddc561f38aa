"""warp_cut/cut/curve/samples.py: a densely sampled curve, against every segment tried and
against the curve's own geometry (a circle's arc)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from warp_cut.cut.curve.samples import CurveSamples, closest_on_polyline


def arc(radius: float, turn: float, k: int) -> np.ndarray:
    """k samples (k, 3) [m] of a circle's arc of ``radius`` [m] turning ``turn`` [rad] from (radius, 0, 0)."""
    a = np.linspace(0.0, turn, k)
    return np.column_stack([radius * np.cos(a), radius * np.sin(a), np.zeros(k)])


@settings(deadline=None, max_examples=60)
@given(seed=st.integers(0, 2**32 - 1), turn=st.floats(0.2, 3.0), k=st.integers(2, 400))
def test_the_closest_point_is_the_one_every_segment_tried_finds(seed, turn, k):
    """Points within a few spacings of a sampled arc: the closest point searched round the
    nearest sample is as near as the one found trying every segment (within rounding), and
    lies on the polyline (its segment and parameter give it back)."""
    samples = CurveSamples(arc(0.02, turn, k))
    rng = np.random.default_rng(seed)
    points = samples.points[rng.integers(0, k, 20)] + rng.normal(scale=0.002, size=(20, 3))
    seg, t, closest, dist = samples.closest(points)
    _, _, _, best = closest_on_polyline(points, samples.points)
    assert np.allclose(dist, best, rtol=0.0, atol=1e-12)
    assert np.allclose(samples.points[seg] + t[:, None] * samples.segments[seg], closest, atol=1e-15)
    assert np.allclose(np.linalg.norm(points - closest, axis=1), dist, atol=1e-15)


def test_arc_lengths_tangents_and_segments_follow_the_circle():
    """A quarter circle of radius 2 cm in 401 samples: the arc length is r * pi / 2 to the
    chord error, each unit tangent is perpendicular to the radius at its segment's middle, and
    ``segment_at`` puts an arc length in the segment that holds it (the first or last beyond
    the ends)."""
    samples = CurveSamples(arc(0.02, np.pi / 2, 401))
    assert abs(samples.cum[-1] - 0.01 * np.pi) < 1e-7
    middle = 0.5 * (samples.points[:-1] + samples.points[1:])
    assert np.abs((samples.unit * middle).sum(axis=1)).max() < 1e-13 * 0.02
    assert np.allclose(np.linalg.norm(samples.unit, axis=1), 1.0)
    u = np.array([-1.0, 0.0, samples.cum[7] + 1e-9, samples.cum[-1], 1.0])
    assert samples.segment_at(u).tolist() == [0, 0, 7, 399, 399]


def test_repeated_samples_make_a_segment_of_no_length():
    """Two equal samples (an incision's start): one segment of no length, tangent 0, every point's
    closest point that sample."""
    samples = CurveSamples(np.zeros((2, 3)))
    assert samples.cum.tolist() == [0.0, 0.0] and samples.unit.tolist() == [[0.0, 0.0, 0.0]]
    _, _, closest, dist = samples.closest(np.array([[0.0, 0.003, 0.004]]))
    assert closest.tolist() == [[0.0, 0.0, 0.0]] and abs(dist[0] - 0.005) < 1e-15
