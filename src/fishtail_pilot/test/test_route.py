"""The route's rule: a waypoint is reached within the tolerance, or passed close by on its leg."""

from __future__ import annotations

import math

from fishtail_pilot.route import PASS_WITHIN_M, GoalRoute, square_route

TOLERANCE_M = 0.2


def test_a_corner_passed_close_by_is_left_for_the_next():
    route = GoalRoute(square_route(2.0), TOLERANCE_M)
    assert route.update((0.0, 0.0)) is None  # the first leg starts here, along +x
    # Abeam of (2, 0), 0.3 m out: not yet past the line through it across the leg.
    assert route.update((1.95, -0.3)) is None
    assert route.update((2.1, -0.3)) == "passed"
    assert route.current == (2.0, 2.0)


def test_a_corner_is_not_passed_from_afar_nor_before_it():
    route = GoalRoute(square_route(2.0), TOLERANCE_M)
    route.update((0.0, 0.0))
    assert route.update((2.0 + PASS_WITHIN_M, 0.1)) is None  # past it, but too far off
    assert route.update((1.7, 0.0)) is None  # 0.3 m short of it, on the leg
    assert route.current == (2.0, 0.0)


def test_the_leg_to_a_corner_starts_at_the_corner_before():
    route = GoalRoute(square_route(2.0), TOLERANCE_M)
    route.update((0.0, 0.0))
    assert route.update((1.9, 0.05)) == "reached"
    # The leg (2, 0) -> (2, 2) points along +y: beside the corner at y = 2.1 is past it,
    # though the fish came from the right.
    assert route.update((2.3, 1.9)) is None
    assert route.update((2.3, 2.1)) == "passed"


def test_the_last_waypoint_must_be_reached():
    route = GoalRoute([(1.0, 0.0)], TOLERANCE_M)
    route.update((0.0, 0.0))
    assert route.update((1.1, 0.3)) is None
    assert not route.finished
    assert route.update((1.1, 0.1)) == "reached"
    assert route.finished and route.current is None
    assert route.update((1.0, 0.0)) is None


def test_an_unknown_position_reaches_and_passes_nothing():
    route = GoalRoute(square_route(2.0), TOLERANCE_M)
    assert route.update((math.nan, math.nan)) is None
    route.update((0.0, 0.0))
    assert route.update((math.nan, 0.0)) is None
    assert route.current == (2.0, 0.0)
