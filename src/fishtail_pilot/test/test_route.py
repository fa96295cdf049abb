"""The route's rule: a waypoint is reached within the tolerance, or rounded in its circle."""

from __future__ import annotations

import math

import pytest

from fishtail_pilot.route import ACCEPTANCE_RADIUS_M, GoalRoute, square_route

TOLERANCE_M = 0.2


def test_a_corner_is_rounded_once_the_fish_is_inside_its_circle_of_acceptance():
    route = GoalRoute(square_route(2.0), TOLERANCE_M)
    just_outside = 2.0 - ACCEPTANCE_RADIUS_M - 0.01
    assert route.update((just_outside, 0.0)) is None
    assert route.current == (2.0, 0.0)
    # From any side: the circle does not depend on where the fish came from.
    assert route.update((2.0 + 0.6, -0.6)) == "rounded"
    assert route.current == (2.0, 2.0)


def test_a_corner_within_the_tolerance_is_reached():
    route = GoalRoute(square_route(2.0), TOLERANCE_M, acceptance_radius_m=0.0)
    assert route.update((1.7, 0.0)) is None
    assert route.update((1.9, 0.05)) == "reached"
    assert route.current == (2.0, 2.0)


def test_the_last_waypoint_must_be_reached():
    route = GoalRoute([(1.0, 0.0)], TOLERANCE_M)
    assert route.update((1.1, 0.3)) is None  # inside the circle of acceptance, not the tolerance
    assert not route.finished
    assert route.update((1.1, 0.1)) == "reached"
    assert route.finished and route.current is None
    assert route.update((1.0, 0.0)) is None


def test_the_square_ends_where_it_starts_and_each_corner_waits_for_the_one_before():
    route = GoalRoute(square_route(2.0), TOLERANCE_M)
    # At the start, which is also the last corner: nothing while three others come first.
    assert route.update((0.0, 0.0)) is None
    # 0.9 m short of each corner on its leg rounds it; the start again is 0.9 m short: not yet.
    for short_of_corner in [(1.1, 0.0), (2.0, 1.1), (0.9, 2.0)]:
        assert route.update(short_of_corner) == "rounded"
    assert route.update((0.0, 0.9)) is None
    assert route.update((0.0, 0.15)) == "reached"
    assert route.finished


@pytest.mark.parametrize("position", [(math.nan, math.nan), (math.nan, 0.0), (2.0, math.inf)])
def test_an_unknown_position_reaches_and_rounds_nothing(position):
    route = GoalRoute(square_route(2.0), TOLERANCE_M)
    assert route.update(position) is None
    assert route.current == (2.0, 0.0)
