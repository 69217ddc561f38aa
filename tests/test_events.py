"""EventClock (warp_cut/cut/events.py) and the event settings (CutSettings.interval / travel):
when cut events fall due, counted against the arithmetic of a tool moving at constant speed."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from warp_cut.cut.events import EventClock
from warp_cut.cut.settings import DEFAULT_TRAVEL, MAX_TRAVEL, CutSettings
from warp_cut.errors import InputError


def due_steps(clock, tips, dt, interval=None, distance=None) -> list[int]:
    """Steps (0-based) at whose end ``clock`` says an event is due, the tip at ``tips[k]``."""
    return [k for k, tip in enumerate(tips) if clock.due((k + 1) * dt, dt, tip, interval, distance)]


@given(speed=st.floats(1e-3, 0.2), dt=st.sampled_from([1e-4, 5e-4, 1e-3]), travel=st.floats(1e-4, 4e-3),
       steps=st.integers(1, 400), direction=st.floats(0, 2 * math.pi))
def test_by_travel_an_event_every_k_steps_of_a_straight_stroke(speed, dt, travel, steps, direction):
    """A tip moving in a straight line at ``speed`` [m/s], ``v dt`` per step: the first step
    with the tool is due at once, then every k-th, k = ceil(distance / (v dt)) (the first step
    at which the tip is at least ``distance`` from where it was at the last event)."""
    per_step = speed * dt
    heading = np.array([math.cos(direction), math.sin(direction), 0.0])
    tips = [k * per_step * heading for k in range(steps)]
    got = due_steps(EventClock(), tips, dt, distance=travel)
    k = math.ceil(travel / per_step)
    if abs(travel / per_step - round(travel / per_step)) < 1e-9:  # on the edge: rounding decides
        return
    assert got == list(range(0, steps, k))


def test_by_travel_no_event_while_the_tool_rests_or_hovers_still():
    """A tool that stops (in the skin or above it) makes no event, however long it stays; when
    it moves again the next is due once it is ``distance`` from the last event's tip."""
    clock = EventClock()
    tips = [np.zeros(3)] * 1000 + [np.array([0.0, 0.0, 1e-3 * k]) for k in range(1, 4)]
    assert due_steps(clock, tips, 1e-3, distance=2e-3) == [0, 1001]


def test_by_travel_an_event_at_once_when_the_tool_comes_back():
    """The tool leaves (tip None: no event, the clock forgets where it was) and comes back at
    the same place: an event is due at its first step back, though the tip has not moved."""
    clock = EventClock()
    here = np.array([0.01, 0.02, 0.0])
    assert clock.due(0.001, 1e-3, here, None, 1e-3)
    assert not clock.due(0.002, 1e-3, here, None, 1e-3)
    assert not clock.due(0.003, 1e-3, None, None, 1e-3)
    assert clock.due(0.004, 1e-3, here, None, 1e-3)


@pytest.mark.parametrize("interval, dt, steps, expected", [
    (0.0, 1e-3, 5, [0, 1, 2, 3, 4]),  # every step
    (0.005, 1e-3, 12, [0, 5, 10]),  # every 5th step
    (1.0 / 60.0, 1e-3, 40, [0, 17, 34]),  # 16.67 steps: the step nearest (17 then 17)
])
def test_on_the_clock_events_every_interval_whatever_the_tool_does(interval, dt, steps, expected):
    """On the clock: due at the step nearest each interval after the last event (the tip,
    still or moving or absent, does not matter)."""
    tips = [None if k % 3 == 0 else np.zeros(3) for k in range(steps)]
    assert due_steps(EventClock(), tips, dt, interval=interval) == expected


def test_event_rule_of_the_settings():
    """``CutSettings.event_rule``: the clock when ``interval`` is given; else by travel,
    ``travel`` (default ``DEFAULT_TRAVEL``) lip spacings."""
    assert CutSettings(interval=0.02).event_rule(2e-3) == (0.02, None)
    assert CutSettings(travel=0.25).event_rule(2e-3) == (None, pytest.approx(5e-4))
    assert CutSettings().event_rule(2e-3) == (None, pytest.approx(DEFAULT_TRAVEL * 2e-3))
    assert CutSettings().lip_spacing(np.array([1.0, 2.0, 5.0])) == 2.0
    assert CutSettings(spacing=3e-3).lip_spacing(np.array([1.0])) == 3e-3


@pytest.mark.parametrize("given_settings, message", [
    ({"interval": 0.01, "travel": 0.5}, "not both"),
    ({"travel": 0.0}, "cutting.travel must be in"),
    ({"travel": -1.0}, "cutting.travel must be in"),
    ({"travel": MAX_TRAVEL * 1.01}, "cutting.travel must be in"),
    ({"travel": float("nan")}, "cutting.travel must be in"),
    ({"interval": -0.1}, "cutting.interval must be >= 0"),
    ({"interval": float("inf")}, "cutting.interval must be >= 0"),
])
def test_bad_event_settings_are_refused(given_settings, message):
    with pytest.raises(InputError, match=message):
        CutSettings(**given_settings)
